"""Overhead of the framework: pick_place run by the framework vs. a hand-written loop.

The hand-written loop performs the same task as the bundled flow (machines/pick_place.yaml and
machines/grasp.yaml) with the same motion generator: `IKSolver` (mink IK + joint limiter),
`CartesianLine` / `BlendedPath` timed by Ruckig and the time-optimal path law and fitted by
the IK's dry runs (`fit_path_to_joints`, `feasible_time_scale`), the IK solved once per
control tick; the same settle times, tolerances, stop conditions and retries; the same end of
run (brake to rest, settle 0.2 s, judge). It runs on the same compiled model
(`World.build(scenario, seed)`) and plant (encoders with realism's quantization, the hand's
DC motor), at the same rates with the same controller (`orchestrator.robots.Controller`),
written as one sequential script: no executor, no guards, no blackboard, no skill classes,
no parameter validation, no events, no metrics, no recorder; no grasp planning, no move's
dry run along its path (reach, lag and torque checks), and a hand's drive of its own (a
servo to an opening, full voltage to close) instead of the framework's current-limited one.
The arm follows the same path (a live IK step gives the reference a dry run's row would);
the grasp takes a few ticks less, so cycle times differ by tens of milliseconds: the ratios
below are of CPU (and wall) time per simulated second.

Each pair runs both on the same seed, in alternating order (drift in the machine's load hits
both alike); the figure is the median of the per-pair ratios, in wall time and in CPU time
(`time.thread_time`, robust to other processes on a shared machine).

    python bench/overhead.py [--pairs 20] [--seed-base 0] [--without-guard-checks]
                             [--pure-python]

`--pure-python` runs the framework's per-step readings and envelope test on their pure-Python
path (`ORCHESTRATOR_PURE_PYTHON=1`, orchestrator/world/native.py) instead of the compiled one;
the hand-written loop uses neither. `--without-guard-checks` runs the framework with its
guards active but never checked (a diagnostic, not a mode the framework offers): the
difference is what checking them every physics step costs. The machine's load average is
printed with the figures: on a shared machine the ratio grows with it (other processes evict
the caches the Python on the physics step relies on). bench/realtime.py runs the same
hand-written loop beside the framework's scenarios, for scale.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time
from dataclasses import dataclass

import mink
import mujoco
import numpy as np
from orchestrator.robots import Controller
from orchestrator.skills.blended_path import BlendedPath
from orchestrator.skills.ik import IKSolver
from orchestrator.skills.targets import rot_down, yaw_of_rot
from orchestrator.skills.time_scaling import feasible_time_scale, fit_path_to_joints
from orchestrator.skills.trajectory import CartesianLine

from orchestrator.engine.executor import Executor
from orchestrator.engine.runner import run_episode
from orchestrator.language.load import LoadedScenario, load_scenario
from orchestrator.language.scenario import Scenario
from orchestrator.world import World, as_index, robot_only_model
from orchestrator.world.native import PURE_PYTHON_ENV, native
from orchestrator.world.pose import quat_from_yaw, yaw_of
from orchestrator.world.realism import link_mass_scale
from orchestrator.world.sensors import JointEncoders

HOVER = np.array([0.0, 0.0, 0.10])
"""Pre-grasp and place approach height above the target [m] (the flow's `hover`)."""
LIFT = np.array([0.0, 0.0, 0.05])
"""Lift from the grasp pose [m] (the grasp machine's `lift`)."""
PLACE = np.array([0.0, 0.0, 0.030])
"""TCP height above the pad when releasing [m] (the flow's `place_height`)."""
PRESHAPE_M = 0.030
"""Each finger's opening on the approach [m] (the grasp machine's `preshape_m`)."""
RELEASE_M = 0.031
"""Each finger's opening at the place [m] (OPEN's `opening_m`)."""
AT_REST_MPS = 0.005
"""TCP speed below which a move counts as at rest [m/s] (skills/move.py)."""
GRIP_SPEED = 0.9
"""Largest voltage (fraction of the motor's free speed) the hand is driven at to an opening."""
GRIP_GAIN = 0.5
"""Fraction of a finger's distance to its opening the drive takes out per control tick."""
SETTLE_S = 0.2
"""Simulated time after the task before success is judged [s] (engine/runner.py)."""
SETTLE_GAIN = 8.0
"""Integral gain of the settling correction once a line has ended [1/s] (skills/move.py)."""
MAX_CORRECTION_M = 0.015
"""Largest settling correction of the position [m] (skills/move.py)."""
MAX_CORRECTION_RAD = math.radians(3.0)
"""Largest settling correction of the orientation [rad] (skills/move.py)."""


@dataclass
class Episode:
    """What one episode did: wall and CPU time [s] from building the world to the result,
    simulated time [s], cycle time [s] (None if it failed) and success."""

    wall_s: float
    cpu_s: float
    sim_s: float
    cycle_s: float | None
    ok: bool

    @property
    def cpu_per_sim(self) -> float:
        """CPU seconds per simulated second (1 / the CPU real-time factor)."""
        return self.cpu_s / self.sim_s

    @property
    def wall_per_sim(self) -> float:
        """Wall seconds per simulated second."""
        return self.wall_s / self.sim_s


class HandWritten:
    """Pick and place written out as one sequential script on the framework's motion
    generator. Every phase starts on the control tick the previous one ended on, then runs
    `physics()` and its checks once per control tick, as the executor's skills do."""

    def __init__(self, scenario: Scenario, seed: int) -> None:
        self.world = w = World.build(scenario, seed)
        self.model, self.data = w.model, w.data
        dt = float(self.model.opt.timestep)
        self.n_sub = max(1, round(1.0 / (scenario.physics.control_hz * dt)))
        self.dt_c = self.n_sub * dt
        realism = scenario.physics.realism
        n_bodies = w.robot.pinocchio_model().njoints - 1
        self.ctrl = Controller(w.robot, dt, link_mass_scale(realism, n_bodies, seed))
        self.ctrl.hold(w.home)
        self.ik = IKSolver(w.robot, robot_only_model(w.robot), self.dt_c, scenario.robot.base_pos)
        self.rng = np.random.default_rng([seed, 1])
        self.noise = scenario.perception
        self.stop_cfg = scenario.physics.safe_stop
        self.n = w.robot.n_arm
        d = self.data
        # views bound once (MjData never reallocates): the Panda's joints are contiguous
        self.q_all, self.qd_all = d.qpos[_span(w.robot_qpos)], d.qvel[_span(w.robot_dof)]
        self.arm_q, self.arm_qd = d.qpos[_span(w.arm_qpos)], d.qvel[_span(w.arm_dof)]
        self.act = as_index(w.arm_act)
        # the same plant: the controller and the skills read the joints through the encoders
        # (quantized, velocity differenced and filtered, with `physics.realism`)
        quantize = realism.enabled and realism.encoder_quantization
        self.encoders = JointEncoders(
            d.qpos,
            d.qvel,
            as_index(w.robot_qpos),
            as_index(w.robot_dof),
            self.n,
            np.random.default_rng([seed, 0xE2C0]),
            w.robot.encoder_resolution_rad if quantize else 0.0,
            w.step_clock,  # advanced with every mj_step below, as the framework's step does
        )
        self.clock, self.dt = w.step_clock, float(w.model.opt.timestep)
        self.loop_views = (self.encoders.read, self.act)
        self.fingers_q = d.qpos[_span(w.finger_qpos)]
        self.fingers_qd = d.qvel[_span(w.robot_dof[self.n :])]
        self.tcp_pos = d.site_xpos[w.tcp_site]
        self.tcp_rot = d.site_xmat[w.tcp_site].reshape(3, 3)
        self.grip_act = w.gripper_act
        self.grip_target = w.robot.gripper_open_m
        self.grip_gain = GRIP_GAIN / (w.robot.gripper_speed_mps * self.dt_c)
        self.cube = w.objects["cube"]
        self.cube_pose = d.qpos[self.cube.qpos_adr : self.cube.qpos_adr + 7]
        self.pad = w.markers["pad"]
        self.cycle_s: float | None = None

    @property
    def t(self) -> float:
        return self.clock.t

    def read_q(self) -> np.ndarray:
        """The arm's joint angles as the encoders read them [rad] (the skills' `ctx.q`)."""
        return self.encoders.read()[0][: self.n].copy()

    # -- the loop -----------------------------------------------------------------------
    def physics(self) -> None:
        """One control period: the fingers' setpoint, then controller and mj_step at 500 Hz."""
        self.advance_gripper()
        m, d, compute, (read, act) = self.model, self.data, self.ctrl.compute, self.loop_views
        clock, dt = self.clock, self.dt
        for _ in range(self.n_sub):
            d.ctrl[act] = compute(*read())
            mujoco.mj_step(m, d)
            clock.t += dt

    def advance_gripper(self) -> None:
        """The hand's motor (its ctrl a voltage in [-1, 1]: free, the fingers run at that
        fraction of the gripper's speed; stalled, they push with that fraction of its force).
        To an opening: a proportional servo at up to 90 % of the speed. Closing (0): full
        voltage, the fingers stall on the object and squeeze with the whole grip force."""
        goal = self.grip_target
        if goal <= 0.0:
            self.data.ctrl[self.grip_act] = -1.0
            return
        error = goal - 0.5 * float(self.fingers_q.sum())
        self.data.ctrl[self.grip_act] = min(max(self.grip_gain * error, -GRIP_SPEED), GRIP_SPEED)

    def finger_forces(self) -> tuple[float, float]:
        """Normal force [N] of the left and the right finger on the cube."""
        m, d = self.model, self.data
        left, right = self.world.finger_body_ids
        cube = self.cube.geom_id
        out = [0.0, 0.0]
        wrench = np.zeros(6)
        for i in range(d.ncon):
            con = d.contact[i]
            if cube not in (con.geom1, con.geom2):
                continue
            body = m.geom_bodyid[con.geom2 if con.geom1 == cube else con.geom1]
            if body in (left, right):
                mujoco.mj_contactForce(m, d, i, wrench)
                out[0 if body == left else 1] += abs(float(wrench[0]))
        return out[0], out[1]

    # -- the task -----------------------------------------------------------------------
    def run(self) -> bool:
        """Pick (three attempts), place, retreat, stop, judge."""
        picked = False
        for _ in range(3):  # PICK: retry 2 on a miss
            seen = self.search()
            if self.approach(seen) == "unreachable":
                continue
            if not self.close():
                self.release(self.world.robot.gripper_open_m)
                continue
            self.move(seen[0] + LIFT, None, 0.5, 6.0, 0.005, 1.0, stop_at_target=False)
            if not self.verify():
                self.release(self.world.robot.gripper_open_m)
                continue
            picked = True
            break
        if picked:
            pad = self.pad
            outcome = self.move(
                pad + PLACE, None, 1.0, 4.0, 0.002, settle_s=0.3, vias=[pad + HOVER]
            )
            if outcome != "unreachable" and self.release(RELEASE_M):
                outcome = self.move(pad + HOVER, None, 0.8, 6.0, 0.005, 2.0, stop_at_target=False)
                if outcome != "unreachable":
                    self.cycle_s = self.t
        self.stop_and_settle()
        return self.cycle_s is not None and self.placed()

    def search(self) -> tuple[np.ndarray, float]:
        """Wait for perception (0.1 s), then the cube's pose with the scenario's noise."""
        t0 = self.t
        while self.t - t0 < 0.1:
            self.physics()
        pose = self.cube_pose
        pos = pose[:3] + self.rng.normal(0.0, self.noise.position_noise_m, 3) * [1, 1, 0]
        yaw = yaw_of(pose[3:]) + self.rng.normal(0.0, math.radians(self.noise.yaw_noise_deg))
        self.ctrl.hold(self.read_q())
        return np.asarray(pos.tolist()), yaw_of(quat_from_yaw(yaw))

    def approach(self, seen: tuple[np.ndarray, float]) -> str:
        """Through the hover point above the cube (yaw aligned) down to it, fingers pre-shaped."""
        pos, yaw_goal = seen
        yaw = yaw_of_rot(self.tcp_rot)
        period = math.radians(90.0)
        yaw = yaw_goal + round((yaw - yaw_goal) / period) * period
        return self.move(pos, rot_down(yaw), 1.0, 6.0, vias=[pos + HOVER], gripper_m=PRESHAPE_M)

    def move(
        self,
        pos1: np.ndarray,
        rot1: np.ndarray | None,
        v: float,
        a: float,
        tol_m: float = 0.001,
        tol_deg: float = 0.5,
        settle_s: float = 1.0,
        stop_at_target: bool = True,
        vias: list[np.ndarray] | None = None,
        gripper_m: float | None = None,
    ) -> str:
        """The TCP to `pos1` [m] with orientation `rot1` (None: keep), straight or through
        `vias` with 4 cm blends; `reached`, `unreachable` or `timeout`."""
        ik, ctrl = self.ik, self.ctrl
        rot0 = self.tcp_rot.copy()
        rot1 = rot0 if rot1 is None else rot1
        q0 = self.read_q()
        ik.reset(q0)
        if gripper_m is not None:
            self.grip_target = gripper_m
        path: CartesianLine | BlendedPath
        if vias:
            path = BlendedPath(
                np.array([self.tcp_pos, *vias, pos1]), rot0, rot1, v, a, 2.0, 8.0, 0.04
            )
        else:
            path = CartesianLine(self.tcp_pos.copy(), rot0, pos1, rot1, v, a, 2.0, 8.0)
        t0 = self.t
        if vias:
            fit_path_to_joints(ik, path, q0)  # type: ignore[arg-type]
        stretch = feasible_time_scale(ik, path, q0)
        ik.restart_from(ctrl.q_d, ctrl.qd_d)  # the command continues from the setpoint
        duration = path.duration * stretch
        tol_rad = math.radians(tol_deg)
        corr_pos, corr_rot = np.zeros(3), np.zeros(3)
        last = self.tcp_pos.copy()
        stalled = 0
        outcome = None
        while outcome is None:
            self.physics()
            elapsed = self.t - t0
            pos, rot = path.sample_so3(elapsed / stretch)
            if elapsed >= duration:  # the settling correction: integrate the TCP's error
                corr_pos += SETTLE_GAIN * self.dt_c * (pos1 - self.tcp_pos)
                norm = float(np.linalg.norm(corr_pos))
                if norm > MAX_CORRECTION_M:
                    corr_pos *= MAX_CORRECTION_M / norm
                tcp_rot = self.tcp_rot
                corr_rot += (
                    SETTLE_GAIN
                    * self.dt_c
                    * (tcp_rot @ mink.SO3.from_matrix(tcp_rot.T @ rot1).log())
                )
                norm = float(np.linalg.norm(corr_rot))
                if norm > MAX_CORRECTION_RAD:
                    corr_rot *= MAX_CORRECTION_RAD / norm
                pos, rot = pos + corr_pos, mink.SO3.exp(corr_rot) @ rot
            q = ik.step(pos, rot)
            ctrl.set_joint_target(q, ik.velocity, ik.acceleration)
            tcp = self.tcp_pos
            if elapsed < duration:
                last[:] = tcp
                continue
            speed = float(np.linalg.norm(tcp - last)) / self.dt_c
            last[:] = tcp
            r_err = self.tcp_rot.T @ rot1
            ang_err = math.acos(max(-1.0, min(1.0, (np.trace(r_err) - 1.0) / 2.0)))
            if np.linalg.norm(tcp - pos1) <= tol_m and ang_err <= tol_rad:
                if speed < AT_REST_MPS or not stop_at_target:
                    outcome = "reached"
                    break
            err = ik.error
            converged = (
                np.linalg.norm(err[:3]) <= 0.5 * tol_m and np.linalg.norm(err[3:]) <= 0.5 * tol_rad
            )
            if not converged and float(np.max(np.abs(ik.velocity))) < 1e-3:
                stalled += 1
                if stalled >= 10:
                    outcome = "unreachable"
            else:
                stalled = 0
            if outcome is None and elapsed > duration + settle_s:
                outcome = "unreachable" if not converged else "timeout"
        ctrl.hold_setpoint()  # no jump of the setpoint or its velocity
        return outcome

    def close(self) -> bool:
        """Close until the fingers stop (squeezing); True if both press with >= 5 N on the
        cube and it lies between them."""
        ctrl = self.ctrl
        ctrl.hold_setpoint()
        self.grip_target = 0.0
        t0, still = self.t, 0
        while True:
            self.physics()
            elapsed = self.t - t0
            still = still + 1 if float(np.max(np.abs(self.fingers_qd))) < 0.005 else 0
            if elapsed >= 0.1 and (still >= 3 or elapsed >= 1.5):
                break
        left, right = self.finger_forces()
        rel = self.tcp_rot.T @ (self.cube_pose[:3] - self.tcp_pos)
        half = float(max(self.cube.half_size))
        between = abs(rel[0]) < half + 0.01 and abs(rel[2]) < half + 0.02
        ctrl.hold_setpoint()
        return min(left, right) >= 5.0 and between

    def verify(self) -> bool:
        """For 50 ms: both fingers press, the cube is within 2 cm of the TCP, off the table."""
        self.ctrl.hold_setpoint()
        t0 = self.t
        table, half_z = self.world.table_height, self.cube.half_size[2]
        while True:
            self.physics()
            left, right = self.finger_forces()
            cube = self.cube_pose[:3]
            if (
                min(left, right) < 5.0
                or np.linalg.norm(cube - self.tcp_pos) > 0.02
                or not cube[2] - half_z - table >= 0.02
            ):
                held = False
                break
            if self.t - t0 >= 0.05:
                held = True
                break
        self.ctrl.hold(self.read_q())
        return held

    def release(self, opening: float) -> bool:
        """Open each finger to `opening` [m]; False if they are not there within 1 s."""
        ctrl = self.ctrl
        opening = min(opening, self.world.robot.gripper_open_m)
        ctrl.hold_setpoint()
        self.grip_target = opening
        t0 = self.t
        while True:
            self.physics()
            if float(self.fingers_q.sum()) >= 2 * opening - 0.002:
                ok = True
                break
            if self.t - t0 > 1.0:
                ok = False
                break
        ctrl.hold_setpoint()
        return ok

    def stop_and_settle(self) -> None:
        """Brake the arm to rest at its acceleration limits, hold, let 0.2 s pass."""
        ctrl, cfg, d = self.ctrl, self.stop_cfg, self.data
        if float(np.max(np.abs(self.arm_qd))) < cfg.rest_speed_rad_s:
            ctrl.hold_setpoint()
        else:
            ctrl.brake(self.q_all, self.qd_all, self.world.robot.acceleration_limits)
        t0 = self.t
        settle_until = t0 + SETTLE_S
        m, compute, (read, act) = self.model, ctrl.compute, self.loop_views
        clock, dt = self.clock, self.dt
        at_rest = False
        while not (at_rest and self.t >= settle_until - 1e-9) and self.t - t0 < cfg.max_stop_s:
            self.advance_gripper()
            for _ in range(self.n_sub):
                d.ctrl[act] = compute(*read())
                mujoco.mj_step(m, d)
                clock.t += dt
                if not at_rest and ctrl.brake_left_s <= 0.0:
                    at_rest = float(np.max(np.abs(self.arm_qd))) < cfg.rest_speed_rad_s

    def placed(self) -> bool:
        """Cube upright and resting within 1 cm of the pad's centre, fingers open and clear."""
        pose = self.cube_pose
        w, x, y, z = pose[3:]
        upright = 1.0 - 2.0 * (x * x + y * y) >= math.cos(math.radians(10.0))
        half = self.cube.half_size
        resting = pose[2] < self.world.table_height + half[2] + 0.01
        on_pad = float(np.linalg.norm(pose[:2] - self.pad[:2])) <= 0.01
        wide = float(self.fingers_q.sum()) >= 2.0 * float(max(half)) + 0.01
        fromto = np.zeros(6)
        clear = all(
            mujoco.mj_geomDistance(self.model, self.data, g, self.cube.geom_id, 0.055, fromto)
            >= 0.005
            for g in self.world.finger_geoms
        )
        return bool(upright and resting and on_pad and wide and clear)


def _span(index: np.ndarray) -> slice:
    span = as_index(index)
    if not isinstance(span, slice):
        raise ValueError(f"joint addresses {index.tolist()} are not contiguous")
    return span


def hand_written(scenario: Scenario, seed: int) -> Episode:
    """One hand-written episode, timed from building the world to the success check."""
    t0, c0 = time.perf_counter(), time.thread_time()
    episode = HandWritten(scenario, seed)
    ok = episode.run()
    wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
    return Episode(wall, cpu, episode.t, episode.cycle_s, ok)


def framework(loaded: LoadedScenario, seed: int) -> Episode:
    """One framework episode (`run_episode`, no observers), timed the same way."""
    t0, c0 = time.perf_counter(), time.thread_time()
    result = run_episode(loaded, seed)
    wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
    ok = result.outcome == "succeeded"
    return Episode(wall, cpu, result.sim_time, result.metrics.get("cycle_time"), ok)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=20, help="Paired runs (seeds).")
    parser.add_argument("--seed-base", type=int, default=0)
    parser.add_argument(
        "--without-guard-checks",
        action="store_true",
        help="Diagnostic: the framework's guards are never checked (what they cost).",
    )
    parser.add_argument(
        "--pure-python",
        action="store_true",
        help="The framework's per-step readings and envelope test in Python, not compiled.",
    )
    args = parser.parse_args()
    if args.without_guard_checks:
        _skip_guard_checks()
    if args.pure_python:
        os.environ[PURE_PYTHON_ENV] = "1"
    print(f"per-step readings and envelope test: {'compiled' if native() else 'pure Python'}")
    loaded = load_scenario("pick_place")
    load0 = os.getloadavg()[0]
    framework(loaded, 10_000)  # warm caches (robot model, imports) for both
    hand_written(loaded.scenario, 10_000)
    pairs: list[tuple[Episode, Episode]] = []
    for i in range(args.pairs):
        seed = args.seed_base + i
        if i % 2 == 0:  # alternate the order: drift in machine load hits both alike
            fw = framework(loaded, seed)
            hw = hand_written(loaded.scenario, seed)
        else:
            hw = hand_written(loaded.scenario, seed)
            fw = framework(loaded, seed)
        pairs.append((fw, hw))
        print(
            f"seed {seed:3d}: framework {fw.wall_s * 1e3:6.1f} ms wall {fw.cpu_s * 1e3:6.1f} ms "
            f"cpu, cycle {_cycle(fw)} | hand-written {hw.wall_s * 1e3:6.1f} ms wall "
            f"{hw.cpu_s * 1e3:6.1f} ms cpu, cycle {_cycle(hw)} | per simulated second ratio "
            f"wall {fw.wall_per_sim / hw.wall_per_sim:.3f} cpu "
            f"{fw.cpu_per_sim / hw.cpu_per_sim:.3f}",
            flush=True,
        )
    med = statistics.median
    wall = [fw.wall_per_sim / hw.wall_per_sim for fw, hw in pairs]
    cpu = [fw.cpu_per_sim / hw.cpu_per_sim for fw, hw in pairs]
    print()
    for name, idx in (("framework", 0), ("hand-written", 1)):
        eps = [p[idx] for p in pairs]
        print(
            f"{name:13s} median {med(e.wall_s for e in eps) * 1e3:6.1f} ms wall, "
            f"{med(e.cpu_s for e in eps) * 1e3:6.1f} ms cpu, {med(e.sim_s for e in eps):.2f} s "
            f"sim, {med(1.0 / e.cpu_per_sim for e in eps):5.1f}x CPU real time, "
            f"success {sum(e.ok for e in eps)}/{len(eps)}"
        )
    same_ok = sum(fw.ok == hw.ok for fw, hw in pairs)
    cycles = [
        fw.cycle_s - hw.cycle_s
        for fw, hw in pairs
        if fw.cycle_s is not None and hw.cycle_s is not None
    ]
    spread = f"{min(cycles):+.3f} to {max(cycles):+.3f} s" if cycles else "n/a"
    print(
        f"same task: success agrees on {same_ok}/{len(pairs)} seeds, cycle time "
        f"framework - hand-written {spread}"
    )
    print(
        f"overhead ratio, wall per simulated second (framework / hand-written): median "
        f"{med(wall):.3f} (IQR {_iqr(wall)}, {len(pairs)} pairs)"
    )
    print(
        f"same ratio in CPU time (thread_time, robust to a busy machine): median {med(cpu):.3f} "
        f"(IQR {_iqr(cpu)})"
    )
    # the ratio grows with the machine's load (other processes evict the caches the Python
    # on the physics step relies on): say what it was measured at
    print(f"load average (1 min) {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end")


def _skip_guard_checks() -> None:
    changed = Executor.changed

    def without_checks(self: Executor) -> None:
        changed(self)
        self.active_checks = ()

    Executor.changed = without_checks  # type: ignore[method-assign]


def _cycle(e: Episode) -> str:
    cycle = f"{e.cycle_s:.2f} s" if e.cycle_s is not None else "  -   "
    return f"{cycle} {'ok' if e.ok else 'FAILED'}"


def _iqr(xs: list[float]) -> str:
    if len(xs) < 2:
        return "n/a"
    q = statistics.quantiles(xs, n=4)
    return f"{q[0]:.3f} - {q[2]:.3f}"


if __name__ == "__main__":
    main()
