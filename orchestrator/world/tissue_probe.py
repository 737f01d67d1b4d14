"""A probe that measures the tissue's force law on a built world, through MuJoCo's own solver
(bench/tissue_probe.py and tests/test_tissue.py draw the curve with it)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

if TYPE_CHECKING:
    from .world import World

__all__ = ["indent"]


def indent(world: World, depth_m: float, speed_m_s: float = 0.0) -> dict[str, float]:
    """The normal force [N] each tool geom feels from the phantom, per geom name, with the tip
    `depth_m` into the phantom's surface and moving in at `speed_m_s` (negative: out).

    The arm rests at home; the phantom is moved and levelled (for this measurement only) so
    that its surface lies `depth_m` above the tip, and MuJoCo's inverse dynamics (`mj_inverse`,
    zero joint acceleration) gives the contact forces its soft-contact solver applies there:
    the tissue's force law as the simulation realises it, without the arm's dynamics. The world
    is reset afterwards.
    """
    ph = world.phantom
    if ph is None:
        raise ValueError(f"scenario {world.scenario.name!r} has no phantom to indent")
    m, d = world.model, world.data
    body, geom = m.body(ph.name).id, m.geom(ph.name).id
    saved, saved_quat = m.body_pos[body].copy(), m.body_quat[body].copy()
    world.reset()
    tip = d.site_xpos[world.tcp_site].copy()
    try:
        m.body_pos[body] = [tip[0], tip[1], tip[2] + depth_m - ph.size[2] / 2.0]
        m.body_quat[body] = [1.0, 0.0, 0.0, 0.0]
        world.static_moved()  # the phantom is static: placed again only on request
        jac = np.zeros((3, m.nv))
        mujoco.mj_jacSite(m, d, jac, None, world.tcp_site)
        d.qvel[:] = np.linalg.pinv(jac) @ np.array([0.0, 0.0, -speed_m_s])
        d.qacc[:] = 0.0
        mujoco.mj_inverse(m, d)
        forces: dict[str, float] = {}
        out = np.zeros(6)
        for i in range(d.ncon):
            c = d.contact[i]
            if geom not in (c.geom1, c.geom2):
                continue
            other = m.geom(int(c.geom2 if c.geom1 == geom else c.geom1)).name
            mujoco.mj_contactForce(m, d, i, out)
            forces[other] = forces.get(other, 0.0) + float(out[0])
        return forces
    finally:
        m.body_pos[body], m.body_quat[body] = saved, saved_quat
        world.reset()
