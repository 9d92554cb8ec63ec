import numpy as np
import pytest

from vilma.trajectory import Trajectory, densify, increase_point_count, resample
from vilma.trajectory.points import MAX_DENSIFY, MAX_POINTS


def test_generate_points_inserts_midpoints():
    t = Trajectory.from_points([(0, 0), (2, 0), (2, 4)], speed=[1, 3, 5])
    d = increase_point_count(t)
    assert np.array_equal(d.xy, [(0, 0), (1, 0), (2, 0), (2, 2), (2, 4)])
    assert np.array_equal(d.speed, [1, 2, 3, 4, 5])
    assert len(increase_point_count(d)) == 2 * len(d) - 1
    with pytest.raises(ValueError, match="2 points"):
        increase_point_count(Trajectory.from_points([(0, 0)]))


def test_resample_is_uniform_and_keeps_the_end():
    t = Trajectory.from_points([(0, 0), (10, 0), (10, 5)])
    r = resample(t, 1.0)
    assert np.allclose(np.diff(r.s), 1.0)
    assert np.array_equal(r.xy[-1], (10, 5)) and len(r) == 16
    with pytest.raises(ValueError, match="spacing"):
        resample(t, 0.0)


def test_densify_stops_at_the_point_limit_before_any_work():
    two = Trajectory.from_points([(0, 0), (1, 0)])
    assert len(densify(two, 3)) == 9  # (n - 1) 2^times + 1
    assert len(densify(two, MAX_DENSIFY)) == 2**MAX_DENSIFY + 1 <= MAX_POINTS < 2 ** (MAX_DENSIFY + 1) + 1
    three = Trajectory.from_points([(0, 0), (1, 0), (2, 0)])
    for times in (MAX_DENSIFY, 10**9):
        with pytest.raises(ValueError, match=f"densifying 3 points {times} times makes more than {MAX_POINTS}"):
            densify(three, times)


def test_resample_stops_at_the_point_limit_and_says_what_spacing_fits():
    t = Trajectory.from_points([(0, 0), (10, 0)])
    with pytest.raises(ValueError, match=r"resampling 10\.0 m every 1e-12 m .* at least (\S+) m$") as e:
        resample(t, 1e-12)
    fits = float(str(e.value).split()[-2])
    assert fits >= 10 / (MAX_POINTS - 1) and len(resample(t, fits)) <= MAX_POINTS
