"""Worker memory in batch results: RSS per episode and the summary's `memory` block."""

from __future__ import annotations

import itertools
import mmap
import os

import pytest

from orchestrator.batch import memory
from orchestrator.batch.episode import same_episode
from orchestrator.batch.memory import memory_stats, rss_mb, worker_stamp


def _line(seed: int, pid: int, episode: int, rss: float) -> dict:
    worker = {"pid": pid, "episode": episode, "rss_before_mb": rss - 1, "rss_mb": rss}
    return {"seed": seed, "outcome": "succeeded", "worker": worker}


def test_rss_follows_memory_that_is_touched():
    # fresh pages of its own (an anonymous mapping), not the allocator's: a bytearray may land
    # in memory an earlier test freed and the allocator kept resident (+16 MB read for 80)
    size = 80 * 1024 * 1024
    with mmap.mmap(-1, size) as block:
        before = rss_mb()
        for offset in range(0, size, mmap.PAGESIZE):  # zero pages are only resident once written
            block[offset] = 1
        grown = rss_mb() - before
    assert 70.0 <= grown <= 90.0, grown


def test_worker_stamp_counts_this_process_episodes(monkeypatch):
    monkeypatch.setattr(memory, "_episodes_run", itertools.count(1))
    first = worker_stamp(100.0)
    second = worker_stamp(101.0)
    assert (first["pid"], first["episode"], second["episode"]) == (os.getpid(), 1, 2)
    assert first["rss_before_mb"] == 100.0 and first["rss_mb"] > 10.0


def test_memory_compares_each_worker_first_episode_with_its_last():
    lines = [
        _line(3, pid=11, episode=3, rss=260.0),  # out of order: a worker's own count decides
        _line(0, pid=11, episode=1, rss=250.0),
        _line(1, pid=22, episode=1, rss=240.0),
        _line(2, pid=11, episode=2, rss=255.5),
        {"seed": 4, "outcome": "error"},  # a dead worker's episode has no stamp
    ]
    stats = memory_stats(lines)
    assert stats is not None
    (a, b) = stats.workers
    assert (a.pid, a.episodes, a.rss_start_mb, a.rss_end_mb, a.growth_mb) == (
        11, 3, 250.0, 260.0, 10.0
    )  # fmt: skip
    assert (b.pid, b.episodes, b.growth_mb) == (22, 1, 0.0)
    assert stats.max_growth_mb == 10.0 and stats.max_rss_mb == 260.0


def test_no_stamps_no_memory_block():
    assert memory_stats([{"seed": 0, "outcome": "succeeded"}]) is None


def test_the_worker_stamp_is_not_part_of_the_episode():
    a, b = _line(0, 11, 1, 250.0), _line(0, 22, 4, 300.0)
    assert same_episode(a, b)
    b["outcome"] = "failed"
    assert not same_episode(a, b)


@pytest.mark.parametrize("missing", ["pid", "rss_mb"])
def test_a_torn_stamp_is_ignored(missing):
    line = _line(0, 11, 1, 250.0)
    del line["worker"][missing]
    assert memory_stats([line]) is None


def test_release_frees_the_episode_world_held_in_reference_cycles():
    import gc
    import weakref

    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    refs: list[weakref.ref] = []

    class Watch:
        def on_start(self, ctx, executor):
            refs.extend([weakref.ref(ctx.world), weakref.ref(ctx), weakref.ref(executor)])

        def on_tick(self, ctx, executor):
            pass

        def on_end(self, ctx, executor, result):
            pass

    loaded = load_scenario("pick_place", ["physics.time_limit_s=0.2"])
    frozen = gc.get_freeze_count()
    gc.disable()  # the only collection is the one release_episode makes
    try:
        run_episode(loaded, 0, [Watch()])
        memory.release_episode()
        assert [r() for r in refs] == [None, None, None]
        assert gc.get_freeze_count() > 0  # the next collections skip what lives on
    finally:
        gc.enable()
        if not frozen:
            gc.unfreeze()
