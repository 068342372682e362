"""How firmly a team decides: the gap between the winning output and the runner-up, tick by tick.

Why this exists: evolution in the original's noise-free float32 world can find teams whose three outputs are
saturated near 1.0 and whose every decision is an exact tie (forward wins ties, left beats right) or a gap of a
few float32 units in the last place.  Outputs saturated near 0 do the same with gaps of 1e-6.  Such a team scores perfectly, then fails under any noise or on a real robot,
because noise of 1e-4 flips those decisions.  The margins make that visible before anyone spends a day on
transfer tests: a team with most decisions tied is brittle by construction.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Optional

import numpy as np

from mahn_envs import patrol_return_v0
from mahn_envs.core.params import TaskParams
from mahn_envs.policy import ControllerPolicy

from .champion import Champion

#: margins below this count as near-ties: the threshold of the original code's (unused) "confused" counter.
NEAR_TIE = 0.001


def decision_margins(champion: "Champion | str | Path", map: str = "plus", params: Optional[TaskParams] = None,
                     seed: int = 0) -> dict[str, Any]:
    """Margin statistics of one training-protocol episode (kinematic engine).

    Returns the number of decisions, the fraction decided by an exact tie of the top two outputs, the fraction
    of near-ties (margin < `NEAR_TIE`), the median margin and the median top output (near 1.0 or 0.0 means
    saturated outputs), and the episode's team fitness, so the figures can be read against the score.
    """
    champ = champion if isinstance(champion, Champion) else Champion.load(champion)
    params = params or TaskParams()
    env = patrol_return_v0.parallel_env(map=map, **{k: v for k, v in params.to_dict().items()
                                                    if k not in ("sample_period",)})
    try:
        obs, _ = env.reset(seed=seed)
        policy = ControllerPolicy(champ.controllers, env.possible_agents)
        margins: list[float] = []
        tops: list[float] = []
        infos: dict = {}
        while env.agents:
            actions = policy.act(obs)
            out = policy.outputs
            for r, agent in enumerate(env.possible_agents):
                if agent in obs:
                    ranked = np.sort(out[r])
                    margins.append(float(ranked[2] - ranked[1]))
                    tops.append(float(ranked[2]))
            obs, _, _, _, infos = env.step(actions)
    finally:
        env.close()
    m = np.asarray(margins)
    info = infos[env.possible_agents[0]]
    return {"map": map, "seed": seed, "decisions": int(m.size),
            "tied_fraction": float(np.mean(m == 0.0)),
            "near_tie_fraction": float(np.mean(m < NEAR_TIE)),
            "median_margin": float(np.median(m)), "median_top_output": float(np.median(tops)),
            "fitness": float(info["team_fitness"]), "solved": bool(info["solved"])}
