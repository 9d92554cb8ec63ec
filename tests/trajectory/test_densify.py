import numpy as np
import pytest

from vilma.trajectory import Trajectory, increase_point_count, resample


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
