"""JointLimiter: in-place arithmetic that equals the plain expressions bit for bit, and limits."""

from __future__ import annotations

import numpy as np
import pytest
from orchestrator.skills.joint_limiter import JointLimiter


class _Expressions:
    """The limiter's step as plain numpy expressions (what it computed before it worked in
    place): the specification the in-place version must match exactly."""

    def __init__(self, dt, v_max, a_max, j_max, gain=20.0):
        self.dt, self.v_max, self.a_max, self.j_max, self.gain = dt, v_max, a_max, j_max, gain
        n = len(v_max)
        self.position, self.velocity, self.acceleration = np.zeros(n), np.zeros(n), np.zeros(n)
        self._v_ref = np.zeros(n)
        self.limited_ticks = 0

    def step(self, q_ref, v_ref):
        dt = self.dt
        err = q_ref - 0.5 * dt * self._v_ref - self.position
        brake = np.sqrt(1.6 * self.a_max * np.abs(err))
        v_want = v_ref + np.sign(err) * np.minimum(self.gain * np.abs(err), brake)
        a_want = (v_want - self.velocity) / dt
        j_lim = self.j_max * dt
        a = np.clip(a_want, self.acceleration - j_lim, self.acceleration + j_lim)
        a = np.clip(a, -self.a_max, self.a_max)
        v = np.clip(self.velocity + a * dt, -self.v_max, self.v_max)
        a = (v - self.velocity) / dt
        if not np.array_equal(v, v_want):
            self.limited_ticks += 1
        self.position = self.position + 0.5 * (self.velocity + v) * dt
        self.velocity, self.acceleration, self._v_ref = v, a, v_ref.copy()


def test_in_place_step_equals_the_expressions_bit_for_bit():
    """A reference that jumps, reverses and rests (limits active and not): every tick's
    position, velocity, acceleration and the count of limited ticks are identical."""
    rng = np.random.default_rng(11)
    limits = (np.full(7, 2.0) * 0.85, np.linspace(8.0, 17.0, 7), np.linspace(3000, 6000, 7))
    fast, plain = JointLimiter(0.01, *limits), _Expressions(0.01, *limits)
    q_ref = np.zeros(7)
    for tick in range(600):
        v_ref = rng.normal(scale=3.0 if tick % 100 < 20 else 0.3, size=7)
        if tick % 150 > 120:
            v_ref[:] = 0.0
        q_ref = q_ref + v_ref * 0.01 + (rng.normal(scale=0.2, size=7) if tick == 300 else 0.0)
        fast.step(q_ref, v_ref)
        plain.step(q_ref, v_ref)
        assert np.array_equal(fast.position, plain.position), tick
        assert np.array_equal(fast.velocity, plain.velocity), tick
        assert np.array_equal(fast.acceleration, plain.acceleration), tick
    assert fast.limited_ticks == plain.limited_ticks
    assert 0 < fast.limited_ticks < 600


@pytest.mark.parametrize("limit", ["v_max", "a_max", "j_max"])
def test_limits_changed_after_construction_take_effect_both_ways(limit):
    """Setting a limit after construction (as tests/mutants.py does) bounds both signs (the
    velocity limit set far away unless it is the one tested: where it binds, it cuts the
    acceleration without regard to jerk)."""
    lim = JointLimiter(0.01, np.full(2, 100.0), np.full(2, 10.0), np.full(2, 500.0))
    setattr(lim, limit, np.full(2, {"v_max": 0.1, "a_max": 1.0, "j_max": 50.0}[limit]))
    peak_v, peak_a, peak_j = 0.0, 0.0, 0.0
    q = np.zeros(2)
    for tick in range(400):
        v_ref = np.array([5.0, -5.0]) * (1 if tick < 200 else -1)
        q = q + v_ref * 0.01
        a_before = lim.acceleration.copy()
        lim.step(q, v_ref)
        peak_v = max(peak_v, float(np.max(np.abs(lim.velocity))))
        peak_a = max(peak_a, float(np.max(np.abs(lim.acceleration))))
        peak_j = max(peak_j, float(np.max(np.abs(lim.acceleration - a_before))) / 0.01)
    bound = {"v_max": peak_v, "a_max": peak_a, "j_max": peak_j}[limit]
    assert bound <= getattr(lim, limit)[0] * (1 + 1e-9)
