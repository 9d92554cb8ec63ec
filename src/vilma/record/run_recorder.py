"""The recorder of a ``vilma run`` (:mod:`vilma.record.run`): ``run.mcap`` written as the run goes."""

from __future__ import annotations

import io
import json
import time
from pathlib import Path

import numpy as np

from vilma.core.messages import Message
from vilma.record.process import Joined, RecorderHere, RecorderProcess
from vilma.record.recorder import Recorder
from vilma.record.road_scene import ROAD, TRAFFIC, TrafficFrames, road_scene, scenario_road
from vilma.scenario.drive_log import DriveLog
from vilma.scenario.result import RunObserver, RunResult
from vilma.scenario.spec import Scenario, to_yaml
from vilma.sensors import Readings
from vilma.sim import Simulator


class RunRecorder(RunObserver):
    """Records one run into ``path`` as it goes (see :mod:`vilma.record.run`); its process starts with the run, or,
    ``here``, it packs in this process (:class:`~vilma.record.process.RecorderHere`)."""

    BLOCK = 2048
    """Control periods gathered before they are handed over (41 s of sim time at 50 Hz)."""
    HAND_OVER_S = 0.5
    """Wall time between hand-overs at most [s] (a paced run's chunks still reach the disk every second)."""

    def __init__(self, path: Path, scenario: Scenario, here: bool = False) -> None:
        self.path, self.scenario, self.here = path, scenario, here
        self.recorder: RecorderProcess | RecorderHere | None = None

    def started(self, sim: Simulator, log: DriveLog) -> None:
        self.log, s = log, self.scenario
        self.path.parent.mkdir(parents=True, exist_ok=True)
        kind = RecorderHere if self.here else RecorderProcess
        self.recorder = kind(self.path, source="vilma run", world_sensors=s.sim.world_sensors)
        self.recorder.call(Recorder.add_attachment, "scenario.yaml", "application/yaml", to_yaml(s).encode())
        self.recorder.call(Recorder.add_metadata, "scenario", {"name": s.name, "description": s.description})
        road = scenario_road(s, sim.config)  # its traffic where the sensors see it (reactive too)
        self._traffic = TrafficFrames(road) if road is not None else None
        if road is not None:
            self.recorder.call(Recorder.add_scenes, ROAD, [(0, road_scene(road))])
        self._row_bytes = log.rows.strides[0]
        self._written = self._marked = self._tried = 0  # log rows handed over, added, at the last hand-over
        self._pending: list[tuple[dict[str, Readings], int, int]] = []  # readings, log rows up to, bytes
        self._tried_at = time.monotonic()

    def add(self, readings: dict[str, Readings]) -> None:
        """The readings of a block or period, after its rows went into the log."""
        marked, self._marked = self._marked, len(self.log)
        size = (self._marked - marked) * self._row_bytes + sum(r.stamp_ns.nbytes + r.values.nbytes
                                                               for r in readings.values())
        self._pending.append((readings, self._marked, size))
        if len(self.log):
            self._traffic_until(float(self.log.rows[-1, 0]))
        if self._marked - self._tried >= self.BLOCK or time.monotonic() - self._tried_at >= self.HAND_OVER_S:
            self._hand_over(wait=False)

    def add_captures(self, captures: list[tuple[str, Message]]) -> None:
        """The world sensors' messages of a block or period (``Simulator.take_captures``): camera images and
        laser scans by topic name; and a planned car's tracks and plans, written with their scenes."""
        for name, msg in captures:
            self.recorder.call(Recorder.add_message, name, msg)

    def _traffic_until(self, t: float) -> None:
        """Write the road scenario's traffic frames from the last written up to sim time ``t`` [s] (excluded)."""
        frames = self._traffic.until(t) if self._traffic is not None else []
        if frames:
            self.recorder.call(Recorder.add_scenes, TRAFFIC, frames)

    def _hand_over(self, wait: bool = True) -> None:
        """The readings (joined a sensor each, in the ring) and log rows pending, to the recorder's
        process: as much as its ring has room for now, or, if ``wait``, all of it in turns."""
        self._tried, self._tried_at = self._marked, time.monotonic()
        while self._pending and self.recorder.ok:
            room = self.recorder.capacity if wait else self.recorder.room()
            take = size = 0
            while take < len(self._pending) and (size + self._pending[take][2] <= room or (wait and not take)):
                size += self._pending[take][2]
                take += 1
            if not take:
                return  # the child is behind (or still starting): kept for the next hand-over
            merged: dict[str, list[Readings]] = {}
            for block, _, _ in self._pending[:take]:
                for name, r in block.items():
                    if len(r):
                        merged.setdefault(name, []).append(r)
            upto = self._pending[take - 1][1]
            joined = {n: (p[0].message, Joined([r.stamp_ns for r in p]), Joined([r.values for r in p]))
                      for n, p in merged.items()}
            self.recorder.call(_write, joined, self.log.rows[self._written:upto])
            del self._pending[:take]
            self._written = upto
        self._pending.clear()  # nothing more goes in once the recording stopped

    def finished(self, result: RunResult) -> None:
        """Hand over what is left, the run's facts, the path and the scorecard, and have the file finished
        (:meth:`close` waits for it)."""
        self._hand_over()
        if len(self.log):
            self._traffic_until(float(self.log.rows[-1, 0]) + 1e-6)  # the last row's time too
        call = self.recorder.call
        call(Recorder.add_metadata, "run", {"t_start": result.t_start, "completed": result.metrics.get("completed"),
                                            "wall_time_s": result.metrics.get("wall_time_s"),
                                            "failures": result.failures})
        call(Recorder.add_metadata, "scorecard", result.metrics)
        if result.path is not None:
            buf = io.StringIO()
            cols = [result.path.xy] + ([result.path.speed[:, None]] if result.path.speed is not None else [])
            np.savetxt(buf, np.hstack(cols), delimiter=",", fmt="%.17g")
            call(Recorder.add_attachment, "path.csv", "text/csv", buf.getvalue().encode())
        call(Recorder.add_attachment, "metrics.json", "application/json",
             (json.dumps(result.metrics, indent=2) + "\n").encode())
        self.recorder.finish()

    def close(self) -> None:
        """Wait until the file is finished."""
        self.recorder.close()

    def failed(self, interrupted: bool) -> None:
        """The run failed: keep what was recorded and close the file."""
        if self.recorder is not None:
            self._hand_over()
            self.recorder.close()


def _write(recorder: Recorder, readings: dict[str, tuple[type[Message], np.ndarray, np.ndarray]],
           rows: np.ndarray) -> None:
    """Readings of a stretch of sim time (message type, stamps and values by sensor), and the log's rows of it."""
    recorder.add_readings({name: Readings(name, *r) for name, r in readings.items()})
    recorder.add_log_rows(rows)
