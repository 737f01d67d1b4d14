"""The world's StepClock is MjData's time, bit for bit, as the one step function keeps it: through
an episode's ticks, a world reset and a snapshot's round trip (where the context, its encoders
and the compiled wrist force keep reading the one clock)."""

from __future__ import annotations

from orchestrator.engine.runner import new_run
from orchestrator.engine.snapshot.world_state import apply_world, capture_world
from orchestrator.language.load import load_scenario


def test_the_clock_is_mjdata_time_bit_for_bit_where_a_step_count_is_not():
    episode = new_run(load_scenario("pick_place"), 0).episode
    ctx = episode.ctx
    clock, data = ctx.world.step_clock, ctx.data
    assert clock.t == data.time == 0.0
    steps, off_by_count = 0, 0
    episode.start()
    for _ in range(300):  # 1,500 physics steps: the cube is grasped and carried
        assert not episode.tick()
        steps += episode.loop.n_sub
        assert clock.t == data.time and ctx.t == data.time  # every bit
        off_by_count += steps * ctx.dt_physics != data.time
    assert off_by_count > 250  # why it is a sum, not a count times the step: 0.002 is inexact


def test_a_world_reset_sets_the_clock_back_with_mjdata():
    episode = new_run(load_scenario("pick_place"), 0).episode
    ctx = episode.ctx
    episode.start()
    for _ in range(3):
        episode.tick()
    assert ctx.t > 0.0
    ctx.world.reset()
    assert ctx.t == ctx.world.step_clock.t == ctx.data.time == 0.0


def test_a_world_restored_from_a_snapshot_keeps_one_clock_for_the_world_and_its_readers():
    run = new_run(load_scenario("pick_place"), 0)
    run.episode.start()
    for _ in range(20):
        run.episode.tick()
    tree, arrays = capture_world(run.ctx)
    again = new_run(load_scenario("pick_place"), 0)
    ctx = again.episode.ctx
    clock = ctx.world.step_clock
    apply_world(tree, arrays, ctx, "test")
    assert clock.t == ctx.data.time == run.episode.ctx.t > 0.0
    assert ctx._time is clock and ctx.cell.encoders._clock is clock
    if ctx.cell.wrist.compiled is not None:  # compiled: its reader reads the same clock
        assert ctx.cell.wrist.compiled.clock is clock
    again.episode.start()
    again.episode.tick()
    assert clock.t == ctx.data.time > run.episode.ctx.t
