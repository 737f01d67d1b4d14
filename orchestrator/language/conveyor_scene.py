"""Scene key of a conveyor cell (`scene.conveyor`): a belt that feeds parcels one after
another to a pick zone guarded by a light barrier, for a shift of `parcels` parcels."""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from .sorting_scene import QUALIFIED

__all__ = ["MAX_SHIFT", "Conveyor"]

MAX_SHIFT = 5_000
"""Most parcels one shift (one episode) may feed."""


_Len = Annotated[float, Field(ge=0.01, le=0.5, description="[m]")]
_LenRange = Annotated[list[_Len], Field(min_length=2, max_length=2)]
_Mass = Annotated[float, Field(ge=0.001, le=QUALIFIED["mass_kg"][0], description="[kg]")]
_Coord = Annotated[float, Field(ge=-10.0, le=10.0)]
_XY = Annotated[list[_Coord], Field(min_length=2, max_length=2)]
_Unit = Annotated[float, Field(ge=0.0, le=1.0)]
_RGBA = Annotated[list[_Unit], Field(min_length=4, max_length=4)]


class Conveyor(BaseModel):
    """A straight belt from `feed_xy` to `pick_xy` (and `overrun_m` past it), its top
    `top_height_m` above the floor. Parcels are put on the belt at the feed one after another,
    `spacing_m` apart, each with a class, size and mass drawn from the seed; the belt carries
    them at `speed_m_s` and stops the moment a parcel breaks the light barrier across the belt
    at `pick_xy` (`barrier_height_m` above the belt), and runs again when the beam is clear.

    The shift ends when `parcels` parcels have been fed and none is left on the belt.
    MuJoCo models cannot grow during a run: a pool of `pool` parcel bodies is recycled (the
    oldest finished parcel — in a bin, on the floor, rejected — is taken back to the feed with
    a new class, size and mass), so a shift of any length has the same bodies.

    `--set parcels=N` sets `parcels`.
    """

    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)

    parcels: int = Field(
        default=20, ge=1, le=MAX_SHIFT, description="Parcels fed in one shift (one episode)."
    )
    feed_xy: _XY = Field(description="Where parcels are put on the belt [m].")
    pick_xy: _XY = Field(description="The pick zone: where the light barrier crosses the belt [m].")
    overrun_m: float = Field(
        default=0.1,
        ge=0.05,
        le=1.0,
        description="Belt past the barrier [m] (parcels passed "
        "through a rejected one fall off its end).",
    )
    width_m: float = Field(default=0.11, ge=0.04, le=1.0, description="Belt width [m].")
    top_height_m: float = Field(
        default=0.25, ge=0.02, le=1.5, description="Height of the belt's top above the floor [m]."
    )
    speed_m_s: float = Field(default=0.25, gt=0.0, le=2.0, description="Belt speed [m/s].")
    spacing_m: float = Field(
        default=0.3,
        ge=0.05,
        le=5.0,
        description="Distance a fed parcel travels before the next one is fed [m]: keeps one "
        "parcel at a time in the pick zone's camera view.",
    )
    barrier_height_m: float = Field(
        default=0.015, ge=0.002, le=0.2, description="Light beam above the belt top [m]."
    )
    pool: int = Field(
        default=8,
        ge=3,
        le=64,
        description="Parcel bodies recycled over the shift: at least the parcels on the belt, "
        "in the hand and settling in a bin at one time.",
    )
    park_xy: _XY = Field(
        default_factory=lambda: [-0.6, 0.9],
        description="Where unused bodies wait on the floor, out of reach [m].",
    )
    time_per_parcel_s: float = Field(
        default=15.0,
        ge=1.0,
        le=600.0,
        description="The run's time limit is at least parcels x this [s] (`physics.time_limit_s` "
        "is raised to it): a shift's time limit grows with the shift.",
    )
    yaw_jitter_deg: float = Field(
        default=10.0,
        ge=0.0,
        le=45.0,
        description="A fed parcel's long side is along the belt within +- this [deg].",
    )
    lateral_jitter_m: float = Field(
        default=0.01,
        ge=0.0,
        le=0.2,
        description="A fed parcel's offset across the belt, drawn within +- this [m].",
    )
    classes: dict[str, _RGBA] = Field(
        min_length=1,
        description="Class -> colour (RGBA, 0..1); a fed parcel's class is drawn uniformly.",
    )
    length_m: _LenRange = Field(
        default_factory=lambda: [0.06, 0.07], description="Long side, along the belt [m]."
    )
    parcel_width_m: _LenRange = Field(
        default_factory=lambda: [0.04, 0.045],
        description="Short side, across the belt [m]; the gripper closes across it.",
    )
    height_m: _LenRange = Field(
        default_factory=lambda: [0.04, 0.05], description="Parcel height [m]."
    )
    mass_kg: Annotated[list[_Mass], Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: [0.05, 0.4],
        description="Parcel mass [kg]; at most 0.4 kg, as the sorting cell's (`QUALIFIED`).",
    )
    friction: float = Field(default=0.8, ge=0.01, le=5.0, description="Sliding friction.")

    @field_validator("mass_kg", mode="before")
    @classmethod
    def _qualified_mass(cls, value: object) -> object:
        """Heavier than the sorting cell's `QUALIFIED` parcels: refused, saying why."""
        limit = QUALIFIED["mass_kg"][0]
        if isinstance(value, list) and any(
            isinstance(v, (int, float)) and v > limit for v in value
        ):
            raise ValueError(
                f"{value} goes above {limit:g} kg, what the sorting cell is qualified for: the "
                "same arm and grasp as sorting's, whose heavier parcels swung the wrist past "
                "its datasheet acceleration as they were lifted (0.8 kg: joint 6 at 1.09x); on "
                "the belt, 1.1-1.8 kg parcels let fall into a bin pushed the fingers open at "
                "1.03x their rated speed"
            )
        return value

    @model_validator(mode="after")
    def _geometry(self) -> Conveyor:
        for name in ("length_m", "parcel_width_m", "height_m", "mass_kg"):
            lo, hi = getattr(self, name)
            if lo > hi:
                raise ValueError(f"{name} {[lo, hi]}: the first bound must not exceed the second")
        if self.parcel_width_m[1] > self.length_m[0]:
            raise ValueError(
                f"parcel_width_m {self.parcel_width_m} must stay below length_m {self.length_m}"
            )
        if self.parcel_width_m[1] / 2 + self.lateral_jitter_m > self.width_m / 2:
            raise ValueError(
                f"parcels {self.parcel_width_m[1]} m wide, +- {self.lateral_jitter_m} m across, "
                f"do not fit on a belt {self.width_m} m wide"
            )
        if self.travel_m() < self.length_m[1]:
            raise ValueError(
                f"feed_xy {self.feed_xy} is {self.travel_m():.3f} m from pick_xy {self.pick_xy}: "
                f"less than a parcel's length ({self.length_m[1]} m)"
            )
        if self.spacing_m < self.length_m[1] + 0.02:
            raise ValueError(
                f"spacing_m {self.spacing_m} leaves no gap between parcels up to "
                f"{self.length_m[1]} m long: use at least {self.length_m[1] + 0.02:g}"
            )
        return self

    def travel_m(self) -> float:
        """Distance from the feed to the barrier [m]."""
        return math.dist(self.feed_xy, self.pick_xy)

    def direction(self) -> tuple[float, float]:
        """Unit vector of the belt's motion in the table plane."""
        d = self.travel_m()
        return (self.pick_xy[0] - self.feed_xy[0]) / d, (self.pick_xy[1] - self.feed_xy[1]) / d
