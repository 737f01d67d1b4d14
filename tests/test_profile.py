"""The jerk-limited 1-D profile every straight move, retract, joint move and contact trace
is timed by: within its limits, time-optimal, and able to start from a moving state."""

from __future__ import annotations

import numpy as np
import pytest
from orchestrator.skills.trajectory import Profile


def _sampled(profile: Profile, dt: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(0.0, profile.duration + dt, dt)
    s = np.array([profile.progress(x)[0] for x in t]) * profile.distance
    return t, s


@pytest.mark.parametrize(
    ("distance", "v_max", "a_max", "j_max"),
    [(0.4, 1.0, 4.0, 100.0), (0.02, 0.5, 4.0, 100.0), (1.2, 0.3, 2.0, 20.0)],
)
def test_a_profile_stays_within_its_velocity_acceleration_and_jerk_limits(
    distance, v_max, a_max, j_max
):
    prof = Profile(distance, v_max, a_max, j_max)
    dt = 1e-4
    _, s = _sampled(prof, dt)
    v = np.diff(s) / dt
    a = np.diff(v) / dt
    j = np.diff(a) / dt
    assert s[0] == pytest.approx(0.0, abs=1e-12)
    assert s[-1] == pytest.approx(distance, abs=1e-9)
    assert np.max(np.abs(v)) <= v_max * 1.001
    assert np.max(np.abs(a)) <= a_max * 1.01
    # finite differences of a piecewise-cubic: jerk within its limit up to the grid's error
    assert np.percentile(np.abs(j), 99) <= j_max * 1.05


def test_a_long_move_cruises_at_its_speed_limit_and_takes_the_time_optimal_duration():
    distance, v_max, a_max, j_max = 1.0, 0.5, 4.0, 100.0
    prof = Profile(distance, v_max, a_max, j_max)
    # rest -> v_max with a jerk-limited ramp takes v/a + a/j; the cruise covers the rest
    ramp = v_max / a_max + a_max / j_max
    expected = distance / v_max + ramp
    assert prof.duration == pytest.approx(expected, rel=1e-6)
    assert prof.progress(prof.duration / 2)[1] * distance == pytest.approx(v_max, rel=1e-6)


def test_a_profile_started_while_moving_continues_from_that_velocity_without_a_jump():
    prof = Profile(0.3, 1.0, 4.0, 100.0, v0=0.6, a0=0.0)
    dt = 1e-4
    s1, v1 = prof.progress(dt)
    assert v1 * prof.distance == pytest.approx(0.6, abs=0.02)
    assert s1 * prof.distance == pytest.approx(0.6 * dt, rel=0.05)
    assert prof.progress(prof.duration) == pytest.approx((1.0, 0.0), abs=1e-9)
    # shorter than from rest: it is already on its way
    assert prof.duration < Profile(0.3, 1.0, 4.0, 100.0).duration


def test_a_zero_length_profile_is_done_at_once_and_impossible_limits_are_refused():
    assert Profile(0.0, 1.0, 4.0).duration == 0.0
    assert Profile(0.0, 1.0, 4.0).progress(0.0) == (1.0, 0.0)
    with pytest.raises(ValueError, match="no jerk-limited profile"):
        Profile(0.1, 0.0, 4.0)
