"""Team policies: what drives the robots of a team, in simulation or on hardware.

This folder holds the evolved team's controllers as plain arrays and their JSON form (`team_controllers`,
`TeamControllers`), the policy that runs them tick by tick on PettingZoo observation dicts (`controller_policy`,
`ControllerPolicy`), the one interface every team policy implements so any protocol runs any team
(`team_policy`, `TeamPolicy`; RL policies in `baselines` implement it too) and the hand-written reference team
that follows waypoints from the poses (`scripted`, `WaypointTeam`).  The compiled network itself is the core's
(`mahn_envs.core.controller`).
"""
from .controller_policy import ControllerPolicy
from .scripted import WaypointTeam
from .team_controllers import TeamControllers
from .team_policy import TeamPolicy

__all__ = ["TeamControllers", "ControllerPolicy", "TeamPolicy", "WaypointTeam"]
