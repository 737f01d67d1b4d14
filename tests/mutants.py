"""Deliberate breakages of the controller and the hand, applied at import time when the
environment names one (`ORCH_MUTANT=<name>`): a pytest plugin (`-p tests.mutants`) that
tests/test_mutations.py loads in a child pytest to check the suite notices each of them.

Not a fixture module: with `ORCH_MUTANT` unset it does nothing.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np
from orchestrator.robots import Panda
from orchestrator.robots.controller import Controller
from orchestrator.skills import hold, ik

__all__ = ["MUTANTS", "apply"]


def _velocity_100() -> None:
    """The IK's (and its limiter's) joint velocity limit 2 -> 100 rad/s."""
    init = ik.IKSolver.__init__

    def patched(self, *args, **kwargs) -> None:
        kwargs["velocity_limit"] = 100.0
        init(self, *args, **kwargs)
        self.limiter.v_max = np.full_like(self.limiter.v_max, 100.0)

    ik.IKSolver.__init__ = patched  # type: ignore[method-assign]


def _grip_200() -> None:
    """Each finger squeezes with 200 N (the Franka Hand: 70 N continuous for both)."""
    Panda.gripper_force_n = 200.0


def _no_nullspace() -> None:
    """The Cartesian impedance without its nullspace posture term."""
    cartesian = Controller._cartesian

    def patched(self, q, qd):
        gains = self.cart
        self.cart = dataclasses.replace(gains, nullspace_stiffness=0.0)
        try:
            tau = cartesian(self, q, qd)
        finally:
            self.cart = gains
        return tau

    Controller._cartesian = patched  # type: ignore[method-assign]


def _posture_0() -> None:
    """The IK's posture cost 0 (the arm's redundancy left to the solver)."""
    init = ik.IKSolver.__init__

    def patched(self, *args, **kwargs) -> None:
        kwargs["posture_cost"] = 0.0
        init(self, *args, **kwargs)

    ik.IKSolver.__init__ = patched  # type: ignore[method-assign]


def _no_hold_brake() -> None:
    """No brake in the safety response: the controlled stop's brake does nothing and the
    `hold` skill (SAFE_HOLD's STOP) keeps the previous Cartesian setpoint instead of braking
    the joints where they are — a probe pressing on tissue keeps pressing."""

    def start(self, ctx) -> None:
        self.t0 = ctx.t

    def brake(self, q, qd, max_decel) -> float:
        return 0.0

    hold.Hold.start = start  # type: ignore[method-assign]
    Controller.brake = brake  # type: ignore[method-assign]


def _no_touch_registration() -> None:
    """The surgical offset fix removed: `register` with `method: touch` keeps the camera's
    estimate (the fiducials', off by 0.1-0.3 mm across the incision) instead of touching."""
    from orchestrator.skills import register

    step = register.Register.step

    def patched(self, ctx):
        if self.params.method == "touch":
            self.params = self.params.model_copy(update={"method": "fiducials"})
        return step(self, ctx)

    register.Register.step = patched  # type: ignore[method-assign]


MUTANTS = {
    "velocity_100": _velocity_100,
    "grip_200": _grip_200,
    "no_nullspace": _no_nullspace,
    "posture_0": _posture_0,
    "no_hold_brake": _no_hold_brake,
    "no_touch_registration": _no_touch_registration,
}


def apply(name: str) -> None:
    """Apply the mutant `name` (one of `MUTANTS`)."""
    MUTANTS[name]()


if os.environ.get("ORCH_MUTANT"):
    apply(os.environ["ORCH_MUTANT"])
