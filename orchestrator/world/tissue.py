"""The tissue's force law: how hard the phantom pushes back on the tool at an indentation and
speed, and the MuJoCo contact parameters that realise it (`world/tissue_probe.py` measures it
on a built world)."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["TISSUE_IMPEDANCE", "TissueLaw"]


TISSUE_IMPEDANCE = 0.1
"""MuJoCo constraint impedance d of tissue contacts at the surface (solimp dmin). A soft
constraint resists acceleration like an added mass of d / ((1 - d) A), A the inverse inertia at
the contact: at MuJoCo's default d ~ 0.9 that is ~60 kg at the Panda's tool tip and a phantom
pressed with a few newtons rings at ~1 Hz; at 0.1 it is ~0.7 kg. A stiffening phantom raises d
with the indentation: ~1.1 kg at 2 N and ~2.6 kg at d_max = 0.28 for the bundled tenfold
stiffening."""


@dataclass(frozen=True)
class TissueLaw:
    """The phantom's force law as MuJoCo's soft contact realises it, for one tip body.

    MuJoCo's impedance d(x) grows linearly (solimp power 1) from `TISSUE_IMPEDANCE` at the
    surface to `d_max` at `depth_m`. At rest its soft contact satisfies R f = k d x with
    R = (1 - d) / d A0 and k = S / d_max^2 (solref[0] = -S), A0 the contact's approximate inverse
    inertia (`body_invweight0` of the tip body; the phantom is fixed): f = S x d^2 / (d_max^2
    (1 - d) A0). The secant stiffness f / x is thus `stiffness` x g(d(x)) / g(d_min) with
    g(d) = d^2 / (1 - d), and `d_max` solves g(d_max) = ratio g(d_min). The damping force
    (solref[1] = -B, b = B / d_max) is B v d / (d_max (1 - d) A0): it grows as d / (1 - d).

    Attributes:
        stiffness: Secant stiffness at the surface [N/m].
        damping: Damping at the surface [N s/m].
        ratio: Secant stiffness at `depth_m` over `stiffness` (1: linear).
        depth_m: Where the stiffening ends [m].
    """

    stiffness: float
    damping: float
    ratio: float = 1.0
    depth_m: float = 0.008

    @property
    def d_max(self) -> float:
        """MuJoCo impedance at `depth_m` and deeper (solimp dmax)."""
        c = self.ratio * _g(TISSUE_IMPEDANCE)  # d^2 / (1 - d) = c: d^2 + c d - c = 0
        return 0.5 * (-c + math.sqrt(c * c + 4.0 * c))

    def impedance(self, x: float) -> float:
        """MuJoCo impedance d at indentation `x` [m]."""
        u = min(max(x / self.depth_m, 0.0), 1.0)
        return TISSUE_IMPEDANCE + u * (self.d_max - TISSUE_IMPEDANCE)

    def force(self, x: float, v: float = 0.0) -> float:
        """Force on the tip [N] at indentation `x` [m], moving in at `v` [m/s] (out if negative;
        no inertia). Never negative: a contact pushes, it does not pull."""
        if x <= 0.0:
            return 0.0
        d = self.impedance(x)
        spring = self.stiffness * x * _g(d) / _g(TISSUE_IMPEDANCE)
        damper = self.damping * v * (d / (1.0 - d)) / (TISSUE_IMPEDANCE / (1.0 - TISSUE_IMPEDANCE))
        return max(0.0, spring + damper)

    def indentation(self, force: float) -> float:
        """The indentation [m] at which the tissue at rest pushes back with `force` [N]
        (bisection: the law increases with depth)."""
        lo, hi = 0.0, 1.0
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            if self.force(mid) < force:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    def tangent_stiffness(self, force: float) -> float:
        """df/dx at rest where the tissue pushes back with `force` [N], in [N/m]: the
        stiffness a force loop works against at that working point (the secant f/x is less:
        the tissue stiffens with depth)."""
        x = self.indentation(force)
        h = 1e-7
        return (self.force(x + h) - self.force(max(x - h, 0.0))) / (x + h - max(x - h, 0.0))

    def solref(self, inv_weight: float) -> tuple[float, float]:
        """Direct (-S, -B) for a tip body of inverse weight `inv_weight` (A0) [1/kg]."""
        d0, dm = TISSUE_IMPEDANCE, self.d_max
        s = self.stiffness * dm * dm * (1.0 - d0) * inv_weight / (d0 * d0)
        b = self.damping * dm * (1.0 - d0) * inv_weight / d0
        return -s, -b

    def solimp(self) -> list[float]:
        """MuJoCo solimp: d from `TISSUE_IMPEDANCE` to `d_max` over `depth_m`, linearly."""
        return [TISSUE_IMPEDANCE, self.d_max, self.depth_m, 0.5, 1.0]


def _g(d: float) -> float:
    return d * d / (1.0 - d)
