"""`grasp_pose`: choose how to grasp an object so that the fingers land beside it, not on a
neighbour or a wall, and the arm can take the pose.

Of the hand's headings the object allows — its symmetric yaws, and turned by each of `turns_deg`
(closing across its other side, where the open hand spans it) — the first whose two finger
footprints, at the opening they come down with, clear every neighbour seen (`neighbours`: the
detections) and every fixed box of the scene by `clearance_m`, whose palm clears every fixed
box standing as high as the palm's bottom (a cabinet beside a block on the floor), and whose
grasp pose the IK reaches from where the arm is, becomes the grasp: its pose, with the chosen
yaw, goes to `into` for the approach (`move` with `align_yaw` and `yaw_symmetry_deg: 360`).
Headings are tried in order of `turns_deg`, then of the wrist's turn from where it stands.

Two parcels touching along their long sides leave no room for a finger between them: the
grasp is `blocked` before the hand goes down (with touching parcels, a finger used to come
down on the neighbour at 87-214 N and the run aborted).

Given the `object` by name, its declared size is checked too: wider than the open hand on every
heading, or so tall that the palm would come down on its top before the fingers reach the
grasp, it is `blocked` with the figures (explore found both: a 0.67 m box struck by the hand
and a 0.18 m cube by the wrist, the joints then past their datasheet acceleration); so is one
so long that, held at the grasp and turned about the hand as it is carried, it would sweep into
the arm's own base column (a 10 m box carried into link 1); so is one heavier than the arm's
rated payload leaves for it once the hand is counted (`Robot.payload_kg`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from pydantic import Field, NonNegativeFloat, PositiveFloat

from orchestrator.world.footprint import Box, separation
from orchestrator.world.pose import Pose, rotation_of

from .base import SCENE_TARGET, Skill, SkillParams
from .ik import IKSolver
from .move import symmetric_yaws
from .targets import resolve_target, rot_down, yaw_of_rot

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["GraspPose", "finger_boxes", "hand_box"]

_MATCH_M = 0.02
"""A neighbour this close (xy) to the target is the target itself, seen [m]."""
_BASE_COLUMN_M = 0.1
"""Radius of the arm's base column about its axis [m] (the Panda's link 0-1, the UR5's base
and shoulder: ~0.08-0.09 m)."""
_BASE_CLEARANCE_M = 0.05
"""Least gap between a carried object's swept circle and the base column [m]."""
_IK_DT = 0.02
_IK_ITERATIONS = 200
_STALL_ITERATIONS = 15


class GraspPoseParams(SkillParams):
    target: Any = Field(
        description="The object: a pose (`$object_pose`, its top-face centre from `detect`), "
        "an object or marker name, or `[x, y, z]` [m].",
        json_schema_extra=SCENE_TARGET,
    )
    offset: list[float] = Field(
        default_factory=lambda: [0.0, 0.0, 0.0],
        min_length=3,
        max_length=3,
        description="TCP from the target when the fingers close, world frame [m].",
    )
    size_m: list[float] | None = Field(
        default=None,
        min_length=2,
        max_length=2,
        description="The object's top face `[long side, short side]` [m] (a detection's "
        "`size_m`): each heading needs the open fingers to clear it by `clearance_m`. "
        "Default: the size of the detection in `neighbours` that is the target, if any.",
    )
    neighbours: list[Any] = Field(
        default_factory=list,
        description="What else lies around (`$detections`): mappings with a `pose` and a "
        "`size_m`; the target itself among them is recognised and skipped.",
    )
    yaw_symmetry_deg: PositiveFloat = Field(
        default=90.0, le=360.0, description="Symmetry of the object about z [deg]."
    )
    turns_deg: list[float] = Field(
        default_factory=lambda: [0.0, 90.0],
        min_length=1,
        max_length=8,
        description="Headings of the hand to try, turned from the object's own (0: the "
        "fingers close across its short side; 90: across its long side, if the open hand "
        "spans it), in order of preference [deg].",
    )
    opening_m: PositiveFloat = Field(
        default=0.04, le=0.2, description="Each finger's opening as it comes down [m]."
    )
    clearance_m: NonNegativeFloat = Field(
        default=0.004, le=0.1, description="Least gap between a finger and anything else [m]."
    )
    tolerance_m: PositiveFloat = Field(
        default=0.001,
        description="Position tolerance of the approach [m] (`move`'s): the IK must get the "
        "TCP within half of it, as the approach's own dry run will.",
    )
    tolerance_deg: PositiveFloat = Field(
        default=0.5, description="Orientation tolerance of the approach [deg] (`move`'s)."
    )
    into: str = Field(
        default="grasp_pose",
        description="Blackboard key the grasp pose (the target's position, the chosen yaw) "
        "is written to.",
    )
    object: str | None = Field(
        default=None,
        description="The scene object to grasp, by name (`*` or none: not known): its "
        "declared size must fit the open hand and stand below the palm at the grasp.",
    )
    guarded_into: list[str] | None = Field(
        default=None,
        min_length=2,
        max_length=2,
        description="Blackboard keys `[top, bottom]` of the approach's guarded stretch "
        "(`move`'s `guarded_from_m`, `guarded_to_m`: above the grasp pose [m]), written with "
        "the stretch the geometry needs: where a fingertip comes down on the object's top "
        "(its declared height above the seen centre, the fingers' depth below the TCP), "
        "`guarded_above_m` above it to `guarded_below_m` below it. The search's noise (1 cm, "
        "5 deg at its bound) moves the object in x, y and yaw, never its top's height: it "
        "decides whether a finger lands on the top, not where. Left as they are when the "
        "top key is 0 (no guarded stretch) or not above the bottom key (`move` refuses "
        "that), the object's size is not declared, or the fingers are not all boxes.",
    )
    guarded_above_m: NonNegativeFloat = Field(
        default=0.002,
        le=0.05,
        description="How far above a fingertip's contact height the guarded stretch starts "
        "[m]: the hand's tilt within the approach's tolerance over a finger's footprint, and "
        "the rounding of a declared size.",
    )
    guarded_below_m: PositiveFloat = Field(
        default=0.004,
        le=0.05,
        description="How far below the contact height it ends [m]: the press that builds "
        "the touch force (2 N within 1-3 mm at 0.05 m/s on the Panda's finger).",
    )


class GraspPose(Skill):
    """Choose the grasp heading whose fingers clear the neighbours and the walls and whose
    pose the arm reaches (see the module's description).

    Outcomes: `ready` (the pose is in `into`), `blocked` (no heading leaves the fingers and
    the palm room: the detail names what is in the way), `unreachable` (the fingers would
    fit, but the arm cannot take any of those poses: the detail gives the IK's residual).
    """

    name: ClassVar[str] = "grasp_pose"
    Params: ClassVar[type[SkillParams]] = GraspPoseParams
    outcomes: ClassVar[tuple[str, ...]] = ("ready", "blocked", "unreachable")
    writes: ClassVar[dict[str, str]] = {"into": "pose"}

    params: GraspPoseParams

    def start(self, ctx: Context) -> None:
        self.why = ""

    def step(self, ctx: Context) -> str | None:
        p = self.params
        goal = resolve_target(ctx, p.target)
        centre = np.asarray(goal.pos, float)
        tcp = centre + np.asarray(p.offset, float)
        here = yaw_of_rot(ctx.tcp_rot)
        fingers = finger_boxes(ctx, p.opening_m)
        others = _neighbours(p.neighbours, centre) + _walls(ctx, tcp[2] - fingers.depth_m)
        hand = hand_box(ctx)
        hand_walls = _walls(ctx, tcp[2] - hand.depth_m)  # what stands as high as the palm
        size = p.size_m if p.size_m is not None else _seen_size(p.neighbours, centre)
        known = ctx.world.objects.get(p.object) if p.object else None
        heading = goal.yaw  # the hand's heading that closes across the short side (turn 0)
        refused = _outside_workspace(ctx, tcp)
        if known is not None:
            hx, hy = (float(v) for v in known.half_size[:2])
            if size is None:
                size = [2.0 * max(hx, hy), 2.0 * min(hx, hy)]
                if hy > hx:  # its long side along its own y: closing along y would span it
                    heading += math.pi / 2.0
            refused = refused or _over_payload(ctx, known)
            refused = refused or _palm_strikes(ctx, known, tcp[2], hand, p.clearance_m)
            refused = refused or _sweeps_the_base(ctx, known, tcp)
        if refused is not None:
            self.why = refused
            ctx.log("skill", f"grasp_pose: {self.why}", level="WARN")
            return "blocked"
        symmetry = p.yaw_symmetry_deg
        if size is not None and abs(size[0] - size[1]) > 1e-3:
            symmetry = max(symmetry, 180.0)  # a quarter turn would close across the other side
        blocked: list[str] = []
        misses: list[float] = []
        for turn in p.turns_deg:
            base = heading + math.radians(turn)
            across = _across(size, turn)
            if across is not None and p.opening_m - across / 2.0 < p.clearance_m:
                blocked.append(
                    f"turned {turn:g} deg the open hand ({2 * p.opening_m * 1000:.0f} mm) does "
                    f"not span the object ({across * 1000:.0f} mm)"
                )
                continue
            for yaw in symmetric_yaws(base, here, math.radians(symmetry)):
                hit = _first_hit(fingers.at(tcp[0], tcp[1], yaw), others, p.clearance_m)
                if hit is not None:
                    blocked.append(f"turned {turn:g} deg a finger comes within {hit}")
                    continue
                hit = _first_hit(hand.at(tcp[0], tcp[1], yaw), hand_walls, p.clearance_m)
                if hit is not None:
                    blocked.append(f"turned {turn:g} deg the hand comes within {hit}")
                    continue
                miss = _ik_miss(ctx, tcp, yaw, p.tolerance_m, math.radians(p.tolerance_deg))
                if miss[0] > 0.5 * p.tolerance_m or miss[1] > 0.5 * math.radians(p.tolerance_deg):
                    misses.append(miss[0])
                    continue
                ctx.blackboard[p.into] = Pose(pos=goal.pos, quat=_yaw_quat(yaw))
                self._guarded_stretch(ctx, known, centre[2] - tcp[2], fingers.depth_m)
                ctx.log(
                    "skill",
                    f"grasp_pose: heading {math.degrees(yaw):.1f} deg (turned {turn:g} deg), "
                    f"fingers clear of {len(others)} neighbour(s) and wall(s)",
                )
                return "ready"
        if misses:
            self.why = (
                f"the fingers fit but the IK gets only within {min(misses) * 1000:.1f} mm of "
                f"the grasp pose at {np.round(tcp, 3).tolist()} (joint limits or the edge of "
                "the reach)"
            )
            outcome = "unreachable"
        else:
            self.why = "no room for the fingers: " + "; ".join(dict.fromkeys(blocked))
            outcome = "blocked"
        ctx.log("skill", f"grasp_pose: {self.why}", level="WARN")
        return outcome

    def _guarded_stretch(self, ctx: Context, known: Any, centre_m: float, depth_m: float) -> None:
        """Write the guarded stretch the geometry needs to `guarded_into` (see there):
        `centre_m` is the object's seen centre above the grasp pose [m], `depth_m` how far
        the fingertips reach below the TCP [m]."""
        p = self.params
        if p.guarded_into is None or known is None or not _box_fingers(ctx):
            return
        top_key, bottom_key = p.guarded_into
        asked = float(ctx.blackboard.get(top_key) or 0.0)
        if not asked > float(ctx.blackboard.get(bottom_key) or 0.0) or not asked > 0.0:
            return  # none asked for (0), or one upside down: `move` refuses it, naming both
        contact = centre_m + float(known.half_size[2]) + depth_m
        top, bottom = contact + p.guarded_above_m, max(contact - p.guarded_below_m, 0.0)
        if top <= bottom:
            return  # the fingertips reach the top at the grasp pose or below it: none
        ctx.blackboard[top_key], ctx.blackboard[bottom_key] = round(top, 4), round(bottom, 4)
        ctx.log(
            "skill",
            f"grasp_pose: a fingertip meets the object's top {contact * 1000:.1f} mm above "
            f"the grasp: guarded from {top * 1000:.1f} to {bottom * 1000:.1f} mm",
        )

    def stop(self, ctx: Context) -> None:
        """Nothing to leave behind: choosing a grasp moves nothing."""

    def explain(self, ctx: Context) -> str | None:
        return self.why or None


class FingerBoxes:
    """The fingers' footprints around the TCP, for a hand pointing down.

    Attributes:
        half_x: Half their extent along the hand's x axis (across the finger) [m].
        inner: Distance of a finger's inner face from the TCP (the opening) [m].
        outer: Distance of its outer face [m].
        depth_m: How far the fingertips reach below the TCP [m].
    """

    def __init__(self, half_x: float, inner: float, outer: float, depth_m: float) -> None:
        self.half_x, self.inner, self.outer, self.depth_m = half_x, inner, outer, depth_m

    def at(self, x: float, y: float, yaw: float) -> list[Box]:
        """The two footprints with the TCP at (x, y) [m], the hand at heading `yaw` [rad]
        (its closing axis, the TCP's y, at yaw - 90 deg)."""
        mid, half_y = 0.5 * (self.inner + self.outer), 0.5 * (self.outer - self.inner)
        cy, sy = math.sin(yaw), -math.cos(yaw)  # the closing axis in the world
        return [
            (x + side * mid * cy, y + side * mid * sy, yaw, self.half_x, half_y)
            for side in (1.0, -1.0)
        ]


_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
"""The eight corners of a unit box's half extents, as signs."""


def _corners_in_tcp(ctx: Context, g: int, centre: np.ndarray, half: np.ndarray) -> np.ndarray:
    """The corners of a box `centre` +- `half` in geom `g`'s frame, in the TCP's frame (x
    across the finger, y closing, z down) [m], shape (8, 3)."""
    d, w = ctx.data, ctx.world
    world = d.geom_xpos[g] + (centre + _CORNERS * half) @ d.geom_xmat[g].reshape(3, 3).T
    return (world - d.site_xpos[w.tcp_site]) @ d.site_xmat[w.tcp_site].reshape(3, 3)


def finger_boxes(ctx: Context, opening_m: float) -> FingerBoxes:
    """The fingers' footprints at each finger's opening `opening_m` [m], measured on the
    model: every collision box of the finger bodies, in the TCP's frame."""
    import mujoco

    m, w = ctx.model, ctx.world
    opening_now = 0.5 * ctx.gripper_width
    half_x, inner, outer, depth = 0.0, math.inf, 0.0, 0.0
    for g in sorted(w.finger_geoms):
        if m.geom_type[g] != mujoco.mjtGeom.mjGEOM_BOX or not (
            m.geom_contype[g] or m.geom_conaffinity[g]
        ):
            continue
        pts = _corners_in_tcp(ctx, g, np.zeros(3), m.geom_size[g])
        half_x = max(half_x, float(np.max(np.abs(pts[:, 0]))))
        ys = np.abs(pts[:, 1]) - opening_now
        inner, outer = min(inner, float(np.min(ys))), max(outer, float(np.max(ys)))
        depth = max(depth, float(np.max(pts[:, 2])))
    if not math.isfinite(inner):  # no box fingers: a point gripper at the opening
        inner = outer = 0.0
    return FingerBoxes(half_x, opening_m + max(inner, 0.0), opening_m + outer, depth)


def _box_fingers(ctx: Context) -> bool:
    """Every finger geom that collides is a box (`finger_boxes` measures those only: a
    mesh jaw, the SO-101's, reaches lower than its boxes)."""
    import mujoco

    m = ctx.model
    colliding = [g for g in ctx.world.finger_geoms if m.geom_contype[g] or m.geom_conaffinity[g]]
    return bool(colliding) and all(m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX for g in colliding)


def _across(size_m: list[float] | None, turn_deg: float) -> float | None:
    """The object's extent along the closing axis for a hand turned `turn_deg` [m]."""
    if size_m is None:
        return None
    long, short = max(size_m), min(size_m)
    t = math.radians(turn_deg)
    return abs(math.cos(t)) * short + abs(math.sin(t)) * long


def _seen_size(items: list[Any], centre: np.ndarray) -> list[float] | None:
    """The `size_m` of the detection among `items` that is the target (at `centre`)."""
    for item in items:
        if isinstance(item, dict) and "pose" in item and item.get("size_m"):
            if math.dist(Pose.coerce(item["pose"]).pos[:2], centre[:2]) <= _MATCH_M:
                return [float(v) for v in item["size_m"]]
    return None


def _neighbours(items: list[Any], centre: np.ndarray) -> list[tuple[str, Box]]:
    """Footprints of the detections around the target (the target itself skipped)."""
    out = []
    for i, item in enumerate(items):
        if not isinstance(item, dict) or "pose" not in item:
            continue
        pose = Pose.coerce(item["pose"])
        if math.dist(pose.pos[:2], centre[:2]) <= _MATCH_M:
            continue
        size = item.get("size_m") or [0.05, 0.05]
        name = f"{item.get('class', 'object')} #{item.get('id', i)} at " + str(
            np.round(pose.pos[:2], 3).tolist()
        )
        out.append((name, (pose.pos[0], pose.pos[1], pose.yaw, size[0] / 2, size[1] / 2)))
    return out


class HandBox:
    """The hand's (palm's) footprint around the TCP, for a hand pointing down.

    Attributes:
        half_x: Half its extent along the hand's x axis [m].
        half_y: Half its extent along the closing axis [m].
        depth_m: How far its lowest point is below the TCP [m] (negative: above it).
    """

    def __init__(self, half_x: float, half_y: float, depth_m: float) -> None:
        self.half_x, self.half_y, self.depth_m = half_x, half_y, depth_m

    def at(self, x: float, y: float, yaw: float) -> list[Box]:
        """The footprint with the TCP at (x, y) [m], the hand at heading `yaw` [rad]."""
        return [(x, y, yaw, self.half_x, self.half_y)]


def hand_box(ctx: Context) -> HandBox:
    """The hand's footprint, measured on the model: the bounding boxes of the hand body's
    collision geoms (any shape), in the TCP's frame. A finger clearing a cabinet is not
    enough: the palm, 20 cm across the closing axis, comes down beside it too."""
    m, w = ctx.model, ctx.world
    half_x = half_y = 0.0
    depth = -math.inf
    for g in range(m.ngeom):
        if m.geom_bodyid[g] != w.hand_body or not (m.geom_contype[g] or m.geom_conaffinity[g]):
            continue
        pts = _corners_in_tcp(ctx, g, m.geom_aabb[g, :3], m.geom_aabb[g, 3:])
        half_x = max(half_x, float(np.max(np.abs(pts[:, 0]))))
        half_y = max(half_y, float(np.max(np.abs(pts[:, 1]))))
        depth = max(depth, float(np.max(pts[:, 2])))
    if not math.isfinite(depth):  # no collision geom on the hand: nothing to clear
        return HandBox(0.0, 0.0, -math.inf)
    return HandBox(half_x, half_y, depth)


def _palm_strikes(
    ctx: Context, obj: Any, tcp_z: float, hand: HandBox, clearance: float
) -> str | None:
    """Why the palm would come down on the object's top with the TCP at height `tcp_z` [m]
    (its declared size, standing as it stands now: where `search` sees it), or None. A hand
    whose own body reaches down to the TCP (a jaw fixed to it, as on the SO-101) has no palm
    above the object to judge: None."""
    if hand.depth_m >= 0.0:
        return None  # the hand's own body reaches the TCP: a jaw of it (the SO-101), no palm
    pose = ctx.object_pose(obj.name)
    up = float(np.abs(rotation_of(pose.quat)[2]) @ obj.half_size)  # half its extent along z
    top = float(pose.pos[2]) + up
    palm = tcp_z - hand.depth_m
    if top + clearance <= palm:
        return None
    return (
        f"{obj.name} stands {2.0 * up * 1000:.0f} mm tall: with the TCP at {tcp_z:.3f} m to "
        f"grasp it, its top ({top:.3f} m) would be {(top - palm) * 1000:.1f} mm above the "
        f"palm's underside ({palm:.3f} m, {-hand.depth_m * 1000:.0f} mm above the TCP; "
        f"{clearance * 1000:.0f} mm below it needed)"
    )


def _over_payload(ctx: Context, obj: Any) -> str | None:
    """Why the object is too heavy for the arm to carry, or None: its mass (the scene's, as a
    cell knows its parts list) plus everything on the flange (the hand, a tool) over the
    robot's rated payload (`Robot.payload_kg`). Explore found 12.5-41 kg cubes lifted until
    the `contact_force` guard aborted, the stop then jolting joint 6 past its deceleration."""
    rated = ctx.robot.payload_kg
    if rated is None:
        return None
    mass = float(ctx.model.body_mass[obj.body_id])
    hand = float(ctx.model.body_subtreemass[ctx.world.hand_body])
    room = rated - hand
    if mass <= room:
        return None
    return (
        f"{obj.name} is {mass:.3g} kg: over the {ctx.robot.name}'s rated payload of "
        f"{rated:g} kg (with the hand's {hand:.2f} kg on the flange, at most "
        f"{max(room, 0.0):.2f} kg to carry)"
    )


def _outside_workspace(ctx: Context, tcp: np.ndarray) -> str | None:
    """Why the grasp pose lies outside the scenario's `workspace` guard box, or None: the
    guard would abort the approach on its way there (explore found a table 1 cm high, the
    cube's centre 12 cm below the box's floor: the stop then jolted joint 2)."""
    for name, params in _guards(ctx.scenario.guards):
        if name != "workspace" or not params:
            continue
        low, high = np.asarray(params["min"], float), np.asarray(params["max"], float)
        out = [
            f"{axis} {tcp[i]:.3f} m {'below' if tcp[i] < low[i] else 'above'} "
            f"{low[i] if tcp[i] < low[i] else high[i]:g}"
            for i, axis in enumerate("xyz")
            if not low[i] <= tcp[i] <= high[i]
        ]
        if out:
            return (
                "the grasp pose lies outside the workspace guard's box (TCP "
                + ", ".join(out)
                + "): the guard would abort the approach"
            )
    return None


def _guards(refs: Any) -> list[tuple[str, Any]]:
    """(name, params) of a scenario's guard list or mapping."""
    if isinstance(refs, dict):
        return list(refs.items())
    out: list[tuple[str, Any]] = []
    for ref in refs:
        if isinstance(ref, str):
            out.append((ref, None))
        else:
            out.extend(ref.items())
    return out


def _sweeps_the_base(ctx: Context, obj: Any, tcp: np.ndarray) -> str | None:
    """Why the object, held at `tcp`, would reach into the arm's own base column, or None.

    Carried, it turns about the TCP (to the place's heading, through the hover points): its
    far corner sweeps a circle of its half-diagonal around the grasp point, which must stay
    clear of the base column (its radius `_BASE_COLUMN_M`, plus `_BASE_CLEARANCE_M`).
    Explore found a 10 m long box in stack, grasped across its short side and carried into
    link 1 (a collision abort).
    """
    reach = math.hypot(*(float(v) for v in obj.half_size[:2]))
    base = ctx.robot.shoulder(ctx.q, np.asarray(ctx.scenario.robot.base_pos))  # on its axis
    room = float(np.hypot(*(tcp[:2] - base[:2]))) - _BASE_COLUMN_M - _BASE_CLEARANCE_M
    if reach <= room:
        return None
    return (
        f"{obj.name} is {2.0 * reach:.2f} m across its diagonal: held at the grasp, "
        f"{float(np.hypot(*(tcp[:2] - base[:2]))):.2f} m from the arm's base axis, it would "
        f"sweep {reach:.2f} m around the hand, into the base column (at most {max(room, 0.0):.2f} "
        f"m: {_BASE_COLUMN_M * 1000:.0f} mm column radius and {_BASE_CLEARANCE_M * 1000:.0f} mm "
        "clearance)"
    )


def _walls(ctx: Context, fingertip_z: float) -> list[tuple[str, Box]]:
    """Footprints of the scene's fixed boxes a finger can collide with that stand higher than
    the fingertips at the grasp (walls, bins, furniture; the surface the object lies on is
    lower)."""
    import mujoco

    m, d, w = ctx.model, ctx.data, ctx.world
    fingers = [g for g in w.finger_geoms if m.geom_contype[g] or m.geom_conaffinity[g]]
    out = []
    for g in range(m.ngeom):
        if m.geom_type[g] != mujoco.mjtGeom.mjGEOM_BOX or m.body_dofnum[m.geom_bodyid[g]] > 0:
            continue
        if g in w.robot_geoms or not any(
            m.geom_contype[g] & m.geom_conaffinity[f] or m.geom_contype[f] & m.geom_conaffinity[g]
            for f in fingers
        ):
            continue  # the robot's own, or what no finger can touch (a hidden fault obstacle)
        rot = d.geom_xmat[g].reshape(3, 3)
        if abs(rot[2, 2]) < 0.999:
            continue  # not standing upright: not a wall
        hx, hy, hz = (float(v) for v in m.geom_size[g])
        x, y, z = (float(v) for v in d.geom_xpos[g])
        if z + hz <= fingertip_z:
            continue  # lower than the fingertips: the surface the object lies on
        name = m.geom(g).name or f"geom {g}"
        out.append((name, (x, y, math.atan2(rot[1, 0], rot[0, 0]), hx, hy)))
    return out


def _first_hit(fingers: list[Box], others: list[tuple[str, Box]], clearance: float) -> str | None:
    """The first neighbour or wall a finger comes within `clearance` [m] of, in words."""
    for name, box in others:
        for finger in fingers:
            gap = separation(finger, box)
            if gap < clearance:
                return f"{max(gap, 0.0) * 1000:.1f} mm of {name}"
    return None


def _ik_miss(
    ctx: Context, pos: np.ndarray, yaw: float, tol_m: float, tol_rad: float
) -> tuple[float, float]:
    """How close the IK gets the TCP to `pos` [m] pointing down at heading `yaw` [rad] from
    the measured joints: (position [m], orientation [rad]) left. On the robot's own IK model,
    never the running solver."""
    from orchestrator.world.world import robot_only_model

    ik = IKSolver(ctx.robot, robot_only_model(ctx.robot), _IK_DT, ctx.scenario.robot.base_pos)
    ik.reset(ctx.q)
    rot = rot_down(yaw)
    history: list[float] = []
    err = np.full(6, math.inf)
    for _ in range(_IK_ITERATIONS):
        ik.reference_step(pos, rot, _IK_DT)
        err = ik.error
        miss = float(np.linalg.norm(err[:3]))
        if miss <= 0.5 * tol_m and float(np.linalg.norm(err[3:])) <= 0.5 * tol_rad:
            break
        history.append(miss + float(np.linalg.norm(err[3:])))
        if (
            len(history) > _STALL_ITERATIONS
            and history[-_STALL_ITERATIONS - 1] - history[-1] < 1e-5
        ):
            break  # stuck: a joint limit or the edge of the reach
    return float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:]))


def _yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0)]
