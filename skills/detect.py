"""`detect`: find objects of colour classes in a camera image and localize them in the world."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Annotated, ClassVar

import numpy as np
from pydantic import Field, NonNegativeFloat, model_validator

from orchestrator.exceptions import SkillError
from orchestrator.world.pose import Pose

from .base import Skill, SkillParams
from .hint import Hint, HintRadius, hint_distance

if TYPE_CHECKING:
    from orchestrator.engine.context import Context
    from orchestrator.perception.detections import Detection

__all__ = ["Detect"]

CAMERA = {"scene_ref": "camera"}
COLOUR_CLASS = {"scene_ref": "colour_class"}


class DetectParams(SkillParams):
    camera: str = Field(description="Camera to look through.", json_schema_extra=CAMERA)
    class_: str | None = Field(
        default=None,
        alias="class",
        description="Only detections of this colour class (default: every class).",
        json_schema_extra=COLOUR_CLASS,
    )
    min_pixels: int = Field(default=30, ge=1, description="Smallest blob reported [px].")
    min_confidence: float = Field(
        default=0.5, ge=0.0, le=1.0, description="`found` needs a detection this confident."
    )
    roi: Annotated[list[int], Field(min_length=4, max_length=4)] | None = Field(
        default=None, description="Region of interest `[x0, y0, x1, y1]` [px], end exclusive."
    )
    into: str = Field(default="detections", description="Blackboard key of the detection list.")
    all_into: str | None = Field(
        default=None,
        description="Blackboard key the detections of every class go to, `class` or not "
        "(what lies around the target: the neighbours `grasp_pose` keeps the fingers clear "
        "of); default: none, and only `class` is segmented.",
    )
    pose_into: str | None = Field(
        default=None,
        description="Blackboard key the pose of the best detection (the first at or above "
        "`min_confidence`) is written to, ready for `grasp`/`move`.",
    )
    duration_s: NonNegativeFloat = Field(default=0.05, description="Time perception takes [s].")
    near: Hint = None
    near_radius_m: HintRadius = 0.05

    @model_validator(mode="after")
    def _roi(self) -> DetectParams:
        if self.roi is not None:
            x0, y0, x1, y1 = self.roi
            if not (0 <= x0 < x1 and 0 <= y0 < y1):
                raise ValueError(f"roi {self.roi}: need 0 <= x0 < x1 and 0 <= y0 < y1 [px]")
        return self


class Detect(Skill):
    """Render `camera`, segment the image by colour in HSV (OpenCV) and localize each blob with
    the depth image: the centre of its top face in the world and its yaw.

    Writes to `into` the detections, sorted by class, confidence (highest first), x, y; each is
    `{id, class, pose: {pos, quat}, confidence, pixels, bbox: [x, y, w, h], size_m, camera}`.
    Blobs cut by the image border, occluded or of an ambiguous colour come with a confidence
    below 0.5. Outcome `found` when one detection (of `class`, if given) reaches
    `min_confidence` (its pose goes to `pose_into`; given a position hint `near`, the one
    nearest the hint, within `near_radius_m` of it), else `none`. Injected perception faults
    (`perception_miss`, `perception_offset`) apply to the best detection.

    Metrics (over the run, against the simulator's truth): `detection_error_mm` (largest
    position error of a matched detection at or above `min_confidence`: a cut blob's centre is
    not its object's), `detection_yaw_error_deg` (largest yaw error, the same detections),
    `misclassified` (detections of a wrong class or of no object), `perception_backend`,
    `detections` (calls that ended `found`).
    """

    name: ClassVar[str] = "detect"
    Params: ClassVar[type[SkillParams]] = DetectParams
    outcomes: ClassVar[tuple[str, ...]] = ("found", "none")
    writes: ClassVar[dict[str, str]] = {"into": "list", "all_into": "list", "pose_into": "pose"}

    params: DetectParams

    def start(self, ctx: Context) -> None:
        p = self.params
        cameras = [c.name for c in ctx.scenario.cameras]
        if p.camera not in cameras:
            valid = ", ".join(cameras) or "none: the scenario has no `cameras`"
            raise SkillError(f"no camera {p.camera!r} (valid: {valid})")
        classes = list(ctx.scenario.perception.classes)
        if p.class_ is not None and p.class_ not in classes:
            raise SkillError(f"no colour class {p.class_!r} (valid: {', '.join(classes)})")
        self.t0 = ctx.clock

    def step(self, ctx: Context) -> str | None:
        from orchestrator.perception.detections import detect_objects, sort_detections

        p = self.params
        if ctx.clock - self.t0 < p.duration_s - 1e-9:
            return None
        scn = ctx.scenario
        frame = ctx.cameras.capture(ctx.data, p.camera)
        classes = scn.perception.class_boxes()
        if p.class_ is not None and p.all_into is None:
            classes = {p.class_: classes[p.class_]}
        roi = (p.roi[0], p.roi[1], p.roi[2], p.roi[3]) if p.roi is not None else None
        found = detect_objects(
            frame, classes, p.min_pixels, roi, scn.perception.randomize.depth_noise_m
        )
        if p.all_into is not None:
            ctx.blackboard[p.all_into] = [d.to_blackboard() for d in found]
            if p.class_ is not None:  # each class is segmented on its own: the same blobs
                found = sort_detections([d for d in found if d.cls == p.class_])
        self._score(ctx, found)
        if ctx.keep_camera_shots:
            ctx.camera_shots.append((ctx.tick, ctx.t, frame, found))
        ctx.blackboard[p.into] = [d.to_blackboard() for d in found]
        sure = [d for d in found if d.confidence >= p.min_confidence]
        if p.near is not None:
            hint, radius = p.near, p.near_radius_m
            near = [(hint_distance(hint, d.pos), i) for i, d in enumerate(sure)]
            sure = [sure[i] for dist, i in sorted(near) if dist <= radius]
        best = sure[0] if sure else None
        seen = None if best is None else ctx.perceived(Pose.coerce(best.to_blackboard()["pose"]))
        what = p.class_ or "any class"
        if p.near is not None:
            what += f" within {p.near_radius_m} m of {p.near}"
        if best is None or seen is None:
            ctx.log("skill", f"detect: {len(found)} blob(s), none of {what} confident enough")
            return "none"
        if p.pose_into is not None:
            ctx.blackboard[p.pose_into] = seen
        ctx.metrics["detections"] = int(ctx.metrics.get("detections", 0)) + 1
        ctx.log(
            "skill",
            f"detect: {len(found)} detection(s) in {p.camera!r}; best {best.cls} at "
            f"{np.round(seen.pos, 4).tolist()}, yaw {math.degrees(best.yaw):.1f} deg, "
            f"confidence {best.confidence:.2f}",
        )
        return "found"

    def _score(self, ctx: Context, found: list[Detection]) -> None:
        """Add this call's errors against the truth to the run's metrics (worst over calls)."""
        from orchestrator.perception.truth import match_detections, true_objects

        m = ctx.metrics
        m["perception_backend"] = ctx.cameras.renderer.name
        matches = match_detections(found, true_objects(ctx.world))
        wrong = sum(1 for x in matches if not x.correct)
        m["misclassified"] = int(m.get("misclassified", 0)) + wrong
        sure = [
            x for x in matches if x.correct and x.detection.confidence >= self.params.min_confidence
        ]
        pos = [x.position_error_m * 1000.0 for x in sure]
        yaw = [x.yaw_error_deg for x in sure]
        if pos:
            m["detection_error_mm"] = round(max(m.get("detection_error_mm", 0.0), *pos), 3)
            m["detection_yaw_error_deg"] = round(
                max(m.get("detection_yaw_error_deg", 0.0), *yaw), 3
            )
