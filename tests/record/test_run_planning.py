"""A planned ``vilma run``'s recording carries its tracks and plans as the live recorder writes them, and its plots
and ``vilma report``'s show the planning cycles and the perception. The bundled ``planned_parked_car``: a car of
4.5 m x 2 m parked in the ego's lane at (80, 0) on CommonRoad's straight tutorial road, ``truth`` perception."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from vilma.app.batch import BUNDLED
from vilma.app.cli import main
from vilma.control.local_planning import RESYNC_OFFSET
from vilma.record.reader import RecordingError, read_recording
from vilma.record.report import report
from vilma.record.run import record_run
from vilma.scenario import load_scenario
from vilma.scenario.drive_log import COLUMNS
from vilma.scenario.folder import PLANNING_PLOTS, PLOTS
from vilma.scenario.report import figures
from vilma.scenario.result import RunObserver

PARKED = (80.0, 0.0)
"""Where the parked car of planned_parked_car stands [m]."""


class Arrivals(RunObserver):
    """The sim time of the log's last row [s] when each plan reached the observers, and the plan's stamp [ns]."""

    def __init__(self) -> None:
        self.plans: list[tuple[float, int]] = []

    def started(self, sim, log) -> None:
        self.log = log

    def add_captures(self, captures) -> None:
        self.plans += [(float(self.log.rows[len(self.log) - 1, 0]), m.stamp_ns) for n, m in captures
                       if n == "planning/plan"]


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """The run's result, its folder and what reached an observer as it went."""
    out, seen = tmp_path_factory.mktemp("planned"), Arrivals()
    return record_run(load_scenario(BUNDLED / "planned_parked_car.yaml"), out, observers=[seen]), out, seen


def _topics(path: Path) -> dict[str, list[tuple[str, int, dict]]]:
    """Each topic's (schema, log time [ns], JSON payload) read with the mcap package's reader, JSON topics only."""
    out: dict[str, list] = {}
    with path.open("rb") as f:
        for schema, channel, msg in make_reader(f).iter_messages():
            if channel.message_encoding == "json":
                out.setdefault(channel.topic.removeprefix("vilma/vilma/"), []).append(
                    (schema.name, msg.log_time, json.loads(msg.data)))
    return out


def test_the_recording_holds_each_scans_tracks_near_the_parked_car(planned):
    _, out, _ = planned
    topics = _topics(out / "run.mcap")
    tracks, scans = topics["perception/objects"], topics["objects"]
    # a track list for each scan of the objects sensor, on the run's clock: the scan's stamp
    assert [t for _, t, _ in tracks] == [t for _, t, _ in scans]
    assert all(s == "vilma.TrackList" and d["stamp_ns"] == t and d["source"] == "truth" for s, t, d in tracks)
    seen = [o for _, _, d in tracks for o in d["objects"]]
    assert seen, "the parked car was never perceived"
    assert all(np.hypot(o["x"] - PARKED[0], o["y"] - PARKED[1]) < 1.0 for o in seen)
    drawn = topics["perception/objects/scene"]
    assert [t for _, t, _ in drawn] == [t for _, t, _ in tracks]
    assert {s for s, _, _ in drawn} == {"foxglove.SceneUpdate"}
    assert [sorted(e["id"] for e in d["entities"]) for _, _, d in drawn] == [
        sorted(f"track/{o['id']}" for o in d["objects"]) for _, _, d in tracks]


def test_the_recording_holds_each_cycles_plan_from_where_the_car_was(planned):
    result, out, _ = planned
    plans, m = _topics(out / "run.mcap")["planning/plan"], result.metrics
    assert len(plans) == m["planning_cycles"] and {s for s, _, _ in plans} == {"vilma.LocalPlan"}
    period = result.scenario.planner.replan_period
    # a cycle at the start of the task, then one each replan period, stamped on the run's clock
    assert np.allclose(np.array([t for _, t, _ in plans]) * 1e-9, result.t_start + period * np.arange(len(plans)),
                       rtol=0, atol=1e-9)
    rows, c = result.log.rows[:len(result.log)], COLUMNS.index
    at = {round(t * 1e9): i for i, t in enumerate(rows[:, 0])}
    for _, t, d in plans:
        row = rows[at[t]]
        # a plan starts from the car's estimated position, its lateral offset the driven plan's while that is near
        assert np.hypot(d["x"][0] - row[c("est_x")], d["y"][0] - row[c("est_y")]) <= RESYNC_OFFSET
        assert d["planning_ms"] > 0
    ms = [d["planning_ms"] for _, _, d in plans]
    assert np.isclose(np.mean(ms), m["planning_ms_mean"]) and np.isclose(max(ms), m["planning_ms_max"])
    assert sum(d["mode"] == "fallback" for _, _, d in plans) == m["planner_fallbacks"]
    drawn = _topics(out / "run.mcap")["planning/plan/scene"]
    assert [t for _, t, _ in drawn] == [t for _, t, _ in plans]
    assert all("plan/chosen" in {e["id"] for e in d["entities"]} for _, _, d in drawn)


def test_plans_reach_the_observers_in_the_period_they_are_made_not_kept(planned):
    result, _, seen = planned
    period = result.scenario.planner.replan_period
    assert len(seen.plans) == result.metrics["planning_cycles"]
    assert all(0 <= t - stamp * 1e-9 < period for t, stamp in seen.plans)


def test_the_runs_plots_show_each_planning_cycle_and_scan(planned):
    result, out, _ = planned
    assert all((out / p).stat().st_size > 0 for p in (*PLOTS, *PLANNING_PLOTS))
    figs = figures(result)
    cycles = figs["planning.png"].axes[0].get_lines()[0]
    assert len(cycles.get_xdata()) == result.metrics["planning_cycles"]
    assert np.allclose(cycles.get_ydata(), result.planning.cycle_ms)
    scans = figs["perception.png"].axes[0].get_lines()[0]
    assert len(scans.get_xdata()) == read_recording(out / "run.mcap").count("objects")
    legend = [t.get_text() for t in figs["perception.png"].axes[0].get_legend().texts]
    assert f"MOTA {result.metrics['mota']:.3g}" in legend
    assert f"identity switches {result.metrics['identity_switches']}" in legend


def test_vilma_report_of_the_runs_folder_plots_the_planning_of_the_recording(planned, tmp_path, capsys):
    result, out, _ = planned
    assert main(["report", str(out), "--out", str(tmp_path / "rep")]) == 0
    assert all((tmp_path / "rep" / p).stat().st_size > 0 for p in PLANNING_PLOTS)
    assert f"mota                             {result.metrics['mota']}" in capsys.readouterr().out
    got = report(read_recording(out / "run.mcap"), tmp_path / "rep2")
    assert got.planning == result.planning  # every cycle's time, planning time and mode; each scan's tracks
    for k in ("planning_cycles", "planner_fallbacks", "mota", "motp_m", "detection_precision", "detection_recall",
              "identity_switches"):
        assert got.metrics[k] == result.metrics[k], k


def test_a_run_without_a_plan_records_and_plots_no_planning(tmp_path):
    result = record_run(load_scenario(BUNDLED / "pi_ff_speed_5.yaml"), tmp_path / "run")
    assert result.planning is None
    assert not any((tmp_path / "run" / p).exists() for p in PLANNING_PLOTS)
    rec = read_recording(tmp_path / "run" / "run.mcap")
    assert not {"perception/objects", "planning/plan"} & set(rec.topics)
    got = report(rec, tmp_path / "rep")
    assert got.planning is None and (tmp_path / "rep" / "path.png").exists()
    assert not any((tmp_path / "rep" / p).exists() for p in PLANNING_PLOTS)


@pytest.mark.parametrize("bad", [b'{"stamp_ns": 5}', b'{"stamp_ns": "soon", "mode": "stop"}', b"not json"])
def test_a_malformed_plan_in_a_recording_is_a_one_line_error(planned, tmp_path, bad):
    """The run's recording copied with the mcap package, its first plan replaced by ``bad``."""
    _, out, _ = planned
    copy = tmp_path / "bad.mcap"
    with (out / "run.mcap").open("rb") as f, copy.open("wb") as g:
        w = Writer(g)
        w.start()
        schemas, channels, replaced = {}, {}, False
        for schema, channel, msg in make_reader(f).iter_messages():
            if schema.id not in schemas:
                schemas[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = w.register_channel(channel.topic, channel.message_encoding, schemas[schema.id])
            data = msg.data
            if channel.topic.endswith("/planning/plan") and not replaced:
                data, replaced = bad, True
            w.add_message(channels[channel.id], msg.log_time, data, msg.publish_time)
        w.finish()
    with pytest.raises(RecordingError, match="planning/plan or perception/objects message is malformed") as e:
        report(read_recording(copy), tmp_path / "rep")
    assert "\n" not in str(e.value) and str(copy) in str(e.value)
