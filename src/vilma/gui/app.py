"""``vilma gui``: the QApplication, the backend (embedded or over Zenoh) and the main window."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path

from vilma.bus.base import Bus
from vilma.core.extras import require
from vilma.scenario.spec import Scenario


def main(args: argparse.Namespace, scenario: Scenario | None = None, bus: Bus | None = None) -> int:
    """Run the GUI until its window closes; returns the exit code.

    With ``bus`` (a Zenoh bus from ``--connect``) it joins the simulator and
    driver on it (a ``scenario`` then names that simulator's cameras, road and
    plan task); otherwise it runs ``scenario`` (or the defaults) embedded, paced
    to ``args.speed`` x real time.
    """
    require("gui", "vilma gui")
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    from vilma.gui.backend import Embedded, Remote
    from vilma.gui.main_window import MainWindow
    from vilma.gui.xcb import check_xcb

    refresh = getattr(args, "refresh", 250)
    if not 10 <= refresh <= 60_000:
        raise ValueError(f"--refresh must be 10..60000 ms, got {refresh}")
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY") \
            and not os.environ.get("QT_QPA_PLATFORM") and sys.platform.startswith("linux"):
        print("vilma gui: no display (DISPLAY unset); running offscreen. Set QT_QPA_PLATFORM to choose.",
              file=sys.stderr)
        os.environ["QT_QPA_PLATFORM"] = "offscreen"
    if sys.platform.startswith("linux"):
        check_xcb(os.environ)  # Qt would abort the process, naming the wrong library
    if bus is not None:
        world = scenario.sim.world_topics if scenario is not None else ()
        backend = Remote(bus, "Zenoh " + ", ".join(getattr(args, "connect", None) or ["peers"]), world_topics=world,
                         driver_params=scenario.driver if scenario is not None else None, scenario=scenario)
    else:
        backend = Embedded(scenario, speed=getattr(args, "speed", 1.0))
    with backend:  # closed however the window ends
        app = QApplication.instance() or QApplication([sys.argv[0]])
        window = MainWindow(backend, refresh_ms=refresh, record_dir=Path(getattr(args, "record_dir", None) or "."))
        window.show()
        backend.start()
        previous = signal.signal(signal.SIGINT, lambda *_: app.quit())
        tick = QTimer()  # lets Python run its signal handlers while Qt's loop waits
        tick.timeout.connect(lambda: None)
        tick.start(200)
        try:
            quit_after = getattr(args, "quit_after", None)
            if quit_after is not None:
                QTimer.singleShot(int(quit_after * 1000), app.quit)
            return app.exec()
        finally:
            signal.signal(signal.SIGINT, previous)
            window.close()
