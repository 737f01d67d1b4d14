"""The wrist sensor's noise is a function of the physics step a reading is taken at, not of the
readings before it: who reads the sensor, and when (a recorder, a status poll, a guard on in
one state only), changes neither the readings the run's guards and skills get nor the episode.
Both paths (world/_native.c's `FtNoise` and its Python twin) are held to it."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from orchestrator.engine.context import Context
from orchestrator.engine.executor import Executor
from orchestrator.engine.result import RunResult
from orchestrator.engine.runner import Observer, drive, new_run
from orchestrator.language.load import load_scenario
from orchestrator.recording import RerunRecorder
from orchestrator.world.native import PURE_PYTHON_ENV, compiled
from orchestrator.world.random_streams import stream
from orchestrator.world.realism import WristForceNoise

DT = 0.002
PATHS = [
    pytest.param("compiled", marks=pytest.mark.skipif(compiled is None, reason="not built")),
    "python",
]


@pytest.fixture(params=PATHS)
def path(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run the test on the compiled path, then on the pure-Python one."""
    if request.param == "python":
        monkeypatch.setenv(PURE_PYTHON_ENV, "1")
    else:
        monkeypatch.delenv(PURE_PYTHON_ENV, raising=False)
    return str(request.param)


def _clock(n: int) -> list[float]:
    """The step function's time at steps 0..n [s]: a sum of DT, as `StepClock` keeps it."""
    t, out = 0.0, [0.0]
    for _ in range(n):
        t += DT
        out.append(t)
    return out


def _noise(path: str) -> WristForceNoise:
    noise = WristForceNoise(0.3, 0.05, seed=11, dt=DT)
    assert (noise.compiled is not None) == (path == "compiled")
    return noise


def test_reading_every_step_is_six_draws_a_step_and_a_walk_of_the_time_stepped(path: str):
    """The stream a guard reading every step sees: step k's white noise and bias-walk step are
    the k-th six samples of the episode's generator, the walk `drift * sqrt(t_k - t_(k-1))`
    (none at the first step): the definition the runs have always had, bit for bit."""
    n = 1200  # > 2 blocks of 512 steps
    times = _clock(n)
    noise = _noise(path)
    draws = stream(11, "wrist_noise").standard_normal(6 * 1536).reshape(-1, 6)
    bias = [0.0, 0.0, 0.0]
    for k in range(1, n + 1):
        d = draws[k - 1].tolist()
        walk = 0.05 * math.sqrt(times[k] - times[k - 1] if k > 1 else 0.0)
        bias = [bias[i] + walk * d[3 + i] for i in range(3)]
        expected = tuple(bias[i] + 0.3 * d[i] for i in range(3))
        assert noise.offset(times[k]) == expected, f"step {k}"
        assert noise.offset(times[k]) == expected  # a second reading at the same step
    assert noise.bias == bias


def test_a_reading_gets_its_steps_noise_whatever_was_read_before(path: str):
    """Readings at a random few steps (t = 0 among them, steps skipped by the hundred) get what
    the readings of every step get at those steps; the drift walked ends the same."""
    n = 3000
    times = _clock(n)
    every = _noise(path)
    full = [every.offset(t) for t in times]
    rng = np.random.default_rng(2)
    steps = sorted({0, 1, *rng.choice(n + 1, 40, replace=False).tolist(), n})
    sparse = _noise(path)
    for k in steps:
        assert sparse.offset(times[k]) == full[k], f"step {k}"
    assert sparse.bias == every.bias
    assert full[0] == full[1]  # before the first step: the first step's sample


class _WristReader:
    """An observer that reads the wrist force at every control tick (a status poll)."""

    def __init__(self) -> None:
        self.readings = 0

    def on_start(self, ctx: Context, executor: Executor) -> None:
        ctx.wrist_force()  # at t = 0, before the first physics step
        self.readings += 1

    def on_tick(self, ctx: Context, executor: Executor) -> None:
        ctx.wrist_force()
        self.readings += 1

    def on_end(self, ctx: Context, executor: Executor, result: RunResult) -> None:
        pass


def _episode(name: str, sets: list[str], observers: list[Observer]) -> tuple[RunResult, bytes]:
    run = new_run(load_scenario(name, sets), 0)
    result = drive(run, observers)
    assert result is not None
    data = run.episode.ctx.data
    return result, data.qpos.tobytes() + data.qvel.tobytes()


def _assert_same_episode(a: tuple[RunResult, bytes], b: tuple[RunResult, bytes]) -> None:
    (ra, qa), (rb, qb) = a, b
    assert (rb.outcome, rb.reason) == (ra.outcome, ra.reason)  # the guard's value, every bit
    assert rb.metrics == ra.metrics
    assert rb.transitions == ra.transitions
    assert qb == qa, "the final joint state differs"


def test_an_observer_reading_the_wrist_force_does_not_change_the_episode(path: str):
    """pick_place with a 3 N force limit: the hand's noisy zero trips it within the first
    steps; the guard's reading must not depend on an observer's readings at t = 0 and at every
    tick (it did when the stream drew a sample per new reading instant)."""
    sets = ["guards.contact_force.max_n=3"]
    quiet = _episode("pick_place", sets, [])
    reader = _WristReader()
    polled = _episode("pick_place", sets, [reader])
    assert quiet[0].outcome == "aborted" and quiet[0].reason is not None
    assert quiet[0].reason["guard"] == "contact_force"
    assert reader.readings > 2
    _assert_same_episode(quiet, polled)


@pytest.mark.slow
def test_a_recording_and_a_status_poll_do_not_change_the_surgical_complication(tmp_path: Path):
    """The case `batch --record failures` re-runs: the aborted surgical_complication with the
    Rerun recorder and a reader of the wrist force at t = 0 and every tick (through the stop
    after the abort too, when no guard reads it) against the run without them (the force
    controls the trace here: before, the abort came at 9.73 N instead of 9.50 N)."""
    quiet = _episode("surgical_complication", [], [])
    watched = _episode(
        "surgical_complication", [], [RerunRecorder(path=tmp_path / "r.rrd"), _WristReader()]
    )
    assert quiet[0].outcome == "aborted"
    _assert_same_episode(quiet, watched)
