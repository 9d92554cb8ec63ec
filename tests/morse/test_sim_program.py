"""``vilma sim`` serves the MORSE interface: a raw MORSE client drives it and quits it."""

from __future__ import annotations

import json
import re
import subprocess
import sys

from tests.morse.conftest import LineClient


def test_vilma_sim_serves_morse_until_quit(processes):
    p = processes.vilma("sim", "--listen", "tcp/127.0.0.1:0", "--morse-port", "0", "--morse-stream-port", "0",
                        "--speed", "2", stderr=subprocess.PIPE)
    port = None
    for line in p.stdout:
        m = re.search(r"MORSE services on 127\.0\.0\.1:(\d+)", line)
        if m:
            port = int(m.group(1))
            break
    assert port, p.stderr.read()
    c = LineClient(port)
    assert c.ask(b"a vilma controlpower [1,1000,3]\n") == b"a SUCCESS\n"
    c.ask(b"w time sleep [3.0]\n")
    assert json.loads(c.ask(b"s vilma status []\n").split(b" ", 2)[2]) > 1.0
    assert c.ask(b"r simulation reset_objects\n") == b'r SUCCESS "Objects restored to initial position"\n'
    assert float((c.ask(b"t vilma status\n").split(b" ", 2)[2:] or [0.0])[0]) < 0.2  # at rest again
    assert c.ask(b"b vilma controlpower [1,1000,3]\n") == b"b SUCCESS\n"
    c.ask(b"w time sleep [3.0]\n")
    assert c.ask(b"q simulation quit []\n") == b"q SUCCESS\n"
    out, err = p.communicate(timeout=60)  # it ends by itself (how fast is a benchmark's business)
    c.close()
    assert p.returncode == 0, err
    speed = float(re.search(r"speed ([\d.]+) m/s", out).group(1))
    assert abs(speed - 3.0) < 0.5  # held at velocityAmount 3 m/s


def test_bad_morse_options_exit_with_one_line():
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "sim", "--allow-commands-from", "no.such/99"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines() == [
        "vilma sim: error: allow_commands_from: 'no.such/99' is not an IP address or network; "
        "use e.g. '127.0.0.1' or '192.168.1.0/24'"]


def test_an_address_not_of_this_machine_is_one_line_naming_the_option():
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "sim", "--listen", "tcp/127.0.0.1:0", "--morse-host",
                        "192.0.2.1", "--morse-port", "0"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    (line,) = r.stderr.strip().splitlines()
    assert line.startswith("vilma sim: error: --morse-host: cannot listen on 192.0.2.1: ")
    assert line.endswith("; give an address of this machine, e.g. 127.0.0.1")
