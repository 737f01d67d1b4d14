"""A minimal stock mink + MuJoCo pick-and-place loop on pick_place's plant: the yardstick.

What someone would write without the framework, from the libraries' own examples: mink's
differential IK (`FrameTask` + `PostureTask`, `solve_ik` with daqp, the configuration limit)
once per control tick on a straight Cartesian line with a quintic time law, and a joint PD
with MuJoCo's own bias forces (`qfrc_bias`: gravity and Coriolis of the true plant) every
physics step, written in numpy; the hand driven by its motor (full voltage to close, a
proportional servo to open). It runs on the same compiled model as the framework's
pick_place (`World.build(scenario, seed)`: the same cube pose, the same scene and the same
rates), reads the cube's true pose (no perception noise) and the joints' true state (no
encoders), plans nothing, checks nothing (no guards, no reach or torque checks, no retries),
records nothing. Only the plant is borrowed from the framework; `rot_down` is the TCP's
pointing-down orientation.

    python bench/stock_mink_loop.py [--seeds 5]

prints each episode's success, cycle time and CPU per simulated second. bench/speed_paired.py
runs it beside the framework's episodes in the same process.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass

import mink
import mujoco
import numpy as np
from orchestrator.skills.targets import rot_down

from orchestrator.language.load import load_scenario
from orchestrator.language.scenario import Scenario
from orchestrator.world import World, robot_only_model

HOVER_M = 0.10
"""Approach height above the cube and the pad [m] (the bundled flow's)."""
LIFT_M = 0.05
"""Lift after the grasp [m]."""
PLACE_M = 0.030
"""TCP height above the pad when releasing [m]."""
PRESHAPE_M = 0.030
"""Each finger's opening on the approach [m]."""
SPEED_MPS = 1.0
"""Cartesian cruise speed of a line [m/s] (its duration: 1.875 x length / speed, the quintic's
peak speed ratio, at least 0.25 s)."""
SETTLE_S = 0.3
"""Longest wait after a line's end for the TCP to come within `TOL_M` [s]."""
TOL_M = 0.002
"""TCP position tolerance at a line's end [m]."""


@dataclass
class StockEpisode:
    """One episode: CPU time [s] (thread time), simulated time [s], cycle [s] or None, success."""

    cpu_s: float
    sim_s: float
    cycle_s: float | None
    ok: bool

    @property
    def cpu_per_sim(self) -> float:
        return self.cpu_s / self.sim_s


class StockLoop:
    """Pick the cube, place it on the pad, retreat: one script, one control tick at a time."""

    def __init__(self, scenario: Scenario, seed: int) -> None:
        w = World.build(scenario, seed)
        self.w, self.m, self.d = w, w.model, w.data
        dt = float(self.m.opt.timestep)
        self.dt = dt
        self.n_sub = max(1, round(1.0 / (scenario.physics.control_hz * dt)))
        self.dt_c = self.n_sub * dt
        robot = w.robot
        self.kp, self.kd = robot.gains.kp, robot.gains.kd
        self.n = robot.n_arm
        self.qa, self.va = w.arm_qpos, w.arm_dof
        self.act = w.arm_act
        self.grip = w.gripper_act
        self.fingers = w.finger_qpos
        self.open_m = robot.gripper_open_m
        self.grip_gain = 0.5 / (robot.gripper_speed_mps * self.dt_c)
        self.base = np.asarray(scenario.robot.base_pos, float)
        model = robot_only_model(robot)
        self.cfg = mink.Configuration(model)
        self.frame = mink.FrameTask(
            robot.tcp_site, "site", position_cost=1.0, orientation_cost=1.0, lm_damping=1e-6
        )
        self.posture = mink.PostureTask(model, cost=1e-2)
        self.limits = [mink.ConfigurationLimit(model)]
        q = self.cfg.q.copy()
        q[: self.n] = w.home
        self.d.qpos[self.qa] = w.home
        mujoco.mj_forward(self.m, self.d)
        self.cfg.update(q)
        self.posture.set_target(q)
        self.q_d, self.qd_d = w.home.copy(), np.zeros(self.n)
        self.grip_goal = self.open_m
        self.tcp = self.d.site_xpos[w.tcp_site]
        self.tcp_rot = self.d.site_xmat[w.tcp_site].reshape(3, 3)
        cube = w.objects["cube"]
        self.cube = self.d.qpos[cube.qpos_adr : cube.qpos_adr + 7]
        self.pad = w.markers["pad"]
        self.t = 0.0

    def tick(self) -> None:
        """One control period: the hand's drive, then the joint PD + bias every physics step."""
        d, m = self.d, self.m
        if self.grip_goal <= 0.0:
            d.ctrl[self.grip] = -1.0
        else:
            err = self.grip_goal - 0.5 * float(d.qpos[self.fingers].sum())
            d.ctrl[self.grip] = min(max(self.grip_gain * err, -0.9), 0.9)
        for _ in range(self.n_sub):
            tau = (
                self.kp * (self.q_d - d.qpos[self.qa])
                + self.kd * (self.qd_d - d.qvel[self.va])
                + d.qfrc_bias[self.va]
            )
            d.ctrl[self.act] = tau
            mujoco.mj_step(m, d)
        self.t += self.dt_c

    def line(self, goal: np.ndarray, rot: np.ndarray) -> bool:
        """The TCP along a straight line to `goal` (world) with orientation `rot`; True once
        within `TOL_M` after the line's time (False after `SETTLE_S` more)."""
        p0 = self.tcp.copy()
        r0 = mink.SO3.from_matrix(self.tcp_rot.copy())
        r1 = mink.SO3.from_matrix(rot)
        dr = (r0.inverse() @ r1).log()
        duration = max(0.25, 1.875 * float(np.linalg.norm(goal - p0)) / SPEED_MPS)
        t0 = self.t
        q = self.cfg.q.copy()
        q[: self.n] = self.d.qpos[self.qa]
        self.cfg.update(q)
        while True:
            s = min(1.0, (self.t - t0) / duration)
            u = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
            target = mink.SE3.from_rotation_and_translation(
                r0 @ mink.SO3.exp(u * dr), p0 + u * (goal - p0) - self.base
            )
            self.frame.set_target(target)
            v = mink.solve_ik(
                self.cfg, [self.frame, self.posture], self.dt_c, "daqp", 1e-2, limits=self.limits
            )
            self.cfg.integrate_inplace(v, self.dt_c)
            self.q_d = self.cfg.q[: self.n].copy()
            self.qd_d = v[: self.n].copy()
            self.tick()
            if s >= 1.0:
                self.qd_d[:] = 0.0
                if float(np.linalg.norm(self.tcp - goal)) <= TOL_M:
                    return True
                if self.t - t0 > duration + SETTLE_S:
                    return False

    def hold(self, seconds: float) -> None:
        """Hold the setpoint for `seconds` of simulated time."""
        self.qd_d[:] = 0.0
        t0 = self.t
        while self.t - t0 < seconds - 1e-9:
            self.tick()

    def grip_to(self, opening: float, at_most_s: float) -> None:
        """Drive the hand to `opening` per finger (0: close) until the fingers stop."""
        self.grip_goal = opening
        self.qd_d[:] = 0.0
        t0, last, still = self.t, float(self.d.qpos[self.fingers].sum()), 0
        while self.t - t0 < at_most_s:
            self.tick()
            now = float(self.d.qpos[self.fingers].sum())
            still = still + 1 if abs(now - last) < 1e-5 else 0
            last = now
            if self.t - t0 >= 0.1 and still >= 3:
                break

    def run(self) -> tuple[float | None, bool]:
        """The task; its cycle time [s] (None if a line failed) and whether the cube ended
        on the pad (within 1 cm, upright, the fingers open)."""
        self.hold(0.1)  # as long as the framework's search waits for perception
        cube = self.cube[:3].copy()
        w, x, y, z = self.cube[3:]
        yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        current = math.atan2(self.tcp_rot[1, 0], self.tcp_rot[0, 0])
        yaw += round((current - yaw) / (math.pi / 2)) * (math.pi / 2)
        down = rot_down(yaw)
        hover = np.array([0.0, 0.0, HOVER_M])
        self.grip_goal = PRESHAPE_M
        ok = self.line(cube + hover, down) and self.line(cube, down)
        if ok:
            self.grip_to(0.0, 1.5)
            pad = self.pad
            ok = (
                self.line(cube + [0.0, 0.0, LIFT_M], down)
                and self.line(pad + hover, down)
                and self.line(pad + [0.0, 0.0, PLACE_M], down)
            )
        if ok:
            self.grip_to(self.open_m, 1.0)
            ok = self.line(self.pad + hover, down)
        cycle = self.t if ok else None
        self.hold(0.2)
        pose = self.cube
        upright = 1.0 - 2.0 * (pose[4] ** 2 + pose[5] ** 2) >= math.cos(math.radians(10.0))
        on_pad = float(np.linalg.norm(pose[:2] - self.pad[:2])) <= 0.01
        return cycle, bool(ok and upright and on_pad)


def stock_episode(scenario: Scenario, seed: int) -> StockEpisode:
    """One stock episode timed from building the world to the result (thread CPU time)."""
    c0 = time.thread_time()
    loop = StockLoop(scenario, seed)
    cycle, ok = loop.run()
    return StockEpisode(time.thread_time() - c0, loop.t, cycle, ok)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    scenario = load_scenario("pick_place").scenario
    stock_episode(scenario, 10_000)  # warm caches
    for seed in range(args.seeds):
        e = stock_episode(scenario, seed)
        cycle = f"{e.cycle_s:.2f} s" if e.cycle_s is not None else "-"
        print(
            f"seed {seed}: {'ok' if e.ok else 'FAILED'}, cycle {cycle}, "
            f"{e.cpu_per_sim * 1e3:.1f} ms CPU per simulated s ({e.sim_s:.2f} s simulated)"
        )


if __name__ == "__main__":
    main()
