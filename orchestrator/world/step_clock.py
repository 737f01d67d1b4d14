"""StepClock: the simulated time of a world, kept where Python reads it cheaply.

MuJoCo keeps the time in `MjData.time` and advances it by `time += opt.timestep` at every
`mj_step`. Reading it through the bindings builds a new float through a property lookup
(~0.5 us, more with cold caches after `mj_step`), ~1,500 times per simulated second (the
encoders, the wrist force, the skills). The one step function (engine/step.py `StepLoop`)
advances a `StepClock` the same way after every `mj_step`: one float addition, in the same
order, so `t` equals `MjData.time` bit for bit (a step counter times the timestep does not:
0.002 is not a binary fraction, and `n * dt` differs from the sum in the last bits at 2,989
of the first 3,000 steps). The compiled wrist force (world/_native.c) reads `t` as an
attribute too.
"""

from __future__ import annotations

__all__ = ["StepClock"]


class StepClock:
    """Simulated time [s] of a world, advanced by the step function after every `mj_step`.

    Args:
        t: Simulated time now [s] (`MjData.time` of a freshly reset world: 0).

    Attributes:
        t: Simulated time [s]; equal to `MjData.time` while only the step function steps the
            world. Code that sets `MjData.time` itself (a test faking a new instant) sets
            this instead: the readings cached per instant are keyed on it.
    """

    __slots__ = ("t",)

    def __init__(self, t: float = 0.0) -> None:
        self.t = float(t)

    def __repr__(self) -> str:
        return f"StepClock(t={self.t!r})"
