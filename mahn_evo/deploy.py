"""``mahn-evo deploy``: run an evolved team on real Khepera III robots (or the emulator), logging every tick.

The champion's decoded controllers drive ``KheperaHardwareEnv`` through ``ControllerPolicy`` - the same network
code as in training - so standard (signal as input) and situational (brain switch at the signal) teams both
work.  Every tick of every robot becomes one CSV row: the inputs the network saw, its three outputs, the
chosen action, the reflex's wheel motion, the exact ``D`` command sent, the measured control period and, when
known, the pose.  The log is flushed each tick, so a run cut short still leaves its record.

    mahn-evo deploy runs/s1/champion.json --ports /dev/rfcomm0 /dev/rfcomm1 /dev/rfcomm2
    mahn-evo deploy champion.json --ports socket://127.0.0.1:4000 socket://127.0.0.1:4001 socket://127.0.0.1:4002 \\
        --placement none
    mahn-evo deploy champion.json --emulate            # starts an in-process emulator, no robots needed
"""
from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core.params import ORIGINAL_MAX_TICKS, ORIGINAL_SIGNAL_TICK
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_envs.policies.team_controllers import TeamControllers

LOG_HEADER = ("tick", "time", "agent", "ir0", "ir1", "ir2", "ir3", "ir4", "ir5", "signal", "out_left",
              "out_forward", "out_right", "action", "motion", "command", "period", "x", "y", "heading")


@dataclass
class DeployResult:
    ticks: int
    log_path: Path
    mode: str
    mean_period: float
    max_period: float
    overruns: int
    team_fitness: float | None
    solved: bool | None


def load_team(path: str | Path) -> tuple[TeamControllers, dict[str, Any]]:
    """The controllers of a champion file (``{"controllers": {...}}``) or of a bare controllers file."""
    from .storage.files import read_json_object

    data = read_json_object(path, "champion")
    ctrl = data.get("controllers", data if "w_ih" in data else None)
    if not isinstance(ctrl, dict):
        raise ValueError(f"champion file {str(path)!r} has no 'controllers' object")
    try:
        team = TeamControllers.from_dict(ctrl)
    except ValueError as exc:
        raise ValueError(f"champion file {str(path)!r}: {exc}") from exc
    if team.batched:
        raise ValueError(f"champion file {str(path)!r} holds a batch of teams; deploy takes one team")
    return team, data


def _champion_driving(driving: Any, data: Mapping[str, Any], path: str | Path) -> Any:
    """`driving` (default Driving()) with the reflex variant the champion was evolved with (its `reflex_arc`,
    false in files before it): a team meets the situations its own reflex gives it, on robots as in simulation."""
    from mahn_envs.hardware import Driving

    if driving is not None and not isinstance(driving, Driving):
        raise TypeError(f"env_kwargs['driving'] must be a Driving record, got {type(driving).__name__}")
    arc = data.get("reflex_arc", False)
    if not isinstance(arc, bool):
        raise ValueError(f"champion file {str(path)!r}: field 'reflex_arc' must be true or false, got {arc!r}")
    return replace(driving or Driving(), reflex_arc=arc)


def _champion_sensing(sensing: Any, data: Mapping[str, Any], path: str | Path) -> Any:
    """`sensing` (default Sensing()) with the input ceiling the champion was evolved with (its `input_ceiling`,
    1, the original's encoding, in files before it): the robots encode their readings as the team learned them."""
    from mahn_envs.hardware import Sensing

    if sensing is not None and not isinstance(sensing, Sensing):
        raise TypeError(f"env_kwargs['sensing'] must be a Sensing record, got {type(sensing).__name__}")
    ceiling = data.get("input_ceiling", 1.0)
    try:
        return replace(sensing or Sensing(), input_ceiling=ceiling)
    except ValueError as exc:
        raise ValueError(f"champion file {str(path)!r}: field 'input_ceiling': {exc}") from None


def _fmt(v: float) -> str:
    return "" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.6g}"


def deploy(champion_path: str | Path, ports: Sequence[str] | None = None, *,
           log_path: str | Path | None = None, emulate: bool = False, emulator_seed: int = 0, clock: Any = None,
           env_kwargs: Mapping[str, Any] | None = None, on_tick: Callable[[int, dict], None] | None = None,
           quiet: bool = True, stop_wait: float | None = None) -> DeployResult:
    """Run the champion's team for one episode on the robots at `ports` and log every tick to CSV.

    How the robots run is the hardware env's own settings, passed as `env_kwargs` (the keyword arguments of
    ``KheperaHardwareEnv``, its settings records: ``episode=Episode(max_cycles=...)``,
    ``driving=Driving(reflex=False)``, ``sensing=Sensing(calibration="linear")``,
    ``link=Link(retry=RetryPolicy(timeout=0.2))``, ...), so each has one default and one validation, the env's.
    deploy chooses only: ``map`` (default the champion's), the placement when `env_kwargs` has no ``poses``
    (``Poses(placement="prompt")`` on robots: it waits for Enter and needs a terminal or a line on stdin;
    "none" with the emulator, which places its robots itself), the pose source with the emulator (unless
    ``poses`` has one), and the clock: `clock`, else real time at ``Timing.time_scale``.

    With ``emulate=True`` an in-process emulator stands in for the robots (`ports` must then be None); it
    also acts as the overhead tracker, so the log has poses and the result the task's fitness.  The CSV log is
    created once the robots are placed, so a run that fails before that leaves no empty log.  `clock`
    (default: real time) paces the env and the emulator; a VirtualClock runs lock-step.
    Returns a :class:`DeployResult`; the robots are stopped whatever happens.  A stop that a robot has not
    confirmed is resent in the background: before returning (or raising) deploy waits up to `stop_wait`
    seconds (None: until every robot confirms, or Ctrl-C) for it, since the resending ends with the program.
    """
    from mahn_envs.hardware import KheperaEmulator, KheperaHardwareEnv, Poses, RealClock, Timing

    kwargs = dict(env_kwargs or {})
    for name, kind in (("timing", Timing), ("poses", Poses)):
        if kwargs.get(name) is not None and not isinstance(kwargs[name], kind):
            raise TypeError(f"env_kwargs[{name!r}] must be a {kind.__name__} record, got {type(kwargs[name]).__name__}")
    timing = kwargs.pop("timing", None) or Timing()
    if timing.clock is not None:
        raise ValueError("pass the clock to deploy (clock=...), which paces the emulator too, not in env_kwargs")
    if clock is not None and timing.time_scale != 1.0:
        raise ValueError("give deploy either a clock or Timing(time_scale=...) in env_kwargs, not both")
    team, data = load_team(champion_path)
    map_name = kwargs.get("map") or data.get("map", "plus")
    kwargs["driving"] = _champion_driving(kwargs.get("driving"), data, champion_path)
    kwargs["sensing"] = _champion_sensing(kwargs.get("sensing"), data, champion_path)
    n = team.n_robots
    if emulate:
        if ports:
            raise ValueError("give either ports or emulate=True, not both")
    elif not ports:
        raise ValueError("deploy needs one port per robot (or emulate=True)")
    elif len(ports) != n:
        raise ValueError(f"the team has {n} robots but {len(ports)} port(s) were given")
    if log_path is None:
        stamp = time.strftime("%Y%m%d-%H%M%S")
        log_path = Path(champion_path).with_name(f"deploy-{stamp}.csv")
    log_path = Path(log_path)
    log_path.parent.mkdir(parents=True, exist_ok=True)
    poses = kwargs.pop("poses", None) or Poses(placement="none" if emulate else "prompt")
    clock = clock if clock is not None else RealClock(timing.time_scale)
    kwargs.update(map=map_name, timing=Timing(period=timing.period, clock=clock))
    emulator = None
    try:
        if emulate:
            emulator = KheperaEmulator(n, map=map_name, clock=clock, seed=emulator_seed).start()
            ports = emulator.ports
            poses = Poses(placement=_emulator_placement(emulator, poses.placement),
                          pose_source=poses.pose_source or emulator.poses)
        assert ports is not None  # the emulator's, or checked non-empty above
        env = KheperaHardwareEnv(list(ports), poses=poses, **kwargs)
        try:
            with env:
                policy = ControllerPolicy(team, env.possible_agents)  # compiles its network, before placement
                obs, infos = env.reset()
                policy.reset()
                return _run_episode(env, policy, team, obs, infos, clock, log_path, on_tick, quiet)
        finally:
            _wait_for_stops(env, stop_wait)
    finally:
        if emulator is not None:
            emulator.stop()


def _wait_for_stops(env: Any, stop_wait: float | None) -> None:
    """Keep the program (and so the background stop resending) alive until every robot confirmed its stop."""
    pending = env.unconfirmed_stops
    if not pending:
        return
    limit = "" if stop_wait is None else f" (at most {stop_wait:g} s)"
    print(f"deploy: the stop of {pending} is not confirmed; resending it until the robot answers{limit}, "
          "Ctrl-C to give up (then stop the robot by hand)", file=sys.stderr, flush=True)
    try:
        left = env.wait_stops(stop_wait)
    except KeyboardInterrupt:
        left = env.give_up_stops()
        print(f"deploy: gave up on the stop of {left}: STOP THEM BY HAND", file=sys.stderr, flush=True)
        raise
    if left:
        env.give_up_stops()
        print(f"deploy: the stop of {left} is still not confirmed: STOP THEM BY HAND", file=sys.stderr, flush=True)
    else:
        print(f"deploy: stop of {pending} confirmed", file=sys.stderr, flush=True)


def _emulator_placement(emulator: Any, placement: Any) -> Callable[[dict], None]:
    """The emulator puts its robots at the targets itself; an explicit "prompt" still asks first."""
    if placement == "prompt":
        from mahn_envs.hardware import prompt_placement

        def prompt_then_place(targets: dict) -> None:
            prompt_placement(targets)
            emulator.place(targets)

        return prompt_then_place
    if callable(placement):
        def call_then_place(targets: dict) -> None:
            placement(targets)
            emulator.place(targets)

        return call_then_place
    return emulator.place


def _run_episode(env: Any, policy: ControllerPolicy, team: TeamControllers, obs: dict, infos: dict, clock: Any,
                 log_path: Path, on_tick: Callable[[int, dict], None] | None, quiet: bool) -> DeployResult:
    """Drive the episode from its first observations, one CSV row per robot per tick."""
    with open(log_path, "w", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(LOG_HEADER)
        periods = []
        t0 = clock.now()
        last_infos = infos
        while env.agents:
            live = list(env.agents)
            actions = policy.act(obs)
            outputs = policy.outputs
            inputs = {a: obs[a].copy() for a in live}
            obs, rewards, terms, truncs, infos = env.step(actions)
            now = clock.now() - t0
            for k, a in enumerate(env.possible_agents):
                if a not in infos:
                    continue
                info = infos[a]
                pose = info["pose"] or (float("nan"),) * 3
                writer.writerow([info["tick"], f"{now:.4f}", a, *(f"{v:.6g}" for v in inputs[a]),
                                 *(f"{v:.6g}" for v in outputs[k]), actions[a], info["motion"],
                                 info["command"], f"{info['period']:.6f}", *(_fmt(v) for v in pose)])
            f.flush()
            periods.append(infos[live[0]]["period"])
            last_infos = infos
            if on_tick is not None:
                on_tick(infos[live[0]]["tick"], infos)
            if not quiet and infos[live[0]]["tick"] % 100 == 0:
                print(f"tick {infos[live[0]]['tick']}: period {periods[-1] * 1000:.1f} ms", flush=True)
        last = last_infos[env.possible_agents[0]]
        p = np.asarray(periods) if periods else np.zeros(1)
        return DeployResult(ticks=int(last.get("tick", 0)), log_path=log_path, mode=team.mode,
                            mean_period=float(p.mean()), max_period=float(p.max()), overruns=env.overruns,
                            team_fitness=last.get("team_fitness"), solved=last.get("solved"))


# ---------------------------------------------------------------------------------------------- CLI
def add_deploy_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``deploy`` on an argparse subparsers object; the parser's ``func`` runs it (returns an exit code).
    The defaults repeat the settings records' (tests/hardware/test_settings.py checks that they agree) so that
    building the ``mahn-evo`` parser does not import the hardware package."""
    p = subparsers.add_parser("deploy", help="run an evolved team on Khepera III robots or the emulator",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("champion", help="champion.json (or a controllers JSON file)")
    p.add_argument("--ports", nargs="+", default=None, metavar="URL",
                   help="one pyserial URL per robot: /dev/rfcomm0, socket://host:port, rfc2217://host:port")
    p.add_argument("--emulate", action="store_true", help="run against an in-process emulator instead of robots")
    p.add_argument("--log", default=None, help="CSV log path (default: deploy-<time>.csv next to the champion)")
    p.add_argument("--map", default=None, help="map for start poses and scoring (default: the champion's)")
    p.add_argument("--max-cycles", type=int, default=ORIGINAL_MAX_TICKS,
                   help="ticks to run (default %(default)s = 45 s, as the paper)")
    p.add_argument("--signal-tick", type=int, default=ORIGINAL_SIGNAL_TICK,
                   help="tick of the come-home signal (default %(default)s, as the paper)")
    p.add_argument("--no-auto-signal", action="store_true", help="no scheduled signal")
    p.add_argument("--placement", choices=["prompt", "none"], default=None,
                   help="prompt: wait for Enter after asking to place the robots (needs a terminal); none: they "
                        "are in place (use it without a terminal). Default: prompt with --ports, none with "
                        "--emulate (the emulator places its robots)")
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="robot seconds per wall second (only with an emulator started with the same value)")
    p.add_argument("--forward-speed", type=float, default=None, help="cm/s (default 9, the simulator's)")
    p.add_argument("--turn-rate", type=float, default=None, help="rad/s (default 2.0933, the simulator's)")
    p.add_argument("--wheel-base", type=float, default=8.85, help="cm (default 8.85)")
    p.add_argument("--speed-unit", type=float, default=None,
                   help="firmware units per mm/s (default: from the B reply, 218.72 for firmware >= 3)")
    p.add_argument("--calibration", choices=["paper", "linear"], default="paper", help="raw IR -> [0, 1]")
    p.add_argument("--no-reflex", action="store_true", help="turn the collision-avoidance reflex off")
    p.add_argument("--timeout", type=float, default=0.12, help="seconds to wait for a reply before resending "
                   "(default 0.12: with 3 attempts a silent robot is detected, and the others stopped, within 0.5 s)")
    p.add_argument("--attempts", type=int, default=3, help="tries per command (default 3)")
    p.add_argument("--seed", type=int, default=0, help="emulator noise seed (with --emulate)")
    p.set_defaults(func=run_deploy)
    return p


def run_deploy(args: argparse.Namespace) -> int:
    import signal as _signal
    import threading

    def _exit_on_sigterm(signum: int, frame: Any) -> None:
        raise SystemExit(128 + signum)

    previous = None
    if threading.current_thread() is threading.main_thread():  # SIGTERM -> SystemExit: the stops still run
        previous = _signal.signal(_signal.SIGTERM, _exit_on_sigterm)
    try:
        result = deploy(args.champion, args.ports, log_path=args.log, emulate=args.emulate,
                        emulator_seed=args.seed, env_kwargs=_env_kwargs(args), quiet=False)
    except KeyboardInterrupt:
        print("deploy: interrupted; robots stopped", file=sys.stderr)
        return 130
    except (ValueError, RuntimeError, OSError) as exc:
        print(f"deploy: {exc}", file=sys.stderr)
        return 1
    finally:
        if previous is not None:
            _signal.signal(_signal.SIGTERM, previous)
    fit = "n/a (no pose tracking)" if result.team_fitness is None else f"{result.team_fitness:.3f}"
    print(f"{result.mode} team, {result.ticks} ticks; control period mean {result.mean_period * 1000:.1f} ms, "
          f"max {result.max_period * 1000:.1f} ms, {result.overruns} overruns; team fitness {fit}, "
          f"solved {result.solved}; log {result.log_path}")
    return 0


def _env_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The hardware env's settings (KheperaHardwareEnv keywords: its records) from the command line; without
    --placement deploy picks it (prompt on robots, none with the emulator)."""
    from mahn_envs.hardware import Driving, Episode, Link, Poses, RetryPolicy, Sensing, Timing

    kwargs: dict[str, Any] = dict(
        map=args.map,
        episode=Episode(max_cycles=args.max_cycles, signal_tick=args.signal_tick,
                        auto_signal=not args.no_auto_signal),
        driving=Driving(forward_speed=args.forward_speed, turn_rate=args.turn_rate, wheel_base=args.wheel_base,
                        speed_unit="auto" if args.speed_unit is None else args.speed_unit,
                        reflex=not args.no_reflex),
        sensing=Sensing(calibration=args.calibration),
        timing=Timing(time_scale=args.time_scale),
        link=Link(retry=RetryPolicy(timeout=args.timeout, attempts=args.attempts)))
    if args.placement is not None:
        kwargs["poses"] = Poses(placement=args.placement)
    return kwargs


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="mahn-evo")
    sub = parser.add_subparsers(dest="command", required=True)
    add_deploy_parser(sub)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
