"""`orchestrator show robot NAME`: a robot's declaration as a Markdown page (no simulator:
only the class and, for the joint limits, its URDF read by pinocchio)."""

from __future__ import annotations

import math

import numpy as np

from .base import Robot

__all__ = ["robot_markdown"]


def _deg(values) -> str:
    return ", ".join(f"{math.degrees(v):g}" for v in values)


def robot_markdown(cls: type[Robot], level: int = 1) -> str:
    """The page of robot class `cls`: joints, home, limits (with the datasheet's source),
    gripper, gains, reach."""
    robot = cls()
    h = "#" * level
    doc = " ".join((cls.__doc__ or "").split())
    lines = [f"{h} robot `{robot.name}`", "", doc, ""]
    sheet = robot.datasheet
    lines += [
        f"* arm joints ({robot.n_arm}): " + ", ".join(f"`{j}`" for j in robot.arm_joints),
        "* gripper joints: "
        + ", ".join(f"`{j}`" for j in robot.finger_joints)
        + (" (a revolute jaw)" if len(robot.finger_joints) == 1 else " (parallel fingers)"),
        f"* URDF: `{robot.urdf_path()}`",
        f"* home [deg]: {_deg(robot.home)}",
        f"* TCP: site `{robot.tcp_site}` (URDF frame `{robot.tcp_frame}`), hand body "
        f"`{robot.hand_body}`",
        f"* shoulder height {robot.shoulder_height_m:g} m, reach {robot.reach_m:.3f} m",
        f"* gripper: {2 * robot.gripper_open_m * 1000:g} mm "
        + ("open (its set point)" if len(robot.finger_joints) == 1 else "stroke")
        + ", "
        f"{robot.gripper_force_n:g} N per finger, {robot.gripper_speed_mps * 1000:g} mm/s per "
        "finger",
        "",
        f"{h}# joint limits",
        "",
        "| joint | range | speed | torque | acceleration | jerk |",
        "|---|---|---|---|---|---|",
    ]
    speed = robot.joint_velocity_limits()
    for i, joint in enumerate(robot.arm_joints):
        lo, hi = sheet.position[i] if sheet else (float("nan"), float("nan"))
        torque = sheet.torque[i] if sheet else float("nan")
        lines.append(
            f"| `{joint}` | {lo:.4g} .. {hi:.4g} | {speed[i]:.4g} | {torque:g} | "
            f"{robot.acceleration_limits[i]:g} | {robot.jerk_limits[i]:g} |"
        )
    lines += [
        "",
        "Units: rad, rad/s, Nm, rad/s², rad/s³ (m, m/s, N for a base's linear joints).",
        "",
        f"Source: {sheet.source if sheet else 'none declared'}",
        "",
        f"{h}# default gains",
        "",
        f"* kp [Nm/rad]: {', '.join(f'{v:g}' for v in np.asarray(robot.gains.kp))}",
        f"* kd [Nm s/rad]: {', '.join(f'{v:g}' for v in np.asarray(robot.gains.kd))}",
        "* Cartesian stiffness [N/m, Nm/rad]: "
        + ", ".join(f"{v:g}" for v in robot.gains.cartesian_stiffness),
        "",
    ]
    return "\n".join(lines)
