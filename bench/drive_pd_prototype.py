"""Prototype (issue 43): the joint impedance in MuJoCo's actuators, the feed-forward once per
control tick, all the tick's physics steps in one `mj_step(..., nstep)` call. Not the product.

bench/overhead.py's hand-written pick_place loop (the framework's controller, motion
generator and plant, no executor) is the baseline: there `Controller.compute` runs every
physics step (pinocchio's RNEA at the measured state, PD on the encoders' reading, the setpoint
advanced along the tick's constant acceleration). The prototype changes only that:

* each arm motor becomes a position servo in the drive: MuJoCo's affine bias gives
  force = kp ctrl - kp q - kd qd, with the robot's kp/kd, clamped to the motor's torque
  limit (`forcerange`); the drive sees MuJoCo's true joint state, not the encoders' reading;
* once per control tick: the setpoint at the middle of the tick (q_d, qd_d along its constant
  acceleration), pinocchio's RNEA there (gravity, Coriolis, the tick's acceleration; the
  controller's own, mass-mismatched model), folded into the servo's command,
  ctrl = q_d + (kd qd_d + tau_ff) / kp;
* `mujoco.mj_step(m, d, nstep)` for the whole tick; the controlled stop at the end keeps the
  per-step path (the motors switched back).

Variants timed (`VARIANTS`): `nstep` as above; `record`, the tick's steps one call each with
each step's arm velocities and motor forces copied and checked (datasheet speed,
acceleration, 90 % torque) once per tick, the tick re-simulated from its start on a violation
(the guarantee issue 43 keeps); `ramp`, as `record` with the servo's setpoint written every
step along the tick's acceleration.

Measured, per seed and alternating the order: CPU per simulated second of each (the ratio to
the baseline, median), success and cycle time; in separate runs stepped one physics step at a
time (the same arithmetic), the worst joint tracking error against the tick's setpoint
trajectory (the baseline's `q_d`, which it advances every step; the quadratic the prototype's
setpoint follows) on every physics step while the arm is commanded, the steps over the
datasheet, and whether re-simulating every tick from its start (`mj_getState` of the
integration state, or a whole `mj_copyData`) reproduces the recorded steps bit for bit.

    python bench/drive_pd_prototype.py [--seeds 10]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parent))
from orchestrator.robots.controller import ControlMode
from overhead import HandWritten  # bench/overhead.py

from orchestrator.language.load import load_scenario


class DrivePD(HandWritten):
    """The hand-written loop with the joint impedance in the drives (see the module doc)."""

    def __init__(
        self, *args: object, mode: str = "nstep", copy_data: bool = False, ramp: bool = False
    ) -> None:
        super().__init__(*args)  # type: ignore[arg-type]
        m, act = self.model, self.act
        self.motor = {
            k: getattr(m, k)[act].copy()
            for k in (
                "actuator_gainprm",
                "actuator_biasprm",
                "actuator_biastype",
                "actuator_ctrllimited",
                "actuator_forcelimited",
                "actuator_forcerange",
            )
        }
        c = self.ctrl
        servo = {k: v.copy() for k, v in self.motor.items()}
        servo["actuator_gainprm"][:, 0] = c.kp
        servo["actuator_biasprm"][:, :3] = np.column_stack([np.zeros(self.n), -c.kp, -c.kd])
        servo["actuator_biastype"][:] = mujoco.mjtBias.mjBIAS_AFFINE
        servo["actuator_ctrllimited"][:] = 0
        servo["actuator_forcelimited"][:] = 1
        servo["actuator_forcerange"][:] = np.column_stack([-c.effort_limit, c.effort_limit])
        self.servo = servo
        self._use(self.servo)
        self.mode = mode
        """`nstep`: one mj_step call per tick; `record`: the tick's steps one call each,
        each step's arm velocities and motor forces copied for a check of all of them once
        per tick; `resim`: as `record`, then every tick re-simulated step by step from its
        start and compared (what a guard's violation would do); `per_step`: the tracking
        error read on every step."""
        self.worst_rad = 0.0
        self.resim_ticks = 0
        self.resim_mismatches = 0
        self.flagged = [0, 0, 0]
        """Steps over the joint speed, acceleration and 90 %-torque bounds."""
        self.ramp = ramp
        """The servo's setpoint written on every physics step along the tick's constant
        acceleration (the feed-forward still once per tick), not held at the tick's middle:
        not with `nstep`, whose one call takes one ctrl."""
        self._ctrl_rows: np.ndarray | None = None
        self._steps_t = np.arange(self.n_sub)[:, None] * self.dt
        self._copy: mujoco.MjData | None = mujoco.MjData(self.model) if copy_data else None
        """With `copy_data`, the tick's start is a whole copy of MjData (mj_copyData), not
        the integration state (mj_getState, mjSTATE_INTEGRATION)."""
        n_sub, n = self.n_sub, self.n
        self._qd_rows = np.empty((n_sub + 1, n))
        self._force_rows = np.empty((n_sub, n))
        self._state_kind = mujoco.mjtState.mjSTATE_INTEGRATION
        self._state = np.empty(mujoco.mj_stateSize(self.model, self._state_kind))
        robot = self.world.robot
        self._v_max = np.asarray(robot.joint_velocity_limits(), float)
        self._a_max = np.asarray(robot.acceleration_limits, float) * self.dt
        self._tau_max = 0.9 * c.effort_limit
        self._q_full = np.zeros(c.model.nq)
        self._v_full = np.zeros(c.model.nv)
        self._a_full = np.zeros(c.model.nv)

    def _use(self, params: dict[str, np.ndarray]) -> None:
        for k, v in params.items():
            getattr(self.model, k)[self.act] = v

    def physics(self) -> None:
        c = self.ctrl
        if c.mode not in (ControlMode.JOINT, ControlMode.HOLD):
            self._use(self.motor)
            super().physics()
            self._use(self.servo)
            return
        self.advance_gripper()
        d, dt_c, n = self.data, self.dt_c, self.n
        half = 0.5 * dt_c
        q0, v0, a = c.q_d.copy(), c.qd_d.copy(), c.qdd_d.copy()
        q_mid = q0 + v0 * half + 0.5 * a * half * half
        v_mid = v0 + a * half
        q_full, v_full, a_full = self._q_full, self._v_full, self._a_full
        q_full[:n], q_full[n:] = q_mid, self.fingers_q
        v_full[:n] = v_mid
        a_full[:n] = a
        tau = pin.rnea(c.model, c.data, q_full, v_full, a_full)[:n]
        d.ctrl[self.act] = q_mid + (c.kd * v_mid + tau) / c.kp
        if self.ramp:  # the setpoint at each step's start, as Controller.compute has it
            t = self._steps_t
            q_t, v_t = q0 + v0 * t + 0.5 * a * t * t, v0 + a * t
            self._ctrl_rows = q_t + (c.kd * v_t + tau) / c.kp
        m = self.model
        if self.mode == "nstep":
            mujoco.mj_step(m, d, self.n_sub)
        elif self.mode == "per_step":  # the same steps, one at a time, the tracking error
            for i in range(1, self.n_sub + 1):
                if self._ctrl_rows is not None:
                    d.ctrl[self.act] = self._ctrl_rows[i - 1]
                mujoco.mj_step(m, d)
                t = i * self.dt
                ref = q0 + v0 * t + 0.5 * a * t * t
                self.worst_rad = max(self.worst_rad, float(np.max(np.abs(self.arm_q - ref))))
        else:
            self._recorded_tick()
        self.clock.t += dt_c
        # the setpoint moves on as Controller.compute moves it, by a whole tick
        c.q_d[:] = q0 + v0 * dt_c + 0.5 * a * dt_c * dt_c
        c.qd_d[:] = v0 + a * dt_c
        if c._rest_left_s > 0.0:
            c._rest_left_s -= dt_c
            if c._rest_left_s <= 1e-9:
                c.hold(c.q_d)

    def _recorded_tick(self) -> None:
        """The tick's physics steps with each step's data recorded, then checked at once:
        joint speed, acceleration (velocity change per step) and motor torque, on every
        step. A step over a bound (or, in `resim` mode, every tick) re-simulates the tick from
        its start one step at a time, where a guard would react on the next step: the
        re-simulated steps must be the recorded ones, bit for bit."""
        m, d, kind = self.model, self.data, self._state_kind
        qd, force = self._qd_rows, self._force_rows
        if self._copy is not None:
            mujoco.mj_copyData(self._copy, m, d)
        else:
            mujoco.mj_getState(m, d, self._state, kind)
        arm_qd, act = self.arm_qd, self.act
        qd[0] = arm_qd
        rows = self._ctrl_rows
        for i in range(self.n_sub):
            if rows is not None:
                d.ctrl[act] = rows[i]
            mujoco.mj_step(m, d)
            qd[i + 1] = arm_qd
            force[i] = d.actuator_force[act]
        over = (
            np.abs(qd[1:]) > self._v_max,
            np.abs(np.diff(qd, axis=0)) > self._a_max,
            np.abs(force) > self._tau_max,
        )
        flagged = False
        for k, bad in enumerate(over):
            hits = int(bad.any(axis=1).sum())
            self.flagged[k] += hits
            flagged = flagged or hits > 0
        if flagged or self.mode == "resim":
            self.resim_ticks += 1
            recorded = qd.copy()
            if self._copy is not None:
                mujoco.mj_copyData(d, m, self._copy)
            else:
                mujoco.mj_setState(m, d, self._state, kind)
            for i in range(self.n_sub):
                if rows is not None:
                    d.ctrl[act] = rows[i]
                mujoco.mj_step(m, d)  # (a guard's check of step i here)
                if not np.array_equal(arm_qd, recorded[i + 1]):
                    self.resim_mismatches += 1

    def stop_and_settle(self) -> None:
        self._use(self.motor)  # the controlled stop keeps the per-step path
        super().stop_and_settle()


class Tracked(HandWritten):
    """The baseline loop stepped as it is, the tracking error read on every physics step."""

    def __init__(self, *args: object) -> None:
        super().__init__(*args)  # type: ignore[arg-type]
        self.worst_rad = 0.0
        self.flagged = [0, 0, 0]
        robot = self.world.robot
        self._v_max = np.asarray(robot.joint_velocity_limits(), float)
        self._a_max = np.asarray(robot.acceleration_limits, float) * self.dt
        self._tau_max = 0.9 * self.ctrl.effort_limit

    def physics(self) -> None:
        self.advance_gripper()
        m, d, c = self.model, self.data, self.ctrl
        read, act = self.loop_views
        before = self.arm_qd.copy()
        for _ in range(self.n_sub):
            commanded = c.mode in (ControlMode.JOINT, ControlMode.HOLD)
            d.ctrl[act] = c.compute(*read())
            mujoco.mj_step(m, d)
            self.clock.t += self.dt
            if commanded:  # compute advanced q_d to this step's end
                self.worst_rad = max(self.worst_rad, float(np.max(np.abs(self.arm_q - c.q_d))))
            qd = self.arm_qd
            self.flagged[0] += bool(np.any(np.abs(qd) > self._v_max))
            self.flagged[1] += bool(np.any(np.abs(qd - before) > self._a_max))
            self.flagged[2] += bool(np.any(np.abs(d.actuator_force[act]) > self._tau_max))
            before = qd.copy()


def _episode(loop: HandWritten) -> tuple[float, float, float | None, bool]:
    c0 = time.thread_time()
    ok = loop.run()
    return time.thread_time() - c0, loop.t, loop.cycle_s, ok


VARIANTS = ("baseline", "nstep", "record", "ramp")
"""The loops timed: bench/overhead.py's; the drive PD with one mj_step call per tick; the
drive PD with each step's data recorded and checked once per tick; that with the servo's
setpoint written every step along the tick's acceleration."""


def _loop(which: str, scenario: object, seed: int) -> HandWritten:
    if which == "baseline":
        return HandWritten(scenario, seed)  # type: ignore[arg-type]
    if which == "ramp":
        return DrivePD(scenario, seed, mode="record", ramp=True)
    return DrivePD(scenario, seed, mode=which)


def _add(a: list[int], b: list[int]) -> list[int]:
    return [x + y for x, y in zip(a, b, strict=True)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()
    scenario = load_scenario("pick_place").scenario
    load0 = os.getloadavg()[0]
    for which in VARIANTS:
        _episode(_loop(which, scenario, 10_000))  # warm caches
    per: dict[str, list[tuple[float, float, float | None, bool]]] = {v: [] for v in VARIANTS}
    for seed in range(args.seeds):
        order = VARIANTS if seed % 2 == 0 else VARIANTS[::-1]
        for which in order:  # the world is built outside the timed part, for all alike
            per[which].append(_episode(_loop(which, scenario, seed)))
        row = " | ".join(
            f"{v} {per[v][-1][0] / per[v][-1][1] * 1e3:6.1f}{'' if per[v][-1][3] else ' FAIL'}"
            for v in VARIANTS
        )
        print(f"seed {seed:3d} ms CPU per simulated s: {row}", flush=True)
    worst = {"baseline": 0.0, "drive PD": 0.0, "drive PD, ramp": 0.0}
    resim = {"mj_getState": [0, 0], "mj_copyData": [0, 0]}  # ticks, steps that differed
    flagged = {k: [0, 0, 0] for k in worst}
    for seed in range(min(args.seeds, 5)):
        base = Tracked(scenario, seed)
        base.run()
        worst["baseline"] = max(worst["baseline"], base.worst_rad)
        flagged["baseline"] = _add(flagged["baseline"], base.flagged)
        for name, ramp in (("drive PD", False), ("drive PD, ramp", True)):
            proto = DrivePD(scenario, seed, mode="per_step", ramp=ramp)
            proto.run()
            worst[name] = max(worst[name], proto.worst_rad)
            again = DrivePD(scenario, seed, mode="resim", copy_data=True, ramp=ramp)
            again.run()
            flagged[name] = _add(flagged[name], again.flagged)
            resim["mj_copyData"][0] += again.resim_ticks
            resim["mj_copyData"][1] += again.resim_mismatches
        again = DrivePD(scenario, seed, mode="resim")
        again.run()
        resim["mj_getState"][0] += again.resim_ticks
        resim["mj_getState"][1] += again.resim_mismatches
    med = statistics.median
    print()
    for which in VARIANTS[1:]:
        ratios = [
            (c / s) / (cb / sb)
            for (c, s, _, _), (cb, sb, _, _) in zip(per[which], per["baseline"], strict=True)
        ]
        q = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else [ratios[0]] * 3
        print(
            f"CPU per simulated second, drive PD ({which}) / baseline: median "
            f"{med(ratios):.3f} (IQR {q[0]:.3f}-{q[2]:.3f}, {len(ratios)} seeds)"
        )
    for which in VARIANTS:
        ok = sum(e[3] for e in per[which])
        cycles = [e[2] for e in per[which] if e[2] is not None]
        p50 = f", cycle p50 {med(cycles):.2f} s" if cycles else ""
        print(f"{which:9s} success {ok}/{args.seeds}{p50}")
    n = min(args.seeds, 5)
    print(
        f"worst joint tracking error per physics step (seeds 0-{n - 1}): "
        + ", ".join(f"{k} {v * 1e3:.2f} mrad" for k, v in worst.items())
    )
    for how, (ticks, differ) in resim.items():
        print(
            f"every tick re-simulated step by step from its start ({how}, seeds 0-{n - 1}): "
            f"{ticks} ticks, {differ} steps differing from the recorded ones"
        )
    for who, (v, a, t) in flagged.items():
        print(
            f"{who:14s} steps over the datasheet speed {v}, acceleration {a}, 90 % torque {t} "
            f"(seeds 0-{n - 1})"
        )
    print(f"load average (1 min) {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
