"""What an episode reads of the world's cell: the interface `Context.cell` is typed with.

The cell (engine/cell.py) builds the step loop, and the step loop is handed the episode's
context; typing the context against this protocol instead of the `Cell` class keeps the
modules free of an import cycle (tests/test_layers.py) and says what an episode may reach.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import numpy as np

    from ..perception.rig import CameraRig
    from ..robots import Controller
    from ..robots.hand import HandDrive
    from ..skills.ik import IKSolver
    from ..world.actuators import ActuatorFault
    from ..world.sensors import JointEncoders, PerceptionFaults
    from ..world.world import World
    from ..world.wrist import WristSensor

__all__ = ["Hardware"]


class Hardware(Protocol):
    """The world and the robot's hardware, as long as the world lives (see `Cell`)."""

    world: World
    controller: Controller
    n_sub: int
    dt_control: float
    dt_physics: float
    rng: np.random.Generator
    tick: int
    sensor_faults: np.ndarray
    encoders: JointEncoders
    wrist: WristSensor
    hand: HandDrive
    actuator_fault: ActuatorFault | None
    perception: PerceptionFaults
    ik: IKSolver
    workspace_box: tuple[np.ndarray, np.ndarray] | None

    @property
    def cameras(self) -> CameraRig: ...

    def close(self) -> None: ...
