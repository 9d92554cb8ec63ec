"""The readings in ``data/vilma_msgs.mcap``: a recording as vilma wrote it before the standard ROS types
(``vilma_msgs/msg/<Type>`` for every sensor, ``gps/fix`` beside ``tf``), which must still read back exactly.

The file was written from :func:`readings` and :func:`log_rows` by ``python -m tests.record.legacy OUT`` with
vilma at commit f88f940 (main before the standard types); it is kept as it was written.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from vilma.bus.topics import SENSOR_TOPICS
from vilma.core import messages as m
from vilma.scenario.drive_log import COLUMNS
from vilma.sensors import Readings

FILE = Path(__file__).parent / "data" / "vilma_msgs.mcap"
COUNT = 40
"""Messages a topic."""
CMD = m.ActuatorCommand(stamp_ns=20_000_000, steer=0.25, drive=100.0, autonomous=True)


def readings() -> dict[str, Readings]:
    """Every sensor topic: ``COUNT`` messages 20 ms apart of seeded random values, a NaN and an infinity in each."""
    rng = np.random.default_rng(17)
    stamps = np.arange(1, COUNT + 1, dtype=np.int64) * 20_000_000
    out = {}
    for name, cls in SENSOR_TOPICS.items():
        values = rng.normal(size=(COUNT, len(cls.__struct_fields__) - 1)) * 10
        values[3, 0], values[5, -1] = np.nan, -np.inf
        out[name] = Readings(name, cls, stamps, values)
    return out


def log_rows() -> np.ndarray:
    """``COUNT`` drive log rows: ``t`` [s] 20 ms apart, then seeded random values."""
    rows = np.random.default_rng(18).normal(size=(COUNT, len(COLUMNS)))
    rows[:, 0] = np.arange(1, COUNT + 1) * 0.02
    return rows


if __name__ == "__main__":
    from vilma.record.recorder import Recorder

    rec = Recorder(Path(sys.argv[1]))
    rec.add_readings(readings())
    rec.add_log_rows(log_rows())
    rec.add_message("cmd", CMD)
    rec.close()
