"""Faults a scenario injects: what breaks, when, and with which parameters.

A fault starts at a simulated time (`at: 1.5`) or when a state is first entered (`on_enter:
PICK.GRASP.LIFT`, plus `delay_s`). On the command line, `--fault SPEC` adds one, written
`KIND[:KEY=VALUE[,KEY=VALUE...]]@WHEN[+DELAY]`, e.g. `estop@1.5`,
`ft_bias:force_n=[0,0,150]@2.0`, `slip:factor=0.05@PICK.GRASP.LIFT+0.1`.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    NonNegativeFloat,
    PositiveFloat,
    PositiveInt,
    model_validator,
)

from ..exceptions import ConfigError
from .diagnostics import Diagnostic
from .yamlio import parse_yaml

__all__ = [
    "FAULT_KINDS",
    "HELD",
    "Fault",
    "FaultSpec",
    "parse_fault_spec",
]

# Bounded so that every accepted fault runs to a result: `offset_m: [1e308, 0, 0]` once ended
# `run` in an OverflowError traceback, a 1e308 N push in diverged physics.
Metres = Annotated[float, Field(ge=-10.0, le=10.0, description="[m]")]
Newtons = Annotated[float, Field(ge=-1e4, le=1e4, description="[N]")]
PushNewtons = Annotated[float, Field(ge=-1e3, le=1e3, description="[N]")]
Vec3m = Annotated[list[Metres], Field(min_length=3, max_length=3)]
Vec3N = Annotated[list[Newtons], Field(min_length=3, max_length=3)]


class _Fault(BaseModel):
    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)

    at: NonNegativeFloat | None = Field(
        default=None, le=1e6, description="Simulated time the fault starts [s]."
    )
    on_enter: str | None = Field(
        default=None,
        description="Dotted state path (`PICK.GRASP.LIFT`, or a parent such as `PICK`): the "
        "fault starts when that state is first entered.",
    )
    delay_s: NonNegativeFloat = Field(
        default=0.0, le=1e6, description="Start this long after `on_enter` [s]."
    )

    @model_validator(mode="after")
    def _one_trigger(self) -> _Fault:
        if (self.at is None) == (self.on_enter is None):
            raise ValueError("a fault needs exactly one of `at` (a time) or `on_enter` (a state)")
        if self.at is not None and self.delay_s:
            raise ValueError("`delay_s` only applies to `on_enter`")
        return self

    @property
    def when(self) -> str:
        """The trigger in words (`t=1.5 s`, `on entering PICK.GRASP`)."""
        if self.at is not None:
            return f"t={self.at:g} s"
        delay = f" + {self.delay_s:g} s" if self.delay_s else ""
        return f"on entering {self.on_enter}{delay}"


Joint = Annotated[int, Field(ge=1, le=64, description="Arm joint number, 1 = the first.")]


class EStop(_Fault):
    """An operator's emergency stop: outranks every guard; the run ends `aborted` (guard
    `estop`) after the controlled safety stop. A machine cannot map it to another state."""

    kind: Literal["estop"]


class FtDropout(_Fault):
    """The wrist force/torque sensor stops updating: its last reading stays (stale)."""

    kind: Literal["ft_dropout"]


class FtBias(_Fault):
    """A constant offset added to every wrist force reading from then on."""

    kind: Literal["ft_bias"]
    force_n: Vec3N = Field(
        default_factory=lambda: [0.0, 0.0, 80.0], description="Offset, world frame [N]."
    )


class FtSpike(_Fault):
    """A short offset on the wrist force readings (electrical noise, a cable knock)."""

    kind: Literal["ft_spike"]
    force_n: Vec3N = Field(
        default_factory=lambda: [0.0, 0.0, 200.0], description="Offset, world frame [N]."
    )
    duration_ms: PositiveFloat = Field(default=6.0, le=1e6, description="[ms]")


class FtNan(_Fault):
    """The wrist force/torque sensor returns NaN from then on."""

    kind: Literal["ft_nan"]


class EncoderFreeze(_Fault):
    """One joint's encoder keeps its last value (position and velocity) from then on."""

    kind: Literal["encoder_freeze"]
    joint: Joint = 2


class EncoderNoise(_Fault):
    """Gaussian noise on one joint's encoder position from then on."""

    kind: Literal["encoder_noise"]
    joint: Joint = 2
    std_rad: PositiveFloat = Field(default=0.02, le=10.0, description="Std. dev. [rad].")


class EncoderNan(_Fault):
    """One joint's encoder returns NaN from then on."""

    kind: Literal["encoder_nan"]
    joint: Joint = 2


class ActuatorSaturate(_Fault):
    """One joint's motor delivers at most `fraction` of its torque limit from then on."""

    kind: Literal["actuator_saturate"]
    joint: Joint = 2
    fraction: float = Field(default=0.2, ge=0.0, lt=1.0, description="Of the torque limit.")


class ActuatorLost(_Fault):
    """One joint's motor delivers no torque from then on (a drive fault)."""

    kind: Literal["actuator_lost"]
    joint: Joint = 2


class ObstacleFault(_Fault):
    """A fixed box appears in the scene (something put in the robot's way)."""

    kind: Literal["obstacle"]
    pos: Vec3m = Field(description="Centre in the world [m].")
    size: Annotated[list[float], Field(min_length=3, max_length=3)] = Field(
        default_factory=lambda: [0.1, 0.1, 0.1], description="Full edge lengths [m]."
    )

    @model_validator(mode="after")
    def _size(self) -> ObstacleFault:
        if not all(0.001 <= s <= 5.0 for s in self.size):
            raise ValueError(f"size must be within [0.001, 5] m per edge, got {self.size}")
        return self


HELD = "held"
"""A fault's `object: held`: the object in the hand when the fault starts (parcels are drawn
per seed: which one is carried is known only then)."""


class Slip(_Fault):
    """The grip loses friction: friction between the fingers and `object` x `factor`."""

    kind: Literal["slip"]
    object: str = Field(
        description="Scene object whose grip slips (`held`: the one in the hand then)."
    )
    factor: float = Field(default=0.02, gt=0.0, le=1.0, description="Friction multiplier.")


class Push(_Fault):
    """An external force on a scene object for a while (someone bumps it)."""

    kind: Literal["push"]
    object: str = Field(description="Scene object pushed (`held`: the one in the hand then).")
    force_n: Annotated[list[PushNewtons], Field(min_length=3, max_length=3)] = Field(
        description="Force at its centre, world frame [N] (at most 1 kN per axis)."
    )
    duration_ms: PositiveFloat = Field(default=50.0, le=1e6, description="[ms]")


class PerceptionMiss(_Fault):
    """The next `count` perception calls find nothing."""

    kind: Literal["perception_miss"]
    count: PositiveInt = Field(default=1, le=1000)


class PerceptionOffset(_Fault):
    """Perception reports poses offset by `offset_m` (a miscalibrated camera)."""

    kind: Literal["perception_offset"]
    offset_m: Vec3m = Field(description="Added to every reported position, world frame [m].")
    count: PositiveInt | None = Field(
        default=None, le=1000, description="How many perception calls (default: all later)."
    )


Fault = Annotated[
    EStop
    | FtDropout
    | FtBias
    | FtSpike
    | FtNan
    | EncoderFreeze
    | EncoderNoise
    | EncoderNan
    | ActuatorSaturate
    | ActuatorLost
    | ObstacleFault
    | Slip
    | Push
    | PerceptionMiss
    | PerceptionOffset,
    Field(discriminator="kind"),
]
"""One injected fault (the `kind` key selects which)."""

FaultSpec = _Fault
"""Base class of every fault model (trigger fields `at`, `on_enter`, `delay_s`)."""

FAULT_KINDS: tuple[str, ...] = (
    "estop",
    "ft_dropout",
    "ft_bias",
    "ft_spike",
    "ft_nan",
    "encoder_freeze",
    "encoder_noise",
    "encoder_nan",
    "actuator_saturate",
    "actuator_lost",
    "obstacle",
    "slip",
    "push",
    "perception_miss",
    "perception_offset",
)


def _split_top(text: str, sep: str) -> list[str]:
    """Split at `sep` outside brackets and quotes."""
    parts, depth, quote, current = [], 0, "", ""
    for ch in text:
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "[{(":
            depth += 1
        elif ch in "]})":
            depth -= 1
        elif ch == sep and depth == 0:
            parts.append(current)
            current = ""
            continue
        current += ch
    parts.append(current)
    return parts


def parse_fault_spec(text: str) -> dict[str, Any] | Diagnostic:
    """`KIND[:K=V,...]@WHEN[+DELAY]` -> the raw mapping of a `faults:` entry.

    Values are YAML (`0.05`, `[0, 0, 150]`, `cube`); WHEN is a time in seconds or a state path.
    """

    def bad(message: str) -> Diagnostic:
        return Diagnostic("<--fault>", 0, 0, text[:80], message)

    head, sep, when = text.rpartition("@")
    if not sep or not head.strip() or not when.strip():
        return bad(
            "expected KIND[:KEY=VALUE,...]@WHEN, e.g. estop@1.5 or slip:factor=0.05@PICK.GRASP.LIFT"
        )
    kind, _, params = head.partition(":")
    out: dict[str, Any] = {"kind": kind.strip()}
    for item in (p for p in _split_top(params, ",") if p.strip()):
        key, eq, raw = item.partition("=")
        if not eq or not key.strip():
            return bad(f"parameter {item.strip()!r} is not KEY=VALUE")
        try:  # the loader of the files, with their caps: no tags, huge integers or deep nests
            out[key.strip()] = parse_yaml(raw, "<--fault>").data if raw.strip() else None
        except ConfigError as exc:
            why = "; ".join(d.message for d in exc.diagnostics)
            return bad(f"cannot read the value of {key.strip()!r} ({raw.strip()!r}): {why}")
    when = when.strip()
    state, plus, delay = when.partition("+")
    try:
        out["at"] = float(when)
    except ValueError:
        out["on_enter"] = state.strip()
        if plus:
            try:
                out["delay_s"] = float(delay)
            except ValueError:
                return bad(f"delay {delay.strip()!r} after {state.strip()!r} is not a number")
    return out
