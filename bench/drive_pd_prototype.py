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

Measured, per seed and alternating the order: CPU per simulated second of each (the ratio
prototype / baseline, median), success and cycle time, and in separate runs stepped one
physics step at a time (the same arithmetic), the worst joint tracking error against the
tick's setpoint trajectory (the baseline's `q_d`, which it advances every step; the quadratic
the prototype's setpoint follows) on every physics step while the arm is commanded.

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

    def __init__(self, *args: object, per_step: bool = False) -> None:
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
        self.per_step = per_step
        self.worst_rad = 0.0
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
        if self.per_step:  # the same steps, one at a time, the tracking error on each
            for i in range(1, self.n_sub + 1):
                mujoco.mj_step(self.model, d)
                t = i * self.dt
                ref = q0 + v0 * t + 0.5 * a * t * t
                self.worst_rad = max(self.worst_rad, float(np.max(np.abs(self.arm_q - ref))))
        else:
            mujoco.mj_step(self.model, d, self.n_sub)
        self.clock.t += dt_c
        # the setpoint moves on as Controller.compute moves it, by a whole tick
        c.q_d[:] = q0 + v0 * dt_c + 0.5 * a * dt_c * dt_c
        c.qd_d[:] = v0 + a * dt_c
        if c._rest_left_s > 0.0:
            c._rest_left_s -= dt_c
            if c._rest_left_s <= 1e-9:
                c.hold(c.q_d)

    def stop_and_settle(self) -> None:
        self._use(self.motor)  # the controlled stop keeps the per-step path
        super().stop_and_settle()


class Tracked(HandWritten):
    """The baseline loop stepped as it is, the tracking error read on every physics step."""

    def __init__(self, *args: object) -> None:
        super().__init__(*args)  # type: ignore[arg-type]
        self.worst_rad = 0.0

    def physics(self) -> None:
        self.advance_gripper()
        m, d, c = self.model, self.data, self.ctrl
        read, act = self.loop_views
        for _ in range(self.n_sub):
            commanded = c.mode in (ControlMode.JOINT, ControlMode.HOLD)
            d.ctrl[act] = c.compute(*read())
            mujoco.mj_step(m, d)
            self.clock.t += self.dt
            if commanded:  # compute advanced q_d to this step's end
                self.worst_rad = max(self.worst_rad, float(np.max(np.abs(self.arm_q - c.q_d))))


def _episode(loop: HandWritten) -> tuple[float, float, float | None, bool]:
    c0 = time.thread_time()
    ok = loop.run()
    return time.thread_time() - c0, loop.t, loop.cycle_s, ok


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()
    scenario = load_scenario("pick_place").scenario
    load0 = os.getloadavg()[0]
    _episode(HandWritten(scenario, 10_000))
    _episode(DrivePD(scenario, 10_000))
    ratios, oks, cycles = [], [0, 0], ([], [])
    for seed in range(args.seeds):
        runs = {}
        order = ("base", "proto") if seed % 2 == 0 else ("proto", "base")
        for which in order:
            # the world is built outside the timed part for both alike
            loop = HandWritten(scenario, seed) if which == "base" else DrivePD(scenario, seed)
            runs[which] = _episode(loop)
        (cb, sb, yb, okb), (cp, sp, yp, okp) = runs["base"], runs["proto"]
        ratios.append((cp / sp) / (cb / sb))
        oks[0] += okb
        oks[1] += okp
        if yb is not None:
            cycles[0].append(yb)
        if yp is not None:
            cycles[1].append(yp)
        print(
            f"seed {seed:3d}: baseline {cb / sb * 1e3:6.1f} ms CPU/sim s {'ok' if okb else 'FAIL'}"
            f" | drive PD {cp / sp * 1e3:6.1f} {'ok' if okp else 'FAIL'} | ratio {ratios[-1]:.3f}",
            flush=True,
        )
    worst = [0.0, 0.0]
    for seed in range(min(args.seeds, 5)):
        base, proto = Tracked(scenario, seed), DrivePD(scenario, seed, per_step=True)
        base.run()
        proto.run()
        worst = [max(worst[0], base.worst_rad), max(worst[1], proto.worst_rad)]
    med = statistics.median
    q = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else [ratios[0]] * 3
    print(
        f"\nCPU per simulated second, drive PD / baseline: median {med(ratios):.3f} "
        f"(IQR {q[0]:.3f}-{q[2]:.3f}, {len(ratios)} seeds)"
    )
    print(f"success: baseline {oks[0]}/{args.seeds}, drive PD {oks[1]}/{args.seeds}")
    if cycles[0] and cycles[1]:
        print(f"cycle p50: baseline {med(cycles[0]):.2f} s, drive PD {med(cycles[1]):.2f} s")
    print(
        f"worst joint tracking error per physics step (seeds 0-{min(args.seeds, 5) - 1}): "
        f"baseline {worst[0] * 1e3:.2f} mrad, drive PD {worst[1] * 1e3:.2f} mrad"
    )
    print(f"load average (1 min) {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
