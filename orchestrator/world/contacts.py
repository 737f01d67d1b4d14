"""Contact sensors that tell the robot's contacts apart, for the `collision` guard.

MuJoCo's contact sensors count matching contacts in C during the step, so the guard only
reads a few numbers per physics step instead of walking the contact list in Python.

* Every robot body with collision geometry except the end effector (the fingers, a tool) gets
  one sensor counting its contacts with anything: each is a collision (with the scene, or —
  through the self-collision proxies — with another link).
* The end effector's contact elements (each finger; a tool's geoms) get one sensor per scene
  body they may not touch by default: the free objects and the phantom, which they always may,
  get none; the guard's `allow` list decides about the rest.
* A mobile base's chassis gets one sensor per scene body but the free objects: a free object
  pushed against it (a block someone kicks) is not a collision; a wall, furniture or a fixed
  obstacle is.

The contact list read in Python instead (a lookup of each contact's geom pair in a table)
costs more than these sensors cost `mj_step` (bench/contact_read.py, docs/performance.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

__all__ = ["ContactSensor", "add_contact_sensors", "bind_contact_sensors", "contact_addresses"]

_FOUND = [1, 0, 1]
"""Contact sensor data spec: `found` (the number of matching contacts), no reduction, 1."""


@dataclass(frozen=True)
class ContactSensor:
    """One contact sensor of the compiled model.

    Attributes:
        name: Sensor name.
        robot: The robot side (a body or geom name).
        partner: The scene body it counts contacts with, or None for anything.
        end_effector: The robot side is an end-effector contact element (a finger, a tool tip).
        adr: Address of its value in `MjData.sensordata` (-1 until compiled).
        chassis: The robot side is a mobile base's chassis.
    """

    name: str
    robot: str
    partner: str | None
    end_effector: bool
    adr: int = -1
    chassis: bool = False


def _add(spec, name, objtype, objname, partner) -> None:
    s = spec.add_sensor(name=name, type=mujoco.mjtSensor.mjSENS_CONTACT)
    s.objtype, s.objname = objtype, objname
    if partner is not None:
        s.reftype, s.refname = mujoco.mjtObj.mjOBJ_BODY, partner
    s.intprm[:3] = _FOUND


def add_contact_sensors(
    spec: mujoco.MjSpec,
    robot_root: str,
    finger_bodies: tuple[str, ...],
    tool_tip: str | None,
    touchable: set[str],
    chassis: tuple[str, ...] = (),
    pushable: set[str] | None = None,
) -> list[ContactSensor]:
    """Add the contact sensors (after the whole scene is in `spec`).

    A pair the guard allows whatever its parameters gets no sensor: the end effector with
    what it touches by default, a chassis with a free object. Each contact sensor walks the
    step's whole contact list in `mj_step`; those 16 of sorting's 29 sensors only counted
    contacts nobody read (bench/contact_read.py).

    Args:
        spec: The whole model.
        robot_root: The robot's first body.
        finger_bodies: The gripper's fingers.
        tool_tip: The tip geom of a mounted tool (its body's geoms are the tool), or None.
        touchable: Scene bodies the end effector touches by default (free objects, a
            phantom): no sensor.
        chassis: Bodies of a mobile base's chassis (one sensor per scene body each).
        pushable: Scene bodies a chassis may touch (the free objects): no sensor. None:
            `touchable`.
    """
    pushable = touchable if pushable is None else pushable
    robot: set[str] = set()
    stack = [spec.body(robot_root)]
    while stack:
        body = stack.pop()
        robot.add(body.name)
        stack.extend(body.bodies)
    scene = ["world"] + [b.name for b in spec.bodies if b.name not in robot and b.name != "world"]
    out: list[ContactSensor] = []

    def sensor(
        robot_side: str, partner: str | None, ee: bool, geom: bool, base: bool = False
    ) -> None:
        if (ee and partner in touchable) or (base and partner in pushable):
            return  # always allowed: the guard would never read it
        name = f"contact__{robot_side}__{partner or 'any'}"
        objtype = mujoco.mjtObj.mjOBJ_GEOM if geom else mujoco.mjtObj.mjOBJ_BODY
        _add(spec, name, objtype, robot_side, partner)
        out.append(ContactSensor(name, robot_side, partner, ee and not base, chassis=base))

    for body in spec.bodies:
        if body.name not in robot or not body.geoms:
            continue
        if body.name in chassis:
            for partner in scene:
                sensor(body.name, partner, False, geom=False, base=True)
            continue
        if body.name in finger_bodies:
            for partner in scene:
                sensor(body.name, partner, True, geom=False)
            continue
        if tool_tip is not None and tool_tip in [g.name for g in body.geoms]:
            for g in body.geoms:  # the tool: its tip, and its shaft pressed into tissue
                for partner in scene:
                    sensor(g.name, partner, True, geom=True)
            continue
        sensor(body.name, None, False, geom=False)
    return out


def bind_contact_sensors(
    model: mujoco.MjModel, sensors: list[ContactSensor]
) -> tuple[ContactSensor, ...]:
    """The sensors with their `sensordata` addresses in the compiled `model`."""
    return tuple(
        ContactSensor(
            s.name,
            s.robot,
            s.partner,
            s.end_effector,
            int(model.sensor_adr[model.sensor(s.name).id]),
            s.chassis,
        )
        for s in sensors
    )


def contact_addresses(sensors: tuple[ContactSensor, ...], allowed) -> np.ndarray:
    """`sensordata` addresses of the sensors whose contacts are collisions, given `allowed(s)`
    (True when an end-effector element may touch its partner)."""
    return np.array([s.adr for s in sensors if not (s.end_effector and allowed(s))], dtype=int)
