"""The SO-101 plant: example-robot-data's so101.urdf (upstream TheRobotStudio/SO-ARM100),
five Feetech STS3215 servo joints and a sixth servo driving a revolute jaw against a fixed one.

The URDF the plant and the controller's pinocchio model are built from is generated once per
process into the temporary directory (named by its content's hash), from the shipped file:

* the arm joints' torque and speed limits are the servo's (`DATASHEET`);
* the jaw's joint is re-zeroed where its inner face would meet the fixed jaw's (the shipped
  zero leaves a 15.8 mm gap at the tips), so that its angle times the jaw's radius is the gap:
  the gripper's opening in metres, as the engine's hand drive and grasp checks count it
  (`Robot.finger_m_per_unit`);
* a TCP frame between the jaws, `TCP_FROM_FIXED_JAW_M` off the fixed jaw's inner face, with
  its y axis the closing direction and z pointing out of the tips (the Panda's convention).
"""

from __future__ import annotations

import functools
import math
import re
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..assembly import assemble, write_urdf
from ..base import (
    CONTACT_SOLIMP,
    CONTACT_TIMECONST_S,
    ROBOT_CONAFFINITY,
    ROBOT_CONTYPE,
    Datasheet,
    Gains,
    Robot,
)
from ..exceptions import RobotError

if TYPE_CHECKING:
    import mujoco

__all__ = ["SO101", "so101_urdf"]

_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll")
STALL_TORQUE_NM = 2.94
"""Feetech STS3215 (12 V, 1:345 gear) stall torque: 30 kg cm."""
NO_LOAD_SPEED_RAD_S = 4.71
"""Feetech STS3215 no-load speed: 0.222 s per 60 deg."""
DATASHEET = Datasheet(
    position=(
        (-1.91986, 1.91986),
        (-1.74533, 1.74533),
        (-1.69, 1.69),
        (-1.65806, 1.65806),
        (-2.74385, 2.84121),
    ),
    velocity=(NO_LOAD_SPEED_RAD_S,) * 5,
    torque=(STALL_TORQUE_NM,) * 5,
    source="Feetech STS3215 serial bus servo datasheet (12 V version, 1:345): stall torque "
    "30 kg cm (2.94 Nm), no-load speed 0.222 s/60 deg (4.71 rad/s); joint ranges: the SO-101's "
    "URDF (TheRobotStudio/SO-ARM100, as shipped in example-robot-data), its mechanical stops",
)
JAW_RADIUS_M = 0.067
"""Distance from the jaw's pivot to its inner face near the tips [m], measured on the meshes:
the tip gap grows by 6.9 mm per 0.1 rad near closed, 6.5 mm per 0.1 rad further out."""
JAW_ZERO_RAD = -0.236
"""Angle of the shipped jaw joint at which its inner face meets the fixed jaw's [rad] (15.8
mm / 0.067 m before the shipped zero)."""
TCP_FROM_FIXED_JAW_M = 0.014
"""The TCP's distance from the fixed jaw's inner face [m]: the centre of the 20 mm cubes this
arm picks, plus 4 mm of clearance on the fixed side (the moving jaw pushes a cube that much
towards the fixed one as it closes). A jaw closing on a fixed one has no centre of its own:
like a real SO-101's users, the TCP is set for the objects it handles."""
TCP_BELOW_TIPS_M = 0.0
"""How far the TCP sits inside the jaws from the URDF's `gripper_frame_link` [m]: at it, 6 mm
in from the tips. With the TCP at a 20 mm cube's centre the tips are 4 mm above the table
(its lowest collision box, the fixed jaw's, 6 mm below the TCP)."""

FIXED_JAW_BOXES = (
    ("so101_fixed_jaw", (-0.0139, -0.0002, -0.0786), (0.006, 0.009, 0.0255)),
    ("so101_follower", (-0.0024, -0.0022, -0.0236), (0.0325, 0.026, 0.0245)),
)
"""Collision boxes of the fixed jaw and of the wrist-roll follower behind it, in the hand
link's frame (name, centre [m], half sizes [m]): in the gripper frame (z out of the tips, x
the opening) the jaw spans x 0..12 mm, y +-9 mm, z -45..6 mm, measured on the mesh."""


def _so_arm_description() -> Path:
    from ..panda.model import panda_urdf_path

    try:
        path = panda_urdf_path().parents[2] / "so_arm_description"
    except RobotError as exc:
        raise RobotError(f"the SO-101 URDF comes from example-robot-data too: {exc}") from None
    if not (path / "urdf" / "so101.urdf").is_file():
        raise RobotError(
            f"example-robot-data is installed but has no so101.urdf under {path};"
            " upgrade it (pip install -U example-robot-data)"
        )
    return path


def _rpy(rot: np.ndarray) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw of rotation matrix `rot` (R = Rz(y) Ry(p) Rx(r))."""
    pitch = math.asin(-max(-1.0, min(1.0, float(rot[2, 0]))))
    return math.atan2(rot[2, 1], rot[2, 2]), pitch, math.atan2(rot[1, 0], rot[0, 0])


def _rot(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = (math.cos(r), math.sin(r), math.cos(p), math.sin(p),
                              math.cos(y), math.sin(y))  # fmt: skip
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


@functools.cache
def so101_urdf() -> Path:
    """The SO-101 URDF as the robot uses it (see the module's docstring), written once."""
    text = (_so_arm_description() / "urdf" / "so101.urdf").read_text()
    for i, name in enumerate(_JOINTS):
        pattern = rf'(<joint name="{name}" type="revolute">.*?<limit )[^/]*/>'
        lo, hi = DATASHEET.position[i]
        limit = (
            f'effort="{DATASHEET.torque[i]}" velocity="{DATASHEET.velocity[i]}" '
            f'lower="{lo}" upper="{hi}"/>'
        )
        text, n = re.subn(pattern, lambda m, lim=limit: m.group(1) + lim, text, count=1, flags=re.S)
        if n != 1:
            raise RobotError(f"so101.urdf has no limit on {name}: the file changed")
    jaw = re.search(r'<joint name="gripper" type="revolute">.*?</joint>', text, flags=re.S)
    if jaw is None:
        raise RobotError("so101.urdf has no `gripper` joint: the file changed")
    block = jaw.group(0)
    origin = re.search(r'<origin xyz="([^"]+)" rpy="([^"]+)"/>', block)
    limits = re.search(r'lower="([^"]+)" upper="([^"]+)"', block)
    assert origin is not None and limits is not None
    rot = _rot(*map(float, origin.group(2).split())) @ _rot(0.0, 0.0, JAW_ZERO_RAD)
    rpy = " ".join(f"{v:.9f}" for v in _rpy(rot))
    lower, upper = (float(v) - JAW_ZERO_RAD for v in limits.groups())
    new = block.replace(origin.group(0), f'<origin xyz="{origin.group(1)}" rpy="{rpy}"/>')
    new = new.replace(limits.group(0), f'lower="{lower:.6f}" upper="{upper:.6f}"')
    text = text.replace(block, new)
    tcp = (
        '<link name="so101_tcp"/><joint name="so101_tcp_joint" type="fixed">'
        '<parent link="gripper_frame_link"/><child link="so101_tcp"/>'
        f'<origin xyz="{-TCP_FROM_FIXED_JAW_M} 0 {-TCP_BELOW_TIPS_M}" rpy="0 0 {math.pi / 2}"/>'
        "</joint>"
    )
    text = text.replace("</robot>", tcp + "\n</robot>")
    return write_urdf("so101", text)


class SO101(Robot):
    """SO-101 (TheRobotStudio, Hugging Face LeRobot): 5 servo joints (torque-controlled here
    within the STS3215's stall torque and speed), a revolute jaw closing against a fixed one."""

    name: ClassVar[str] = "so101"
    arm_joints: ClassVar[tuple[str, ...]] = _JOINTS
    finger_joints: ClassVar[tuple[str, ...]] = ("gripper",)
    hand_body: ClassVar[str] = "gripper_link"
    """The wrist's last link, which carries the fixed jaw (and the wrist sensor's site)."""
    root_body: ClassVar[str] = "base_link"
    finger_bodies: ClassVar[tuple[str, str]] = ("gripper_link", "moving_jaw_so101_v1_link")
    """The fixed jaw (part of the hand's link) and the moving jaw."""
    tcp_frame: ClassVar[str] = "so101_tcp"
    home: ClassVar[tuple[float, ...]] = (0.0, -0.35, 0.6, 1.3, 0.0)
    gripper_open_m: ClassVar[float] = 0.03
    """Each side's opening when open [m]: a 60 mm gap at the tips (the jaw at 0.9 rad of its
    2.04 rad travel: `open` is the servo's set point, not the end stop)."""
    gripper_force_n: ClassVar[float] = 10.0
    """[N] at the jaw's inner face: 0.67 Nm, 23 % of the servo's stall torque, the torque
    limit LeRobot's SO-101 follower sets on its gripper servo so that it does not burn out
    squeezing (a current limit); a 10 g cube needs 0.05 N."""
    gripper_speed_mps: ClassVar[float] = 0.05
    """[m/s] per side (0.1 m/s at the tips, the jaw at 1.5 rad/s: a third of the servo's
    no-load speed, its speed register set there)."""
    finger_m_per_unit: ClassVar[float] = JAW_RADIUS_M / 2.0
    grip_touch_speed_mps: ClassVar[float | None] = 0.01
    """[m/s] per side over the jaw's last 4 mm before the cube: the jaw meets the cube first
    and pushes it over to the fixed jaw (`TCP_FROM_FIXED_JAW_M`). At the full 0.05 m/s, on a
    cube or table of friction 2.3-10 (within the validated 10), the cube stuck and tipped
    against the jaw, the wrist gave way and, as the cube slipped and the jaw struck it against
    the fixed one, the arm sprang back: joints 1-4 at 1.01-1.28x their acceleration limit in
    CLOSE (explore, pick_place_so101, `scene.objects.cube.friction=2.287887` seed 1841569580)."""
    gains: Gains = Gains(
        kp=np.array([150.0, 150.0, 150.0, 60.0, 30.0]),
        kd=np.array([2.4, 2.4, 2.4, 1.0, 0.5]),
        cartesian_stiffness=(100.0, 100.0, 100.0, 3.0, 3.0, 3.0),
    )
    datasheet: ClassVar[Datasheet | None] = DATASHEET
    payload_kg: ClassVar[float | None] = 0.25
    """[kg], the jaw (0.10 kg in the model) included. TheRobotStudio publishes no payload for
    the SO-101; derived from its weakest point, shoulder_lift's STS3215 holding the arm
    stretched out level (the TCP 0.41 m from the axis): the arm itself takes 0.86 Nm there
    (this model), 0.15 kg at the TCP adds 0.60 Nm, 1.46 Nm in all, half the servo's 2.94 Nm
    stall torque (a hobby servo held near stall overheats within seconds; half of it is a
    common continuous rating). So 0.15 kg to carry, plus the jaw."""
    acceleration_limits: ClassVar[tuple[float, ...]] = (20.0,) * 5
    """[rad/s^2]: Feetech publishes no limit (the STS3215's acceleration register tops out at
    254 x 100 steps/s^2, 39 rad/s^2): an assumption, about half of that. At 39 the IK's
    commands (0.7 of it) made the light elbow ring on pick_place_so101's carry, 187 rad/s^2
    for a few steps (bench/physical_honesty.py); at 20, with the jaw's servo rotor in the
    plant (`gripper_armature`), no physics step is above it (BENCHMARKS.md, issue 44)."""
    jerk_limits: ClassVar[tuple[float, ...]] = (2000.0,) * 5
    """[rad/s^3], an assumption likewise."""
    shoulder_height_m: ClassVar[float] = 0.1166
    """The shoulder-lift axis above the base [m] (the URDF's 0.0624 + 0.0542)."""
    reach_m: ClassVar[float] = 0.30
    """Farthest TCP, hand pointing down, from the pan axis at shoulder height [m] (`shoulder`
    is on the axis; the shoulder-lift axis is 69 mm ahead of it): upper arm 0.116, forearm
    0.135 and the wrist, the jaws hanging ~0.1 below."""
    self_collision_bodies: ClassVar[tuple[str, ...]] = ()
    """None: the arm's links are small servo housings a capsule fits badly; its flows keep
    the arm stretched out over the table."""
    armature: ClassVar[float] = 0.01
    """Rotor inertia seen at each joint [kg m^2]: a coreless motor's ~1e-7 kg m^2 through the
    STS3215's 1:345 gear (an assumption: Feetech publishes no figure)."""

    gripper_armature: ClassVar[float | None] = 0.01
    """The jaw's servo is an STS3215 with the same 1:345 gear as the arm's: the same rotor
    inertia at its joint (`armature`). Modelled as 10 g at the jaw (1.1e-5 kg m^2, the jaw's
    link adding 1.6e-5), the jaw was so light that every step of its motor's torque (the
    drive's current limit as it met the cube, its squeeze ramp) threw it against the cube
    and back at up to 1 rad/s, the reaction landing on the wrist-flex axis, parallel to the
    jaw's: 1.73x the wrist's acceleration limit during CLOSE (bench/physical_honesty.py).
    With the rotor the motor's torque spins the rotor, not the hand; the jaw takes 22 ms
    (`gripper_time_constant_s`) to reach its speed."""

    def urdf_path(self) -> str:
        return str(so101_urdf())

    def build_spec(self) -> mujoco.MjSpec:
        import mujoco

        spec = assemble(self, _so_arm_description() / "meshes" / "so101")
        # MuJoCo collides a mesh through its convex hull: the fixed jaw's part (one mesh with
        # the wrist-roll follower) fills the gap between the jaw and the follower with a face
        # sloping 7 mm into the grip at a 30 mm cube's top edge (the hand touched the cube on
        # its way down). It collides as two boxes instead: the jaw, the follower behind it.
        hand = spec.body(self.hand_body)
        for geom in hand.geoms:
            if geom.type == mujoco.mjtGeom.mjGEOM_MESH and "follower" in geom.meshname:
                geom.contype = geom.conaffinity = 0
        for name, centre, half in FIXED_JAW_BOXES:
            box = hand.add_geom(
                name=name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(centre), size=list(half)
            )
            box.contype, box.conaffinity = ROBOT_CONTYPE, ROBOT_CONAFFINITY
            box.solref = [CONTACT_TIMECONST_S, 1.0]
            box.solimp = list(CONTACT_SOLIMP)
            box.friction = [1.5, 0.01, 0.001]
            box.condim = 4
            box.density = 0.0  # the link's mass is the URDF's
            box.group = 3
        return spec

    def joint_armature(self, joint: str) -> float:
        del joint
        return self.armature
