"""The cell: everything that lives as long as the world, built once.

Three lifetimes run through a run or a live session:

* the **cell** (this module): the MuJoCo world, the torque controller, the hand's drive
  (robots/hand.py), the wrist force sensor (world/wrist.py), the joint encoders, the IK, the
  step loop, the faults injected into the hardware, the control tick count, the cameras. One
  per `orchestrator run` episode; one per live session, kept from task to task (the cube stays
  where the last task put it, the hand keeps its grip, the sensor its bias);
* the **episode** (engine/context.py `Context`): the blackboard, the events, the metrics, the
  task log, the skills' clock, what the active skill aims at. One per run; a fresh one per
  live task;
* the **live task** (live/task.py): the episode's machine, its owner and its result.

`Cell.build` is the one place a world's hardware is assembled: `runner.new_run`, the live
session and a session snapshot's read all call it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..language.scenario_checks import workspace_box
from ..perception.rig import CameraRig
from ..robots.hand import HandDrive
from ..skills.ik import IKSolver
from ..world.actuators import ActuatorFault
from ..world.random_streams import stream
from ..world.realism import WristForceNoise
from ..world.sensors import JointEncoders, PerceptionFaults
from ..world.world import World, as_index, robot_only_model
from ..world.wrist import WristSensor
from .episode import make_controller
from .step import StepLoop

if TYPE_CHECKING:
    from ..language.scenario import Scenario
    from ..robots import Controller

__all__ = ["Cell", "control_substeps"]


def control_substeps(scenario: Scenario, dt_physics: float) -> int:
    """Physics steps per control tick (`physics.control_hz` on a `dt_physics` [s] step)."""
    return max(1, round(1.0 / (scenario.physics.control_hz * dt_physics)))


class Cell:
    """A world and the robot's hardware and low-level software around it.

    Build it with `Cell.build`. The episode's `Context` (`ctx.cell`) reads its sensors through
    it; the framework (the step loop, the fault injector, the recorder, the guards) uses the
    members below directly, a skill never does.

    Attributes:
        world: The MuJoCo world (its objects, markers, model and data).
        controller: The torque controller (pinocchio model, with the link-mass mismatch).
        n_sub: Physics steps per control tick.
        dt_control: Control period [s].
        dt_physics: Physics step [s].
        rng: The skills' random generator (`ctx.rng`; seeded: the same noise every run).
        sensor_faults: Flags of the sensor faults in effect, shape (2,): [0] the wrist force
            sensor's, [1] a joint encoder's (until the safety channel takes over); read by
            `sensor_health`'s envelope (guards/bank.py).
        encoders: The joint encoders the controller, the skills and `sensor_health` read.
        wrist: The wrist force sensor (its noise, its fault, its bias).
        hand: The hand's current-limited drive.
        actuator_fault: An injected motor fault, if any (the step loop applies it to the
            commanded torques).
        perception: Perception faults; every perception skill reports through
            `Context.perceived`.
        ik: The IK solver motion skills share.
        workspace_box: The box of the scenario's `workspace` guard, (min, max) [m]; None
            without one.
        tick: Control ticks run on this world so far.
        loop: Steps the world one control tick at a time (bound to the current episode's
            context with `loop.bind`).
    """

    def __init__(self, world: World, controller: Controller, seed: int) -> None:
        scn = world.scenario
        d = world.data
        self.world = world
        self.controller = controller
        self.dt_physics = float(world.model.opt.timestep)
        self.n_sub = control_substeps(scn, self.dt_physics)
        self.dt_control = self.n_sub * self.dt_physics
        self.rng = stream(seed, "skills")
        self.tick = 0
        self.sensor_faults = np.zeros(2)
        realism = scn.physics.realism
        quantize = realism.enabled and realism.encoder_quantization
        self.encoders = JointEncoders(
            d.qpos,
            d.qvel,
            as_index(world.robot_qpos),
            as_index(world.robot_dof),
            world.robot.n_arm,
            stream(world.seed, "encoders"),
            world.robot.encoder_resolution_rad if quantize else 0.0,
            world.step_clock,
            status=self.sensor_faults[1:],
        )
        noise = (
            WristForceNoise(
                realism.ft_noise_n, realism.ft_drift_n_per_sqrt_s, world.seed, self.dt_physics
            )
            if realism.enabled and (realism.ft_noise_n > 0 or realism.ft_drift_n_per_sqrt_s > 0)
            else None
        )
        self.wrist = WristSensor(world, world.step_clock, noise, self.sensor_faults[0:1])
        self.hand = HandDrive(
            world.robot,
            d.qpos,
            as_index(world.finger_qpos),
            d.ctrl,
            world.gripper_act,
            self.dt_control,
        )
        self.actuator_fault: ActuatorFault | None = None
        self.perception = PerceptionFaults()
        self.ik = IKSolver(
            world.robot, robot_only_model(world.robot), self.dt_control, scn.robot.base_pos
        )
        self.workspace_box = workspace_box(scn)
        self._cameras: CameraRig | None = None
        self.loop = StepLoop(self)

    @classmethod
    def build(cls, scenario: Scenario, seed: int, world: World | None = None) -> Cell:
        """The cell of `scenario` for `seed`.

        Args:
            scenario: The validated scenario.
            seed: The world's seed.
            world: The world of `scenario` already built for `seed` and never stepped (the one
                `prepare` compiled and checked the goals on, engine/prepare.py); None: build it.
        """
        if world is None:
            world = World.build(scenario, seed)
        return cls(world, make_controller(world, seed), seed)

    @property
    def cameras(self) -> CameraRig:
        """The scenario's cameras (the renderer opens on first use, not before)."""
        if self._cameras is None:
            self._cameras = CameraRig(self.world.model, self.world.scenario, self.world.seed)
        return self._cameras

    def close(self) -> None:
        """Free what the cell holds outside Python (a camera's OpenGL context)."""
        if self._cameras is not None:
            self._cameras.close()
            self._cameras = None
