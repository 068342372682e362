"""Score a saved champion (`mahn-evo eval`): any map, either engine, noise, several episodes, optional video.

Kinematic episodes run in the batch core; pymunk episodes (and videos) run through the PettingZoo env with a
ControllerPolicy.  Both paths share the task code, so the same team scores the same (tested to 1e-9).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core import BatchSim, TaskParams
from mahn_envs.policies.controller_policy import ControllerPolicy

from ..training.champion import Champion
from .task_setup import task_env


def champion_policy(champ: Champion) -> ControllerPolicy:
    """The champion's team as a protocol policy for the env's agents robot_0, robot_1, ... (the sequential
    protocol and deploy drive teams through this, the training protocol through the batch core)."""
    return ControllerPolicy(champ.controllers, [f"robot_{k}" for k in range(champ.controllers.n_robots)])


def evaluate_champion(champion: Champion | str | Path, map: str = "plus", engine: str = "kinematic",
                      episodes: int = 1, params: TaskParams | None = None, seed: int = 0,
                      video: str | Path | None = None, video_every: int = 4, video_scale: float = 1.0
                      ) -> dict[str, Any]:
    """Per-episode and mean team fitness and `solved`; writes a GIF of the first episode if `video`."""
    champ = champion if isinstance(champion, Champion) else Champion.load(champion)
    params = champ.task(params)
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    fits: list[float] = []
    solved: list[bool] = []
    if engine == "kinematic" and video is None:
        sim = BatchSim(map, episodes, params)
        res = sim.run_controllers(champ.controllers, seed=seed)
        fits, solved = res.fitness.tolist(), [bool(s) for s in res.solved]
    else:
        for e in range(episodes):
            env = task_env(map, params, engine, render_mode="rgb_array" if (video and e == 0) else None)
            obs, _ = env.reset(seed=seed if episodes == 1 else seed + e)
            policy = ControllerPolicy(champ.controllers, env.possible_agents)
            frames = [env.render()] if (video and e == 0) else None
            while env.agents:
                obs, rew, te, tr, infos = env.step(policy.act(obs))
                if frames is not None and (env.sim.tick % video_every == 0 or not env.agents):
                    frames.append(env.render())
            info = infos[env.possible_agents[0]]
            fits.append(info["team_fitness"])
            solved.append(info["solved"])
            if frames is not None and video is not None:
                from ..plots import save_gif

                save_gif(frames, video, fps=max(1, int(30 / video_every)), scale=video_scale)
            env.close()
    return {"champion_mode": champ.mode, "map": map, "engine": engine, "episodes": episodes, "seed": seed,
            "params": params.to_dict(), "fitness": float(np.mean(fits)), "solved": bool(all(solved)),
            "solved_fraction": float(np.mean(solved)), "episode_fitness": fits, "episode_solved": solved}
