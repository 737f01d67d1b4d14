"""The tissue phantom: a stiffening, damped force law; the shaft collides with it; the buried
nodule of the complication lies under the surface (that the tip meets it, never the shaft, is
checked at every physics step of the complication's episode in tests/test_physical_honesty.py,
which shares that episode)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.world import World
from orchestrator.world.phantom import tissue_law
from orchestrator.world.tissue import TissueLaw
from orchestrator.world.tissue_probe import indent

TIP_RADIUS_M = 0.0025


@pytest.fixture(scope="module")
def world():
    return World.build(load_scenario("surgical").scenario, seed=0)


def _tip(world: World, depth: float, speed: float = 0.0) -> float:
    forces = indent(world, depth, speed)
    assert set(forces) == {"probe_tip"}, forces  # shallower than the tip's radius: tip only
    return forces["probe_tip"]


def test_the_phantom_stiffens_with_indentation(world):
    # measured from MuJoCo's solver: twice as deep pushes back more than twice as hard
    for x in (0.0005, 0.001):
        assert _tip(world, 2 * x) > 2.2 * _tip(world, x)
    # and the force MuJoCo applies is the documented law, at every depth of the working range
    law = tissue_law(world.scenario, world.seed)
    for x in np.linspace(0.0002, 0.0024, 12):
        assert _tip(world, x) == pytest.approx(law.force(x), rel=1e-6)


def test_the_stiffening_puts_2_n_at_about_2_mm_for_every_seed():
    scenario = load_scenario("surgical").scenario
    for seed in range(20):
        law = tissue_law(scenario, seed)
        lo, hi = 0.0, 0.01
        for _ in range(40):  # bisection: the indentation where the tissue pushes 2 N
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if law.force(mid) < 2.0 else (lo, mid)
        assert 0.0015 < lo < TIP_RADIUS_M - 1e-4, (seed, lo)  # the shaft stays out at 2 N


def test_a_linear_phantom_stays_linear():
    law = TissueLaw(stiffness=500.0, damping=20.0)
    assert law.d_max == pytest.approx(law.impedance(0.0))
    assert law.force(0.004) == pytest.approx(2.0) and law.force(0.008) == pytest.approx(4.0)
    assert law.force(-0.001) == 0.0 and law.force(0.0001, -0.01) == 0.0  # it never pulls


def test_the_phantom_is_damped(world):
    # moving in it pushes back harder than at rest, moving out less: a hysteresis loop
    law = tissue_law(world.scenario, world.seed)
    for x in (0.0005, 0.001, 0.002):
        rest, loading, unloading = (_tip(world, x, v) for v in (0.0, 0.01, -0.01))
        assert loading - rest == pytest.approx(rest - unloading, rel=1e-6)
        assert loading == pytest.approx(law.force(x, 0.01), rel=1e-6)  # the documented law
        assert loading - rest >= 0.01 * law.damping  # at least the surface's 20 N s/m
    # the damping grows with the indentation (as d / (1 - d): 1.36x from 0.5 to 2 mm)
    assert _tip(world, 0.002, 0.01) - _tip(world, 0.002) > 1.3 * (
        _tip(world, 0.0005, 0.01) - _tip(world, 0.0005)
    )


def test_the_phantom_settles_where_the_law_says_in_the_closed_loop(tmp_path):
    """A dynamic check of the static law: the contact skill holds 3 N on a stiffening phantom
    and the tip comes to rest at the law's indentation for 3 N."""
    from .test_contact import ForceProbe, _scenario

    phantom = (
        "  table: {center_xy: [0.3, 0.0], size_xy: [0.3, 0.3], height: 0.33}\n"
        "  phantom: {size: [0.1, 0.1, 0.04], xy: [0.307, 0.0], stiffness_n_per_m: 500,"
        " stiffening: {ratio: 10, depth_m: 0.008}, damping_n_s_per_m: 20}"
    )
    with_ = (
        "{target_force_n: 3.0, approach_speed: 0.01, hold_s: 1.5, surface_stiffness_n_per_m: 2000}"
    )
    probe = ForceProbe()
    result = run_episode(_scenario(tmp_path, with_, phantom), 0, [probe])
    assert result.outcome == "succeeded", result.transitions
    end = np.flatnonzero(probe.pressing())[-1]
    indentation = probe.world.phantom.surface_pos[2] - probe.tip[end][2]
    law = tissue_law(probe.world.scenario, 0)
    assert probe.force[end][2] == pytest.approx(3.0, abs=0.05)
    assert law.force(indentation) == pytest.approx(probe.force[end][2], rel=0.05)
    assert indentation < 0.5 * 3.0 / 500.0  # a linear 500 N/m phantom would yield 6 mm


def test_the_shaft_collides_with_tissue(world):
    # pressed deeper than the ball tip's radius, the shaft's end meets the surface and pushes too
    forces = indent(world, 0.0035)
    assert set(forces) == {"probe_tip", "probe_shaft"}
    assert forces["probe_shaft"] > 1.0


def test_the_nodule_lies_under_the_surface():
    world = World.build(load_scenario("surgical_complication").scenario, seed=0)
    m = world.model
    mujoco.mj_forward(m, world.data)
    g = m.geom("nodule").id
    ph = world.phantom
    assert ph is not None
    # in the phantom's surface frame (it is turned and tilted per seed)
    centre = ph.rotation.T @ (world.data.geom_xpos[g] - ph.surface_pos)
    assert centre[2] + m.geom_size[g][2] == pytest.approx(-0.0005, abs=1e-9)
