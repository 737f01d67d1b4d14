"""Scene keys of sorting cells: a pick area of random parcels (`scene.parcels`) and bins
with walls (`scene.bins`) a released parcel falls into."""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator, model_validator

__all__ = ["Bin", "Parcels", "bin_walls"]

_Len = Annotated[float, Field(ge=0.01, le=0.5, description="[m]")]
_LenRange = Annotated[list[_Len], Field(min_length=2, max_length=2)]
_Mass = Annotated[float, Field(ge=0.001, le=0.4, description="[kg]")]
_Height = Annotated[float, Field(ge=0.01, le=0.06, description="[m]")]
QUALIFIED = {"height_m": (0.06, "m"), "mass_kg": (0.4, "kg")}
"""What the sorting cell was qualified on (the bundled ranges' upper ends), and why no more
(sorting seed 0 at the values explore draws, 2026-11-29): parcels of 0.8, 1.0 and 1.5 kg
swung the wrist past its datasheet acceleration as they were lifted (joint 6 at 1.03-1.11x),
3 kg took joint 2 to 90 % of its torque; parcels 7.5 cm tall jolted joint 1 to 1.2x on the
way to the bin, 9 cm ones were held 27 mm off the TCP, judged dropped while still in the
hand, and the arm was jolted to 3x letting them go."""
WALL_QUALIFIED_M = 0.12
"""The tallest bin wall the sorting flows were qualified with [m] (the bundled bins'): they
let go 0.2 m above a bin's floor after carrying the parcel in over its walls (explore on
sorting, seed 1256578096, bin_B's walls 0.15, 0.18, 0.22 and 0.36 m: the parcel or the hand
struck a wall on the way in, the arm jolted to 1.9-19x its datasheet acceleration)."""
INNER_HALF_QUALIFIED_M = 0.07
"""The least distance from a bin's floor centre to its walls the sorting flows were qualified
with [m] (the bundled bins': 75 mm): they let go up to 35 mm off the centre and a parcel of
the bundled 7 cm reaches 35 mm beyond that (explore on sorting, seed 988324937, bin_B's walls
5.2 cm thick, 33 mm inside: the parcel struck a wall in TO_BIN, joint 6 at 1.8x)."""
_Coord = Annotated[float, Field(ge=-10.0, le=10.0)]
_XY = Annotated[list[_Coord], Field(min_length=2, max_length=2)]
_Size2 = Annotated[
    list[Annotated[float, Field(ge=0.02, le=5.0)]], Field(min_length=2, max_length=2)
]
_Unit = Annotated[float, Field(ge=0.0, le=1.0)]
_RGBA = Annotated[list[_Unit], Field(min_length=4, max_length=4)]


class _Strict(BaseModel):
    model_config = ConfigDict(
        defer_build=True, extra="forbid", populate_by_name=True, allow_inf_nan=False
    )


def _ordered(name: str, pair: list[float]) -> None:
    if pair[0] > pair[1]:
        raise ValueError(f"{name} {pair}: the first bound must not exceed the second")


class Parcels(_Strict):
    """Parcels at random poses in a pick area, drawn per seed: class (uniformly among
    `classes`), size, mass, pose; a fraction `touching` is placed against a parcel of another class
    already there (end to end along their long sides, where no finger goes); every other pair
    stays at least `gap_m` apart.

    `--set parcels=N` sets `count`.
    """

    count: int = Field(default=8, ge=0, le=10_000, description="How many parcels.")
    area_center_xy: _XY = Field(description="Centre of the pick area on the table [m].")
    area_size_xy: _Size2 = Field(description="Extent of the pick area [m].")
    classes: dict[str, _RGBA] = Field(
        min_length=1,
        description="Class -> colour (RGBA, 0..1) of its parcels; perception names the class "
        "by that colour (`perception.classes`).",
    )
    length_m: _LenRange = Field(
        default_factory=lambda: [0.06, 0.07], description="Long side, drawn uniformly [m]."
    )
    width_m: _LenRange = Field(
        default_factory=lambda: [0.04, 0.045],
        description="Short side, drawn uniformly [m]; the gripper closes across it. At least "
        "1.5 cm shorter than the long side by default: a near-square top face (5.5 x 4.9 cm) "
        "let perception report the wrong side as the long one, and the fingers closed onto the "
        "neighbour touching its end.",
    )
    height_m: Annotated[list[_Height], Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: [0.04, 0.06],
        description="Height, drawn uniformly [m]; at most 6 cm (`QUALIFIED`).",
    )
    mass_kg: Annotated[list[_Mass], Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: [0.05, 0.4],
        description="Mass, drawn uniformly [kg]; at most 0.4 kg (`QUALIFIED`).",
    )
    touching: _Unit = Field(
        default=0.25, description="Probability that a parcel is placed touching another one."
    )
    gap_m: float = Field(
        default=0.03,
        ge=0.0,
        le=0.5,
        description="Least distance between parcels that do not touch [m] (room for fingers).",
    )
    friction: float = Field(default=0.8, ge=0.01, le=5.0, description="Sliding friction.")

    @field_validator("height_m", "mass_kg", mode="before")
    @classmethod
    def _qualified(cls, value: object, info: ValidationInfo) -> object:
        """Above what the cell was qualified on: refused, saying why (`QUALIFIED`)."""
        limit, unit = QUALIFIED[str(info.field_name)]
        if isinstance(value, list) and any(
            isinstance(v, (int, float)) and v > limit for v in value
        ):
            raise ValueError(
                f"{value} goes above {limit:g} {unit}, what the sorting cell is qualified for: "
                + (
                    "heavier parcels swung the wrist past its datasheet acceleration as they "
                    "were lifted (0.8 kg: joint 6 at 1.09x)"
                    if info.field_name == "mass_kg"
                    else "taller parcels are held too far above their centre (9 cm: judged "
                    "dropped while in the hand) and jolted the arm on the way to the bin "
                    "(7.5 cm: joint 1 at 1.2x its datasheet acceleration)"
                )
            )
        return value

    @model_validator(mode="after")
    def _ranges(self) -> Parcels:
        for name in ("length_m", "width_m", "height_m", "mass_kg"):
            _ordered(name, getattr(self, name))
        if self.width_m[1] > self.length_m[0]:
            raise ValueError(
                f"width_m {self.width_m} must stay below length_m {self.length_m}: the long "
                "side is what perception reports as the parcel's heading"
            )
        return self

    @field_validator("touching")
    @classmethod
    def _touching_fits(cls, touching: float, info: ValidationInfo) -> float:
        """`touching` 1.0 puts every parcel but the first end to end with one of another
        class, along that one's long side: all in one chain along the first parcel's
        heading, which only the area's diagonal can hold (and never with a single class)."""
        d = info.data
        if touching < 1.0 or not {"count", "classes", "area_size_xy", "length_m"} <= set(d):
            return touching
        count, classes, area, length = d["count"], d["classes"], d["area_size_xy"], d["length_m"]
        if count < 2:
            return touching
        if len(classes) < 2:
            raise ValueError(
                "touching 1.0 puts every parcel against one of another class, and there is "
                f"only one class ({', '.join(classes)}) (valid: touching < 1)"
            )
        diagonal = math.hypot(*area)
        most = int(diagonal // length[0])
        if count > most:
            raise ValueError(
                f"touching 1.0 with {count} parcels can never be laid out: it puts every "
                "parcel end to end with another, all in one chain along the first one's long "
                f"side, and the pick area's diagonal ({diagonal:.3f} m) holds at most {most} "
                f"parcels of length_m {length[0]:g} m or more (valid: touching < 1, or at "
                f"most {most} parcels)"
            )
        return touching


class Bin(_Strict):
    """A box with walls standing on the table, open at the top, for the parcels of one class.
    Its floor is a marker of the same name (a `move` target: the centre of the floor)."""

    name: str = Field(description="Its name as a target (`move`'s `target: bin_A`).")
    class_: str = Field(alias="class", description="The parcel class it is meant for.")
    xy: _XY = Field(description="Centre on the table [m].")
    size_xy: _Size2 = Field(default_factory=lambda: [0.17, 0.17], description="Outer size [m].")
    wall_height_m: float = Field(
        default=0.07,
        ge=0.005,
        le=WALL_QUALIFIED_M,
        description="[m]; at most 12 cm (`WALL_QUALIFIED_M`): the sorting flows let go 0.2 m "
        "above the floor.",
    )
    wall_thickness_m: float = Field(default=0.01, ge=0.002, le=0.1, description="[m]")
    rgba: _RGBA = Field(default_factory=lambda: [0.45, 0.45, 0.48, 1.0])

    @field_validator("wall_height_m", mode="before")
    @classmethod
    def _wall_qualified(cls, value: object) -> object:
        """Taller than `WALL_QUALIFIED_M`: refused, saying why (before the bound's bare text)."""
        if isinstance(value, (int, float)) and value > WALL_QUALIFIED_M:
            raise ValueError(
                f"{value:g} m is above {WALL_QUALIFIED_M:g} m, the tallest bin wall the sorting "
                "cell is qualified for: its flows carry a parcel in over the wall and let go "
                "0.2 m above the bin's floor (blackboard `drop_spots`), so a taller wall is in "
                "the way of the parcel and the hand (15 cm: a parcel struck the wall, joint 5 at "
                "2.5x its datasheet acceleration; 22 cm: the hand struck it)"
            )
        return value

    @model_validator(mode="after")
    def _walls(self) -> Bin:
        if min(self.size_xy) <= 2 * self.wall_thickness_m + 0.01:
            raise ValueError(
                f"size_xy {self.size_xy} leaves no room inside walls "
                f"{self.wall_thickness_m} m thick"
            )
        inner = min(self.inner_half())
        if inner < INNER_HALF_QUALIFIED_M:
            raise ValueError(
                f"size_xy {self.size_xy} with walls {self.wall_thickness_m:g} m thick leaves "
                f"{inner * 1000:.0f} mm from the floor's centre to a wall, under the "
                f"{INNER_HALF_QUALIFIED_M * 1000:.0f} mm the sorting cell is qualified for: its "
                "flows let go up to 35 mm off the centre (blackboard `drop_spots`) and a 7 cm "
                "parcel reaches 35 mm beyond that (walls 5.2 cm thick: a parcel struck one on "
                "the way in, joint 6 at 1.8x its datasheet acceleration); widen the bin or "
                "thin its walls"
            )
        return self

    def inner_half(self) -> tuple[float, float]:
        """Half extents of the floor inside the walls [m]."""
        t = self.wall_thickness_m
        return self.size_xy[0] / 2 - t, self.size_xy[1] / 2 - t


def bin_walls(b: Bin, table_height: float) -> list[tuple[str, list[float], list[float]]]:
    """The four walls of `b`: `(name, centre [m], full size [m])` each."""
    (sx, sy), t, h = b.size_xy, b.wall_thickness_m, b.wall_height_m
    x, y, z = b.xy[0], b.xy[1], table_height + h / 2
    return [
        (f"{b.name}_wall_xn", [x - sx / 2 + t / 2, y, z], [t, sy, h]),
        (f"{b.name}_wall_xp", [x + sx / 2 - t / 2, y, z], [t, sy, h]),
        (f"{b.name}_wall_yn", [x, y - sy / 2 + t / 2, z], [sx - 2 * t, t, h]),
        (f"{b.name}_wall_yp", [x, y + sy / 2 - t / 2, z], [sx - 2 * t, t, h]),
    ]
