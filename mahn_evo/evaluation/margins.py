"""How firmly a team decides: the gap between the winning output and the runner-up, and whether a tiny input
perturbation changes the decision, tick by tick.

Why this exists: evolution in the original's noise-free float32 world finds teams whose outputs are saturated
near 1.0 (or 0.0) and whose decisions are exact ties (forward wins ties, left beats right) or gaps of a few float32
units.  A tie is harmless when saturated hidden nodes pin the outputs, so input noise cannot reach them; it is
fatal when the outputs still move with the inputs, because then noise of 1e-4 flips the decision.  The margins
show the ties; the probe (every tick, the same network state fed inputs jittered by +-`PROBE`) shows which kind
they are, before anyone spends a day on noisy transfer tests.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core.params import TaskParams
from mahn_envs.policies.controller_policy import ControllerPolicy

from ..training.champion import Champion
from .task_setup import task_env

#: margins below this count as near-ties: the threshold of the original code's (unused) "confused" counter.
NEAR_TIE = 0.001
#: half-width of the uniform input jitter of the probe: 0.01 % sensor noise in the original's units.
PROBE = 1e-4


def _jittered(obs: dict, rng: np.random.Generator, probe: float) -> dict:
    """The IR inputs moved by U(-probe, probe) as sensor noise moves them (capped at 1, floored inputs stay 0);
    the signal input is left alone."""
    out = {}
    for agent, o in obs.items():
        x = np.array(o, dtype=np.float32)
        ir = x[:6]
        moved = np.minimum(ir + rng.uniform(-probe, probe, 6).astype(np.float32), np.float32(1.0))
        x[:6] = np.where(ir == 0.0, ir, moved)
        out[agent] = x
    return out


def decision_margins(champion: Champion | str | Path, map: str = "plus", params: TaskParams | None = None,
                     seed: int = 0, probe: float = PROBE) -> dict[str, Any]:
    """Margin statistics of one training-protocol episode (kinematic engine).

    Margins are between the values the team decides by (its outputs, or their net inputs for a team with
    decision "net_input").  Returns the number of decisions, the fraction decided by an exact tie of the top two,
    the fraction of near-ties (margin < `NEAR_TIE`), the median margin and the median top output (near 1.0 or 0.0 means
    saturated outputs), how many decisions the probe flips (inputs jittered by +-`probe` from the same network
    state; the episode itself runs on the true inputs: a handful of flips at a junction is enough to fail), and
    the episode's team fitness.
    """
    champ = champion if isinstance(champion, Champion) else Champion.load(champion)
    params = champ.task(params)
    env = task_env(map, params)
    try:
        obs, _ = env.reset(seed=seed)
        policy = ControllerPolicy(champ.controllers, env.possible_agents)
        margins: list[float] = []
        tops: list[float] = []
        flips = 0
        rng = np.random.default_rng(seed)
        infos: dict = {}
        while env.agents:
            state = policy.snapshot()
            probed = policy.act(_jittered(obs, rng, probe))
            policy.restore(state)
            actions = policy.act(obs)
            flips += sum(probed[a] != actions[a] for a in actions)
            out = policy.outputs
            values = policy.decision_values
            for r, agent in enumerate(env.possible_agents):
                if agent in obs:
                    ranked = np.sort(values[r])
                    margins.append(float(ranked[2] - ranked[1]))
                    tops.append(float(np.max(out[r])))
            obs, _, _, _, infos = env.step(actions)
    finally:
        env.close()
    m = np.asarray(margins)
    info = infos[env.possible_agents[0]]
    return {"map": map, "seed": seed, "decisions": int(m.size),
            "tied_fraction": float(np.mean(m == 0.0)),
            "near_tie_fraction": float(np.mean(m < NEAR_TIE)),
            "median_margin": float(np.median(m)), "median_top_output": float(np.median(tops)),
            "probe": probe, "flipped": int(flips), "flipped_fraction": flips / max(1, m.size),
            "decision": champ.controllers.decision,
            "fitness": float(info["team_fitness"]), "solved": bool(info["solved"])}
