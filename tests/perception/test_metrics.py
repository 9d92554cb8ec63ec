"""CLEAR MOT by its definition (Bernardin & Stiefelhagen 2008): perfect tracks score MOTA 1 and MOTP 0, and a
hand-built sequence scores what the formulas give."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vilma.perception.metrics import MotFrame, clear_mot


def frame(truth: dict[int, tuple], tracks: dict[int, tuple]) -> MotFrame:
    """A frame of ``{id: (x, y[, vx, vy])}`` for the truth and the tracks."""

    def arrays(objs):
        rows = [(*v, 0.0, 0.0)[:4] for v in objs.values()]
        a = np.array(rows, float).reshape(-1, 4)
        return np.array(list(objs), np.int64), a[:, :2], a[:, 2:]

    return MotFrame(*arrays(truth), *arrays(tracks))


def test_perfect_tracks_score_mota_one_and_motp_zero():
    a, b = [(k, 0.0, 1.0, 0.0) for k in range(5)], [(0.0, 5 - k, 0.0, -1.0) for k in range(5)]
    frames = [frame({1: a[k], 2: b[k]}, {7: a[k], 9: b[k]}) for k in range(5)]
    s = clear_mot(frames, threshold=2.0)
    assert (s.mota, s.motp, s.precision, s.recall, s.id_switches) == (1.0, 0.0, 1.0, 1.0, 0)
    assert (s.objects, s.matches, s.position_rmse, s.velocity_rmse) == (10, 10, 0.0, 0.0)


def test_a_miss_a_false_positive_and_an_identity_switch_give_the_formulas_scores():
    """Two objects over four frames, 8 in all, every match 0.3 m off and 0.5 m/s off: one miss (object 2 in frame
    2), one false positive (track 30 far from all) and one switch (object 1 taken by track 11 from frame 3 on; not
    a second switch in frame 4). MOTA = 1 - (1 + 1 + 1) / 8, MOTP = 0.3 m, precision 7 / 8, recall 7 / 8."""
    frames = [
        frame({1: (0, 0), 2: (10, 0)}, {10: (0.3, 0, 0.5, 0), 20: (10, 0.3, 0, 0.5)}),
        frame({1: (1, 0), 2: (11, 0)}, {10: (1.3, 0, 0.5, 0), 30: (50, 50)}),
        frame({1: (2, 0), 2: (12, 0)}, {11: (2.3, 0, 0.5, 0), 20: (12, 0.3, 0, 0.5)}),
        frame({1: (3, 0), 2: (13, 0)}, {11: (3.3, 0, 0.5, 0), 20: (13, 0.3, 0, 0.5)}),
    ]
    s = clear_mot(frames, threshold=1.0)
    assert (s.objects, s.matches, s.misses, s.false_positives, s.id_switches) == (8, 7, 1, 1, 1)
    assert s.mota == pytest.approx(1 - 3 / 8) and s.motp == pytest.approx(0.3)
    assert s.precision == pytest.approx(7 / 8) and s.recall == pytest.approx(7 / 8)
    assert s.position_rmse == pytest.approx(0.3) and s.velocity_rmse == pytest.approx(0.5)


def test_a_match_is_kept_while_within_the_threshold_even_if_another_track_comes_nearer():
    """Bernardin & Stiefelhagen's rule: last frame's pair stays while valid, so no switch is counted, and the
    nearer track is a false positive."""
    frames = [frame({1: (0, 0)}, {5: (0.5, 0)}), frame({1: (0, 0)}, {5: (0.8, 0), 6: (0.1, 0)})]
    s = clear_mot(frames, threshold=1.0)
    assert (s.id_switches, s.false_positives, s.matches) == (0, 1, 2) and s.motp == pytest.approx(0.65)


def test_pairs_farther_than_the_threshold_are_a_miss_and_a_false_positive():
    s = clear_mot([frame({1: (0, 0)}, {5: (1.5, 0)})], threshold=1.0)
    assert (s.misses, s.false_positives, s.mota, s.precision, s.recall) == (1, 1, -1.0, 0.0, 0.0)
    assert math.isnan(s.motp) and math.isnan(s.position_rmse)


def test_no_objects_leaves_the_rates_undefined():
    s = clear_mot([frame({}, {})], threshold=1.0)
    assert s.objects == 0 and math.isnan(s.mota) and math.isnan(s.recall) and math.isnan(s.precision)


def test_bad_input_is_refused_in_one_line():
    with pytest.raises(ValueError, match="threshold must be a positive"):
        clear_mot([], threshold=0.0)
    bad = MotFrame(np.array([1, 2]), np.zeros((1, 2)), np.zeros((1, 2)), np.zeros(0), np.zeros((0, 2)),
                   np.zeros((0, 2)))
    with pytest.raises(ValueError, match="frame 0: give as many positions"):
        clear_mot([bad], threshold=1.0)
