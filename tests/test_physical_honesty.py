"""Physical honesty: what the plant does at every physics step, the realism it runs with, and
figures measured against ground truth (the true incision, the true force).

Bounds over whole episodes, not spot checks: a controller that whips the arm, a gripper that
crushes the cube or a safe hold that keeps pushing fails here.
"""

from __future__ import annotations

import math
from importlib.resources import files

import mujoco
import numpy as np
import pytest
from orchestrator.robots import Controller, Panda
from orchestrator.skills.ik import IKSolver
from orchestrator.skills.trajectory import CartesianLine

from orchestrator.engine.blackboard import Blackboard
from orchestrator.engine.cell import Cell
from orchestrator.engine.context import Context
from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.world import World
from orchestrator.world.world import robot_only_model

SATURATED = 0.999
HAND_GRIP_N = 20.0
"""The grasp force the Panda's hand model squeezes with (robots/panda: 20 N per finger; the
real Franka Hand is rated 70 N continuous). Written out, not read from the model: a hand that
squeezes harder than designed must fail here."""


class StepProbe:
    """Worst per-step figures of one episode (ground truth, after every mj_step)."""

    def on_start(self, ctx, executor) -> None:
        w = ctx.world
        self.executor = executor
        self.dof, self.act = w.arm_dof, w.arm_act
        self.vlim = ctx.robot.joint_velocity_limits()
        self.tlim = w.arm_effort_limit
        self.fingers, self.robot = w.finger_geoms, w.robot_geoms
        self.objects = {h.geom_id for h in w.objects.values()}
        self.alim = np.asarray(ctx.robot.acceleration_limits, float)
        self.dt = ctx.dt_physics
        self.prev_v = ctx.data.qvel[self.dof].copy()
        self.speed = 0.0
        self.accel = 0.0
        self.accel_at = ""
        self.torque = 0.0
        self.saturated_outside_contact = 0
        self.last_contact_t = -math.inf
        self.pen_m = 0.0
        self.force = 0.0
        self.forces: list[tuple[float, float]] = []
        self.grip_n = 0.0
        self._wrench = np.zeros(6)
        m = ctx.model
        self.finger_dof = [int(m.jnt_dofadr[m.joint(j).id]) for j in ctx.robot.finger_joints]
        self.finger_speed = 0.0
        self.object_vel = {h.geom_id: h.qvel_adr for h in w.objects.values()}
        self.moving_t = dict.fromkeys(self.object_vel, 0.0)
        self.rest_pen_m = 0.0

    def on_tick(self, ctx, executor) -> None:
        pass

    def on_step(self, ctx) -> None:
        d = ctx.data
        v = d.qvel[self.dof]
        self.speed = max(self.speed, float(np.max(np.abs(v) / self.vlim)))
        # the arm's measured acceleration over this step, against the datasheet
        accel = np.abs(v - self.prev_v) / (self.dt * self.alim)
        self.prev_v = v.copy()
        if accel.max() > self.accel:
            self.accel = float(accel.max())
            self.accel_at = f"{self.executor.leaf} joint {int(accel.argmax()) + 1} t={d.time:.3f}"
        grip = 0.0
        for g, a in self.object_vel.items():  # at rest: slower than 1 cm/s for 0.1 s
            if np.linalg.norm(d.qvel[a : a + 3]) >= 0.01:
                self.moving_t[g] = d.time
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            if g1 in self.objects or g2 in self.objects:
                at_rest = all(
                    d.time - self.moving_t[g] >= 0.1 for g in (g1, g2) if g in self.objects
                )
                if at_rest:
                    self.rest_pen_m = max(self.rest_pen_m, -float(c.dist))
            if (g1 in self.fingers and g2 in self.objects) or (
                g2 in self.fingers and g1 in self.objects
            ):
                self.pen_m = max(self.pen_m, -float(c.dist))
                mujoco.mj_contactForce(ctx.model, d, i, self._wrench)
                grip += float(self._wrench[0])  # normal force, both fingers
            elif g1 in self.robot or g2 in self.robot:
                self.last_contact_t = d.time
        self.grip_n = max(self.grip_n, 0.5 * grip)  # each finger squeezes with half the sum
        self.finger_speed = max(
            self.finger_speed, *(abs(float(d.qvel[i])) for i in self.finger_dof)
        )
        tau = float(np.max(np.abs(d.actuator_force[self.act]) / self.tlim))
        self.torque = max(self.torque, tau)
        if tau >= SATURATED and d.time - self.last_contact_t > 0.01:
            self.saturated_outside_contact += 1
        f = math.sqrt(ctx.cell.wrist.true_norm_sq())
        self.force = max(self.force, f)
        self.forces.append((float(d.time), f))

    def on_end(self, ctx, executor, result) -> None:
        pass


def _run(name: str, seed: int, overrides: list[str] | None = None, faults=None):
    probe = StepProbe()
    result = run_episode(load_scenario(name, overrides, faults), seed, [probe])
    return result, probe


@pytest.fixture(scope="module")
def pick_runs():
    return [_run("pick_place", seed) for seed in (0, 1, 2)]


def test_pick_place_stays_within_the_pandas_limits_at_every_physics_step(pick_runs):
    for result, probe in pick_runs:
        assert result.outcome == "succeeded"
        assert probe.speed <= 1.0, f"seed {result.seed}: joint speed {probe.speed:.2f}x limit"
        assert probe.accel <= 1.0, (
            f"seed {result.seed}: joint acceleration {probe.accel:.2f}x the datasheet limit"
            f" at {probe.accel_at}"
        )
        assert probe.saturated_outside_contact == 0
        assert probe.torque < SATURATED
        assert probe.pen_m <= 0.001, f"fingers {probe.pen_m * 1000:.2f} mm into the cube"
        assert 0.5 * HAND_GRIP_N < probe.grip_n <= 1.2 * HAND_GRIP_N, f"grip {probe.grip_n:.0f} N"
        assert probe.force <= 15.0, f"peak wrist force {probe.force:.1f} N"
        # the Franka Hand: at most 0.05 m/s per finger, whatever the hand is told
        assert probe.finger_speed <= 0.05 + 1e-9, f"finger at {probe.finger_speed:.4f} m/s"
        # nothing at rest sits deeper than 1 mm in anything (the cube on the table, the grip)
        assert probe.rest_pen_m <= 0.001, f"{probe.rest_pen_m * 1000:.2f} mm deep at rest"
        # the reported peak is the per-step ground truth, not a per-tick sample
        assert result.metrics["max_wrist_force_n"] == pytest.approx(probe.force, abs=1e-3)


def test_realism_is_on_by_default_with_the_robots_datasheet_values():
    scn = load_scenario("pick_place").scenario
    assert scn.physics.realism.enabled
    world = World.build(scn, 0)
    friction = world.model.dof_frictionloss[world.arm_dof]
    expected = scn.physics.realism.joint_friction_scale * np.array(world.robot.joint_friction_nm)
    np.testing.assert_allclose(friction, expected)
    off = World.build(load_scenario("pick_place", ["physics.realism.enabled=false"]).scenario, 0)
    assert not off.model.dof_frictionloss[off.arm_dof].any()


def test_encoders_read_in_steps_of_their_resolution_and_difference_velocity():
    world = World.build(load_scenario("pick_place").scenario, 0)
    ctx = Context(Cell(world, Controller(world.robot), 0), Blackboard())
    res = world.robot.encoder_resolution_rad
    world.data.qpos[world.arm_qpos[0]] += 0.3 * res  # below one step: unseen
    world.step_clock.t = 0.002  # a new instant (the step function advances it)
    q, _ = ctx.cell.encoders.read()
    np.testing.assert_allclose(np.round(q / res) * res, q)
    world.data.qpos[world.arm_qpos[0]] += 10 * res
    world.step_clock.t = 0.004
    q2, v2 = ctx.cell.encoders.read()
    assert q2[0] - q[0] == pytest.approx(10 * res)
    assert 0.0 < v2[0] < 10 * res / 0.002  # differenced, then low-pass filtered


def test_wrist_sensor_is_noisy_and_drifts_but_deterministic():
    def readings(seed: int) -> np.ndarray:
        world = World.build(load_scenario("surgical").scenario, seed)
        ctx = Context(Cell(world, Controller(world.robot), 0), Blackboard())
        out, dt = [], float(world.model.opt.timestep)
        for k in range(2000):
            world.step_clock.t = k * dt
            out.append(ctx.wrist_force() - np.array(ctx.cell.wrist.true_force()))
        return np.array(out)

    a, b = readings(3), readings(3)
    np.testing.assert_array_equal(a, b)
    scn = load_scenario("surgical").scenario.physics.realism
    white = np.diff(a, axis=0).std(axis=0) / math.sqrt(2)
    np.testing.assert_allclose(white, scn.ft_noise_n, rtol=0.15)
    assert not np.array_equal(a, readings(4))


def test_a_misregistered_phantom_fails_the_surgical_success_check(tmp_path):
    # registered by the camera alone, which reports everything 1.5 mm off in y: the
    # registered line is traced well, the real incision is missed — only the ground truth
    # sees it
    machine = files("orchestrator.machines").joinpath("surgical.yaml").read_text()
    assert "method: touch" in machine
    (tmp_path / "surgical.yaml").write_text(machine.replace("method: touch", "method: fiducials"))
    scenario = files("orchestrator.scenarios").joinpath("surgical.yaml").read_text()
    (tmp_path / "scenario.yaml").write_text(
        scenario.replace("machine: surgical", "machine: surgical.yaml")
    )
    fault = "perception_offset:offset_m=[0,0.0015,0]@0"
    probe = StepProbe()
    result = run_episode(load_scenario(str(tmp_path / "scenario.yaml"), None, [fault]), 0, [probe])
    m = result.metrics
    assert m["path_deviation_max_mm"] < 0.1
    assert m["true_cross_track_max_mm"] > 1.0
    assert result.success["incision_traced"] is False
    assert result.outcome == "failed"


@pytest.mark.slow  # in the default run: tests/test_register.py (a 1.5 mm-off prior, touched)
def test_touching_the_phantom_corrects_a_misregistered_camera():
    # the same 1.5 mm perception error, the bundled flow: the touches find the phantom
    result, _ = _run("surgical", 0, faults=["perception_offset:offset_m=[0,0.0015,0]@0"])
    m = result.metrics
    assert m["true_cross_track_max_mm"] <= 0.1
    assert result.outcome == "succeeded"


def test_a_move_starts_its_command_where_the_setpoint_is_when_it_first_steps():
    # pick_place_vision, seed 3: TRANSPORT ends by bringing its setpoint to rest and LOWER
    # starts from the setpoint; restarted from where it was when LOWER started instead of
    # where the stop had taken it a control tick later, joint 3 kicked at 1.14x its limit
    result, probe = _run("pick_place_vision", 3)
    assert result.outcome == "succeeded"
    assert probe.accel <= 1.0, f"joint acceleration {probe.accel:.2f}x limit at {probe.accel_at}"


@pytest.mark.slow
def test_a_parcel_grazing_its_neighbour_leaves_the_arm_within_its_limits():
    # sorting, seed 3, PICK.LIFT at 10.194 s: the lifted parcel grazes its neighbour (9.9 N for
    # one step) and knocks joint 2 by 0.26 of its limit above the command; with the commands at
    # 85 % of the acceleration limits that step measured 1.01x (1.16x on joint 6 before the
    # controller's model had the rotor inertia), at 70 % (`ACCELERATION_MARGIN`) 0.90x
    result, probe = _run("sorting", 3)
    assert result.outcome == "succeeded"
    assert probe.accel <= 1.0, f"joint acceleration {probe.accel:.3f}x limit at {probe.accel_at}"


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "seed", "why"),
    [
        # the end-of-run stop: the brake's feed-forward switched between decelerating and
        # coasting every step or two (joint 3 at 1.054x under a profile at 0.5x)
        ("pick_place", 53, "the controlled stop"),
        # HOME's move_joints started its profile at rest while the setpoint still moved from
        # RETREAT: its velocity stepped by 0.05 rad/s (joint 3 at 2.08x)
        ("stack", 2, "move_joints from a moving setpoint"),
    ],
)
def test_the_arm_stays_within_its_acceleration_limits_where_it_did_not(name, seed, why):
    result, probe = _run(name, seed)
    assert result.outcome == "succeeded"
    assert probe.accel <= 1.0, f"{why}: {probe.accel:.3f}x the limit at {probe.accel_at}"


def _drop(world: World, body: str, height_m: float, tilt: tuple[float, float]) -> tuple:
    """Drop a free object `height_m` onto the table; the deepest contact [m] in the step its
    contact is found, after that step, and at rest 1 s later."""
    m, d = world.model, world.data
    m.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    h = world.objects[body]
    mujoco.mj_resetData(m, d)
    d.qpos[world.arm_qpos] = world.home
    d.qpos[h.qpos_adr : h.qpos_adr + 3] = [
        0.6,
        -0.25,
        world.table_height + h.half_size[2] + height_m,
    ]
    quat = np.zeros(4)
    mujoco.mju_euler2Quat(quat, np.array([*tilt, 0.3]), "xyz")
    d.qpos[h.qpos_adr + 3 : h.qpos_adr + 7] = quat
    mujoco.mj_forward(m, d)
    first = after = rest = 0.0
    found = False
    for _ in range(int(1.5 / m.opt.timestep)):
        d.ctrl[world.arm_act] = d.qfrc_bias[world.arm_dof]
        mujoco.mj_step(m, d)
        depth = max(
            (
                -d.contact[k].dist
                for k in range(d.ncon)
                if h.geom_id in (d.contact[k].geom1, d.contact[k].geom2)
            ),
            default=0.0,
        )
        if depth > 0.0 and not found:
            found, first = True, depth
        elif found:
            after = max(after, depth)
        rest = depth
    return first, after, rest


@pytest.mark.parametrize("tilt", [(0.0, 0.0), (0.3, 0.2)])
def test_a_20_cm_drop_sinks_at_most_3_mm_and_rests_on_the_surface(tilt):
    """Every rigid surface shares one contact softness (robots/base.py): a cube dropped 20 cm
    (2 m/s) onto the table, flat or corner first, sinks at most 3 mm once its contact is found
    and rests 0.1 mm deep. In the step its contact is found, a corner may have crossed the
    surface by up to its speed x the step (4 mm): the step, not the softness."""
    world = World.build(load_scenario("pick_place").scenario, 0)
    first, after, rest = _drop(world, "cube", 0.2, tilt)
    assert after <= 0.003, f"{after * 1000:.2f} mm"
    assert first <= 2.0 * 0.2**0.5 * 9.81**0.5 * world.model.opt.timestep
    assert rest <= 0.1e-3, f"{rest * 1000:.3f} mm at rest"


def test_a_reshaped_conveyor_parcel_falls_at_g():
    # the conveyor gives its pooled bodies a new size and mass per parcel; MuJoCo 4 keeps the
    # mass matrix's diagonal at qpos0 for free bodies, which must follow (it did not: a
    # 0.4 kg parcel compiled at 0.05 kg fell at 8 g and hit the table at 4.8 m/s)
    world = World.build(load_scenario("sorting_conveyor").scenario, 0)
    m, d = world.model, world.data
    h = world.objects["pool_parcel_0"]
    slot = next(s for s in world.conveyor.slots if s.name == "pool_parcel_0")
    world.conveyor._reshape(slot, np.array([0.06, 0.042, 0.049]), 0.4, [1.0, 0.0, 0.0, 1.0])
    d.qpos[h.qpos_adr : h.qpos_adr + 3] = [0.45, 0.21, 0.40]
    d.qvel[h.qvel_adr : h.qvel_adr + 6] = 0.0
    mujoco.mj_forward(m, d)
    for _ in range(20):
        d.ctrl[world.arm_act] = d.qfrc_bias[world.arm_dof]
        mujoco.mj_step(m, d)
    assert d.qvel[h.qvel_adr + 2] == pytest.approx(-9.81 * 20 * m.opt.timestep, rel=1e-6)


def _complication(seed: int) -> tuple:
    """The complication's episode with the step probe and the nodule's contacts (neither reads
    the noisy sensor, so the run is the one the CLI makes)."""
    probe, nodule = StepProbe(), NoduleContacts()
    result = run_episode(load_scenario("surgical_complication"), seed, [probe, nodule])
    return result, probe, nodule


class NoduleContacts:
    """Every physics step: which geoms touch the nodule, with what normal force [N]."""

    def on_start(self, ctx, executor):
        self.nodule = ctx.model.geom("nodule").id
        self.touched: dict[str, float] = {}

    def on_tick(self, ctx, executor):
        pass

    def on_step(self, ctx):
        m, d = ctx.model, ctx.data
        out = np.zeros(6)
        for i in range(d.ncon):
            c = d.contact[i]
            if self.nodule in (c.geom1, c.geom2):
                other = m.geom(int(c.geom2 if c.geom1 == self.nodule else c.geom1)).name
                mujoco.mj_contactForce(m, d, i, out)
                self.touched[other] = max(self.touched.get(other, 0.0), float(out[0]))

    def on_end(self, ctx, executor, result):
        pass


@pytest.mark.slow  # a surgical complication run (~7 s)
def test_a_force_ceiling_watches_the_safety_response_itself():
    # SAFE_HOLD backs the probe out; 0.2 s in, the wrist feels 20 N (above the scenario's
    # 10 N ceiling): the response ends, the arm is stopped again and held
    fault = "ft_bias:force_n=[0,0,20]@SAFE_HOLD.BACK_OUT+0.2"
    result, _ = _run("surgical_complication", 0, faults=[fault])
    assert result.outcome == "aborted"
    assert result.reason is not None and result.reason["guard"] == "contact_force"
    moves = [(t["from"], t["to"]) for t in result.transitions]
    assert moves[-1] == ("SAFE_HOLD.BACK_OUT", "SAFE_STOP")
    assert result.final_state == "SAFE_STOP"
    assert result.metrics["rest_speed_rad_s"] < 0.01


def test_ik_holds_the_arms_posture_round_a_closed_path():
    """Three rounds of a 20 cm square, each side a move of its own (the IK re-seeded at the
    corner it reached, as `move` does): the TCP returns to its start, and so must the joints.
    Without a posture the 7th joint's freedom drifts (0.40 rad); the nullspace posture task
    holds it to < 1e-3 rad, at no cost to the TCP's accuracy."""
    robot = Panda()
    ik = IKSolver(robot, robot_only_model(robot), 0.01, np.zeros(3))
    q0 = np.array(robot.home)
    ik.reset(q0)
    p0, rot = ik.tcp_pose()
    corners = [p0 + np.array(c) for c in ([0, 0, 0], [0.2, 0, 0], [0.2, 0.2, 0], [0, 0.2, 0])]
    worst_tcp = 0.0
    for k in range(12):
        ik.reset(ik.q.copy())
        line = CartesianLine(corners[k % 4], rot, corners[(k + 1) % 4], rot, 0.5, 2.0, 2.0, 8.0)
        for i in range(int(np.ceil(line.duration / 0.01)) + 30):
            ik.step(*line.sample_so3((i + 1) * 0.01))
        worst_tcp = max(worst_tcp, float(np.linalg.norm(ik.tcp_pose()[0] - corners[(k + 1) % 4])))
    drift = float(np.max(np.abs(ik.q - q0)))
    assert worst_tcp < 1e-4, f"TCP {worst_tcp * 1000:.2f} mm off a corner"
    assert drift < 1e-3, f"the joints drifted {drift:.3f} rad round a closed path"


def test_ik_commands_stay_within_the_pandas_limits_whatever_the_target():
    """A target 45 cm away in one tick (a jump no move makes, a planner might): the IK wants
    far more than the arm may do; the command it sends stays within the Panda's velocity and
    acceleration limits, continuous from tick to tick, and still gets there."""
    robot = Panda()
    ik = IKSolver(robot, robot_only_model(robot), 0.01, np.zeros(3))
    ik.reset(np.array(robot.home))
    p0, rot = ik.tcp_pose()
    goal = p0 + np.array([0.0, 0.4, -0.2])
    vlim = robot.joint_velocity_limits()
    alim = np.asarray(robot.acceleration_limits, float)
    end_v = ik.velocity.copy()
    for _ in range(300):
        ik.step(goal, rot)
        assert np.all(np.abs(ik.velocity) <= vlim), f"joint speed {ik.velocity.round(2)}"
        assert np.all(np.abs(ik.acceleration) <= alim), f"accel {ik.acceleration.round(1)}"
        np.testing.assert_allclose(ik.velocity, end_v, atol=1e-12)  # no jump between ticks
        end_v = ik.limiter.velocity.copy()
    assert float(np.linalg.norm(ik.tcp_pose()[0] - goal)) < 1e-3
