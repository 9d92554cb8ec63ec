"""Before Qt starts on an X display: the system libraries its xcb platform plugin needs, and what to install.

Without them Qt aborts the process (exit 134) naming one library, often not the missing one. The list is the
direct needs of PySide6 6.11's ``libqxcb.so`` and the Qt libraries it loads (``objdump -p``), with the Debian 12
packages that hold them (``dpkg -S``); the check asks the dynamic loader (``ldd``) what it cannot find.
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
from collections.abc import Callable, Mapping
from pathlib import Path

PACKAGES = {
    "libxcb-icccm.so.4": "libxcb-icccm4", "libxcb-keysyms.so.1": "libxcb-keysyms1",
    "libxcb-cursor.so.0": "libxcb-cursor0", "libxcb-image.so.0": "libxcb-image0", "libxcb-randr.so.0": "libxcb-randr0",
    "libxcb-render-util.so.0": "libxcb-render-util0", "libxcb-render.so.0": "libxcb-render0",
    "libxcb-shape.so.0": "libxcb-shape0", "libxcb-shm.so.0": "libxcb-shm0", "libxcb-sync.so.1": "libxcb-sync1",
    "libxcb-util.so.1": "libxcb-util1", "libxcb-xfixes.so.0": "libxcb-xfixes0", "libxcb-xkb.so.1": "libxcb-xkb1",
    "libxcb.so.1": "libxcb1", "libxkbcommon-x11.so.0": "libxkbcommon-x11-0", "libxkbcommon.so.0": "libxkbcommon0",
    "libX11-xcb.so.1": "libx11-xcb1", "libX11.so.6": "libx11-6", "libEGL.so.1": "libegl1", "libGL.so.1": "libgl1",
    "libfontconfig.so.1": "libfontconfig1", "libfreetype.so.6": "libfreetype6", "libglib-2.0.so.0": "libglib2.0-0",
    "libgthread-2.0.so.0": "libglib2.0-0", "libdbus-1.so.3": "libdbus-1-3", "libzstd.so.1": "libzstd1",
    "libz.so.1": "zlib1g",
}
"""Debian 12 package of each system library (soname) the xcb plugin loads."""

_NOT_FOUND = re.compile(r"^\s*(\S+)\s+=>\s+not found", re.MULTILINE)


def uses_xcb(env: Mapping[str, str]) -> bool:
    """Whether Qt will try its xcb plugin under ``env``: ``QT_QPA_PLATFORM`` names it (``xcb``, or in a
    ``wayland;xcb`` fallback list), or is unset with an X ``DISPLAY`` outside a Wayland session."""
    platform = env.get("QT_QPA_PLATFORM", "")
    if platform:
        return "xcb" in (name.split(":")[0].strip() for name in platform.split(";"))
    return bool(env.get("DISPLAY")) and env.get("XDG_SESSION_TYPE") != "wayland"


def xcb_plugin() -> Path | None:
    """PySide6's xcb platform plugin, or None without PySide6 (or a build without it)."""
    spec = importlib.util.find_spec("PySide6")
    if spec is None or spec.origin is None:
        return None
    plugin = Path(spec.origin).parent / "Qt" / "plugins" / "platforms" / "libqxcb.so"
    return plugin if plugin.exists() else None


def ldd(library: Path) -> str:
    """What ``ldd`` says of ``library`` ("" when there is no ``ldd`` to ask: then nothing is known missing)."""
    try:
        return subprocess.run(["ldd", str(library)], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.TimeoutExpired):
        return ""


def missing_libraries(plugin: Path, lookup: Callable[[Path], str] | None = None) -> list[str]:
    """The sonames the dynamic loader cannot find for ``plugin``, in order (``lookup``: its ``ldd`` output;
    default :func:`ldd`)."""
    return list(dict.fromkeys(_NOT_FOUND.findall((lookup or ldd)(plugin))))


def check_xcb(env: Mapping[str, str], plugin: Path | None = None, lookup: Callable[[Path], str] | None = None) -> None:
    """Raise when Qt would load its xcb plugin under ``env`` and the system lacks a library it needs
    (``lookup``: as for :func:`missing_libraries`).

    Raises:
        ValueError: one line naming the missing libraries and the packages to install.
    """
    plugin = plugin or xcb_plugin()
    if plugin is None or not uses_xcb(env):
        return
    missing = missing_libraries(plugin, lookup)
    if missing:
        packages = " ".join(dict.fromkeys(PACKAGES[s] for s in missing if s in PACKAGES))
        how = f"sudo apt-get install {packages}" if packages else "apt-file search LIBRARY names the package"
        raise ValueError(f"Qt's X display plugin (xcb) needs {', '.join(missing)}, not on this system: install "
                         f"them (Debian/Ubuntu: {how}), or run without a window with QT_QPA_PLATFORM=offscreen")
