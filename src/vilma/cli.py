"""The ``vilma`` command."""

from __future__ import annotations

import argparse
import logging
import sys
import time


def _demo(args: argparse.Namespace) -> int:
    from vilma import demo
    from vilma.control.driver import DriverParams
    from vilma.sim import SimConfig
    from vilma.vehicle.params import preset

    if not 0 < args.duration < float("inf"):
        raise ValueError(f"--duration must be a positive number of seconds, got {args.duration:g}")
    if args.speed is not None and not 0 < args.speed < float("inf"):
        raise ValueError(f"--speed must be a positive factor, got {args.speed:g}")
    config = SimConfig(vehicle=preset(args.vehicle), model=args.model, seed=args.seed)
    params = DriverParams(speed_controller=args.speed_controller, path_controller=args.path_controller,
                          pose_source=args.pose)
    t0 = time.perf_counter()
    result = demo.drive(config, params, duration=args.duration, speed=args.speed)
    wall = time.perf_counter() - t0
    print(f"vilma demo: the {config.vehicle.name} car ({config.model} model, {config.step * 1e3:g} ms step, "
          f"all sensors, seed {config.seed}) follows the paper-style course at 30 km/h with "
          f"{params.speed_controller} + {params.path_controller} from the {params.pose_source} pose")
    print(demo.format_rows(result.rows))
    print(f"\n{'Arrived' if result.arrived else 'Did not arrive'}: {result.end_distance:.2f} m from the last point "
          f"after {result.sim_seconds:.1f} s of sim time; off path RMS {result.rms_cross_track:.3f} m, "
          f"max {result.max_cross_track:.3f} m. Wall {wall:.2f} s, start-up included "
          f"({result.sim_seconds / wall:.0f}x real time).")
    return 0 if result.arrived else 1


def _parser() -> argparse.ArgumentParser:
    from vilma import __version__
    from vilma.control.driver import PATH_CONTROLLERS, SPEED_CONTROLLERS
    from vilma.localization import SOURCES
    from vilma.vehicle import models
    from vilma.vehicle.params import PRESETS

    p = argparse.ArgumentParser(prog="vilma", description="Simulate, drive and monitor an autonomous car.")
    p.add_argument("--version", action="version", version=f"vilma {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="a closed-loop demo drive on the paper-style course, headless")
    d.add_argument("--vehicle", choices=sorted(PRESETS), default="vilma", help="vehicle preset (default vilma)")
    d.add_argument("--model", choices=models.MODELS, default="single_track", help="plant model")
    d.add_argument("--duration", type=float, default=120.0, help="longest sim time to drive [s] (default 120)")
    d.add_argument("--speed-controller", choices=SPEED_CONTROLLERS, default="pi_ff", help="speed controller")
    d.add_argument("--path-controller", choices=PATH_CONTROLLERS, default="stanley", help="path controller")
    d.add_argument("--pose", choices=SOURCES, default="truth", help="pose source for the controllers")
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
