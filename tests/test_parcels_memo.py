"""A sorting cell's parcels are drawn once per settings and seed in a process."""

from __future__ import annotations

from orchestrator.language import parcels
from orchestrator.language.load import load_scenario
from orchestrator.language.parcels import draw_parcels


def _fresh(p, seed):
    parcels._DRAWN.clear()
    return draw_parcels(p, seed)


def test_a_kept_layout_is_the_one_drawn_afresh_and_each_caller_gets_its_own():
    p = load_scenario("sorting").scenario.scene.parcels
    first = draw_parcels(p, 5)
    first[0][1][1][0] = -1.0  # a caller changing its copy of a size
    assert draw_parcels(p, 5) == _fresh(p, 5)
    assert draw_parcels(p, 5)[0][1][1][0] > 0.0


def test_other_settings_or_another_seed_draw_anew():
    p = load_scenario("sorting").scenario.scene.parcels
    base = draw_parcels(p, 2)
    assert draw_parcels(p, 3) != base
    fewer = p.model_copy(update={"count": p.count - 1})
    assert len(draw_parcels(fewer, 2)) == p.count - 1
    assert draw_parcels(fewer, 2) == _fresh(fewer, 2)


def test_the_same_seed_builds_the_same_sorting_scene_twice():
    from orchestrator.world import World

    scenario = load_scenario("sorting").scenario
    a, b = World.build(scenario, 4), World.build(scenario, 4)
    names = [o.name for o in a.scenario.scene.objects]
    assert names == [o.name for o in b.scenario.scene.objects]
    assert (a.data.qpos == b.data.qpos).all()
