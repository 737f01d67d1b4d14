"""Scenario models of perception: cameras, colour classes, randomization of what they see."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    ValidationInfo,
    field_validator,
    model_validator,
)

from ..perception.colours import NAMED_COLOURS, hsv_boxes

__all__ = ["CameraSpec", "Perception", "PerceptionRandomize"]

Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Range = Annotated[list[float], Field(min_length=2, max_length=2)]


class _Strict(BaseModel):
    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)


class CameraSpec(_Strict):
    """A pinhole camera: fixed in the world, or mounted on a robot body (it moves with it).

    Pose: `pos` and either `look_at` (a point it looks at; the image's up is towards `up`) or
    `quat` (MuJoCo's camera frame: it looks along its -z axis, image up is its +y). For a
    mounted camera (`body`), `pos`, `look_at` and `quat` are in that body's frame.
    """

    name: str
    width: int = Field(default=320, ge=16, le=1920, description="Image width [px].")
    height: int = Field(default=240, ge=16, le=1080, description="Image height [px].")
    fovy_deg: float = Field(default=60.0, gt=1.0, lt=170.0, description="Vertical field of view.")
    body: str | None = Field(
        default=None, description="Robot body it is mounted on (`hand`: the robot's hand)."
    )
    pos: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0], description="[m]")
    look_at: Vec3 | None = Field(default=None, description="Point it looks at [m].")
    up: Vec3 = Field(
        default_factory=lambda: [0.0, 0.0, 1.0],
        description="Direction the image's top points to (with look_at). When it is parallel to "
        "the view, +x is used.",
    )
    quat: Annotated[list[float], Field(min_length=4, max_length=4)] | None = Field(
        default=None, description="Orientation (w, x, y, z) of the camera frame."
    )

    @model_validator(mode="after")
    def _pose(self) -> CameraSpec:
        if self.look_at is not None and self.quat is not None:
            raise ValueError("give either look_at or quat, not both")
        if self.look_at is not None and self.look_at == self.pos:
            raise ValueError(f"look_at {self.look_at} is the camera's own position")
        if self.quat is not None and sum(q * q for q in self.quat) < 1e-12:
            raise ValueError(f"quat {self.quat} has zero norm")
        if self.body is None and self.look_at is None and self.quat is None:
            raise ValueError("a fixed camera needs look_at or quat")
        return self


def _colour_class(value: Any) -> Any:
    if isinstance(value, str):
        if value not in NAMED_COLOURS:
            raise ValueError(f"unknown colour {value!r} (valid: {', '.join(NAMED_COLOURS)})")
        return value
    boxes = value
    if (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(b, list) and b and not isinstance(b[0], list) for b in value)
    ):
        boxes = [value]  # a single [lo, hi] box
    if not isinstance(boxes, list) or not boxes:
        raise ValueError("a class is a colour name or HSV boxes [[h, s, v], [h, s, v]]")
    for box in boxes:
        if not (isinstance(box, list) and len(box) == 2):
            raise ValueError(f"{box!r} is not an HSV box [[h, s, v], [h, s, v]]")
        for corner in box:
            ok = isinstance(corner, list) and len(corner) == 3
            if not ok or not all(isinstance(c, (int, float)) for c in corner):
                raise ValueError(f"{corner!r} is not an HSV triple [h, s, v]")
        (h0, s0, v0), (h1, s1, v1) = box
        if not (0 <= h0 <= h1 <= 179 and 0 <= s0 <= s1 <= 255 and 0 <= v0 <= v1 <= 255):
            raise ValueError(
                f"HSV box {box} out of order or range (OpenCV units: 0 <= lo <= hi, "
                "h <= 179, s and v <= 255)"
            )
    return boxes


ColourClass = Annotated[str | list[Any], AfterValidator(_colour_class)]


def _default_classes() -> dict[str, Any]:
    return {"red": "red", "green": "green", "blue": "blue", "yellow": "yellow"}


class PerceptionRandomize(_Strict):
    """Per-seed variation of what cameras see (its own random stream: it never moves objects)."""

    light_intensity: Range = Field(
        default_factory=lambda: [1.0, 1.0],
        description="Factor on the scene light's diffuse intensity, drawn per seed.",
    )
    light_tilt_deg: float = Field(
        default=0.0, ge=0.0, le=60.0, description="Largest tilt of the light from vertical [deg]."
    )
    colour_jitter: float = Field(
        default=0.0, ge=0.0, le=0.2, description="Std. dev. of each object's RGB components."
    )
    pixel_noise: float = Field(
        default=0.0, ge=0.0, le=50.0, description="Std. dev. of image noise [8-bit levels]."
    )
    depth_noise_m: float = Field(default=0.0, ge=0.0, le=0.01, description="Std. dev. [m].")

    @model_validator(mode="after")
    def _ordered(self) -> PerceptionRandomize:
        lo, hi = self.light_intensity
        if not 0.0 < lo <= hi:
            raise ValueError(f"light_intensity: need 0 < lower <= upper, got {lo}, {hi}")
        return self


class Perception(_Strict):
    """Perception: the `search` oracle's noise, and the camera pipeline of `detect`."""

    position_noise_m: float = Field(
        default=0.0,
        ge=0.0,
        le=0.01,
        description="`search`: std. dev. [m]; at most 1 cm (see `_within_what_a_grasp_takes`).",
    )
    yaw_noise_deg: float = Field(
        default=0.0,
        ge=0.0,
        le=5.0,
        description="`search`: std. dev. [deg]; at most 5 (see `_within_what_a_grasp_takes`).",
    )
    backend: Literal["auto", "opengl", "raycast"] = Field(
        default="auto",
        description="Renderer: `auto` uses OpenGL (MUJOCO_GL) when it loads, else ray casting.",
    )
    classes: dict[str, ColourClass] = Field(
        default_factory=_default_classes,
        description="Colour classes: name -> a colour name or HSV boxes (OpenCV units).",
    )
    randomize: PerceptionRandomize = Field(default_factory=PerceptionRandomize)

    @field_validator("position_noise_m", "yaw_noise_deg", mode="before")
    @classmethod
    def _within_what_a_grasp_takes(cls, value: Any, info: ValidationInfo) -> Any:
        """Refuse, saying why, a `search` noise no cell qualified here can work with (found by
        `orchestrator explore`: at 0.6-1 m the hand was sent out of the workspace; at 160-180
        deg a finger came down on a 5 cm cube and jolted joint 2 to 1.3x its datasheet
        acceleration, the fingers clearing it by 5 mm a side at the right heading and by
        nothing 13 deg off)."""
        limit = {"position_noise_m": (0.01, "m"), "yaw_noise_deg": (5.0, "deg")}[info.field_name]
        if isinstance(value, (int, float)) and value > limit[0]:
            raise ValueError(
                f"{value:g} {limit[1]} is above {limit[0]:g} {limit[1]}: the bundled grasps "
                "come down with the fingers 5 mm clear of a 5 cm cube a side (13 deg of yaw); "
                "a perception noise past this bound lands a finger on the object at approach "
                "speed"
            )
        return value

    def class_boxes(self) -> dict[str, tuple]:
        """Class name -> its HSV boxes."""
        return {name: hsv_boxes(spec) for name, spec in self.classes.items()}
