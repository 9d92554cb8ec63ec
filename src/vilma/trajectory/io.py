"""Trajectory files: the original's ``x y`` pairs, CSV with a header, GPX tracks; atomic saves.

- original (``PositionLog.txt``; any extension but .csv and .gpx): numbers
  separated by any whitespace, alternating x y [m]. The original skipped
  tokens that were not numbers; vilma reports them.
- CSV: a header naming ``x`` and ``y`` and optionally ``speed``, then rows.
- GPX: track points (or route points, or waypoints) in WGS84, converted to
  local ENU [m] around a geodetic origin (default: the first point).

Every error is a :class:`TrajectoryFileError` saying ``file:line: what; how to fix``.
"""

from __future__ import annotations

import csv
import io
import math
import os
import stat
from pathlib import Path

import numpy as np

from vilma.core.files import write_atomic
from vilma.core.geodesy import GeodeticOrigin
from vilma.trajectory.trajectory import Trajectory

MAX_FILE_BYTES = 8 * 2**20
"""The largest trajectory file read [bytes]: 8 MiB, about 400 000 points in the original's format (``%f\\t%f``
lines of 20-24 bytes); a larger file is refused before it is read (parsing takes up to 40 times its size)."""


class TrajectoryFileError(ValueError):
    """A trajectory file that cannot be read or written: ``what`` is wrong at ``line`` (None: the whole file)."""

    def __init__(self, path: Path, line: int | None, what: str) -> None:
        super().__init__(f"{path}:{line}: {what}" if line else f"{path}: {what}")
        self.line, self.what = line, what


def _fail(path: Path, line: int | None, what: str) -> TrajectoryFileError:
    return TrajectoryFileError(path, line, what)


def _number(token: str, path: Path, line: int, what: str) -> float:
    try:
        v = float(token)
    except ValueError:
        raise _fail(path, line, f"{what} {token!r} is not a number; remove it or fix the value") from None
    if not math.isfinite(v):
        raise _fail(path, line, f"{what} {token!r} is not finite; give a finite number")
    return v


def check_trajectory_file(path: Path) -> int:
    """The size of the trajectory file ``path`` [bytes], checked without opening it: a regular file (a device or a
    pipe could block, never end, or act when opened) of at most :data:`MAX_FILE_BYTES`.

    Raises:
        TrajectoryFileError: missing, unreadable, not a regular file, or too large (never quoting the file).
    """
    try:
        st = path.stat()
    except FileNotFoundError:
        raise _fail(path, None, "no such file; check the path") from None
    except OSError as e:
        raise _fail(path, None, f"cannot read it ({e.strerror}); check permissions") from None
    if not stat.S_ISREG(st.st_mode):
        raise _fail(path, None, "not a regular file (a folder, device or pipe); give a trajectory file")
    if st.st_size > MAX_FILE_BYTES:
        raise _fail(path, None, f"{st.st_size} bytes, over the {MAX_FILE_BYTES >> 20} MiB a trajectory file may "
                                "hold; keep fewer points (every n-th line)")
    return st.st_size


def _read_text(path: Path) -> str:
    size = check_trajectory_file(path)
    try:  # non-blocking, and no more than was checked: what is put in its place since cannot hang or flood us
        with os.fdopen(os.open(path, os.O_RDONLY | os.O_NONBLOCK), "rb") as f:
            data = f.read(size)
    except OSError as e:
        raise _fail(path, None, f"cannot read it ({e.strerror}); check permissions") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data[: e.start].count(b"\n") + 1
        raise _fail(path, line, "not UTF-8 text; is this a trajectory file?") from None


def _load_pairs(path: Path, text: str) -> Trajectory:
    """The original's format: numbers split by any white space, read as x, y, x, y ... [m]."""
    values: list[float] = []
    last_line, widths = 0, set()
    for n, line in enumerate(text.splitlines(), start=1):
        tokens = line.split()
        widths.add(len(tokens) or 2)
        for token in tokens:
            values.append(_number(token, path, n, "token"))
            last_line = n
    if len(widths) == 1 and (k := widths.pop()) > 2 and last_line > 1:  # columns, not pairs: x y speed, say
        raise _fail(path, None, f"{k} numbers on every line; this format holds x y pairs: for more columns write a CSV "
                                "file with a header x,y[,speed]")
    if not values:
        raise _fail(path, None, "no points; a trajectory file holds 'x y' pairs of numbers")
    if len(values) % 2:
        raise _fail(path, last_line, f"odd count of numbers ({len(values)}): the last x has no y; add it or remove it")
    return Trajectory(np.array(values).reshape(-1, 2))


def _load_csv(path: Path, text: str) -> Trajectory:
    try:
        rows = list(csv.reader(io.StringIO(text, newline="")))
    except csv.Error as e:
        raise _fail(path, None, f"not readable as CSV ({e}); save it as plain comma-separated text") from None
    header_line = next((i for i, r in enumerate(rows) if any(c.strip() for c in r)), None)
    if header_line is None:
        raise _fail(path, None, "no points; a CSV trajectory has a header 'x,y[,speed]' and rows")
    header = [c.strip().lower() for c in rows[header_line]]
    unknown = [c for c in header if c not in ("x", "y", "speed")]
    if unknown or "x" not in header or "y" not in header or len(set(header)) != len(header):
        raise _fail(path, header_line + 1, f"header {rows[header_line]!r} must name x, y and optionally speed, once "
                                           f"each{f' (unknown: {unknown})' if unknown else ''}")
    cols = {name: i for i, name in enumerate(header)}
    xy, speed = [], []
    for n, row in enumerate(rows[header_line + 1:], start=header_line + 2):
        if not any(c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise _fail(path, n, f"{len(row)} fields where the header has {len(header)}; fix the row")
        xy.append((_number(row[cols["x"]], path, n, "x"), _number(row[cols["y"]], path, n, "y")))
        if "speed" in cols:
            speed.append(_number(row[cols["speed"]], path, n, "speed"))
    if not xy:
        raise _fail(path, None, "no points after the header; add rows 'x,y[,speed]'")
    return Trajectory(np.array(xy), np.array(speed) if speed else None)


def _load_gpx(path: Path, text: str, origin: GeodeticOrigin | None) -> Trajectory:
    import xml.etree.ElementTree as ET  # here: GPX files only (a run that loads none need not import them)

    import pymap3d

    try:
        root = ET.fromstring(text)
    except ET.ParseError as e:
        raise _fail(path, e.position[0], f"malformed GPX ({e}); is it a GPX 1.1 file?") from None
    points = []
    for tag in ("trkpt", "rtept", "wpt"):
        points = [el for el in root.iter() if el.tag.rsplit("}", 1)[-1] == tag]
        if points:
            break
    if not points:
        raise _fail(path, None, "no track points (trkpt, rtept or wpt); export a track")
    lat, lon, alt = [], [], []
    for el in points:
        try:
            lat.append(float(el.attrib["lat"]))
            lon.append(float(el.attrib["lon"]))
        except (KeyError, ValueError):
            raise _fail(path, None, f"a {el.tag.rsplit('}', 1)[-1]} without numeric lat/lon; fix that point") from None
        ele = next((c.text for c in el if c.tag.rsplit("}", 1)[-1] == "ele"), None)
        try:
            alt.append(float(ele) if ele else 0.0)
        except ValueError:
            alt.append(0.0)
    lat_a, lon_a, alt_a = np.array(lat), np.array(lon), np.array(alt)
    if not (np.isfinite(lat_a).all() and np.isfinite(lon_a).all()) or np.abs(lat_a).max() > 90 or \
            np.abs(lon_a).max() > 180:
        raise _fail(path, None, "latitude/longitude out of range; GPX uses degrees")
    o = origin or GeodeticOrigin(latitude=lat[0], longitude=lon[0], altitude=alt[0])
    e, n, _ = pymap3d.geodetic2enu(lat_a, lon_a, alt_a, o.latitude, o.longitude, o.altitude)
    return Trajectory(np.column_stack([e, n]))


def load_trajectory(path: str | os.PathLike, origin: GeodeticOrigin | None = None) -> Trajectory:
    """Read a trajectory file (format by extension: .csv, .gpx, anything else the original's pairs)."""
    path = Path(path)
    text = _read_text(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return _load_csv(path, text)
    if suffix == ".gpx":
        return _load_gpx(path, text, origin)
    return _load_pairs(path, text)


def save_trajectory(path: str | os.PathLike, path_: Trajectory) -> None:
    """Write a trajectory atomically: CSV (x,y[,speed]) for .csv, else the original's ``%f\\t%f`` lines (no speeds;
    not .gpx, whose points are geodetic).

    The file is written beside the target and renamed over it, so a failed
    save never damages an existing file.
    """
    path = Path(path)
    if path.suffix.lower() == ".gpx":
        raise _fail(path, None, "GPX holds latitudes and longitudes, not a path's metres: save it as .csv "
                                "(x,y[,speed]) or in the original's x y lines")
    if path.suffix.lower() == ".csv":
        cols = ["x", "y"] + (["speed"] if path_.speed is not None else [])
        data = path_.xy if path_.speed is None else np.column_stack([path_.xy, path_.speed])
        text = ",".join(cols) + "\n" + "".join(",".join(f"{v:.6f}" for v in row) + "\n" for row in data)
    else:
        text = "".join(f"{x:f}\t{y:f}\n" for x, y in path_.xy)
    try:
        write_atomic(path, text)
    except OSError as e:
        raise _fail(path, None, f"cannot save it ({e.strerror}); choose another folder") from None
