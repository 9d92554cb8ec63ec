"""The ``vilma`` command."""

from __future__ import annotations

import argparse
import logging
import sys
import time


def _demo(args: argparse.Namespace) -> int:
    from vilma import demo
    from vilma.sim import SimConfig
    from vilma.vehicle.params import preset

    if not 0 < args.duration < float("inf"):
        raise ValueError(f"--duration must be a positive number of seconds, got {args.duration:g}")
    config = SimConfig(vehicle=preset(args.vehicle), model=args.model, seed=args.seed)
    t0 = time.perf_counter()
    if args.speed is not None and not 0 < args.speed < float("inf"):
        raise ValueError(f"--speed must be a positive factor, got {args.speed:g}")
    rows = demo.drive(duration=args.duration, config=config, speed=args.speed)
    wall = time.perf_counter() - t0
    print(f"vilma demo drive: {config.vehicle.name} car, {config.model} model, "
          f"step {config.step * 1e3:g} ms, all sensors, seed {config.seed}")
    print(demo.format_rows(rows))
    end = rows[-1]
    print(f"\nDrove {args.duration:g} s of sim time in {wall:.2f} s wall, start-up included "
          f"({args.duration / wall:.0f}x real time): ended at ({end.x:.1f}, {end.y:.2f}) m, {end.speed:.2f} m/s.")
    return 0


def _parser() -> argparse.ArgumentParser:
    from vilma import __version__
    from vilma.vehicle import models
    from vilma.vehicle.params import PRESETS

    p = argparse.ArgumentParser(prog="vilma", description="Simulate, drive and monitor an autonomous car.")
    p.add_argument("--version", action="version", version=f"vilma {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="a short closed-loop demo drive, headless, printing what happened")
    d.add_argument("--vehicle", choices=sorted(PRESETS), default="vilma", help="vehicle preset (default vilma)")
    d.add_argument("--model", choices=models.MODELS, default="single_track", help="plant model")
    d.add_argument("--duration", type=float, default=22.0, help="sim time to drive [s] (default 22)")
    d.add_argument("--seed", type=int, default=0, help="noise seed")
    d.add_argument("--speed", type=float, default=None, metavar="K",
                   help="pace to K times real time (default: as fast as possible)")
    d.set_defaults(func=_demo)
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point: parse ``argv`` and run the subcommand; returns the exit code."""
    args = _parser().parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    try:
        return args.func(args)
    except (ValueError, OSError) as e:
        print(f"vilma {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
