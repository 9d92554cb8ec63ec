"""The paper and vilma side by side: the bundled paper scenarios and the comparison set, one table.

Runs the paper's Figure 11 speed steps and Figure 12 path with the original's
controllers, then the same tasks (and the paper-style course) with vilma's
controllers, writes every run's files, and tabulates the figures next to the
original program's (measured on its logs with the same code as vilma's runs).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from rich.table import Table
from rich.text import Text

from vilma.app import batch
from vilma.scenario.metrics import step_response
from vilma.scenario.result import RunResult
from vilma.trajectory import load_speed_log


@dataclass(frozen=True, slots=True)
class Group:
    """One task of the table: its title, the original's figures, and the bundled scenarios that drive it."""

    title: str
    original: str | None
    """The original's speed log (bundled data) for a speed step, else None."""
    claim: str | None
    """The lateral error the paper claims for this task (it gives no figure)."""
    scenarios: tuple[str, ...]


GROUPS = tuple(
    [Group(f"Fig. 11: rest to {v} m/s, straight", f"SpeedLog{v}.txt", None,
           (f"paper_fig11_speed_{v}", f"pi_ff_speed_{v}")) for v in (5, 10, 15)]
    + [Group("Fig. 12: recorded curve at 5 m/s", None, "centimetres",
             ("paper_fig12_path", "fig12_path_stanley", "fig12_path_pure_pursuit")),
       Group("Course at 30 km/h", None, None, ("course_30kmh_vilma_heading", "course_30kmh_pure_pursuit",
                                               "course_30kmh_stanley", "course_30kmh_lqr", "course_30kmh_ekf"))])
"""The demo's tasks, in table order."""

HEADINGS = ("t90 [s]", "overshoot [%]", "lat RMS [m]", "lat max [m]", "done", "pass")


def scenario_names() -> list[str]:
    """Every scenario the demo runs, in order."""
    return [name for g in GROUPS for name in g.scenarios]


def controllers(r: RunResult) -> str:
    """``speed + path`` controllers of a run, with the pose source when it is not the exact pose."""
    d = r.scenario.driver
    text = d.speed_controller if r.scenario.task.kind == "speed" else f"{d.speed_controller} + {d.path_controller}"
    return text + (f" ({d.pose_source} pose)" if d.pose_source != "truth" else "")


def comparison_table(results: dict[str, RunResult]) -> Table:
    """The original's figures and each run's, task by task."""
    table = Table(title="vilma demo: the paper's figures and vilma's, side by side")
    table.add_column("task")
    table.add_column("who")
    for h in HEADINGS:
        table.add_column(Text(h), justify="right")
    for g in GROUPS:
        first = True
        if g.original is not None:
            t, v = load_speed_log(batch.BUNDLED / "data" / g.original)
            target = results[g.scenarios[0]].scenario.task.speed
            s = step_response(t, v, target, 0.02, 5.0)
            table.add_row(g.title, "original program (log)", _f(s.get("speed_rise_time_90_s")),
                          _f(s.get("speed_overshoot_pct")), "-", "-", "-", "-")
            first = False
        if g.claim is not None:
            table.add_row(g.title, "original program (paper)", "-", "-", g.claim, "-", "-", "-")
            first = False
        for name in g.scenarios:
            r = results[name]
            m = r.metrics
            table.add_row(g.title if first else "", controllers(r), _f(m["speed_rise_time_90_s"]),
                          _f(m["speed_overshoot_pct"]), _f(m["lateral_error_rms_m"]), _f(m["lateral_error_max_m"]),
                          "yes" if m["completed"] else "no", "yes" if r.passed else "NO")
            first = False
        table.add_section()
    return table


def _f(v) -> str:
    return "-" if v is None else f"{v:.3g}"


def out_root(out: Path | None) -> Path:
    """Where the demo's runs go: ``out``, else ``runs/demo-<timestamp>``."""
    return out or Path("runs") / f"demo-{datetime.now().strftime('%Y%m%d-%H%M%S')}"
