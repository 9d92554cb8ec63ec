"""Many cars at once: each its own scenario (parameters, seed, sensors, controllers), driven side by side.

:func:`run_fleet` drives the cars a wave at a time (:data:`WAVE`). It sets a wave's cars up, then drives those that
qualify for the compiled loop (:func:`~vilma.scenario.lockstep.compiled_ok`) block by block, in a thread a core
(:data:`THREADS`; the compiled loop runs without the GIL): each round of a thread, a block of driver periods of every
car of its share still driving, so they stay within a block of one another in sim time. The others run after, one
after another, in the runner's Python loop. A car's drive and scorecard are bit-identical to
:func:`~vilma.scenario.runner.run` of its scenario alone: the same kernels on the same inputs (tested).

A block is one compiled call a car. A single call for all the cars (a numba typed list of their arguments) was
measured: building the list costs 3.5-7 us a car a block, no less than a call's own overhead, and numba compiles
the list's code anew in every process (0.6-1.5 s, not cached), so it would cost more than it saves. Either way
nearly all the time is each car's own plant and driver (microseconds a period).
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait

from numba.core.event import install_listener

from vilma.scenario.lockstep import CompiledDrive, _loop, compiled_ok
from vilma.scenario.result import RunObserver, RunResult
from vilma.scenario.runner import Car, LoadTimer, failing, finish
from vilma.scenario.spec import Scenario
from vilma.sim import Simulator
from vilma.trajectory import Trajectory

WAVE = 100
"""Cars driven side by side at most: the next ones start when these are done, so that memory holds a wave's
simulators (about 2 MB a car: its sensors' blocks of readings and noise) and every car's log, not every car's
simulator (2 GB for 1000 cars)."""
THREADS = len(os.sched_getaffinity(0))
"""Threads that drive a wave's compiled cars at once: one per core this process may use (the compiled loop runs
without the GIL)."""


def run_fleet(scenarios: Sequence[Scenario],
              observers: Callable[[int, Scenario], Sequence[RunObserver]] = lambda i, s: (),
              progress: Callable[[list[RunResult]], None] | None = None) -> list[RunResult]:
    """Drive every scenario's car to its end and score it, as :func:`~vilma.scenario.runner.run` would one by one.

    ``observers(i, scenario)`` gives the observers of car ``i`` (its folder, say); ``progress(results)`` hears the
    results of the cars done so far, in order, after each wave (:data:`WAVE`): their scorecards are final. Cars of
    one scenario that differ only in their settings (``seed``, gains, sensors) share its reference path. Each
    result's ``loop_wall_time_s`` is the car's own share of the loop; ``wall_time_s`` the command's time over the
    cars; ``load_time_s`` its wave's loading of compiled code over the wave's cars.

    Raises:
        SpecError: a scenario's files cannot be used.
        KeyboardInterrupt: Ctrl-C; the cars' observers were told (the waves before were whole: ``progress`` heard
            them).
    """
    started, loading, paths = time.perf_counter(), LoadTimer(), {}
    results: list[RunResult] = []
    with install_listener("numba:compiler_lock", loading):
        for w in range(0, len(scenarios), WAVE):
            wave = scenarios[w:w + WAVE]
            seen = [observers(w + i, s) for i, s in enumerate(wave)]
            loaded = loading.seconds
            with failing([o for obs in seen for o in obs]):
                done = _wave([Car(s, _path(paths, s), obs) for s, obs in zip(wave, seen, strict=True)], loading)
            share = (loading.seconds - loaded) / len(wave)  # the loading of compiled code in the wave, over its cars
            results += [finish(r, obs, lambda: (time.perf_counter() - started) / len(scenarios), share)
                        for r, obs in zip(done, seen, strict=True)]
            if progress is not None:
                progress(results)
    return results


def _wave(cars: list[Car], loading: LoadTimer) -> list[RunResult]:
    """Drive ``cars`` side by side, a block of each in turn, those that can run compiled; the others after. A car's
    loop time leaves out the loading of compiled code (``loading``) its calls waited for."""
    loops = [0.0] * len(cars)
    with contextlib.ExitStack() as stack:
        for car in cars:
            car.start(stack.enter_context(Simulator(car.config, car.initial)))
            car.begin()
        drives = {i: CompiledDrive(c.sim, c.driver, c.log, c.periods, c.follows, c.block_taker)
                  for i, c in enumerate(cars) if compiled_ok(c.sim, c.driver)}
        slow = [i for i in range(len(cars)) if i not in drives]
        groups = [dict(list(drives.items())[k::THREADS]) for k in range(min(THREADS, len(drives)))]
        stop = threading.Event()
        with ThreadPoolExecutor(len(groups) or 1) as pool:
            threads = [pool.submit(_drive, g, loops, loading, stop) for g in groups]
            try:
                wait(threads, return_when=FIRST_EXCEPTION)
            finally:  # Ctrl-C or a failure: the other threads stop after their block
                stop.set()
        for thread in threads:
            thread.result()
        for i in slow:
            t0 = time.perf_counter() - loading.seconds
            cars[i].loop(None, compiled=False)
            loops[i] += time.perf_counter() - loading.seconds - t0
        return [car.score(loop) for car, loop in zip(cars, loops, strict=True)]


def _drive(drives: dict[int, CompiledDrive], loops: list[float], loading: LoadTimer, stop: threading.Event) -> None:
    """Drive each car of ``drives`` (by its index) a block at a time in turn until it is done, or until ``stop``;
    adds each block's wall time to the car's ``loops`` entry, the loading of compiled code aside."""
    while drives and not stop.is_set():
        for i, d in list(drives.items()):
            t0 = time.perf_counter() - loading.seconds
            args = d.start()
            wall = time.perf_counter()
            ran = _loop(*args)
            d.end(ran, time.perf_counter() - wall)
            loops[i] += time.perf_counter() - loading.seconds - t0
            if not d.running:
                del drives[i]


def _path(paths: dict, scenario: Scenario) -> Trajectory | None:
    """The scenario's reference path, made once for the cars whose task, files and road (and, for a route, the
    driver's limits, which time it) are the same."""
    s = scenario
    key = (s.task, s.file, id(s.road), s.driver if s.task.kind in ("route", "plan") else None)
    if key not in paths:
        paths[key] = s.reference_path()
    return paths[key]
