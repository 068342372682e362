"""The standard PettingZoo route: SuperSuit turns `patrol_return_v0` into an SB3 vector env for shared PPO.

This is what most users try first, so it is shown working here.  For real runs prefer
`baselines.PatrolReturnVecEnv` (`mahn-baselines train`): same observations and rewards (tested step for step),
but 15-45x faster (benchmarks/bench_vec_env.py), time-outs reported as truncation rather than termination, and
SB3's `seed=` honoured.  Two things the recipe needs on this env:

* `agent_indicator_v0` appends a one-hot agent index so one shared policy can give each robot its own role;
* SuperSuit's vector env lacks the `seed()` SB3 calls for `PPO(seed=...)` (and its `reset(seed=)` forwards to
  it): seed the inner ConcatVecEnv's `reset(seed=)` and torch via `set_random_seed` instead.

    python examples/supersuit_ppo.py [--steps 20000]
"""
from __future__ import annotations

import argparse

from mahn_envs.core.params import ORIGINAL_MAX_TICKS


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=20_000, help="robot-steps to train")
    ap.add_argument("--envs", type=int, default=4, help="PettingZoo envs (episodes) in parallel")
    ap.add_argument("--max-cycles", type=int, default=ORIGINAL_MAX_TICKS, help="episode length in ticks")
    args = ap.parse_args()

    import supersuit as ss
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.utils import set_random_seed

    from mahn_envs import patrol_return_v0

    torch.set_num_threads(1)
    set_random_seed(0)
    env = patrol_return_v0.parallel_env(max_cycles=args.max_cycles)
    env = ss.agent_indicator_v0(env)  # obs: 7 inputs + one-hot agent index (10)
    venv = ss.pettingzoo_env_to_vec_env_v1(env)
    venv = ss.concat_vec_envs_v1(venv, args.envs, num_cpus=0, base_class="stable_baselines3")
    venv.venv.reset(seed=0)  # the ConcatVecEnv underneath takes a seed; the SB3 wrapper's seed() would fail
    model = PPO("MlpPolicy", venv, n_steps=256, batch_size=1024, gamma=0.999, verbose=0, device="cpu")
    model.learn(args.steps)

    # score the trained shared policy on one episode with the plain PettingZoo API
    test = ss.agent_indicator_v0(patrol_return_v0.parallel_env(max_cycles=args.max_cycles))
    obs, _ = test.reset(seed=0)
    infos: dict = {}
    while test.agents:
        actions = {a: int(model.predict(o, deterministic=True)[0]) for a, o in obs.items()}
        obs, _, _, _, infos = test.step(actions)
    info = next(iter(infos.values()))
    print(f"trained {args.steps} robot-steps with SuperSuit + PPO: team fitness {info['team_fitness']:.3f}, "
          f"solved {info['solved']}  (policy input size {model.observation_space.shape[0]})")


if __name__ == "__main__":
    main()
