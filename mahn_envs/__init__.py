"""mahn_envs: the patrol-and-return multirobot task as PettingZoo environments."""
