"""Scenario: the robot, the scene, the machine to run, guards and what success means."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PositiveFloat, model_validator

from .machine import GuardRef

__all__ = [
    "Marker",
    "ObjectSpec",
    "Physics",
    "RobotRef",
    "Scenario",
    "SceneSpec",
    "SuccessCheck",
    "Table",
]

Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Range = Annotated[list[float], Field(min_length=2, max_length=2)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class RobotRef(_Strict):
    """Which robot, and where its base stands."""

    name: str = "panda"
    base_pos: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0], description="[m]")


class Table(_Strict):
    """A table: a box whose top surface is at `height`."""

    center_xy: Annotated[list[float], Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: [0.55, 0.0]
    )
    size_xy: Annotated[list[float], Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: [0.7, 0.9], description="Top surface size [m]."
    )
    height: PositiveFloat = Field(default=0.2, description="Height of the top surface [m].")
    friction: PositiveFloat = 1.0


class Randomize(_Strict):
    """Uniform per-seed offsets added to an object's nominal pose."""

    x: Range = Field(default_factory=lambda: [0.0, 0.0], description="[m]")
    y: Range = Field(default_factory=lambda: [0.0, 0.0], description="[m]")
    yaw_deg: Range = Field(default_factory=lambda: [0.0, 0.0], description="[deg]")

    @model_validator(mode="after")
    def _ordered(self) -> Randomize:
        for name in ("x", "y", "yaw_deg"):
            lo, hi = getattr(self, name)
            if lo > hi:
                raise ValueError(f"{name}: lower bound {lo} is above upper bound {hi}")
        return self


class ObjectSpec(_Strict):
    """A free rigid object resting on the table."""

    name: str
    shape: Literal["box"] = "box"
    size: Vec3 = Field(description="Full edge lengths [m].")
    mass: PositiveFloat = Field(default=0.1, description="[kg]")
    xy: Annotated[list[float], Field(min_length=2, max_length=2)] = Field(
        description="Nominal position on the table [m]."
    )
    yaw_deg: float = 0.0
    randomize: Randomize = Field(default_factory=Randomize)
    friction: PositiveFloat = 1.0
    rgba: Annotated[list[float], Field(min_length=4, max_length=4)] = Field(
        default_factory=lambda: [0.85, 0.2, 0.2, 1.0]
    )

    @model_validator(mode="after")
    def _positive_size(self) -> ObjectSpec:
        if min(self.size) <= 0:
            raise ValueError(f"size must be positive, got {self.size}")
        return self


class Marker(_Strict):
    """A visual-only target on the table (a place pad): no collision."""

    name: str
    xy: Annotated[list[float], Field(min_length=2, max_length=2)]
    size_xy: Annotated[list[float], Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: [0.08, 0.08]
    )
    rgba: Annotated[list[float], Field(min_length=4, max_length=4)] = Field(
        default_factory=lambda: [0.2, 0.7, 0.3, 1.0]
    )


class SceneSpec(_Strict):
    table: Table = Field(default_factory=Table)
    objects: list[ObjectSpec] = Field(default_factory=list)
    markers: list[Marker] = Field(default_factory=list)

    @model_validator(mode="after")
    def _unique_names(self) -> SceneSpec:
        names = [o.name for o in self.objects] + [m.name for m in self.markers]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"scene names must be unique; repeated: {', '.join(dup)}")
        return self


class Physics(_Strict):
    timestep_s: PositiveFloat = Field(default=0.002, le=0.01, description="Physics step [s].")
    control_hz: PositiveFloat = Field(default=100.0, le=1000.0, description="Control rate [Hz].")
    time_limit_s: PositiveFloat = Field(
        default=30.0, description="Simulated time after which the run ends `failed`."
    )
    safe_stop_s: PositiveFloat = Field(
        default=0.3, description="Simulated time kept running after an abort, holding the pose."
    )


class SuccessCheck(_Strict):
    """A named success criterion, evaluated once at the end of the run.

    `object_at`: the object rests within `xy_tol_m` of the marker centre and is upright within
    `upright_tol_deg`. `gripper_clear`: the gripper is open and its fingers at least
    `min_distance_m` from the object.
    """

    kind: Literal["object_at", "gripper_clear"]
    object: str
    target: str | None = None
    xy_tol_m: PositiveFloat = 0.01
    upright_tol_deg: PositiveFloat = 10.0
    min_distance_m: float = Field(default=0.01, ge=0.0)

    @model_validator(mode="after")
    def _target(self) -> SuccessCheck:
        if self.kind == "object_at" and self.target is None:
            raise ValueError("`object_at` needs a `target` (a marker name)")
        return self


class Perception(_Strict):
    """Noise of the simulated perception used by `search`."""

    position_noise_m: float = Field(default=0.0, ge=0.0, description="Std. dev. [m].")
    yaw_noise_deg: float = Field(default=0.0, ge=0.0, description="Std. dev. [deg].")


class Scenario(_Strict):
    """One runnable episode family: everything but the seed."""

    name: str
    description: str | None = None
    robot: RobotRef = Field(default_factory=RobotRef)
    scene: SceneSpec = Field(default_factory=SceneSpec)
    machine: str = Field(description="Machine file (relative to this file) or bundled name.")
    blackboard: dict[str, Any] = Field(default_factory=dict, description="Overrides defaults.")
    guards: list[GuardRef] | dict[str, dict[str, Any] | None] = Field(
        default_factory=list, description="Guards active for the whole run."
    )
    success: dict[str, SuccessCheck] = Field(default_factory=dict)
    physics: Physics = Field(default_factory=Physics)
    perception: Perception = Field(default_factory=Perception)
