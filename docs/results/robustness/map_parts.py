"""Which change of the test map breaks a team?  The sequential protocol on plus maps that carry one part of the
asymmetric plus at a time.

The asymmetric plus differs from `plus` in two ways: its arms have other lengths (left 48.43 cm, top and right
118.11 cm, against 78.74) and its right arm leaves the top arm 77.5 cm above the crossing, so at the crossing the
right side is a wall.  Each part is a member of the plus family (`mahn_envs.maps.variants.plus_variant`):

- `plus`: the training map;
- `lengths`: the test map's arm lengths, all arms at the crossing;
- `left_short`: only the left arm shortened to 48.43;
- `branch`: plus arm lengths, the top arm 118.11 long and the right arm leaving it 77.5 above the crossing;
- `asymmetric_plus`: the test map itself (both changes).

Each team runs `EPISODES` episodes of the sequential protocol per map, with the noise preset given (episode seeds
0, 1, ...); the output is one line per team: successes and the stages done (of 9) per episode.

Usage: python docs/results/robustness/map_parts.py NOISE EPISODES CHAMPION.json [CHAMPION.json ...]
"""
from __future__ import annotations

import sys

from mahn_envs.maps.variants import PLUS_ARM, plus_variant
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_evo.evaluation.protocols import sequential_episode
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.training.champion import Champion

#: the test map's arm lengths (cm) and its right arm's offset above the crossing (mahn_envs/maps/data)
LEFT, LONG, BRANCH = 48.43, 118.11, 77.5
MAPS = {
    "plus": "plus",
    "lengths": plus_variant(LEFT, LONG, LONG),
    "left_short": plus_variant(LEFT, PLUS_ARM, PLUS_ARM),
    "branch": plus_variant(PLUS_ARM, LONG, PLUS_ARM, right_offset=BRANCH),
    "asymmetric_plus": "asymmetric_plus",
}


def main(argv: list[str]) -> int:
    if len(argv) < 3:
        print(__doc__)
        return 2
    noise, episodes, files = argv[0], int(argv[1]), argv[2:]
    params = task_params(noise)
    for path in files:
        champ = Champion.load(path)
        cells = []
        for name, world in MAPS.items():
            stages, wins = [], 0
            for e in range(episodes):
                policy = ControllerPolicy(champ.controllers, ["robot_0", "robot_1", "robot_2"])
                result = sequential_episode(policy, world, params, seed=e)
                wins += result.success
                stages.append(result.stages_completed)
            cells.append(f"{name} {wins}/{episodes} {stages}")
        print(f"{path} (seed {champ.seed}, generation {champ.generation}): " + " | ".join(cells), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
