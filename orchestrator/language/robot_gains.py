"""`robot.gains`: the controller's gains as robot parameters a scenario overrides in YAML.

```yaml
robot:
  name: panda
  gains:
    kp: [600, 600, 600, 600, 250, 150, 50]   # joint stiffness [Nm/rad], one per arm joint
    kd: [50, 50, 50, 50, 20, 15, 5]          # joint damping [Nm s/rad]
    cartesian: {stiffness: [800, 800, 800, 40, 40, 40], nullspace_stiffness: 5}
```

Every key is optional: what is left out keeps the robot's own value (docs/robots.md lists
them). The joint gains are the joint impedance every `move`,
`move_joints`, hold and controlled stop runs on; the Cartesian ones are the controller's
default impedance, used when a skill commands a Cartesian pose without gains of its own (the
bundled `contact` and `retract` set theirs per state in `with:`).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

from ..robots import ROBOTS
from .diagnostics import Diagnostic
from .yamlio import SourceMap

__all__ = ["CartesianGainsSpec", "RobotGains", "check_gains"]

MAX_KP = 10_000.0
"""Largest joint stiffness [Nm/rad]: 16x the Panda's stiffest default (600)."""
MAX_KD = 1_000.0
"""Largest joint damping [Nm s/rad]; covers a mobile base's 900 N s/m."""
MAX_CART_K = (5_000.0, 500.0)
"""Largest Cartesian stiffness, translational [N/m] and rotational [Nm/rad] (libfranka's
examples use up to 3,000 and 300)."""
MAX_CART_D = (1_000.0, 100.0)
"""Largest Cartesian damping, translational [N s/m] and rotational [Nm s/rad]."""

Kp = Annotated[float, Field(ge=0.0, le=MAX_KP)]
Kd = Annotated[float, Field(ge=0.0, le=MAX_KD)]
Six = Annotated[list[float], Field(min_length=6, max_length=6)]


class _Strict(BaseModel):
    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)


class CartesianGainsSpec(_Strict):
    """The controller's default Cartesian impedance: for a skill that commands a Cartesian pose
    without gains of its own (`contact` and `retract` set theirs in `with:`)."""

    stiffness: Six | None = Field(
        default=None,
        description="x, y, z [N/m] (0 to 5000), then rx, ry, rz [Nm/rad] (0 to 500), in the "
        "robot's base axes. Default: the robot's (Panda: 500 N/m, 30 Nm/rad).",
    )
    damping: Six | None = Field(
        default=None,
        description="x, y, z [N s/m] (0 to 1000), then rx, ry, rz [Nm s/rad] (0 to 100). "
        "Default: critically damped for the stiffness (2 kg, 0.1 kg m^2 apparent inertia).",
    )
    nullspace_stiffness: float | None = Field(
        default=None,
        ge=0.0,
        le=200.0,
        description="Posture stiffness in the task's nullspace [Nm/rad] (Panda: 10).",
    )

    @field_validator("stiffness", "damping")
    @classmethod
    def _ranges(cls, values: list[float] | None, info: ValidationInfo) -> list[float] | None:
        stiffness = info.field_name == "stiffness"
        tops = MAX_CART_K if stiffness else MAX_CART_D
        units = ("N/m", "Nm/rad") if stiffness else ("N s/m", "Nm s/rad")
        for i, v in enumerate(values or ()):
            top, unit = (tops[0], units[0]) if i < 3 else (tops[1], units[1])
            if not 0.0 <= v <= top:
                raise ValueError(f"[{i}] = {v:g} is outside 0 to {top:g} {unit}")
        return values


class RobotGains(_Strict):
    """Controller gains that replace the robot's defaults (each key optional)."""

    kp: list[Kp] | None = Field(
        default=None,
        description="Joint stiffness, one per arm joint in the robot's order [Nm/rad] (a "
        "mobile base's x, y first [N/m]); 0 to 10000. Default: the robot's.",
    )
    kd: list[Kd] | None = Field(
        default=None,
        description="Joint damping, one per arm joint [Nm s/rad] ([N s/m] for a base's x, y); "
        "0 to 1000. Default: the robot's.",
    )
    cartesian: CartesianGainsSpec = Field(
        default_factory=CartesianGainsSpec, description="The default Cartesian impedance."
    )


def check_gains(robot: str, spec: RobotGains | None, source: SourceMap) -> list[Diagnostic]:
    """`kp` and `kd` have one value per arm joint of `robot` (an unknown robot is reported
    elsewhere)."""
    cls = ROBOTS.get(robot)
    if spec is None or cls is None:
        return []
    n = len(cls.arm_joints)
    out = []
    for key in ("kp", "kd"):
        values = getattr(spec, key)
        if values is not None and len(values) != n:
            out.append(
                source.diag(
                    ("robot", "gains", key),
                    f"{len(values)} values; {robot} has {n} arm joints "
                    f"({', '.join(cls.arm_joints)}): give one per joint, in that order",
                )
            )
    return out
