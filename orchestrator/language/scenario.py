"""Scenario: the robot, the scene, the machine to run, guards and what success means.

The scene (table, objects, phantom, zones...) is language/scene.py's; its models are
exported from here too.
"""

from __future__ import annotations

import math
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, PositiveFloat, model_validator

from ..success.params import CheckParams
from ..world.pool import pool_body_name
from .conveyor_scene import Conveyor
from .events import ScheduledEvent
from .faults import Fault
from .machine import GuardRef
from .parcels import draw_parcels
from .perception import CameraSpec, Perception
from .random_goals import DrawnValues, draw_goals
from .robot_gains import CartesianGainsSpec, RobotGains
from .scene import (
    RGBA,
    Friction,
    Marker,
    ObjectSpec,
    Obstacle,
    Phantom,
    PhantomStiffening,
    Randomize,
    SceneSpec,
    Spot,
    Table,
    Vec3,
    Zone,
)

__all__ = [
    "CameraSpec",
    "CartesianGainsSpec",
    "Marker",
    "ObjectSpec",
    "Obstacle",
    "Perception",
    "Phantom",
    "PhantomStiffening",
    "Physics",
    "Realism",
    "RobotGains",
    "RobotRef",
    "SafeStop",
    "Scenario",
    "SceneSpec",
    "SuccessEntry",
    "Table",
    "ToolSpec",
    "Zone",
]


class _Strict(BaseModel):
    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)


class RobotRef(_Strict):
    """Which robot, where its base stands, and its controller gains."""

    name: str = Field(
        default="panda", description="A registered robot (`orchestrator list robots`)."
    )
    base_pos: Vec3 = Field(
        default_factory=lambda: [0.0, 0.0, 0.0], description="Base position in the world [m]."
    )
    gains: RobotGains | None = Field(
        default=None,
        description="Controller gains replacing the robot's defaults: joint `kp`, `kd` and the "
        "default `cartesian` impedance (docs/robots.md#gains).",
    )


class SafeStop(_Strict):
    """The controlled stop every abort, e-stop and end of run goes through.

    The arm decelerates from its measured velocity to standstill along a synchronized
    constant-deceleration profile (all joints stop together, the slowest at
    `max_decel_rad_s2`). A joint that cannot follow the profile (a lost or weak motor) gets
    its holding brake at once; after an abort, once every joint is slower than
    `rest_speed_rad_s`, every joint's holding brake holds the stopped pose (a category-1
    stop), so a lost or saturated motor cannot let the arm sag. A normal end of a run holds
    the pose with the motors (gravity-compensated, damped joint impedance). At the defaults
    the Panda stops from 2 rad/s in 40 ms.
    """

    max_decel_rad_s2: PositiveFloat = Field(
        default=50.0, ge=1.0, le=100.0, description="Deceleration of the slowest joint [rad/s^2]."
    )
    hold_s: float = Field(
        default=0.3,
        ge=0.0,
        le=1e6,
        description="Time the built-in safe stop holds the stopped pose before the run ends [s].",
    )
    rest_speed_rad_s: PositiveFloat = Field(
        default=0.01,
        le=1.0,
        description="Joint speed below which the arm counts as at rest, and an aborted arm's"
        " brakes engage [rad/s].",
    )
    max_stop_s: PositiveFloat = Field(
        default=2.0,
        le=60.0,
        description="Longest the stop may take before the run ends anyway (reported) [s].",
    )
    force_ceiling_n: PositiveFloat = Field(
        default=30.0,
        le=500.0,
        description="Hard wrist-force ceiling while the `on_abort` response moves the stopped"
        " arm [N]; above it the response ends and the arm is stopped and held. The joint"
        " limits stay checked during every safety response too.",
    )


class Realism(_Strict):
    """Imperfections of the plant and of the controller's knowledge of it (on by default).

    Without them the simulated Panda is frictionless, its sensors exact and its controller's
    model perfect: figures measured that way flatter. The robot documents its own datasheet
    values (joint friction, encoder resolution); these keys scale or add to them.
    """

    enabled: bool = Field(default=True, description="Apply every imperfection below.")
    joint_friction_scale: float = Field(
        default=0.25,
        ge=0.0,
        le=10.0,
        description="Fraction of the robot's identified Coulomb and viscous joint friction"
        " the controller meets uncompensated (the Panda's torque interface compensates"
        " friction inside the robot, with a model as good as its identification).",
    )
    ft_noise_n: float = Field(
        default=0.01,
        ge=0.0,
        le=10.0,
        description="White noise of the wrist force sensor, std. dev. per axis per reading [N]"
        " (a Nano17-class sensor resolves 3 mN; 10 mN covers its electronics at 500 Hz).",
    )
    ft_drift_n_per_sqrt_s: float = Field(
        default=0.005,
        ge=0.0,
        le=10.0,
        description="Random-walk bias drift of the wrist force sensor per axis [N/sqrt(s)]"
        " (0.04 N after a minute: why a sensor is zeroed before each contact task).",
    )
    encoder_quantization: bool = Field(
        default=True,
        description="Joint positions in steps of the robot's encoder resolution; velocities"
        " the difference of successive readings.",
    )
    mass_mismatch: float = Field(
        default=0.0,
        ge=0.0,
        le=0.5,
        description="The controller's link masses (and inertias) are each off by a seeded"
        " factor in [1 - x, 1 + x] (a model identified to within x). 0 by default: the"
        " Panda compensates gravity inside the robot with Franka's own model; at x = 0.02 the"
        " joint impedance (no integral action) already misses the surgical 0.3 mm approach"
        " tolerance.",
    )


class Physics(_Strict):
    """Integration step, control rate and how long a run may last (all simulated time)."""

    timestep_s: float = Field(
        default=0.002, ge=1e-4, le=0.01, description="Physics step [s] (0.1 ms to 10 ms)."
    )
    control_hz: float = Field(
        default=100.0,
        ge=1.0,
        le=1000.0,
        description="Control rate [Hz] (1 to 1000): a tick every whole number of physics"
        " steps, at most one per step.",
    )
    time_limit_s: PositiveFloat = Field(
        default=30.0,
        le=86_400.0,
        description="Simulated time after which the run ends `failed` [s] (at most a day; "
        "bound the wall time with `run --max-wall-s`).",
    )
    safe_stop: SafeStop = Field(
        default_factory=SafeStop,
        description="The controlled stop after an abort, an e-stop or at the end of a run.",
    )
    realism: Realism = Field(
        default_factory=Realism,
        description="Joint friction, sensor noise and drift, encoder quantization, model mismatch.",
    )
    sleep: bool = Field(
        default=True,
        description="Free objects at rest sleep (MuJoCo island sleeping) until a contact with "
        "a moving body, a velocity or a force wakes them: the step skips their collisions. "
        "Turn off if a scene moves objects by some other means and they stay put.",
    )

    @model_validator(mode="after")
    def _tick_fits_steps(self) -> Physics:
        if self.control_hz * self.timestep_s > 1.0 + 1e-9:
            raise ValueError(
                f"control_hz {self.control_hz} ticks faster than the physics steps "
                f"(timestep_s {self.timestep_s}: at most {1.0 / self.timestep_s:g} Hz)"
            )
        steps = 1.0 / (self.control_hz * self.timestep_s)
        if abs(steps - round(steps)) > 1e-6 * steps:
            # the runner ticks every round(steps) steps: 100 Hz at 4 ms would run at 125 Hz
            lo, hi = math.floor(steps), math.ceil(steps)
            rates = ", ".join(f"{1.0 / (n * self.timestep_s):g} Hz ({n} steps)" for n in (lo, hi))
            raise ValueError(
                f"control_hz {self.control_hz} ticks every {steps:g} physics steps of "
                f"{self.timestep_s} s: a tick must be a whole number of steps (valid: {rates})"
            )
        return self


SuccessEntry = CheckParams | dict[str, Any]
"""One named success criterion: `{kind: KIND, ...its parameters}` (orchestrator/success/);
`load_scenario` validates it by its kind and keeps it as that kind's `Params`."""


class ToolSpec(_Strict):
    """A probe mounted on the flange: a shaft along the flange z axis ending in a ball tip.

    The tip becomes the TCP of every motion skill, of the Cartesian controller and of the
    guards; the wrist force/torque sensor feels the tool's weight until it is zeroed.
    """

    name: str = "probe"
    mass_kg: float = Field(default=0.25, ge=1e-3, le=3.0, description="[kg] (the Panda carries 3).")
    length_m: float = Field(
        default=0.2, ge=0.01, le=0.5, description="From the flange to the tip [m]."
    )
    shaft_radius_m: float = Field(default=0.004, ge=1e-4, le=0.05, description="[m]")
    tip_radius_m: float = Field(default=0.0025, ge=1e-4, le=0.05, description="[m]")
    com_m: PositiveFloat | None = Field(
        default=None, description="Centre of mass on the axis, from the flange [m] (default: L/2)."
    )
    friction: Friction = Field(default=0.1, description="Sliding friction of the tip.")
    rgba: RGBA = Field(default_factory=lambda: [0.75, 0.78, 0.82, 1.0])
    controller_payload: bool = Field(
        default=True,
        description="The controller's model knows the tool's mass (false: an unmodelled payload).",
    )

    @model_validator(mode="after")
    def _geometry(self) -> ToolSpec:
        if self.length_m <= 2.0 * self.tip_radius_m:
            raise ValueError(
                f"length_m {self.length_m} must exceed the tip diameter {2 * self.tip_radius_m}"
            )
        if self.com_m is not None and self.com_m > self.length_m:
            raise ValueError(f"com_m {self.com_m} lies beyond the tip (length_m {self.length_m})")
        return self


class Scenario(_Strict):
    """One runnable episode family: everything but the seed."""

    name: str = Field(description="Printed in results and recordings.")
    description: str | None = Field(default=None, description="Free text.")
    robot: RobotRef = Field(default_factory=RobotRef, description="The robot and its base.")
    tool: ToolSpec | None = Field(default=None, description="A tool on the flange (a probe).")
    scene: SceneSpec = Field(default_factory=SceneSpec, description="Table, objects, markers.")
    machine: str = Field(description="Machine file (relative to this file) or bundled name.")
    skills: list[str] = Field(
        default_factory=list,
        description="Your own skills: folders of skill modules or `.py` files, relative to "
        "this file and inside its directory tree (or an `--allow-path` directory). Every Skill "
        "subclass they define is available by its `name`. Imported when the scenario runs "
        "(`run`, `batch`, `faults`, `serve`), never by `validate`, `graph` or `show` "
        "(pass `--skills DIR` to check against them).",
    )
    blackboard: dict[str, Any] = Field(
        default_factory=dict,
        description="Values for the machine's blackboard keys (overrides their defaults).",
    )
    guards: list[GuardRef] | dict[str, dict[str, Any] | None] = Field(
        default_factory=list,
        description="Guards active for the whole run: `{name: {params}}` or a list of names "
        "(docs/skills.md#guards).",
    )
    success: dict[str, SuccessEntry] = Field(
        default_factory=dict,
        description="Named checks judged at the end, each `{kind: KIND, ...}`; any failing one "
        "makes the run `failed` (kinds: docs/skills.md#success-checks).",
    )
    physics: Physics = Field(default_factory=Physics, description="Rates and time limit.")
    perception: Perception = Field(default_factory=Perception, description="Noise of `search`.")
    cameras: list[CameraSpec] = Field(
        default_factory=list, description="Cameras (see docs/perception.md)."
    )
    faults: list[Fault] = Field(
        default_factory=list, description="Faults injected into the run (see docs/safety.md)."
    )
    events: list[ScheduledEvent] = Field(
        default_factory=list,
        description="Events sent into the run at simulated times (see docs/live.md).",
    )
    randomize: DrawnValues = Field(
        default_factory=DrawnValues,
        description="Blackboard values drawn per seed (a reach test's target: "
        "`randomize: {blackboard: {target: {x: [..], y: [..], z: [..]}}}`).",
    )

    @model_validator(mode="after")
    def _shift_time(self) -> Scenario:
        """A conveyor shift's time limit grows with the shift (`time_per_parcel_s`)."""
        c = self.scene.conveyor
        if c is not None:
            need = min(86_400.0, c.parcels * c.time_per_parcel_s)
            self.physics.time_limit_s = max(self.physics.time_limit_s, need)
        return self

    def for_seed(self, seed: int) -> tuple[Scenario, dict[str, str]]:
        """This scenario with what is drawn per seed: the blackboard values of
        `randomize.blackboard`, and as scene objects the parcels of `scene.parcels` (with the
        class of each parcel by name)."""
        drawn = draw_goals(self.randomize, seed)
        scn = self
        if drawn:
            scn = self.model_copy(update={"blackboard": {**self.blackboard, **drawn}})
        return scn._with_parcels(seed)

    def _with_parcels(self, seed: int) -> tuple[Scenario, dict[str, str]]:
        if self.scene.conveyor is not None:
            return self._with_pool(self.scene.conveyor), {}
        p = self.scene.parcels
        if p is None or p.count == 0:
            return self, {}
        objects = list(self.scene.objects)
        classes: dict[str, str] = {}
        for name, (cls, size, mass, x, y, yaw) in draw_parcels(p, seed):
            objects.append(
                ObjectSpec(
                    name=name,
                    size=size,
                    mass=mass,
                    xy=[x, y],
                    yaw_deg=math.degrees(yaw),
                    friction=p.friction,
                    rgba=list(p.classes[cls]),
                )
            )
            classes[name] = cls
        scene = self.scene.model_copy(update={"objects": objects})
        return self.model_copy(update={"scene": scene}), classes

    def _with_pool(self, c: Conveyor) -> Scenario:
        """The conveyor's pool of parcel bodies as scene objects, parked in a row on the
        floor at `park_xy` (world/conveyor.py takes them to the feed one at a time)."""
        size = [c.length_m[1], c.parcel_width_m[1], c.height_m[1]]
        objects = list(self.scene.objects)
        for i in range(c.pool):
            spot = Spot(xy=[c.park_xy[0] + 0.1 * i, c.park_xy[1]], height=0.0)
            objects.append(
                ObjectSpec(
                    name=pool_body_name(i),
                    size=size,
                    mass=c.mass_kg[0],
                    xy=spot.xy,
                    randomize=Randomize(spots=[spot]),
                    friction=c.friction,
                    rgba=[0.5, 0.5, 0.5, 1.0],
                )
            )
        scene = self.scene.model_copy(update={"objects": objects})
        return self.model_copy(update={"scene": scene})
