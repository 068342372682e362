"""``mahn-envs``: command-line tools of the environment package.

``mahn-envs emulate --robots 3 --port 4000`` starts one Khepera III protocol server per robot on 127.0.0.1
(robot k on port 4000 + k), answering from the simulator in real time, until Ctrl-C.  Point
``KheperaHardwareEnv(ports=[...])`` or ``mahn-evo deploy`` at the printed ``socket://`` URLs.
"""
from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from collections.abc import Sequence


def _firmware(text: str) -> tuple[int, int]:
    try:
        parts = [int(p) for p in text.split(".")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"firmware must look like 3.0, got {text!r}") from None
    if len(parts) not in (1, 2) or any(p < 0 for p in parts):
        raise argparse.ArgumentTypeError(f"firmware must look like 3.0, got {text!r}")
    return parts[0], parts[1] if len(parts) > 1 else 0


def add_emulate_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("emulate", help="run Khepera III emulators (TCP, ASCII protocol) from the simulator",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--robots", type=int, default=3, help="number of robots (default 3)")
    p.add_argument("--port", type=int, default=4000, help="port of robot 0; robot k uses port+k (0 = pick free ports)")
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1, loopback only)")
    p.add_argument("--allow-remote", action="store_true", help="allow binding a non-loopback --host")
    p.add_argument("--map", default="plus", help="map name or JSON path (default plus)")
    p.add_argument("--seed", type=int, default=0, help="seed of the sensor noise")
    p.add_argument("--noise", type=float, default=1.0, help="IR noise relative to a real robot's (0 = none)")
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="robot seconds per wall second (use the same value on the env / deploy side)")
    p.add_argument("--firmware", type=_firmware, default=(3, 0), help="version answered to B (default 3.0)")
    p.add_argument("--speed-unit", type=float, default=None,
                   help="firmware units per mm/s (default: from --firmware, 218.72 for >= 3)")
    p.add_argument("--wheel-base", type=float, default=8.85, help="wheel base in cm (default 8.85)")
    p.add_argument("--calibration", default="paper", choices=["paper", "linear"],
                   help="calibration whose inverse makes the IR counts (default paper)")
    p.add_argument("--see-robots", action="store_true", help="IR rays see the other robots")
    p.add_argument("--watchdog", type=float, default=None,
                   help="robot-side safety: stop a robot's motors after this many seconds without a command")
    p.add_argument("--idle-timeout", type=float, default=60.0,
                   help="disconnect a client that sends nothing for this many seconds, freeing the robot's port "
                        "for the next one (default 60; 0 = never)")
    p.add_argument("--fault", action="append", default=[], metavar="ROBOT:KIND[:COUNT[:LETTERS[:DELAY]]]",
                   help="inject a fault: KIND drop|garbage|delay|disconnect, COUNT a number or 'forever', "
                        "LETTERS the commands it applies to (e.g. N), DELAY seconds; repeatable")
    p.add_argument("--status", type=float, default=0.0, help="print the poses every this many seconds (0 = never)")
    p.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (0 = run until Ctrl-C)")
    p.set_defaults(func=run_emulate)
    return p


def run_emulate(args: argparse.Namespace) -> int:
    from .hardware import KheperaEmulator, parse_fault
    from .hardware.clock import RealClock
    from .hardware.emulator import LOOPBACK
    from .hardware.kinematics import speed_unit_for_version

    if args.robots < 1:
        print("mahn-envs emulate: --robots must be at least 1", file=sys.stderr)
        return 2
    try:
        faults = [parse_fault(s) for s in args.fault]
    except ValueError as exc:
        print(f"mahn-envs emulate: {exc}", file=sys.stderr)
        return 2
    if args.host not in LOOPBACK and not args.allow_remote:
        print(f"mahn-envs emulate: --host {args.host} is not a loopback address; the emulator answers anyone who "
              "connects, so it binds 127.0.0.1 only unless you add --allow-remote", file=sys.stderr)
        return 2
    try:
        speed_unit = args.speed_unit if args.speed_unit is not None else speed_unit_for_version(*args.firmware)
        emu = KheperaEmulator(args.robots, host=args.host, port=args.port, allow_remote=args.allow_remote,
                              map=args.map, clock=RealClock(args.time_scale), seed=args.seed, noise=args.noise,
                              firmware=args.firmware, speed_unit=speed_unit, wheel_base=args.wheel_base,
                              calibration=args.calibration, robots_see_each_other=args.see_robots,
                              watchdog=args.watchdog, idle_timeout=args.idle_timeout or None)
        for f in faults:
            emu.add_fault(f)
    except ValueError as exc:
        print(f"mahn-envs emulate: {exc}", file=sys.stderr)
        return 2
    try:
        emu.start()
    except OSError as exc:
        print(f"mahn-envs emulate: cannot listen on {args.host} port {args.port}: {exc}", file=sys.stderr)
        return 2
    done = threading.Event()

    def _on_term(signum, frame):  # SIGTERM: shut down like Ctrl-C
        done.set()

    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _on_term)
    try:
        for k, url in enumerate(emu.ports):
            print(f"robot_{k}: {url}")
        print(f"ports: {','.join(emu.ports)}")
        print(f"Khepera III emulator on map {args.map!r}, time scale {args.time_scale:g}, firmware "
              f"{args.firmware[0]}.{args.firmware[1]} ({speed_unit:g} units per mm/s); Ctrl-C to stop", flush=True)
        t0 = time.monotonic()
        next_status = t0 + args.status if args.status > 0 else float("inf")
        while not done.is_set():
            done.wait(0.1)
            now = time.monotonic()
            if args.duration > 0 and now - t0 >= args.duration:
                break
            if now >= next_status:
                next_status += args.status
                poses = emu.poses()
                print("  ".join(f"robot_{k}: ({p[0]:6.1f}, {p[1]:6.1f}, {p[2] % 6.283185:4.2f})"
                                for k, p in enumerate(poses)), flush=True)
    except KeyboardInterrupt:
        pass
    finally:
        emu.stop()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if emu.errors:
            print("emulator errors:\n  " + "\n  ".join(emu.errors), file=sys.stderr)
        print("emulator stopped", flush=True)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="mahn-envs", description="mahn environment tools")
    sub = parser.add_subparsers(dest="command", required=True)
    add_emulate_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
