"""Real Khepera III robots behind the patrol_return_v0 interface, and an emulator to run that path without them.

- :class:`KheperaHardwareEnv` (``env``): the PettingZoo ParallelEnv on real robots, configured by one record per
  concern (``settings``: :class:`Driving`, :class:`Sensing`, :class:`Timing`, :class:`Episode`, :class:`Poses`,
  :class:`Link`).
- ``protocol``: codec of K-Team's ASCII protocol; ``transport``: one pyserial link per robot with timeouts and
  bounded retries; ``calibration``: raw IR <-> [0, 1]; ``kinematics``: the simulator's decisions (the core's
  reflex) as wheel motions, motions <-> firmware wheel units; ``clock``: real, scaled and lock-step time.
- :class:`KheperaEmulator` (``emulator``): TCP servers answering the protocol from the simulator
  (``mahn-envs emulate``), with fault injection.
See docs/hardware.md.
"""
from __future__ import annotations

from .calibration import LinearCalibration, LogCalibration, TableCalibration, make_calibration
from .clock import RealClock, VirtualClock
from .emulated_world import EmulatedWorld
from .emulator import Fault, KheperaEmulator, parse_fault
from .env import KheperaHardwareEnv, prompt_placement
from .errors import HardwareError, LinkError, ProtocolError, RobotTimeout
from .kinematics import Drive, Motion, reflex_motion, speed_unit_for_version
from .settings import Driving, Episode, Link, Poses, Sensing, Timing
from .transport import RetryPolicy, RobotLink

__all__ = ["KheperaHardwareEnv", "Driving", "Sensing", "Timing", "Episode", "Poses", "Link", "KheperaEmulator",
           "EmulatedWorld", "Fault", "parse_fault", "RetryPolicy", "RobotLink", "RealClock", "VirtualClock",
           "LogCalibration", "LinearCalibration", "TableCalibration", "make_calibration", "Motion", "reflex_motion",
           "Drive", "speed_unit_for_version", "HardwareError", "LinkError", "ProtocolError", "RobotTimeout",
           "prompt_placement"]
