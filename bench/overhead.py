"""Overhead of the framework: pick_place run by the framework vs. a hand-written loop.

The hand-written loop does the same pick-and-place on the same compiled model
(`World.build(scenario, seed)`) at the same rates (500 Hz physics, 100 Hz IK) with the same
controller law (`orchestrator.robots.Controller`) and mink used directly: no executor, no
guards, no blackboard, no skills, no recorder. Each pair runs both on the same seed, in
alternating order; the figure is the median of the per-pair ratios.

    python bench/overhead.py [--pairs 15] [--seed-base 0]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from dataclasses import dataclass

import mink
import mujoco
import numpy as np
from orchestrator.robots import Controller

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import LoadedScenario, load_scenario
from orchestrator.language.scenario import Scenario
from orchestrator.world import World, as_index, robot_only_model

DOWN = np.diag([1.0, -1.0, -1.0])
"""TCP pointing down, fingers closing along world y."""
HOVER = np.array([0.0, 0.0, 0.10])
"""Pre-grasp, lift and retreat height above the target [m]."""
PLACE = np.array([0.0, 0.0, 0.03])
"""TCP height above the pad when releasing [m]."""


@dataclass
class Episode:
    """What one episode did: wall and CPU time [s] from building the world to the result."""

    wall_s: float
    cpu_s: float
    sim_s: float
    ok: bool


def _trapezoid(distance: float, v_max: float, a_max: float) -> tuple[float, float, float]:
    """(t_acc [s], t_cruise [s], duration [s]) of a rest-to-rest profile."""
    t_acc = v_max / a_max
    if a_max * t_acc * t_acc >= distance:
        t_acc = math.sqrt(distance / a_max)
        return t_acc, 0.0, 2.0 * t_acc
    t_cruise = (distance - a_max * t_acc * t_acc) / v_max
    return t_acc, t_cruise, 2.0 * t_acc + t_cruise


def _progress(t: float, distance: float, a_max: float, t_acc: float, t_cruise: float) -> float:
    """Normalized position in [0, 1] along a trapezoidal profile at time `t` [s]."""
    if distance <= 0.0:
        return 1.0
    total = 2.0 * t_acc + t_cruise
    t = min(max(t, 0.0), total)
    if t < t_acc:
        pos = 0.5 * a_max * t * t
    elif t < t_acc + t_cruise:
        pos = 0.5 * a_max * t_acc * t_acc + a_max * t_acc * (t - t_acc)
    else:
        tr = total - t
        pos = distance - 0.5 * a_max * tr * tr
    return pos / distance


class HandWritten:
    """Pick and place written out as one sequential script."""

    def __init__(self, scenario: Scenario, seed: int) -> None:
        self.world = w = World.build(scenario, seed)
        self.model, self.data = w.model, w.data
        self.dt = float(self.model.opt.timestep)
        self.n_sub = max(1, round(1.0 / (scenario.physics.control_hz * self.dt)))
        self.dt_c = self.n_sub * self.dt
        self.ctrl = Controller(w.robot, self.dt)
        self.ctrl.hold(w.home)
        self.q_idx, self.v_idx = as_index(w.robot_qpos), as_index(w.robot_dof)
        self.arm = as_index(w.arm_qpos)
        self.act = as_index(w.arm_act)
        self.rng = np.random.default_rng([seed, 1])
        self.base = np.asarray(scenario.robot.base_pos, float)
        self.noise = scenario.perception
        ik_model = robot_only_model(w.robot.name)
        self.config = mink.Configuration(ik_model)
        self.frame_task = mink.FrameTask(
            w.robot.tcp_site, "site", position_cost=1.0, orientation_cost=1.0, lm_damping=1e-6
        )
        self.posture = mink.PostureTask(ik_model, cost=1e-3)
        self.limits = [
            mink.ConfigurationLimit(ik_model),
            mink.VelocityLimit(ik_model, {j: 2.0 for j in w.robot.arm_joints}),
        ]
        self.n = w.robot.n_arm
        self.cube = w.objects["cube"]
        self.pad = w.markers["pad"]

    # -- the loop ---------------------------------------------------------------------------
    def physics(self) -> None:
        """One control period: controller and mj_step at the physics rate."""
        m, d, ctrl = self.model, self.data, self.ctrl
        for _ in range(self.n_sub):
            d.ctrl[self.act] = ctrl.compute(d.qpos[self.q_idx], d.qvel[self.v_idx])
            mujoco.mj_step(m, d)

    @property
    def t(self) -> float:
        return float(self.data.time)

    def tcp(self) -> tuple[np.ndarray, np.ndarray]:
        d, s = self.data, self.world.tcp_site
        return d.site_xpos[s].copy(), d.site_xmat[s].reshape(3, 3).copy()

    def finger_forces(self) -> tuple[float, float]:
        m, d = self.model, self.data
        left, right = self.world.finger_body_ids
        out = [0.0, 0.0]
        wrench = np.zeros(6)
        for i in range(d.ncon):
            con = d.contact[i]
            if self.cube.geom_id not in (con.geom1, con.geom2):
                continue
            other = con.geom2 if con.geom1 == self.cube.geom_id else con.geom1
            body = m.geom_bodyid[other]
            if body in (left, right):
                mujoco.mj_contactForce(m, d, i, wrench)
                out[0 if body == left else 1] += abs(float(wrench[0]))
        return out[0], out[1]

    # -- the task -----------------------------------------------------------------------------
    def run(self) -> bool:
        # look: wait for the perception time, then read the cube's pose with noise
        self.wait(0.1)
        self.ctrl.hold(self.data.qpos[self.arm].copy())
        qpos = self.data.qpos[self.cube.qpos_adr : self.cube.qpos_adr + 7]
        pos = qpos[:3] + self.rng.normal(0.0, self.noise.position_noise_m, 3) * [1, 1, 0]
        w, x, y, z = qpos[3:]
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        yaw += self.rng.normal(0.0, math.radians(self.noise.yaw_noise_deg))
        # grasp
        self.move(pos + HOVER, yaw=yaw, v=0.8, a=4.0, tol_m=0.002, tol_deg=1.0)
        self.move(pos, yaw=yaw, v=0.4, a=4.0)
        self.close()
        self.move(pos + HOVER, v=0.5, a=4.0, tol_m=0.003, tol_deg=1.0)
        if not self.verify():
            return False
        # place
        self.move(self.pad + HOVER, v=0.8, a=4.0, tol_m=0.003, tol_deg=1.0)
        self.move(self.pad + PLACE, v=0.4, a=4.0, tol_m=0.002, settle_s=0.3)
        self.open()
        self.move(self.pad + HOVER, v=0.8, a=4.0, tol_m=0.005, tol_deg=2.0)
        # settle, then check
        self.ctrl.hold(self.ctrl.q_d.copy())
        end = self.t + 0.2
        while self.t < end - 1e-9:
            self.physics()
        c = self.data.qpos[self.cube.qpos_adr : self.cube.qpos_adr + 3]
        return bool(np.linalg.norm(c[:2] - self.pad[:2]) <= 0.01)

    def wait(self, seconds: float) -> None:
        t0 = self.t
        while self.t - t0 < seconds:
            self.physics()

    def move(
        self,
        pos1: np.ndarray,
        yaw: float | None = None,
        v: float = 0.5,
        a: float = 2.0,
        tol_m: float = 0.001,
        tol_deg: float = 0.5,
        settle_s: float = 1.0,
    ) -> bool:
        """Straight line to `pos1`: pointing down turned to the nearest symmetric `yaw`, or
        keeping the start orientation when `yaw` is None. True once there and at rest."""
        pos0, rot0 = self.tcp()
        if yaw is None:
            rot1 = rot0
        else:
            cur = math.atan2(rot0[1, 0], rot0[0, 0])
            period = math.pi / 2
            yaw = yaw + round((cur - yaw) / period) * period
            c, s = math.cos(yaw), math.sin(yaw)
            rot1 = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ DOWN
        q = self.config.q.copy()
        q[: self.n] = self.data.qpos[self.arm]
        self.config.update(q)
        self.posture.set_target(q)
        r0 = mink.SO3.from_matrix(rot0)
        delta = (r0.inverse() @ mink.SO3.from_matrix(rot1)).log()
        dist_lin, dist_ang = float(np.linalg.norm(pos1 - pos0)), float(np.linalg.norm(delta))
        lin, ang = _trapezoid(dist_lin, v, a), _trapezoid(dist_ang, 2.0, 8.0)
        dist, acc, (t_acc, t_cruise, duration) = (
            (dist_lin, a, lin) if lin[2] >= ang[2] else (dist_ang, 8.0, ang)
        )
        vel = np.zeros(self.n)
        last = pos0.copy()
        t0 = self.t
        try:
            while True:
                el = self.t - t0
                s = _progress(el, dist, acc, t_acc, t_cruise)
                target = mink.SE3.from_rotation_and_translation(
                    r0 @ mink.SO3.exp(s * delta), pos0 + s * (pos1 - pos0) - self.base
                )
                self.frame_task.set_target(target)
                dq = mink.solve_ik(
                    self.config,
                    [self.frame_task, self.posture],
                    self.dt_c,
                    "daqp",
                    damping=1e-4,
                    limits=self.limits,
                )
                self.config.integrate_inplace(dq, self.dt_c)
                acc_j = (dq[: self.n] - vel) / self.dt_c
                vel = dq[: self.n].copy()
                self.ctrl.set_joint_target(self.config.q[: self.n], vel, acc_j)
                tcp_pos, tcp_rot = self.tcp()
                speed = float(np.linalg.norm(tcp_pos - last)) / self.dt_c
                last = tcp_pos
                if el >= duration:
                    r_err = tcp_rot.T @ rot1
                    ang_err = math.acos(max(-1.0, min(1.0, (np.trace(r_err) - 1.0) / 2.0)))
                    there = np.linalg.norm(tcp_pos - pos1) <= tol_m
                    if there and ang_err <= math.radians(tol_deg) and speed < 0.005:
                        return True
                    if el > duration + settle_s:
                        return False
                self.physics()
        finally:
            self.ctrl.hold(self.config.q[: self.n].copy())

    def close(self) -> bool:
        self.ctrl.hold(self.ctrl.q_d.copy())
        self.data.ctrl[self.world.gripper_act] = 0.0
        fingers = self.world.robot_dof[self.n :]
        t0, still = self.t, 0
        while True:
            el = self.t - t0
            still = still + 1 if np.max(np.abs(self.data.qvel[fingers])) < 0.005 else 0
            if el >= 0.1 and (still >= 3 or el >= 1.5):
                left, right = self.finger_forces()
                self.ctrl.hold(self.ctrl.q_d.copy())
                return min(left, right) >= 5.0
            self.physics()

    def verify(self) -> bool:
        self.ctrl.hold(self.ctrl.q_d.copy())
        t0 = self.t
        while True:
            left, right = self.finger_forces()
            cube = self.data.qpos[self.cube.qpos_adr : self.cube.qpos_adr + 3]
            held = min(left, right) >= 5.0 and np.linalg.norm(cube - self.tcp()[0]) <= 0.02
            if not held:
                return False
            if self.t - t0 >= 0.05:
                self.ctrl.hold(self.data.qpos[self.arm].copy())
                return True
            self.physics()

    def open(self) -> bool:
        self.ctrl.hold(self.ctrl.q_d.copy())
        opening = self.world.robot.gripper_open_m
        self.data.ctrl[self.world.gripper_act] = opening
        t0 = self.t
        try:
            while True:
                width = float(self.data.qpos[self.world.finger_qpos].sum())
                if width >= 2 * opening - 0.002:
                    return True
                if self.t - t0 > 1.0:
                    return False
                self.physics()
        finally:
            self.ctrl.hold(self.ctrl.q_d.copy())


def hand_written(scenario: Scenario, seed: int) -> Episode:
    """One hand-written episode, timed from building the world to the success check."""
    t0, c0 = time.perf_counter(), time.thread_time()
    episode = HandWritten(scenario, seed)
    ok = episode.run()
    return Episode(time.perf_counter() - t0, time.thread_time() - c0, episode.t, ok)


def framework(loaded: LoadedScenario, seed: int) -> Episode:
    """One framework episode (`run_episode`, no observers), timed the same way."""
    t0, c0 = time.perf_counter(), time.thread_time()
    result = run_episode(loaded, seed)
    wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
    return Episode(wall, cpu, result.sim_time, result.outcome == "succeeded")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=15, help="Paired runs (seeds).")
    parser.add_argument("--seed-base", type=int, default=0)
    args = parser.parse_args()
    loaded = load_scenario("pick_place")
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
            f"seed {seed:3d}: framework {fw.wall_s * 1e3:6.1f} ms wall "
            f"{fw.cpu_s * 1e3:6.1f} ms cpu "
            f"({fw.sim_s:.2f} s sim, {'ok' if fw.ok else 'FAILED'}) | hand-written "
            f"{hw.wall_s * 1e3:6.1f} ms wall {hw.cpu_s * 1e3:6.1f} ms cpu ({hw.sim_s:.2f} s sim, "
            f"{'ok' if hw.ok else 'FAILED'}) | ratio {fw.wall_s / hw.wall_s:.3f}"
        )
    med = statistics.median
    wall = [fw.wall_s / hw.wall_s for fw, hw in pairs]
    cpu = [fw.cpu_s / hw.cpu_s for fw, hw in pairs]
    per_sim = [(fw.wall_s / fw.sim_s) / (hw.wall_s / hw.sim_s) for fw, hw in pairs]
    print()
    for name, idx in (("framework", 0), ("hand-written", 1)):
        eps = [p[idx] for p in pairs]
        print(
            f"{name:13s} median {med(e.wall_s for e in eps) * 1e3:6.1f} ms wall, "
            f"{med(e.cpu_s for e in eps) * 1e3:6.1f} ms cpu, {med(e.sim_s for e in eps):.2f} s sim"
        )
    print(
        f"overhead ratio wall(framework) / wall(hand-written): median {med(wall):.3f} "
        f"(IQR {_iqr(wall)}, {len(pairs)} pairs)"
    )
    print(
        f"same ratio in CPU time (thread_time, robust to a busy machine): median {med(cpu):.3f} "
        f"(IQR {_iqr(cpu)})"
    )
    print(f"wall per simulated second: median {med(per_sim):.3f}")


def _iqr(xs: list[float]) -> str:
    if len(xs) < 2:
        return "n/a"
    q = statistics.quantiles(xs, n=4)
    return f"{q[0]:.3f} - {q[2]:.3f}"


if __name__ == "__main__":
    main()
