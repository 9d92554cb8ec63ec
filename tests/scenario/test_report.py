"""The run's plots: the world's obstacles on the path, the reference visible under the car, legends off the
curves."""

from __future__ import annotations

import math

import numpy as np
import pytest
from matplotlib.patches import Polygon

from vilma.app.batch import find_scenario
from vilma.scenario.drive_log import COLUMNS, DriveLog
from vilma.scenario.report import DPI, figures, footprint, plot_run
from vilma.scenario.result import RunResult
from vilma.scenario.spec import load_scenario


@pytest.fixture(scope="module")
def result() -> RunResult:
    """The 3D obstacle course driven exactly along its reference path at the task's speed."""
    sc = load_scenario(find_scenario("course_3d_obstacles"))
    path = sc.reference_path()
    rows = np.zeros((len(path), len(COLUMNS)))
    ds = np.hypot(*np.diff(path.xy, axis=0).T)
    rows[:, COLUMNS.index("t")] = np.concatenate([[0.0], np.cumsum(ds)]) / sc.task.speed
    rows[:, COLUMNS.index("x")], rows[:, COLUMNS.index("y")] = path.xy.T
    rows[:, COLUMNS.index("vx")] = rows[:, COLUMNS.index("target_speed")] = sc.task.speed
    log = DriveLog()
    log.extend(rows)
    return RunResult(sc, {}, [], log, path, 0.0)


def test_a_footprint_turned_a_quarter_swaps_its_sides():
    corners = footprint((1.0, 2.0), math.pi / 2, 2.0, 1.0)  # 4 m long, pointing north
    assert sorted(map(tuple, np.round(corners, 12) + 0.0)) == [(0, 0), (0, 4), (2, 0), (2, 4)]


def test_the_path_plot_draws_every_obstacle_where_the_world_has_it(result):
    fig = figures(result)["path.png"]
    ax = fig.axes[0]
    world = result.scenario.sim.world
    shapes = [p.get_xy()[:4] for p in ax.patches if isinstance(p, Polygon)]
    assert len(shapes) == len(world.boxes) + len(world.ramps) + len(world.bumps)
    crate = world.boxes[0]
    assert any(np.allclose(s, footprint(crate.pos[:2], crate.yaw, crate.size[0], crate.size[1])) for s in shapes)
    ramp = world.ramps[0]  # up slope, top, down slope: 2 length + top long, from its start
    end = np.add(ramp.start, (2 * ramp.length + ramp.top) * np.array([math.cos(ramp.yaw), math.sin(ramp.yaw)]))
    ramp_shape = next(s for s in shapes if np.isclose(np.hypot(*(s[0] - s[3])), ramp.width))
    assert np.allclose(ramp_shape.mean(axis=0), (np.asarray(ramp.start) + end) / 2)
    cones = next(line for line in ax.get_lines() if line.get_label() == "cones")
    np.testing.assert_allclose(np.column_stack(cones.get_data()), [c.pos for c in world.cones])


def test_the_reference_path_is_drawn_wider_beneath_the_cars_line(result):
    lines = {line.get_label(): line for line in figures(result)["path.png"].axes[0].get_lines()}
    ref, car = lines["reference path"], lines["car position"]
    np.testing.assert_array_equal(ref.get_xydata(), car.get_xydata())  # the car drove exactly on it
    assert ref.get_zorder() < car.get_zorder() and ref.get_linewidth() > 2 * car.get_linewidth()


def test_no_legend_covers_any_axes(result):
    for name, fig in figures(result, speed_log=(np.array([0.0, 5.0]), np.array([0.0, 8.0]))).items():
        fig.canvas.draw()
        legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
        assert legends or name == "cross_track.png"
        for legend in legends:
            box = legend.get_window_extent()
            for ax in fig.axes:
                assert not box.overlaps(ax.get_window_extent()), f"{name}: a legend covers an axes"
        # every labelled curve is in a legend, the twin axis's too
        drawn = {a.get_label() for ax in fig.axes for a in ax.get_lines() + ax.patches}
        drawn = {label for label in drawn if label and not label.startswith("_")}
        assert drawn == {t.get_text() for legend in legends for t in legend.get_texts()}


def test_plot_run_writes_the_four_pngs(result, tmp_path):
    plot_run(result, tmp_path)
    for name in ("path.png", "speed.png", "cross_track.png", "effort.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def road_result() -> RunResult:
    """The CommonRoad tutorial driven in 2 s from its path's start to its end, the goal not reached."""
    sc = load_scenario(find_scenario("commonroad_tutorial"))
    path = sc.reference_path()
    rows = np.zeros((2, len(COLUMNS)))
    rows[:, COLUMNS.index("t")] = (0.0, 2.0)
    rows[:, COLUMNS.index("x")], rows[:, COLUMNS.index("y")] = path.xy[[0, -1]].T
    log = DriveLog()
    log.extend(rows)
    return RunResult(sc, {"time_to_goal_s": None}, [], log, path, 0.0)


def test_a_road_run_draws_the_lanelets_goal_and_traffic_beneath_the_car(road_result):
    from tests.world.test_commonroad import TUTORIAL, _lanelets

    ax = figures(road_result)["path.png"].axes[0]
    drawn = [line.get_xydata() for line in ax.get_lines() if line.get_linestyle() == "-" and line.get_zorder() < 1]
    for left, right in _lanelets(TUTORIAL).values():
        assert any(np.array_equal(d, left) for d in drawn) and any(np.array_equal(d, right) for d in drawn)
    car = next(line for line in ax.get_lines() if line.get_label() == "car position")
    road = [p for p in ax.patches if p.get_label() == "road" or p.get_zorder() == 0]
    assert len(road) == len(_lanelets(TUTORIAL)) and all(p.get_zorder() < car.get_zorder() for p in road)
    # the tutorial's one car, 23 m/s from (2.25, 3.5) heading east, is drawn where it is at the run's end (2 s)
    traffic = next(p for p in ax.patches if str(p.get_label()).startswith("traffic at"))
    assert traffic.get_label() == "traffic at 2.0 s"
    assert traffic.get_xy()[:4].mean(axis=0)[0] == pytest.approx(2.25 + 23.0 * 2.0, abs=1.0)


def _png_size(data: bytes) -> tuple[int, int]:
    """Width and height [px] of a PNG: its IHDR chunk's first two 4-byte big-endian fields (PNG spec 11.2.2)."""
    assert data[12:16] == b"IHDR"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_each_png_is_its_figure_at_the_plots_dpi(result, tmp_path):
    plot_run(result, tmp_path)
    for name, fig in figures(result).items():  # no margin trimmed or added: the size the figure was made
        width, height = fig.get_size_inches()
        assert _png_size((tmp_path / name).read_bytes()) == (round(width * DPI), round(height * DPI)), name
    assert _png_size((tmp_path / "path.png").read_bytes()) == (770, 715)  # 7 x 6.5 in at 110 px/in


@pytest.mark.parametrize("which", ["result", "road_result"])
def test_every_label_title_and_legend_is_inside_the_image_and_apart(which, request):
    """The fixed margins hold the tick labels, axis labels, the title and two-row legends (the obstacle course
    and the road both have six entries on the path)."""
    run = request.getfixturevalue(which)
    for name, fig in figures(run, speed_log=(np.array([0.0, 5.0]), np.array([0.0, 8.0]))).items():
        renderer = fig.canvas.get_renderer()
        fig.canvas.draw()
        page = fig.bbox
        title = next(t for t in fig.texts if t.get_text() == fig.get_suptitle()).get_window_extent(renderer)
        for ax in fig.axes:
            box = ax.get_tightbbox(renderer)  # its ticks, tick labels, axis labels and legend
            assert page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0 and box.y1 <= page.y1, name
            legend = ax.get_legend()
            if legend is not None:
                assert not legend.get_window_extent(renderer).overlaps(title), f"{name}: a legend covers the title"
