"""Island sleeping in the world: resting objects sleep, anything that acts on them wakes them.

The physics step skips a sleeping object's collisions and contact rows; what must hold is that
nothing the flows, the faults or the guards rely on is lost to it.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from orchestrator.language.load import load_scenario
from orchestrator.world.world import World


def _settle(world: World, steps: int) -> None:
    """Step with the arm gravity-compensated where it is (no controller needed here)."""
    m, d = world.model, world.data
    for _ in range(steps):
        d.ctrl[world.arm_act] = d.qfrc_bias[world.arm_dof]
        mujoco.mj_step(m, d)


def _asleep(world: World, name: str) -> bool:
    return not bool(world.data.body_awake[world.objects[name].body_id])


@pytest.fixture
def room() -> World:
    return World.build(load_scenario("mobile_search").scenario, 1)


def test_resting_blocks_fall_asleep_and_the_robot_never_does(room):
    _settle(room, 500)
    assert all(_asleep(room, name) for name in room.objects), {
        n: _asleep(room, n) for n in room.objects
    }
    assert room.data.body_awake[room.hand_body]
    assert room.data.ncon == 0  # no block's resting contacts are computed any more


def test_a_push_wakes_a_sleeping_block_and_moves_it(room):
    _settle(room, 500)
    h = room.objects["green_cube"]
    before = room.data.qpos[h.qpos_adr : h.qpos_adr + 3].copy()
    room.effects.push("green_cube", np.array([3.0, 0.0, 0.0]))
    _settle(room, 100)
    room.effects.end_push("green_cube", np.array([3.0, 0.0, 0.0]))
    assert not _asleep(room, "green_cube")
    moved = room.data.qpos[h.qpos_adr] - before[0]
    assert moved > 0.01, f"pushed for 0.2 s with 3 N, the block moved {moved * 1000:.1f} mm"
    assert _asleep(room, "blue_cube")  # the others sleep on


def test_a_body_landing_on_a_sleeping_block_wakes_it_and_their_contact_is_computed(room):
    _settle(room, 500)
    d = room.data
    below, above = room.objects["green_cube"], room.objects["cube"]
    assert _asleep(room, "green_cube")
    # drop the red block on the sleeping green one: its velocity wakes it, the contact the other
    d.qpos[above.qpos_adr : above.qpos_adr + 3] = d.xpos[below.body_id] + [0.0, 0.0, 0.1]
    d.qvel[above.qvel_adr : above.qvel_adr + 3] = [0.0, 0.0, -0.5]
    touched = False
    for _ in range(150):
        _settle(room, 1)
        touched |= any(
            {int(c.geom[0]), int(c.geom[1])} == {above.geom_id, below.geom_id}
            for c in d.contact[: d.ncon]
        )
    assert touched, "the falling block passed through the sleeping one"
    top = d.xpos[above.body_id, 2] - d.xpos[below.body_id, 2]
    assert top == pytest.approx(0.05, abs=0.005)  # it rests on it, one block higher


def test_physics_sleep_false_keeps_every_block_awake():
    world = World.build(load_scenario("mobile_search", ["physics.sleep=false"]).scenario, 1)
    _settle(world, 500)
    assert not any(_asleep(world, name) for name in world.objects)
    assert not world.model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP


def test_a_bad_physics_sleep_value_is_a_located_error(cli):
    res = cli("run", "mobile_search", "--set", "physics.sleep=sometimes")
    assert res.exit_code == 2
    assert "physics.sleep" in res.stderr and "Traceback" not in res.stderr


def test_a_moved_static_body_is_placed_again_by_static_moved(room):
    _settle(room, 500)
    m, d = room.model, room.data
    table = m.body("table").id
    z0 = float(d.xpos[table, 2])
    m.body_pos[table, 2] += 0.1
    mujoco.mj_forward(m, d)
    assert d.xpos[table, 2] == z0  # with sleeping on, MuJoCo placed static bodies at reset only
    room.static_moved()
    assert d.xpos[table, 2] == pytest.approx(z0 + 0.1)
    assert m.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP  # still on afterwards
