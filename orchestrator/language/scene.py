"""A scenario's scene: the table and what stands on it (objects, place markers, a tissue
phantom, no-go zones, obstacles, parcels, bins, a conveyor), and the physical ranges every
length, mass and angle of a scenario is checked against (language/scenario.py uses them)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from .conveyor_scene import Conveyor
from .sorting_scene import Bin, Parcels, bin_walls

__all__ = [
    "Marker",
    "ObjectSpec",
    "Obstacle",
    "Phantom",
    "PhantomRandomize",
    "PhantomStiffening",
    "Randomize",
    "SceneSpec",
    "Spot",
    "Table",
    "Zone",
]

# Physical ranges: wide enough for any bench-top cell, narrow enough that every accepted
# value compiles in MuJoCo and steps in bounded time (a 1e-300 m cube or a 1e300 kg mass
# once crashed or hung `run` after `validate` accepted them).
Coord = Annotated[float, Field(ge=-10.0, le=10.0, description="A position coordinate [m].")]
Size = Annotated[float, Field(ge=1e-3, le=10.0, description="An edge length [m] (1 mm to 10 m).")]
Mass = Annotated[float, Field(ge=1e-3, le=100.0, description="A mass [kg] (1 g to 100 kg).")]
LIGHTEST_KG = 1e-3
"""The lightest object a gripper's squeeze is simulated faithfully on [kg]: MuJoCo's contact
is as soft as the body in it is light. Squeezed at the Panda's 20 N (pick_place's 5 cm cube,
seed 747987931) the fingers sank 16 mm into a 0.1 g cube and 5 mm into a 0.3 g one, and as
they opened the cube sprang them apart at 1.25x and 1.02x their rated 0.05 m/s; 1 g: 1.9 mm,
within the rated speed. (Styrofoam makes a 5 cm cube of 2 g.)"""
Friction = Annotated[float, Field(ge=1e-3, le=10.0, description="Sliding friction coefficient.")]
Unit = Annotated[float, Field(ge=0.0, le=1.0)]
Angle = Annotated[float, Field(ge=-360.0, le=360.0, description="[deg]")]
Vec3 = Annotated[list[Coord], Field(min_length=3, max_length=3)]
XY = Annotated[list[Coord], Field(min_length=2, max_length=2)]
Size3 = Annotated[list[Size], Field(min_length=3, max_length=3)]
Size2 = Annotated[list[Size], Field(min_length=2, max_length=2)]
RGBA = Annotated[list[Unit], Field(min_length=4, max_length=4)]
Range = Annotated[list[Coord], Field(min_length=2, max_length=2)]
Scale = Annotated[float, Field(ge=0.01, le=100.0)]
AngleRange = Annotated[list[Angle], Field(min_length=2, max_length=2)]


class _Strict(BaseModel):
    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)


class Table(_Strict):
    """A table: a box whose top surface is at `height`."""

    center_xy: XY = Field(
        default_factory=lambda: [0.55, 0.0], description="Centre of the top surface [m]."
    )
    size_xy: Size2 = Field(default_factory=lambda: [0.7, 0.9], description="Top surface size [m].")
    height: float = Field(
        default=0.2, ge=0.01, le=3.0, description="Height of the top surface [m]."
    )
    friction: Friction = Field(default=1.0, description="Sliding friction coefficient.")


class Spot(_Strict):
    """A place an object may start at: a region of a surface (a table top, the floor)."""

    xy: XY = Field(description="Centre of the region [m].")
    height: float = Field(
        default=0.0, ge=0.0, le=3.0, description="Height of the surface it rests on [m] (0: floor)."
    )
    x: Range = Field(default_factory=lambda: [0.0, 0.0], description="Offsets in x [m].")
    y: Range = Field(default_factory=lambda: [0.0, 0.0], description="Offsets in y [m].")

    @model_validator(mode="after")
    def _ordered(self) -> Spot:
        for name in ("x", "y"):
            lo, hi = getattr(self, name)
            if lo > hi:
                raise ValueError(f"{name}: lower bound {lo} is above upper bound {hi}")
        return self


class Randomize(_Strict):
    """Uniform per-seed offsets added to an object's nominal pose."""

    x: Range = Field(default_factory=lambda: [0.0, 0.0], description="[m]")
    y: Range = Field(default_factory=lambda: [0.0, 0.0], description="[m]")
    yaw_deg: AngleRange = Field(default_factory=lambda: [0.0, 0.0], description="[deg]")
    spots: list[Spot] = Field(
        default_factory=list,
        max_length=64,
        description="Places the object may start at, one drawn per seed (each equally likely), "
        "then offset within it; instead of `xy` + `x`, `y` and the table. Empty: on the table.",
    )

    @model_validator(mode="after")
    def _ordered(self) -> Randomize:
        for name in ("x", "y", "yaw_deg"):
            lo, hi = getattr(self, name)
            if lo > hi:
                raise ValueError(f"{name}: lower bound {lo} is above upper bound {hi}")
        return self


class ObjectSpec(_Strict):
    """A free rigid object resting on the table."""

    name: str = Field(description="Its name in skills (`search`, `grasp`) and success checks.")
    shape: Literal["box"] = Field(default="box", description="Only boxes for now.")
    size: Size3 = Field(description="Full edge lengths [m].")
    mass: Mass = Field(default=0.1, description="[kg] (at least 1 g: `LIGHTEST_KG`).")
    xy: XY = Field(description="Nominal position on the table [m].")
    yaw_deg: Angle = Field(default=0.0, description="Nominal rotation about z [deg].")
    randomize: Randomize = Field(
        default_factory=Randomize, description="Per-seed offsets added to `xy` and `yaw_deg`."
    )
    friction: Friction = Field(default=1.0, description="Sliding friction coefficient.")
    rgba: RGBA = Field(
        default_factory=lambda: [0.85, 0.2, 0.2, 1.0], description="Colour, 0..1 each."
    )

    @field_validator("mass", mode="before")
    @classmethod
    def _not_too_light(cls, mass: object) -> object:
        """Lighter than `LIGHTEST_KG`: refused, saying why (before the bound's bare message)."""
        if isinstance(mass, (int, float)) and not isinstance(mass, bool) and 0 < mass < LIGHTEST_KG:
            raise ValueError(
                f"{mass:g} kg is lighter than {LIGHTEST_KG * 1000:g} g, the lightest object a "
                "gripper's squeeze is simulated faithfully on: the contact is as soft as the "
                "body is light (a 0.1 g cube let a 20 N grip sink 16 mm into it, and it sprang "
                "the fingers open at 1.25x their rated speed); use 0.001 or more"
            )
        return mass

    @model_validator(mode="after")
    def _positive_size(self) -> ObjectSpec:
        if min(self.size) <= 0:
            raise ValueError(f"size must be positive, got {self.size}")
        return self


class Marker(_Strict):
    """A visual-only target on the table (a place pad): no collision."""

    name: str = Field(description="Its name as a target (`move`'s `target: pad`).")
    xy: XY = Field(description="Centre on the table top [m].")
    size_xy: Size2 = Field(default_factory=lambda: [0.08, 0.08], description="[m]")
    rgba: RGBA = Field(
        default_factory=lambda: [0.2, 0.7, 0.3, 1.0], description="Colour, 0..1 each."
    )


class PhantomRandomize(_Strict):
    """Uniform per-seed variation of the phantom: position offsets, a stiffness scale and
    turns about its own axes (added to the nominal `roll_deg`, `pitch_deg`, `yaw_deg`)."""

    x: Range = Field(default_factory=lambda: [0.0, 0.0], description="[m]")
    y: Range = Field(default_factory=lambda: [0.0, 0.0], description="[m]")
    stiffness_scale: Annotated[list[Scale], Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: [1.0, 1.0],
        description="True stiffness = nominal stiffness x a factor drawn from this range.",
    )
    yaw_deg: AngleRange = Field(default_factory=lambda: [0.0, 0.0], description="[deg]")
    roll_deg: AngleRange = Field(default_factory=lambda: [0.0, 0.0], description="[deg]")
    pitch_deg: AngleRange = Field(default_factory=lambda: [0.0, 0.0], description="[deg]")

    @model_validator(mode="after")
    def _ordered(self) -> PhantomRandomize:
        for name in ("x", "y", "stiffness_scale", "yaw_deg", "roll_deg", "pitch_deg"):
            lo, hi = getattr(self, name)
            if lo > hi:
                raise ValueError(f"{name}: lower bound {lo} is above upper bound {hi}")
        if self.stiffness_scale[0] <= 0.0:
            raise ValueError(f"stiffness_scale must be positive, got {self.stiffness_scale}")
        return self


class PhantomStiffening(_Strict):
    """How the tissue stiffens with indentation x: its secant stiffness f / x grows smoothly
    from `stiffness_n_per_m` at the surface to `ratio` times that at `depth_m`, and stays there
    deeper (linear beyond `depth_m`: put it below the working range). The damping grows with it
    (less steeply). `ratio: 1` is a linear spring."""

    ratio: float = Field(
        default=1.0,
        ge=1.0,
        le=50.0,
        description="Secant stiffness at `depth_m` over the stiffness at the surface.",
    )
    depth_m: float = Field(
        default=0.008, ge=1e-4, le=0.1, description="Indentation where it reaches `ratio` [m]."
    )


class Phantom(_Strict):
    """A tissue phantom: a fixed box on the table whose surface yields like a spring.

    The stiffness is set through MuJoCo's solref/solimp so that the tool tip pressed into it
    x metres deep pushes back with f(x) = stiffness(x) x newtons at rest: stiffness(x) is
    `stiffness_n_per_m` near the surface and grows with `stiffening`. Its frame (the `phantom`
    frame of zones and obstacles) is the centre of its top surface, z out of the tissue, turned
    by `yaw_deg` about the world z, then tilted by `pitch_deg` about its y and `roll_deg` about
    its x (R = Rz(yaw) Ry(pitch) Rx(roll)) about that centre: a tilted phantom lies on a wedge.
    """

    name: str = "phantom"
    size: Size3 = Field(description="Full edge lengths [m].")
    xy: XY = Field(description="Nominal position of its centre on the table [m].")
    yaw_deg: Angle = 0.0
    roll_deg: float = Field(default=0.0, ge=-30.0, le=30.0, description="Tilt about x [deg].")
    pitch_deg: float = Field(default=0.0, ge=-30.0, le=30.0, description="Tilt about y [deg].")
    stiffness_n_per_m: float = Field(
        default=500.0,
        ge=1.0,
        le=1e6,
        description="Nominal (registered) stiffness at the surface, small indentations [N/m].",
    )
    stiffening: PhantomStiffening = Field(default_factory=PhantomStiffening)
    damping_n_s_per_m: float = Field(
        default=20.0, ge=0.01, le=1e5, description="Damping at the surface [N s/m]."
    )
    friction: Friction = 0.1
    randomize: PhantomRandomize = Field(default_factory=PhantomRandomize)
    rgba: RGBA = Field(default_factory=lambda: [0.93, 0.7, 0.66, 1.0])

    @model_validator(mode="after")
    def _positive_size(self) -> Phantom:
        if min(self.size) <= 0:
            raise ValueError(f"size must be positive, got {self.size}")
        return self


class _SceneBox(_Strict):
    name: str
    size: Size3 = Field(description="Full edge lengths [m].")
    center: Vec3 = Field(description="Centre in `frame` [m].")
    frame: Literal["world", "phantom"] = Field(
        default="world",
        description="`world`, or `phantom` (its top-surface centre: moves with the phantom).",
    )

    @model_validator(mode="after")
    def _positive_size(self) -> _SceneBox:
        if min(self.size) <= 0:
            raise ValueError(f"size must be positive, got {self.size}")
        return self


class Zone(_SceneBox):
    """A no-go zone (a critical structure): a box no robot or tool geom may enter. It is drawn
    but has no collision: the `no_go_zone` guard watches it."""

    rgba: RGBA = Field(default_factory=lambda: [0.85, 0.1, 0.1, 0.35])


class Obstacle(_SceneBox):
    """A rigid fixed box (e.g. a hard inclusion on the phantom that registration missed)."""

    rgba: RGBA = Field(default_factory=lambda: [0.95, 0.95, 0.85, 1.0])


class SceneSpec(_Strict):
    """What stands on the table; every name is unique across objects, markers, zones,
    obstacles and the phantom."""

    table: Table = Field(default_factory=Table)
    objects: list[ObjectSpec] = Field(default_factory=list)
    markers: list[Marker] = Field(default_factory=list)
    phantom: Phantom | None = Field(default=None, description="A compliant tissue phantom.")
    zones: list[Zone] = Field(default_factory=list, description="No-go zones.")
    obstacles: list[Obstacle] = Field(default_factory=list, description="Fixed rigid boxes.")
    parcels: Parcels | None = Field(
        default=None, description="Random parcels in a pick area (drawn per seed)."
    )
    bins: list[Bin] = Field(
        default_factory=list,
        description="Bins with walls, each a marker (its floor) and four obstacles (its walls).",
    )
    conveyor: Conveyor | None = Field(
        default=None,
        description="A belt feeding parcels one after another to a light barrier (a shift).",
    )

    @model_validator(mode="after")
    def _one_feed(self) -> SceneSpec:
        if self.conveyor is not None and self.parcels is not None:
            raise ValueError(
                "scene.parcels (a pick area) and scene.conveyor (a belt) are two ways of "
                "feeding parcels: use one"
            )
        return self

    @model_validator(mode="after")
    def _bins_apart(self) -> SceneSpec:
        """Bins apart from one another and from the pick area (found by `orchestrator
        explore` on sorting: bin_A widened to 0.31 m overlapped bin_B, and a parcel of B
        dropped into their shared footprint was judged missorted)."""
        boxes = [(f"bin {b.name}", b.xy, b.size_xy) for b in self.bins]
        if self.parcels is not None:
            p = self.parcels
            boxes.append(("the pick area (scene.parcels)", p.area_center_xy, p.area_size_xy))
        for i, (a, axy, asz) in enumerate(boxes):
            for b, bxy, bsz in boxes[i + 1 :]:
                over = [(asz[k] + bsz[k]) / 2 - abs(axy[k] - bxy[k]) for k in (0, 1)]
                if min(over) > 1e-6:  # touching walls (adjacent bins) are no overlap
                    raise ValueError(
                        f"{a} and {b} overlap ({over[0] * 1000:.0f} x {over[1] * 1000:.0f} mm "
                        "of their footprints): a parcel let go over one lands in the other; "
                        "move them apart or make them smaller"
                    )
        return self

    @model_validator(mode="after")
    def _bin_parts(self) -> SceneSpec:
        """Each bin becomes a marker (its floor, named like it) and four wall obstacles; a
        scenario validated again (dumped and reloaded) keeps the parts it already has."""
        have = {m.name for m in self.markers} | {o.name for o in self.obstacles}
        for b in self.bins:
            if b.name not in have:
                self.markers.append(
                    Marker(
                        name=b.name, xy=b.xy, size_xy=[2 * h for h in b.inner_half()], rgba=b.rgba
                    )
                )
            for name, center, size in bin_walls(b, self.table.height):
                if name not in have:
                    self.obstacles.append(
                        Obstacle(name=name, size=size, center=center, rgba=b.rgba)
                    )
        return self

    @model_validator(mode="after")
    def _unique_names(self) -> SceneSpec:
        names = [o.name for o in self.objects] + [m.name for m in self.markers]
        names += [b.name for b in (*self.zones, *self.obstacles)]
        names += [self.phantom.name] if self.phantom is not None else []
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"scene names must be unique; repeated: {', '.join(dup)}")
        return self

    @model_validator(mode="after")
    def _phantom_frame(self) -> SceneSpec:
        if self.phantom is None:
            for box in (*self.zones, *self.obstacles):
                if box.frame == "phantom":
                    raise ValueError(f"{box.name!r} is placed in the phantom frame: add a phantom")
        return self
