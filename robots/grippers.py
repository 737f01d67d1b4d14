"""Grippers composed on an arm's flange, written as URDF so that the MuJoCo plant and the
controller's pinocchio model get the same links, masses and frames.

`ParallelJaw` is a two-finger parallel gripper: a palm, two slide fingers that close along
the palm's y axis (each finger's joint coordinate is its inner face's distance from the
centre line [m], as the Panda's hand), and a TCP frame between the fingertips. The engine's
hand drive (`gripper_open_m`, `gripper_force_n`, `gripper_speed_mps` of the robot) works on
it unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ROBOTIQ_2F85_CLASS", "ParallelJaw"]


def _inertial(mass: float, size: tuple[float, float, float], xyz: tuple[float, ...]) -> str:
    """URDF <inertial> of a solid box of `mass` [kg] and `size` [m] centred at `xyz` [m]."""
    x, y, z = size
    ixx, iyy, izz = (mass * (y * y + z * z) / 12, mass * (x * x + z * z) / 12,
                     mass * (x * x + y * y) / 12)  # fmt: skip
    return (
        f'<inertial><origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="0 0 0"/>'
        f'<mass value="{mass}"/><inertia ixx="{ixx:.6g}" ixy="0" ixz="0" iyy="{iyy:.6g}" '
        f'iyz="0" izz="{izz:.6g}"/></inertial>'
    )


def _box(size: tuple[float, float, float], xyz: tuple[float, ...]) -> str:
    return (
        f'<collision><origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="0 0 0"/>'
        f'<geometry><box size="{size[0]} {size[1]} {size[2]}"/></geometry></collision>'
    )


@dataclass(frozen=True)
class ParallelJaw:
    """A two-finger parallel gripper (a palm box, two box fingers on slides).

    Attributes:
        prefix: Name prefix of its links and joints.
        stroke_m: Largest gap between the fingers [m] (each finger travels half).
        force_n: Grip force each finger presses with, stalled [N].
        speed_mps: Speed of each finger, free, at full voltage [m/s].
        mass_kg: Mass of the whole gripper [kg] (palm + fingers).
        palm_m: Size of the palm box (x, y, z) [m], z along the flange axis.
        finger_m: Size of a finger box (x across the finger, y its thickness, z its length) [m].
        finger_mass_kg: Mass of one finger [kg] (of `mass_kg`).
        tcp_above_tip_m: How far the TCP sits above the fingertips [m] (where an object's
            centre is held).
        source: Where the figures come from.
    """

    prefix: str
    stroke_m: float
    force_n: float
    speed_mps: float
    mass_kg: float
    palm_m: tuple[float, float, float]
    finger_m: tuple[float, float, float]
    finger_mass_kg: float
    tcp_above_tip_m: float
    source: str

    @property
    def hand_link(self) -> str:
        return f"{self.prefix}_hand"

    @property
    def tcp_link(self) -> str:
        return f"{self.prefix}_tcp"

    @property
    def finger_links(self) -> tuple[str, str]:
        return (f"{self.prefix}_left_finger", f"{self.prefix}_right_finger")

    @property
    def finger_joints(self) -> tuple[str, str]:
        return (f"{self.prefix}_finger_joint1", f"{self.prefix}_finger_joint2")

    @property
    def tcp_depth_m(self) -> float:
        """From the flange to the TCP along the flange axis [m]."""
        return self.palm_m[2] + self.finger_m[2] - self.tcp_above_tip_m

    def urdf(self, parent_link: str) -> str:
        """The gripper's links and joints, the palm fixed on `parent_link`'s frame (its z
        axis the flange axis, pointing out of the arm)."""
        palm_z = self.palm_m[2]
        palm_mass = self.mass_kg - 2.0 * self.finger_mass_kg
        fx, fy, fz = self.finger_m
        out = [
            f'<link name="{self.hand_link}">'
            f"{_box(self.palm_m, (0, 0, palm_z / 2))}"
            f"{_inertial(palm_mass, self.palm_m, (0, 0, palm_z / 2))}</link>",
            f'<joint name="{self.prefix}_mount" type="fixed"><parent link="{parent_link}"/>'
            f'<child link="{self.hand_link}"/><origin xyz="0 0 0" rpy="0 0 0"/></joint>',
            f'<link name="{self.tcp_link}"/>',
            f'<joint name="{self.prefix}_tcp_joint" type="fixed"><parent link="{self.hand_link}"/>'
            f'<child link="{self.tcp_link}"/><origin xyz="0 0 {self.tcp_depth_m}" rpy="0 0 0"/>'
            "</joint>",
        ]
        for link, joint, sign in zip(self.finger_links, self.finger_joints, (1, -1), strict=True):
            centre = (0.0, sign * fy / 2, fz / 2)  # inner face on the joint's origin
            out += [
                f'<link name="{link}">{_box(self.finger_m, centre)}'
                f"{_inertial(self.finger_mass_kg, self.finger_m, centre)}</link>",
                f'<joint name="{joint}" type="prismatic"><parent link="{self.hand_link}"/>'
                f'<child link="{link}"/><origin xyz="0 0 {palm_z}" rpy="0 0 0"/>'
                f'<axis xyz="0 {sign} 0"/><limit lower="0" upper="{self.stroke_m / 2}" '
                f'effort="{self.force_n}" velocity="{self.speed_mps}"/></joint>',
            ]
        return "\n".join(out)


ROBOTIQ_2F85_CLASS = ParallelJaw(
    prefix="gripper",
    stroke_m=0.085,
    force_n=20.0,
    speed_mps=0.05,
    mass_kg=0.925,
    palm_m=(0.075, 0.10, 0.11),
    finger_m=(0.022, 0.012, 0.05),
    finger_mass_kg=0.05,
    tcp_above_tip_m=0.012,
    source=(
        "Robotiq 2F-85 (Robotiq, '2F-85 & 2F-140 Instruction Manual', specifications): stroke "
        "85 mm, grip force 20-235 N, closing speed 20-150 mm/s, mass 0.925 kg, about 0.16 m "
        "from the flange to the fingertips. Modelled as a parallel gripper with flat fingers "
        "(the 2F-85's adaptive linkage is not): its force set at 20 N per finger (40 N grip, "
        "inside the 20-235 N range) and 0.05 m/s per finger (0.1 m/s closing, inside 20-150 "
        "mm/s), the setting a 0.1 kg part needs."
    ),
)
"""A Robotiq 2F-85-class two-finger gripper: the UR5's hand here."""
