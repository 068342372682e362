"""KheperaHardwareEnv: the patrol-and-return env's interface driving real Khepera III robots (or the emulator).

Same agents, spaces and step semantics as ``PatrolReturnEnv``: one observation per agent (six IR values in
[0, 1], 1 = free, values at or below the 0.25 floor read 0, then the come-home signal), one Discrete(3) action
(0 left, 1 forward with the collision-avoidance reflex, 2 right), a tick of 33 ms.  One step:

1. every action goes through the simulator's reflex (on the un-floored readings the agent saw) to a wheel
   motion, then to a ``D`` command in firmware units; the commands go out to all robots, then the replies are
   read (one round trip for the team);
2. the env waits for the tick's deadline (real-time pacing; the measured period is in ``infos``);
3. ``N`` is read from every robot and calibrated to [0, 1]; the signal schedule is applied; those are the
   next observations.

Safety: every robot is sent ``D,l0,l0`` on ``close()``, at the end of an episode, on any exception inside
``reset``/``step`` (including Ctrl-C and a robot that stops answering), at interpreter exit and on SIGTERM;
the env is a context manager.  On the error paths the stops go to all robots in parallel; a stop counts only
when the robot answers that stop (transport.py), and one that is not confirmed is reported (a warning,
``last_stop_report``) and resent in the background until it is.  A robot whose link is dead cannot be
reached by anyone: it needs a robot-side watchdog (docs/hardware.md, section 4).

Rewards need to know where the robots are: give ``Poses(pose_source=...)`` (an overhead tracker; the emulator
provides one) and the env scores the run with the simulator's own fitness code, so ``team_fitness`` /
``solved`` mean exactly what they mean in simulation.  Without it rewards are 0 and those infos are None.
"""
from __future__ import annotations

import atexit
import signal as _signal
import threading
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from ..core.api import ScoreKeeper, encode_inputs
from ..khepera import DEFAULT_MODEL, KheperaModel
from ..maps import World, load_map
from ..patrol_return.env import agent_names, agent_policy_coordinates, coerce_actions, coerce_poses, task_spaces
from . import protocol as P
from .errors import HardwareError, ProtocolError
from .kinematics import SPEED_UNIT_V3, reflex_motion, speed_unit_for_version
from .settings import Driving, Episode, Link, Poses, Sensing, Timing
from .transport import RetryPolicy, RobotLink

NEVER_CONNECTED = "never connected: no command was sent to it"
Placement = Callable[[dict], None]


def prompt_placement(targets: Mapping[str, tuple | None], input_fn: Callable[[str], str] | None = None,
                     print_fn: Callable[..., None] = print) -> None:
    """Ask the operator to put the robots at their start poses and press Enter.  Without a terminal (stdin at
    its end) this is a RuntimeError that names ``--placement none``, not an EOFError traceback."""
    input_fn = input_fn if input_fn is not None else input
    print_fn("Place the robots (map frame: x right, y up, cm; heading in degrees, 90 = up):")
    for agent, pose in targets.items():
        if pose is None:
            print_fn(f"  {agent}: anywhere safe")
        else:
            print_fn(f"  {agent}: x={pose[0]:.1f} y={pose[1]:.1f} heading={np.degrees(pose[2]) % 360:.0f} deg")
    try:
        input_fn("Robots are stopped. Press Enter when they are in place... ")
    except EOFError:
        raise RuntimeError("the placement prompt needs someone to press Enter, but stdin is closed (no terminal); "
                           "place the robots first and run with --placement none (Poses(placement='none') in Python)") \
            from None


R = TypeVar("R")


def _record(name: str, value: R | None, kind: type[R]) -> R:
    """The settings record passed as `name` (None: the defaults); anything else is a TypeError naming it."""
    if value is None:
        return kind()
    if not isinstance(value, kind):
        raise TypeError(f"{name} must be a {kind.__name__} record (mahn_envs.hardware.{kind.__name__}), "
                        f"got {type(value).__name__}")
    return value


def _no_placement(targets: Mapping[str, Any]) -> None:
    return None


def _sigterm_to_exit(signum: int, frame: Any) -> None:
    raise SystemExit(128 + signum)


class _Stopper:
    """One robot's stop, sent from its own daemon thread: the stop stays the link's pending command, resent
    every `interval` seconds, until one of its own writes is answered (see transport: a late reply to an
    earlier command never counts) or it is cancelled.  The thread owns the link while it runs."""

    def __init__(self, env: KheperaHardwareEnv, link: RobotLink, interval: float) -> None:
        self.env, self.link, self.interval = env, link, interval
        self.confirmed = threading.Event()
        self.cancelled = threading.Event()
        self.thread = threading.Thread(target=self._run, name=f"khepera-stop-{link.name}", daemon=True)

    def _run(self) -> None:
        name = self.link.name
        try:
            reply = self.link.transact_until_answered(P.STOP, self.interval, self.cancelled,
                                                      on_error=lambda e: self.env._stop_failed(name, e))
        except BaseException as exc:  # noqa: BLE001 - a bug here must still show in the report
            self.env._stop_failed(name, exc)
            return
        if reply is not None:
            self.env._stop_confirmed(name)
            self.confirmed.set()
            if self.env._closed:
                self.link.close()


class KheperaHardwareEnv(ParallelEnv):
    """Real Khepera III robots (one per pyserial URL in `ports`) behind the patrol_return_v0 interface.

    Everything but `ports` is optional, and every default reproduces the simulator.  `map` gives the start
    poses and the scoring; the settings come as one record per concern (``hardware.settings``, each validated
    when made): `driving` (reflex, speeds, wheel base, firmware speed unit), `sensing` (calibration, floor),
    `timing` (period, real-time scale or a clock), `episode` (max_cycles, signal_tick, auto_signal,
    signal_schedule), `poses` (placement, pose_source: a tracker enables rewards and ``infos['pose']``),
    `link` (retry policy, baudrate, eol, opener).  `model` is the simulated robot the team was trained on (the
    default speeds, floor and tick come from it), `render_mode` as in the simulated env, and `catch_sigterm`
    turns SIGTERM into SystemExit so the stops run.  ``call_home()`` / ``clear_signal()`` give signals by hand::

        KheperaHardwareEnv(ports, map="plus", timing=Timing(time_scale=4), link=Link(retry=RetryPolicy(0.2)))
    """

    metadata: dict[str, Any] = {"name": "khepera_hardware_v0", "render_modes": ["human", "rgb_array"], "render_fps": 30,
                "is_parallelizable": True}

    def __init__(self, ports: Sequence[str], *, map: str | World = "plus", driving: Driving | None = None,
                 sensing: Sensing | None = None, timing: Timing | None = None, episode: Episode | None = None,
                 poses: Poses | None = None, link: Link | None = None, model: KheperaModel = DEFAULT_MODEL,
                 render_mode: str | None = None, catch_sigterm: bool = True) -> None:
        self._links: list[RobotLink] = []
        self._closed = False
        self._prev_sigterm: Any = None
        self.agents: list[str] = []
        if isinstance(ports, (str, bytes)) or not isinstance(ports, Sequence) or len(ports) == 0:
            raise ValueError("ports must be a non-empty list of pyserial URLs, one per robot "
                             "(e.g. ['/dev/rfcomm0', 'socket://127.0.0.1:4001'])")
        for p in ports:
            if not isinstance(p, str) or not p:
                raise ValueError(f"every port must be a non-empty string (a pyserial URL), got {p!r}")
        driving = _record("driving", driving, Driving)
        sensing = _record("sensing", sensing, Sensing)
        timing = _record("timing", timing, Timing)
        episode = _record("episode", episode, Episode)
        poses = _record("poses", poses, Poses)
        link = _record("link", link, Link)
        if not isinstance(model, KheperaModel):
            raise TypeError(f"model must be a KheperaModel, got {type(model).__name__}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, "
                             f"got {render_mode!r}")
        if render_mode is not None and poses.pose_source is None:
            raise ValueError("rendering real robots needs to know where they are: pass Poses(pose_source=...)")
        self.world = load_map(map)
        self.model = model
        n = len(ports)
        self.ports = list(ports)
        self.possible_agents = agent_names(n)
        self.agent_index = {a: k for k, a in enumerate(self.possible_agents)}
        self.policy_coordinates = agent_policy_coordinates(self.possible_agents)
        self.drive = driving.drive(model)
        self.reflex = driving.reflex
        self.reflex_arc = driving.reflex_arc
        speed_units = self._check_speed_units(driving.speed_unit, n)
        self.calibration = sensing.calibration
        self.sensor_floor = sensing.floor(model)
        self.input_ceiling = float(sensing.input_ceiling)
        self.period = timing.tick_seconds(model)
        self.clock = timing.make_clock()
        self.params = episode.task_params()
        self.signal_schedule = self._check_schedule(episode.signal_schedule)
        self._placement = self._placement_function(poses.placement)
        if poses.pose_source is not None and n != self.world.n_robots:
            raise ValueError(f"scoring needs one robot per start pose of map {self.world.name!r} "
                             f"({self.world.n_robots}), got {n} ports")
        self.pose_source = poses.pose_source
        self.retry = link.retry
        self._stop_policy = RetryPolicy(timeout=self.retry.timeout, attempts=min(2, self.retry.attempts),
                                        reconnects=min(1, self.retry.reconnects))
        self.render_mode = render_mode
        self._renderer = None
        self._obs_space, self._act_space, self.state_space = task_spaces(self.world, n)
        self.observation_spaces = {a: self._obs_space for a in self.possible_agents}
        self.action_spaces = {a: self._act_space for a in self.possible_agents}
        # per-episode state
        self._q = np.ones((n, 6))  # un-floored calibrated readings the agents last saw (the reflex uses them)
        self._raw = np.zeros((n, 11), dtype=np.int64)
        self._moving = np.zeros(n, dtype=bool)
        # the tick, the signals and (with a pose source) the score: the core's own rules on the given poses
        self._score = ScoreKeeper(self.world, self.params, model, n_robots=n)
        self._fitness = 0.0
        self._solved = False
        self._t_read = 0.0
        self._deadline = 0.0
        self._period_measured = 0.0
        self.overruns = 0
        self.last_stop_report: dict[str, str | None] = {}
        self._stoppers: dict[str, _Stopper] = {}
        self._report_lock = threading.Lock()
        self.firmware: dict[str, tuple[int, int] | None] = {}
        self.speed_units: list[float] = []
        self._compile_rules()
        # connect; on any failure stop and close what was opened
        self._atexit_hook = self._at_exit
        atexit.register(self._atexit_hook)
        if catch_sigterm:
            self._install_sigterm()
        try:
            self._connect(link, speed_units)
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ configuration checks
    def _compile_rules(self) -> None:
        """Compile (or load from numba's cache) every compiled rule a tick runs, before any robot is connected.
        Without it the first tick that reaches a rule compiles it (seconds with a cold cache, as after an install
        or an update) while the robots drive on their last command, and a reply can time out meanwhile; measured
        before this: the score, the fitness, the reflex and the input encoding compiled inside the first ticks
        (tests/hardware/test_compiled_ahead.py)."""
        self._score.compile_rules()
        encode_inputs(self._q, self._score.signals, self.sensor_floor, self.input_ceiling)
        for action in (0, 1, 2):
            reflex_motion(action, self._q[0], False, self.sensor_floor, self.reflex, self.reflex_arc)

    def _check_speed_units(self, speed_unit: str | float | tuple[float, ...], n: int) -> list[float | None]:
        """One speed unit per robot (None: read from the firmware's B reply)."""
        if isinstance(speed_unit, str):  # "auto", the only string Driving accepts
            return [None] * n
        if isinstance(speed_unit, float):
            return [speed_unit] * n
        if len(speed_unit) != n:
            raise ValueError(f"Driving.speed_unit lists {len(speed_unit)} values for {n} robots")
        return list(speed_unit)

    def _check_schedule(self, schedule: Mapping[str, int]) -> dict[str, int]:
        for agent in schedule:
            if agent not in self.agent_index:
                raise ValueError(f"Episode.signal_schedule names unknown agent {agent!r}; "
                                 f"agents are {self.possible_agents}")
        return dict(schedule)

    @staticmethod
    def _placement_function(placement: str | Placement) -> Placement:
        if placement == "prompt":
            return prompt_placement
        if placement == "none":
            return _no_placement
        assert callable(placement)  # Poses accepts nothing else
        return placement

    def _install_sigterm(self) -> None:
        """Turn SIGTERM into SystemExit so the stop commands run (only from the main thread, only if nobody
        else handles SIGTERM)."""
        if threading.current_thread() is not threading.main_thread():
            return
        try:
            if _signal.getsignal(_signal.SIGTERM) is _signal.SIG_DFL:
                _signal.signal(_signal.SIGTERM, _sigterm_to_exit)
                self._prev_sigterm = _signal.SIG_DFL
        except (ValueError, OSError, AttributeError):  # pragma: no cover - platforms without SIGTERM
            pass

    def _connect(self, settings: Link, units: list[float | None]) -> None:
        n = len(self.ports)
        for agent, url in zip(self.possible_agents, self.ports):
            link = RobotLink(url, agent, settings.retry, baudrate=settings.baudrate, eol=settings.eol,
                             opener=settings.opener)
            self._links.append(link)
            link.open()
        for k, link in enumerate(self._links):
            agent = self.possible_agents[k]
            try:
                ver = link.transact(P.version())
                assert isinstance(ver, P.Version)  # parse_reply answers B with a Version or raises
                self.firmware[agent] = (ver.version, ver.revision)
            except ProtocolError as exc:
                if exc.reply != P.ERROR_MARK:
                    raise
                if units[k] is None:
                    warnings.warn(f"{agent}: firmware does not answer B; assuming speed unit {SPEED_UNIT_V3} "
                                  "units per mm/s (set it with Driving(speed_unit=...))", stacklevel=3)
                self.firmware[agent] = None
            if units[k] is None:
                fw = self.firmware[agent]
                units[k] = SPEED_UNIT_V3 if fw is None else speed_unit_for_version(*fw)
            link.transact(P.init_motors())
        self.speed_units = [float(u) for u in units]  # type: ignore[arg-type]
        self._broadcast([P.STOP] * n)

    # ------------------------------------------------------------------ spaces
    def observation_space(self, agent: str) -> spaces.Box:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Discrete:
        return self.action_spaces[agent]

    @property
    def max_cycles(self) -> int:
        return self.params.max_cycles

    @max_cycles.setter
    def max_cycles(self, value: int) -> None:
        from dataclasses import replace

        self.params = replace(self.params, max_cycles=value)
        self._score.params = self.params

    @property
    def tick(self) -> int:
        return self._score.tick

    # ------------------------------------------------------------------ I/O
    def _broadcast(self, commands: Sequence[P.Command]) -> list[P.Reply]:
        """Send one command to every robot, then collect the replies (one round trip for the team)."""
        for link, cmd in zip(self._links, commands):
            link.send(cmd)
        return [link.finish() for link in self._links]

    def _read_sensors(self) -> None:
        replies = self._broadcast([P.read_proximity()] * len(self._links))
        for k, rep in enumerate(replies):
            assert isinstance(rep, P.SensorReading)  # parse_reply answers N with a SensorReading or raises
            self._raw[k] = rep.values
        front = self._raw[:, list(P.FRONT_SENSORS)]
        q = np.asarray(self.calibration.to_unit(front), dtype=np.float64)
        if q.shape != front.shape or not np.all(np.isfinite(q)):
            raise ValueError(f"calibration {getattr(self.calibration, 'name', self.calibration)!r} returned "
                             f"{q!r} for raw {front.tolist()}: expected finite values of shape {front.shape}")
        self._q[:] = q

    def _read_poses(self) -> np.ndarray | None:
        """The pose source's (n, 3) poses now, or None without one."""
        if self.pose_source is None:
            return None
        raw = self.pose_source()
        if isinstance(raw, Mapping):
            arr = np.array([raw[a] for a in self.possible_agents], dtype=np.float64)
        else:
            arr = np.asarray(raw, dtype=np.float64)
        n = len(self.possible_agents)
        if arr.shape != (n, 3):
            raise ValueError(f"pose_source must return {n} poses (x, y, heading), got shape {arr.shape}")
        return arr

    def _observations(self) -> dict[str, np.ndarray]:
        obs = encode_inputs(self._q, self._score.signals, self.sensor_floor, self.input_ceiling)
        return {a: obs[k] for k, a in enumerate(self.agents)}

    def _info(self, k: int, extra: dict | None = None) -> dict[str, Any]:
        p = self._score.poses[k]
        info = {"pose": None if not np.all(np.isfinite(p[:3])) else (float(p[0]), float(p[1]), float(p[2])),
                "signal": bool(self._score.signals[k]), "tick": self._score.tick,
                "period": self._period_measured, "raw_ir": tuple(int(v) for v in self._raw[k, list(P.FRONT_SENSORS)])}
        if extra:
            info.update(extra)
        return info

    # ------------------------------------------------------------------ episode
    def reset(self, seed: int | None = None, options: dict | None = None):
        """Stop the robots, let the operator place them, read the sensors.  `seed` only seeds the spaces
        (hardware has no randomness to seed); ``options['poses']`` = {agent: (x, y, heading)} targets."""
        self._check_open()
        self._check_stops_confirmed()
        try:
            return self._reset(seed, options)
        except BaseException as exc:
            self._emergency_stop(exc)
            raise

    def _reset(self, seed: int | None, options: dict | None):
        if seed is not None:
            if seed < 0:
                raise ValueError(f"seed must be a non-negative integer, got {seed}")
            for i, a in enumerate(self.possible_agents):
                self.action_spaces[a].seed(seed + 1 + i)
                self.observation_spaces[a].seed(seed + 101 + i)
        options = dict(options or {})
        poses = options.pop("poses", None)
        if options:
            raise ValueError(f"unknown reset option(s) {sorted(options)}; known: ['poses']")
        targets: dict[str, tuple | None] = {}
        for k, a in enumerate(self.possible_agents):
            targets[a] = tuple(float(v) for v in self.world.starts[k]) if k < self.world.n_robots else None
        if poses is not None:
            targets.update(coerce_poses(poses, self.possible_agents))
        self.agents = []
        self._broadcast([P.STOP] * len(self._links))
        self._placement(dict(targets))
        self._moving[:] = False
        self._fitness = 0.0
        self._solved = False
        self.overruns = 0
        self._period_measured = 0.0
        self._read_sensors()
        self._t_read = self.clock.now()
        self._deadline = self._t_read + self.period
        self._score.reset(self._read_poses())
        self.agents = list(self.possible_agents)
        observations = self._observations()
        infos = {a: self._info(k) for k, a in enumerate(self.agents)}
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def step(self, actions: dict):
        self._check_open()
        if not self.agents:
            raise RuntimeError("step() called on a finished episode; call reset() first")
        try:
            return self._step(actions)
        except BaseException as exc:
            self._emergency_stop(exc)
            raise

    def _step(self, actions: dict):
        acts = coerce_actions(actions, self.agents, self.possible_agents)
        # 1. actions -> reflex -> wheel commands, to every robot
        motions, commands = [], []
        for k, action in enumerate(acts):
            m = reflex_motion(action, self._q[k], bool(self._moving[k]), self.sensor_floor, self.reflex,
                              self.reflex_arc)
            self._moving[k] = m.moving
            motions.append(m)
            commands.append(P.set_speed(*self.drive.units(m, self.speed_units[k])))
        t_cmd = time.monotonic()
        self._broadcast(commands)
        command_latency = time.monotonic() - t_cmd
        # 2. pace: the next reading is one period after the last one
        self.clock.sleep_until(self._deadline)
        now = self.clock.now()
        self._period_measured = now - self._t_read
        overrun = self._period_measured > 1.5 * self.period
        if overrun:
            self.overruns += 1
        self._deadline = (now + self.period) if now - self._deadline > self.period else self._deadline + self.period
        self._t_read = now
        # 3. sense, signal, score
        self._read_sensors()
        self._after_motion(self._read_poses())
        done = self._score.tick >= self.params.max_cycles
        observations = self._observations()
        if self.pose_source is not None:
            fit, solved = self._score.fitness()
            reward = float(fit - self._fitness)
            self._fitness, self._solved = float(fit), bool(solved)
        else:
            reward = 0.0
        rewards = {a: reward for a in self.agents}
        terminations = {a: False for a in self.agents}
        truncations = {a: done for a in self.agents}
        infos = {a: self._info(k, {"motion": motions[k].name.lower(), "command": commands[k].text,
                                   "overrun": overrun, "command_latency": command_latency})
                 for k, a in enumerate(self.agents)}
        if done:
            for a in self.agents:
                infos[a]["team_fitness"] = self._fitness if self.pose_source is not None else None
                infos[a]["solved"] = self._solved if self.pose_source is not None else None
            self.agents = []
            self._broadcast([P.STOP] * len(self._links))  # the episode is over: nothing keeps driving
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def _after_motion(self, poses: np.ndarray | None) -> None:
        """The tick has passed: the core's fitness sample and automatic signal (only the signal without poses),
        then this env's scheduled signals."""
        self._score.advance(poses)
        for agent, t in self.signal_schedule.items():
            if t == self._score.tick:
                self._score.set_signal(self.agent_index[agent], True)

    # ------------------------------------------------------------------ operator signal
    def call_home(self, agent: str) -> None:
        """Give one robot the come-home signal now (it shows in the next observation)."""
        self._score.set_signal(self._index(agent), True)

    def clear_signal(self, agent: str) -> None:
        self._score.set_signal(self._index(agent), False)

    def _index(self, agent: str) -> int:
        try:
            return self.agent_index[agent]
        except KeyError:
            raise ValueError(f"unknown agent {agent!r}; agents are {self.possible_agents}") from None

    # ------------------------------------------------------------------ safety
    def stop_all(self) -> dict[str, str | None]:
        """Send every robot a stop, all in parallel (one thread per robot), and wait until each stop is
        confirmed by its own reply or the stop policy's attempts have passed (timeout x attempts, 0.8 s by
        default).  A stop that is not confirmed by then is reported as "unconfirmed" (with a warning) and
        its thread keeps resending it in the background until the robot answers one of those stops (the
        report then says None) or the program exits.  Returns ``last_stop_report``: {agent: None if the
        robot confirmed a stop, else the reason}; never raises."""
        policy = self._stop_policy
        started: list[_Stopper] = []
        for link in self._links:
            if link.stats.commands == 0:  # never reached: nothing of ours can be driving it
                with self._report_lock:
                    self.last_stop_report[link.name] = NEVER_CONNECTED
                continue
            stopper = self._stoppers.get(link.name)
            if stopper is None or not stopper.thread.is_alive():  # none running (a finished one is replaced)
                stopper = _Stopper(self, link, policy.timeout)
                self._stoppers[link.name] = stopper
                with self._report_lock:
                    self.last_stop_report[link.name] = "unconfirmed: stop being sent"
                started.append(stopper)
        for stopper in started:
            stopper.thread.start()
        deadline = time.monotonic() + policy.timeout * policy.attempts
        for stopper in list(self._stoppers.values()):
            stopper.confirmed.wait(max(0.0, deadline - time.monotonic()))
        for name, stopper in list(self._stoppers.items()):
            if stopper.confirmed.is_set():
                stopper.thread.join()
                del self._stoppers[name]
        with self._report_lock:
            report = {link.name: self.last_stop_report.get(link.name) for link in self._links}
            self.last_stop_report = report
        bad = {a: e for a, e in report.items() if e is not None and e != NEVER_CONNECTED}
        if bad:
            warnings.warn(f"stop not confirmed for {sorted(bad)} (retrying in the background until each robot "
                          f"answers a stop; see env.last_stop_report): {bad}", stacklevel=3)
        return dict(report)

    @property
    def unconfirmed_stops(self) -> list[str]:
        """Robots whose stop is still being resent in the background."""
        return [name for name, s in self._stoppers.items() if not s.confirmed.is_set()]

    def wait_stops(self, timeout: float | None = None) -> list[str]:
        """Wait (at most `timeout` seconds) for the background stops to be confirmed; returns the robots
        still unconfirmed."""
        deadline = None if timeout is None else time.monotonic() + timeout
        for stopper in list(self._stoppers.values()):
            stopper.confirmed.wait(None if deadline is None else max(0.0, deadline - time.monotonic()))
        return self.unconfirmed_stops

    def give_up_stops(self) -> list[str]:
        """Stop resending unconfirmed stops (you have stopped those robots by other means, e.g. switched them
        off) and close their links; returns the robots given up on.  Their report stays "unconfirmed"."""
        given_up = self.unconfirmed_stops
        for name in given_up:
            self._stoppers[name].cancelled.set()
        for name in list(self._stoppers):
            stopper = self._stoppers[name]
            stopper.thread.join(5.0)
            if not stopper.thread.is_alive():
                if name in given_up:
                    stopper.link.close()
                del self._stoppers[name]
        return given_up

    def _stop_confirmed(self, name: str) -> None:
        with self._report_lock:
            self.last_stop_report[name] = None

    def _stop_failed(self, name: str, error: BaseException) -> None:
        with self._report_lock:
            self.last_stop_report[name] = f"unconfirmed: {type(error).__name__}: {error}"

    def _check_stops_confirmed(self) -> None:
        pending = self.unconfirmed_stops
        if pending:
            raise RuntimeError(f"the stop of {pending} is not confirmed yet (it is resent in the background until "
                               f"the robot answers; env.wait_stops() waits for it, env.last_stop_report says why)")

    def _emergency_stop(self, exc: BaseException) -> None:
        self.agents = []
        self.stop_all()

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("the hardware env is closed")

    def close(self) -> None:
        """Stop every robot and close the links.  Safe to call more than once."""
        if self._closed:
            return
        self._closed = True
        self.agents = []
        try:
            if self._links:
                self.stop_all()
        finally:
            # pyserial's socket:// close waits 0.3 s per port ("give the server some time"): close in parallel
            # a link whose stop is still unconfirmed stays with its stop thread, which closes it when confirmed
            owned = set(self.unconfirmed_stops)
            closers = [threading.Thread(target=link.close, name=f"khepera-close-{link.name}", daemon=True)
                       for link in self._links if link.name not in owned]
            for t in closers:
                t.start()
            for t in closers:
                t.join(5.0)
            atexit.unregister(self._atexit_hook)
            if self._prev_sigterm is not None:
                try:
                    if _signal.getsignal(_signal.SIGTERM) is _sigterm_to_exit:
                        _signal.signal(_signal.SIGTERM, self._prev_sigterm)
                except (ValueError, OSError):  # pragma: no cover - not in the main thread
                    pass
            if self._renderer is not None:
                self._renderer.close()
                self._renderer = None

    def _at_exit(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 - at exit, stopping is all that matters
            pass

    def __enter__(self) -> KheperaHardwareEnv:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # ------------------------------------------------------------------ state, rendering
    def state(self) -> np.ndarray:
        """(x, y, heading, signal) of every robot, robot-major; NaN poses without a pose_source."""
        s = np.concatenate([self._score.poses, self._score.signals[:, None]], axis=1)
        return s.astype(np.float32).reshape(-1)

    def render(self):
        from ..patrol_return.rendering import render_env

        rays = np.minimum(self.model.radius + self._q * self.model.ir_range, self.model.sensor_range)
        return render_env(self, self._score.poses, rays, self._score.signals.astype(bool), self._score.tick,
                          self._fitness)


__all__ = ["KheperaHardwareEnv", "prompt_placement", "HardwareError"]
