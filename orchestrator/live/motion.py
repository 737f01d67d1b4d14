"""How fast the arm moves, judged on every physics step (not on the published samples).

`MotionProbe` is an observer the session keeps on its step loop, task or not: after every
physics step it takes the largest joint speed of the arm, and the status message carries the
largest one since the previous status (`arm_speed`: the peak [rad/s] and the simulated time
window it covers). A client can then tell, without trusting the session's state, whether the
arm moved while the session said it was stopped: an e-stop's latch is judged by the arm.

The window's times are the earliest and the latest of its steps, not its first and last: a
`restore` moves simulated time back, and a window that holds steps from both sides of it
covers them all. Reported as first..last, a window with steps at 46.38 s, then (restored) at
45.5-45.61 s and an e-stop at 45.59 s read "46.38..45.61": it seemed to start 0.8 s after the
stop, and the restored task's motion before the e-stop counted as motion while ESTOPPED.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["MotionProbe"]


class MotionProbe:
    """The peak joint speed of the arm over the physics steps of a window.

    Args:
        dof: The arm's degrees of freedom (indices into `qvel`).
    """

    def __init__(self, dof: np.ndarray) -> None:
        self.dof = np.asarray(dof)
        self.peak = 0.0
        """Largest |joint speed| of any arm joint on any step of the window [rad/s]."""
        self.t0: float | None = None
        """Simulated time of the window's earliest step [s] (None: no step yet)."""
        self.t1 = 0.0
        """Simulated time of its latest step [s]."""

    # -- an observer of the step loop (engine/runner.py's Observer, with on_step) ----------
    def on_start(self, ctx: Any, executor: Any) -> None:
        """Nothing: the probe measures the arm, task or not."""

    def on_tick(self, ctx: Any, executor: Any) -> None:
        """Nothing: the probe measures every physics step (`on_step`)."""

    def on_end(self, ctx: Any, executor: Any, result: Any) -> None:
        """Nothing."""

    def on_step(self, ctx: Any) -> None:
        """After one physics step: the arm's fastest joint so far in the window."""
        speed = float(np.abs(ctx.data.qvel[self.dof]).max())
        if speed > self.peak:  # noqa: PLR1730 (cheaper than max() per step)
            self.peak = speed
        t = ctx.t
        if self.t0 is None:
            self.t0 = self.t1 = t
        elif t > self.t1:  # noqa: PLR1730
            self.t1 = t
        elif t < self.t0:  # a restore moved time back  # noqa: PLR1730
            self.t0 = t

    def window(self) -> dict[str, Any]:
        """The window so far (`peak` [rad/s], its earliest and latest step's simulated times
        `t0`, `t1` [s]), then a new one begins."""
        out = {"peak": round(self.peak, 6), "t0": None if self.t0 is None else round(self.t0, 6),
               "t1": round(self.t1, 6)}  # fmt: skip
        self.peak, self.t0 = 0.0, None
        return out
