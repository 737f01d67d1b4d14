"""The hand's drive: the software that runs a parallel gripper's motor, one control tick at a time.

A real hand is commanded an opening; its drive moves the fingers there at the motor's speed,
limits the motor's current while they move (a finger that meets an object must not strike it
with the whole stall force), notices when closing fingers are blocked by what they grasp and
then squeezes with the full grip force. This module is that drive: it reads the fingers'
positions and writes the gripper motor's voltage (MuJoCo's `ctrl` of the gripper actuator);
the motor itself, its speed limit and its stall force are the plant's (robots/panda/model.py).

It lives as long as the world (engine/cell.py): a live session's hand keeps its grip from one
task to the next.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .base import Robot

__all__ = [
    "GRIP_MOVE_FORCE_FRACTION",
    "GRIP_OPEN_SPEED_MARGIN",
    "GRIP_SERVO_GAIN",
    "GRIP_SPEED_MARGIN",
    "GRIP_SQUEEZE_RAMP_S",
    "HandDrive",
]

_GRIP_CONTACT_M = 0.002
"""A closing finger still this far short of its target is blocked by an object [m]."""
_GRIP_HELD = 0.5
"""A finger that moved less than this fraction of what its voltage would move it free is held
back by something (the drive's current limit applies; closing, it is blocked)."""
_GRIP_STILL_TICKS = 2
"""Control ticks a closing finger must stay held back, short of its target, to be blocked."""
_GRIP_LEAD_M = 0.001
"""Farthest a finger's reference runs ahead of the finger while moving [m]."""
GRIP_SERVO_GAIN = 0.5
"""Fraction of a finger's position error the hand's drive takes out per control tick (the
motor answers within a physics step: at 1 the servo is deadbeat)."""
GRIP_MOVE_FORCE_FRACTION = 0.1
"""The hand's drive limits its motor's force to this fraction of the grip force while the
fingers move (5 N of the Panda's 20 N; the full force is for squeezing), as a current limit:
the voltage is capped at what pushes with that force at the fingers' measured speed. A DC
motor that meets an object at full speed stalls at once and, without the limit, strikes it
with its whole stall force (16 N at the wrist as a finger knocked a pick_place cube against
the table, seed 2). The drive acts once per control tick, so the first 10 ms of an impact
can still see the stall force."""
GRIP_SPEED_MARGIN = 0.95
"""Fraction of the motor's speed the drive runs the fingers at, moving: the rest is for what
pushes them (a squeezed object springing back as they open pushed them 2 % past the motor's
0.05 m/s at full voltage), as the arm's commands keep 15 % of its limits (`COMMAND_MARGIN`)."""
GRIP_OPEN_SPEED_MARGIN = 0.9
"""Fraction of the motor's speed the drive opens the fingers at: a released object that
slides down between them wedges them apart, back-driving the motor (a tilted sorting parcel
pushed with 2.6 N, the fingers ran at 0.0507 m/s with the voltage at 0.95, seed 1; the motor
gives v_max (u + F_push / F_stall))."""
GRIP_SQUEEZE_RAMP_S = 0.1
"""Time the drive takes to raise the force from the moving limit to the full grip force once
the fingers are blocked by what they grasp [s] (at once: 12 N at the wrist on pick_place's
cube, seed 1, against 5 N before this hand model)."""


class HandDrive:
    """The current-limited drive of a parallel gripper.

    Args:
        robot: The robot (its open opening, its gripper speed).
        qpos: MuJoCo's joint positions (`MjData.qpos`, a view that never moves).
        fingers: Where the finger joints are in `qpos`: a slice (read as a view) or an index
            array.
        ctrl: MuJoCo's actuator controls (`MjData.ctrl`); the drive writes the gripper's.
        actuator: Index of the gripper's actuator in `ctrl`.
        dt_control: Control period [s]: the drive acts once per control tick.

    Attributes:
        target: Each finger's commanded opening [m] (`Context.set_gripper` sets it).
    """

    def __init__(
        self,
        robot: Robot,
        qpos: np.ndarray,
        fingers: slice | np.ndarray,
        ctrl: np.ndarray,
        actuator: int,
        dt_control: float,
    ) -> None:
        self.target = robot.gripper_open_m
        self._qpos, self._index = qpos, fingers
        self._fingers = qpos[fingers] if isinstance(fingers, slice) else None
        self._two_fingers = self._fingers is not None and len(self._fingers) == 2
        self._m_per_unit = robot.finger_m_per_unit
        """Metres of one side's opening per unit of a finger joint's coordinate."""
        self._ctrl, self._act = ctrl, actuator
        self._ref = robot.gripper_open_m
        """Where the drive is taking each finger [m]: the reference it servoes to."""
        self._volt_step = robot.gripper_speed_mps * dt_control
        """How far a free finger goes in a control tick at full voltage [m]."""
        self._gain = GRIP_SERVO_GAIN / self._volt_step
        """Motor voltage per metre of finger error [1/m]."""
        self._limit = 1.0
        """The drive's limit on the motor voltage this tick (its current limit)."""
        self._still = 0
        """Control ticks the closing fingers have been held back short of their target."""
        self._squeeze: float | None = None
        """Where the fingers were blocked, while they squeeze [m]; None otherwise."""
        self._prev = robot.gripper_open_m
        """The finger's position at the last control tick [m]."""
        self._ramp = dt_control / GRIP_SQUEEZE_RAMP_S * (1.0 - GRIP_MOVE_FORCE_FRACTION)
        """Rise of that limit per control tick while squeezing."""
        tau = robot.gripper_time_constant_s
        self._lag = tau / dt_control * -math.expm1(-dt_control / tau) if tau > 0.0 else 0.0
        """Of the change a tick's voltage asks of the finger's speed, the fraction a motor
        with that time constant leaves behind over the tick, in distance (0: it answers at
        once): a free finger moving `s` per tick goes u V + (s - u V) lag in the next."""
        self._moved = 0.0
        """How far the finger moved over the last control tick [m], signed."""

    def width(self) -> float:
        """Distance between the fingers [m]."""
        if self._two_fingers:  # numpy's sum of two, the same float: it adds them to 0.0
            a, b = self._fingers.tolist()  # (so two -0.0 sum to 0.0, as numpy's does)
            return 0.0 + a + b
        # other hands (a revolute jaw: robots/so101): each joint's coordinate in metres of
        # its side's opening (`Robot.finger_m_per_unit`), the two sides' sum the gap
        q = self._qpos[self._index]
        return float(q.sum()) * self._m_per_unit * 2.0 / len(q)

    @property
    def commanded(self) -> bool:
        """The reference has reached `target` (closing on an object: it squeezes with the
        whole grip force)."""
        return self._ref == self.target and (self._squeeze is None or self._limit >= 1.0)

    def advance(self, rate: float = 1.0) -> None:
        """One control tick: move each finger's reference towards `target` at `rate` times the
        gripper's speed (a pause slows it to 0), never more than `_GRIP_LEAD_M` ahead of the
        finger, and set the motor's voltage to follow it (feed-forward of the reference's speed
        plus the position error; the plant's motor caps the speed, robots/panda/model.py), its
        force limited to `GRIP_MOVE_FORCE_FRACTION` of the grip force while the fingers move.
        Closing fingers that stay still short of the target are blocked by what they grasp:
        they squeeze, the force rising to the motor's whole stall force over
        `GRIP_SQUEEZE_RAMP_S`, until the target opens or they reach it (an object that slips
        out of the grasp: they close on after it, as a real hand's grasp command does)."""
        goal = self.target
        finger = 0.5 * self.width()
        moved, self._prev = finger - self._prev, finger
        ref = self._ref
        if goal > ref:  # opening: from where the fingers are, not from a squeezing reference
            ref = max(ref, finger)
        short = goal < finger - _GRIP_CONTACT_M
        # what the last tick's voltage would have moved a free finger [m]; only a finger the
        # drive pushed can be held back (not one a pause holds still)
        free = abs(self._ctrl[self._act]) * self._volt_step
        # and what it did move it, free, from the speed it had (a motor still spinning up or
        # down is not held back by an object): the same when the motor answers at once
        expected = free
        if self._lag:
            pushed_to = self._ctrl[self._act] * self._volt_step
            expected = abs(pushed_to + (self._moved - pushed_to) * self._lag)
        self._moved = moved
        if self._squeeze is not None:  # until the target opens or the fingers reach it
            if not short:  # (an object that slips out: they close on, at the motor's speed)
                self._squeeze, self._still = None, 0
        else:
            pushed = rate > 0.0 and free > GRIP_MOVE_FORCE_FRACTION * self._volt_step
            held = short and pushed and -moved < _GRIP_HELD * expected
            self._still = self._still + 1 if held else 0
            if self._still >= _GRIP_STILL_TICKS:
                self._squeeze = finger
        squeeze = self._squeeze is not None
        if squeeze:
            ref = goal
        margin = GRIP_OPEN_SPEED_MARGIN if goal > finger else GRIP_SPEED_MARGIN
        step = margin * self._volt_step * rate
        new = goal if abs(goal - ref) <= step else ref + math.copysign(step, goal - ref)
        if not squeeze:  # a reference that runs away from the finger would wind up
            new = min(max(new, finger - _GRIP_LEAD_M), finger + _GRIP_LEAD_M)
        self._ref = new
        voltage = (new - ref) / self._volt_step + self._gain * (new - finger)
        if squeeze:  # the force rises to the full grip force
            limit = min(self._limit + self._ramp * rate, 1.0)
        elif abs(moved) >= _GRIP_HELD * expected:  # the fingers went where the voltage sent them
            limit = margin
        else:  # held back: the current limit, stall force x (voltage - speed / v_max) <= move
            limit = min(GRIP_MOVE_FORCE_FRACTION + abs(moved) / self._volt_step, margin)
        self._limit = limit
        self._ctrl[self._act] = min(max(voltage, -limit), limit)
