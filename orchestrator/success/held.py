"""`held`: an object is held in the gripper, lifted above where it was grasped."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from pydantic import Field

from .base import SCENE_OBJECT, CheckParams, SuccessCheck, Verdict

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["Held"]


class HeldParams(CheckParams):
    object: str = Field(description="The scene object judged.", json_schema_extra=SCENE_OBJECT)
    min_lift_m: float = Field(
        default=0.05, ge=0.0, le=3.0, description="Lifted at least this high [m]."
    )


class Held(SuccessCheck):
    """Both fingers touch the object and it is at least `min_lift_m` above where it lay when the
    fingers last closed on it (where it started, if they never did: a block pushed off a desk is
    lifted from the floor)."""

    kind: ClassVar[str] = "held"
    Params: ClassVar[type[CheckParams]] = HeldParams
    params: HeldParams

    def evaluate(self, ctx: Context) -> Verdict:
        p = self.params
        pos = ctx.object_pose(p.object).pos
        grasped = ctx.grasped_at.get(p.object)
        start = grasped if grasped is not None else ctx.start_pose(p.object).pos[2]
        lift = float(pos[2] - start)
        geom = ctx.world.objects[p.object].geom_id
        d, m = ctx.data, ctx.model
        touching = set()
        for i in range(d.ncon):
            g1, g2 = int(d.contact[i].geom1), int(d.contact[i].geom2)
            if geom in (g1, g2):
                other = g2 if g1 == geom else g1
                if other in ctx.world.finger_geoms:
                    touching.add(int(m.geom_bodyid[other]))
        since = "where it was grasped" if grasped is not None else "its start"
        what = f"{p.object} {lift * 1000:.0f} mm above {since}, {len(touching)} finger(s) on it"
        if len(touching) < 2 or lift < p.min_lift_m:
            return Verdict(False, f"{what} (need 2 and min_lift_m {p.min_lift_m * 1000:g} mm)")
        return Verdict(True, what)
