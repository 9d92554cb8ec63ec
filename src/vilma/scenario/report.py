"""PNG plots of a run, as the paper's figures: the path (Figure 12), speed (Figure 11), errors and effort; and a
planned run's planning cycles and perception."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon

from vilma.core.files import atomic_path
from vilma.plant3d.world import World

if TYPE_CHECKING:
    from vilma.scenario.result import RunResult
    from vilma.world.road_view import RoadView

MAX_POINTS = 20_000
"""Points drawn per line at most (every k-th sample of longer runs: a PNG cannot show more)."""
DPI = 110
"""Pixels per inch of the PNGs: a figure of 7 x 6.5 in is 770 x 715 px."""
LEGEND_COLUMNS = 3
"""Entries per row of a legend at most."""
PLAN_MODES = ("velocity", "follow", "stop", "evasive", "fallback")
"""A planning cycle's modes (:class:`~vilma.core.messages.LocalPlan`), bottom to top in the planning plot."""
MOT_SUMMARY = (("mota", "MOTA", ""), ("motp_m", "MOTP", " m"), ("detection_precision", "precision", ""),
               ("detection_recall", "recall", ""), ("identity_switches", "identity switches", ""))
"""The CLEAR MOT scores in the perception plot: scorecard key, name, unit."""
# The fixed margins [in] around the axes, sized for 10 pt tick labels of up to six characters and the axis labels,
# the 12 pt title and the rows of 9 pt legends (laid out once: no layout engine, no tight bounding box, which
# draw each figure two or three times).
LEFT, RIGHT, RIGHT_TWIN, BOTTOM = 0.9, 0.2, 0.8, 0.55
TITLE, LEGEND_ROW, GAP = 0.45, 0.2, 0.15


def agg_figure(width: float, height: float, dpi: float = DPI) -> Figure:
    """A ``width`` x ``height`` [in] figure on its own Agg canvas (no pyplot: a figure costs no global state)."""
    fig = Figure(figsize=(width, height), dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def write_png(fig: Figure, path: Path, dpi: float = DPI) -> Path:
    """Draw ``fig`` into the PNG ``path``, whole or not at all; returns ``path``."""
    with atomic_path(path) as tmp:
        # fast zlib: a third of the time of the default level for files a little larger
        fig.savefig(tmp, dpi=dpi, format="png", pil_kwargs={"compress_level": 1})
    return path


def plot_run(result: RunResult, out_dir: Path, speed_log: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """Write the plots (:data:`vilma.scenario.folder.PLOTS`, and a planned run's ``PLANNING_PLOTS``) into
    ``out_dir``; ``speed_log`` (times [s], speeds [m/s]) is overlaid on the speed."""
    for name, fig in figures(result, speed_log).items():
        write_png(fig, out_dir / name)


def figures(result: RunResult, speed_log: tuple[np.ndarray, np.ndarray] | None = None) -> dict[str, Figure]:
    """The plots of :func:`plot_run` by file name, laid out, not yet drawn: matplotlib figures without pyplot
    (no global state; each has its own Agg canvas). Every legend stands above its axes, so that it covers no
    curve."""
    log = result.log
    every = max(1, -(-len(log) // MAX_POINTS))

    def col(c: str) -> np.ndarray:
        return log.column(c)[::every]

    t, speed = col("t") - result.t_start, np.hypot(col("vx"), col("vy"))
    out = {"path.png": _path_figure(result, col), "speed.png": _speed_figure(result, t, speed, col, speed_log),
           "cross_track.png": _cross_track_figure(result, col), "effort.png": _effort_figure(result, t, speed, col)}
    if result.planning is not None:
        out.update({"planning.png": _planning_figure(result), "perception.png": _perception_figure(result)})
    return out


def _path_figure(result: RunResult, col) -> Figure:
    """The car's path over the reference, the world and the road (x, y [m])."""
    fig, (ax,) = _figure(7, 6.5, f"{result.scenario.name}: path")
    if result.path is not None:
        # wide and pale beneath the car's line, so that it shows where the car runs on it
        ax.plot(result.path.xy[:, 0], result.path.xy[:, 1], "-", color="tab:red", lw=4, alpha=0.35, zorder=2,
                solid_capstyle="round", label="reference path")
    ax.plot(col("x"), col("y"), "-", color="tab:blue", lw=1.2, zorder=3, label="car position")
    draw_world(ax, result.scenario.sim.world)
    if result.scenario.road is not None:
        from vilma.world.road_view import road_view  # the roads extra, which a road run has

        goal_t = result.metrics.get("time_to_goal_s")
        t_end = goal_t if goal_t is not None else float(result.log.column("t")[-1])
        draw_road(ax, road_view(result.scenario.road), t_end)
    ax.set_aspect("equal", adjustable="datalim")  # fills the axes: no blank band between title and plot
    ax.set(xlabel="x [m] (east)", ylabel="y [m] (north)")
    _legend(ax)
    return _layout(fig)


def _speed_figure(result: RunResult, t: np.ndarray, speed: np.ndarray, col,
                  speed_log: tuple[np.ndarray, np.ndarray] | None) -> Figure:
    """``speed`` [m/s] and the target over time ``t`` [s], and the recorded ``speed_log`` if any."""
    fig, (ax,) = _figure(8, 4.5, f"{result.scenario.name}: speed")
    ax.plot(t, speed, "-", color="tab:blue", label="vilma speed")
    ax.plot(t, col("target_speed"), "k--", lw=1.0, label="target")
    if speed_log is not None:
        ax.plot(speed_log[0], speed_log[1], "r.-", ms=3, lw=0.8, label="original (log)")
    ax.set(xlabel="time since start [s]", ylabel="speed [m/s]")
    ax.grid(alpha=0.3)
    _legend(ax)
    return _layout(fig)


def _cross_track_figure(result: RunResult, col) -> Figure:
    """The cross-track error [m] along the path [m]."""
    fig, (ax,) = _figure(8, 4, f"{result.scenario.name}: cross-track error")
    if result.path is not None:
        proj = result.path.project_track(np.column_stack([col("x"), col("y")]))
        ax.plot(proj[:, 0], proj[:, 1], "b-")
        ax.set(xlabel="distance along the path [m]")
    else:
        ax.text(0.5, 0.5, "no path in this task", ha="center", transform=ax.transAxes)
    ax.set(ylabel="cross-track error [m] (left +)")
    ax.grid(alpha=0.3)
    return _layout(fig)


def _effort_figure(result: RunResult, t: np.ndarray, speed: np.ndarray, col) -> Figure:
    """Steering [deg], the drive command, the applied forces [N] and the drive power [kW] over time ``t`` [s]."""
    fig, (a1, a2, a3) = _figure(8, 8.5, f"{result.scenario.name}: steering, drive command and forces", rows=3)
    a1.plot(t, np.degrees(col("steer")), "b-", label="applied")
    a1.plot(t, np.degrees(col("cmd_steer")), "k--", lw=0.8, label="commanded")
    a1.set(ylabel="steering [deg]")
    _legend(a1)
    d = result.scenario.driver
    unit = "power (original units)" if d.speed_controller == "vilma_pid" else "force [N]"
    a2.plot(t, col("cmd_drive"), "m-", label=f"{d.speed_controller} command")
    a2.set(ylabel=f"drive: {unit}")
    _legend(a2)
    a3.plot(t, col("drive_force"), "g-", label="drive force")
    a3.plot(t, -col("brake_force"), "r-", label="brake force (negative)")
    a3.set(xlabel="time since start [s]", ylabel="applied force [N]")
    kw = a3.twinx()
    kw.plot(t, col("drive_force") * speed / 1000.0, "k:", label="drive power (right axis)")
    kw.set(ylabel="drive power [kW]")
    _legend(a3, a3.get_lines() + kw.get_lines())
    for a in (a1, a2, a3):
        a.grid(alpha=0.3)
    return _layout(fig, [a1, a2, a3], twin=True)


def _planning_figure(result: RunResult) -> Figure:
    """Each planning cycle's wall time [ms], the fallbacks marked, and its mode over time [s]."""
    p = result.planning
    fig, (a1, a2) = _figure(8, 6, f"{result.scenario.name}: planning ({len(p.cycle_t)} cycles)", rows=2)
    t, ms, modes = np.asarray(p.cycle_t) - result.t_start, np.asarray(p.cycle_ms), np.asarray(p.modes, dtype=str)
    a1.plot(t, ms, ".-", color="tab:blue", ms=2, lw=0.8, label="planning time")
    fallback = modes == "fallback"
    a1.plot(t[fallback], ms[fallback], "x", color="tab:red", ms=7, ls="none",
            label=f"fallbacks ({int(fallback.sum())})")
    a1.set(ylabel="planning time [ms]")
    _legend(a1)
    names = [*PLAN_MODES, *sorted(set(modes.tolist()) - set(PLAN_MODES))]
    a2.step(t, [names.index(m) for m in modes], where="post", color="k", lw=1)
    a2.plot(t[fallback], np.full(fallback.sum(), names.index("fallback")), "x", color="tab:red", ms=7, ls="none")
    a2.set_yticks(range(len(names)), names)
    a2.set(xlabel="time since start [s]", ylabel="mode", ylim=(-0.5, len(names) - 0.5))
    for a in (a1, a2):
        a.grid(alpha=0.3)
    return _layout(fig, [a1, a2])


def _perception_figure(result: RunResult) -> Figure:
    """The number of tracks after each scan over time [s], and the CLEAR MOT summary of the scorecard."""
    p, m = result.planning, result.metrics
    fig, (ax,) = _figure(8, 4.5, f"{result.scenario.name}: perception ({m.get('perception', 'unknown')})")
    ax.step(np.asarray(p.scan_t) - result.t_start, p.tracks, where="post", color="tab:blue", label="tracks")
    scores = [Line2D([], [], ls="none", label=f"{name} {_score(m.get(key), unit)}")
              for key, name, unit in MOT_SUMMARY]
    ax.set(xlabel="time since start [s]", ylabel="tracks")
    ax.yaxis.get_major_locator().set_params(integer=True)
    ax.grid(alpha=0.3)
    _legend(ax, ax.get_lines() + scores)
    return _layout(fig)


def _score(value, unit: str) -> str:
    """A score as the legend shows it (``n/a``: not in the scorecard, or undefined)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    return f"{value:.3g}{unit}"


def _figure(width: float, height: float, title: str, rows: int = 1) -> tuple[Figure, list[Axes]]:
    """A ``width`` x ``height`` [in] figure on its own Agg canvas, titled, with ``rows`` axes stacked sharing x."""
    fig = agg_figure(width, height)
    fig.suptitle(title, y=1 - 0.1 / height, va="top")  # 0.1 in below the top edge
    return fig, list(fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0])


def _layout(fig: Figure, stacked: list[Axes] | None = None, twin: bool = False) -> Figure:
    """``fig`` with its ``stacked`` axes (default: its one) placed at the fixed margins, top to bottom, with room
    above each for its legend's rows (``twin``: and on the right for a twin axis's labels)."""
    width, height = fig.get_size_inches()
    stacked = stacked or fig.axes
    above = [(TITLE if i == 0 else GAP) + _legend_rows(ax) * LEGEND_ROW for i, ax in enumerate(stacked)]
    h = (height - BOTTOM - sum(above)) / len(stacked)  # each axes' height [in]
    w = width - LEFT - (RIGHT_TWIN if twin else RIGHT)
    top = height
    for ax, room in zip(stacked, above, strict=True):
        top -= room + h
        ax.set_position((LEFT / width, top / height, w / width, h / height))  # a twin follows its axes
    return fig


def _legend_rows(ax: Axes) -> int:
    """The rows of ``ax``'s legend (0 without one)."""
    legend = ax.get_legend()
    return 0 if legend is None else -(-len(legend.texts) // LEGEND_COLUMNS)


def draw_world(ax: Axes, world: World) -> None:
    """The footprints of ``world``'s boxes, ramps and bumps, and its cones as markers, on ``ax`` (x, y [m])."""
    kinds = (
        ("boxes", "k", [(b.pos[:2], b.yaw, b.size[0], b.size[1], b.rgba) for b in world.boxes]),
        ("ramps", "0.4", [(_along(r.start, r.yaw, r.length + r.top / 2), r.yaw, r.length + r.top / 2, r.width / 2,
                           (0.6, 0.6, 0.6, 0.5)) for r in world.ramps]),
        ("bumps", "0.2", [(b.pos, b.yaw, b.length / 2, b.width / 2, (0.95, 0.8, 0.1, 0.8)) for b in world.bumps]),
    )
    for label, edge, parts in kinds:
        for i, (centre, yaw, half_along, half_across, rgba) in enumerate(parts):
            ax.add_patch(Polygon(footprint(centre, yaw, half_along, half_across), closed=True, facecolor=rgba,
                                 edgecolor=edge, lw=0.8, zorder=1, label=None if i else label))
    for b, name in zip(world.boxes, world.obstacle_names(), strict=False):  # the boxes' names come first
        ax.annotate(name, b.pos[:2], xytext=(0, 8), textcoords="offset points", ha="center", fontsize=8, zorder=4)
    if world.cones:
        xy = np.array([c.pos for c in world.cones])
        ax.plot(xy[:, 0], xy[:, 1], "^", color=world.cones[0].rgba, mec="k", mew=0.5, ms=7, ls="none", zorder=4,
                label="cones")


def draw_road(ax: Axes, view: RoadView, t: float) -> None:
    """On ``ax`` (x, y [m]) beneath the car's line: ``view``'s lanelets (surface lightly filled, boundaries as
    lines, dashed where the markings are), its goal region, the obstacles' trajectories (faint) and their
    footprints at sim time ``t`` [s] (the static ones always)."""
    for i, la in enumerate(view.lanelets):
        ax.add_patch(Polygon(la.surface, closed=True, facecolor="0.88", edgecolor="none", zorder=0,
                             label=None if i else "road"))
        for line, dashed in ((la.left, la.left_dashed), (la.right, la.right_dashed)):
            ax.plot(line[:, 0], line[:, 1], "--" if dashed else "-", color="0.45", lw=0.7, zorder=0.5)
    for i, outline in enumerate(view.goal):
        ax.add_patch(Polygon(outline, closed=True, facecolor=(0.1, 0.7, 0.2, 0.25), edgecolor="tab:green", lw=1,
                             zorder=1, label=None if i else "goal region"))
    for i, xy in enumerate(view.paths()):
        ax.plot(xy[:, 0], xy[:, 1], "-", color="tab:orange", lw=0.8, alpha=0.4, zorder=1,
                label=None if i else "traffic paths")
    for i, b in enumerate(view.at(t)):
        ax.add_patch(Polygon(b.footprint, closed=True, facecolor="tab:gray" if b.static else "tab:orange",
                             edgecolor="k", lw=0.6, alpha=0.8, zorder=2, label=None if i else f"traffic at {t:.1f} s"))


def footprint(centre, yaw: float, half_along: float, half_across: float) -> np.ndarray:
    """Corners (4, 2) [m] of a rectangle centred at ``centre`` (x, y) [m], its long side along ``yaw`` [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    local = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * (half_along, half_across)
    return np.asarray(centre, float) + local @ np.array([[c, s], [-s, c]])


def _along(start, yaw: float, distance: float) -> tuple[float, float]:
    """The point ``distance`` [m] from ``start`` (x, y) [m] in direction ``yaw`` [rad]."""
    return start[0] + distance * math.cos(yaw), start[1] + distance * math.sin(yaw)


def _legend(ax: Axes, handles=None) -> None:
    """A legend in a row above ``ax`` (outside it: it covers no curve)."""
    handles = handles if handles is not None else ax.get_legend_handles_labels()[0]
    ax.legend(handles=handles, loc="lower left", bbox_to_anchor=(0, 1.01), ncols=min(len(handles), LEGEND_COLUMNS),
              frameon=False, borderaxespad=0, fontsize=9)
