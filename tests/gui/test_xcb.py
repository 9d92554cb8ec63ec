"""``vilma gui`` on an X display: the libraries Qt's xcb plugin needs are checked first, and named with their
packages in one line (Qt itself aborts naming the wrong one)."""

from __future__ import annotations

from pathlib import Path

import pytest

from vilma.app import cli
from vilma.gui import xcb

PLUGIN = Path("/venv/PySide6/Qt/plugins/platforms/libqxcb.so")
# ldd's format: "<soname> => <path> (<address>)", or "<soname> => not found"; it repeats what two libraries need
LDD = """\tlinux-vdso.so.1 (0x00007ffd)
\tlibQt6XcbQpa.so.6 => /venv/PySide6/Qt/lib/libQt6XcbQpa.so.6 (0x00007efd0aa16000)
\tlibxcb-icccm.so.4 => not found
\tlibxcb-keysyms.so.1 => not found
\tlibxcb.so.1 => /lib/x86_64-linux-gnu/libxcb.so.1 (0x00007efd0a9e0000)
\tlibxcb-icccm.so.4 => not found
\tlibxcb-keysyms.so.1 => not found
"""
X11 = {"DISPLAY": ":0"}


def _ldd(text: str):
    asked = []

    def lookup(path: Path) -> str:
        asked.append(path)
        return text
    return lookup, asked


def test_the_missing_libraries_are_those_ldd_cannot_find_each_once():
    lookup, asked = _ldd(LDD)
    assert xcb.missing_libraries(PLUGIN, lookup) == ["libxcb-icccm.so.4", "libxcb-keysyms.so.1"]
    assert asked == [PLUGIN]
    assert xcb.missing_libraries(PLUGIN, _ldd(LDD.replace("not found", "/lib/x.so (0x1)"))[0]) == []


def test_the_error_names_the_libraries_and_the_packages_to_install_in_one_line():
    with pytest.raises(ValueError) as e:
        xcb.check_xcb(X11, PLUGIN, _ldd(LDD)[0])
    text = str(e.value)
    assert "\n" not in text and "libxcb-icccm.so.4, libxcb-keysyms.so.1" in text
    assert "apt-get install libxcb-icccm4 libxcb-keysyms1)" in text and "QT_QPA_PLATFORM=offscreen" in text
    with pytest.raises(ValueError, match="apt-file search"):  # a library the table does not know
        xcb.check_xcb(X11, PLUGIN, _ldd("\tlibnew.so.9 => not found\n")[0])


def test_nothing_is_asked_when_qt_will_not_load_xcb():
    lookup, asked = _ldd(LDD)
    for env in ({}, {"QT_QPA_PLATFORM": "offscreen", "DISPLAY": ":0"}, {"WAYLAND_DISPLAY": "wayland-0"}):
        xcb.check_xcb(env, PLUGIN, lookup)
    assert asked == []


@pytest.mark.parametrize(("env", "uses"), [
    ({"DISPLAY": ":0"}, True),
    ({"QT_QPA_PLATFORM": "xcb"}, True),
    ({"QT_QPA_PLATFORM": "wayland;xcb"}, True),
    ({"QT_QPA_PLATFORM": "xcb:nograb", "DISPLAY": ""}, True),
    ({"QT_QPA_PLATFORM": "offscreen", "DISPLAY": ":0"}, False),
    ({"QT_QPA_PLATFORM": "wayland"}, False),
    ({"DISPLAY": ":0", "XDG_SESSION_TYPE": "wayland"}, False),
    ({}, False),
])
def test_qt_loads_xcb_when_the_platform_names_it_or_an_x_display_is_set(env, uses):
    assert xcb.uses_xcb(env) is uses


def test_vilma_gui_stops_before_qt_with_exit_2_and_the_packages(monkeypatch, capsys):
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setenv("QT_QPA_PLATFORM", "xcb")
    monkeypatch.setattr(xcb, "xcb_plugin", lambda: PLUGIN)
    monkeypatch.setattr(xcb, "ldd", _ldd(LDD)[0])
    assert cli.main(["gui"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "sudo apt-get install libxcb-icccm4 libxcb-keysyms1" in err
    assert "Traceback" not in err

