"""The lean PPO family on torch (issue 12): IPPO and MAPPO with GRU actors and frame-stacked feed-forward PPO,
playing whole episodes of the batch core.  `config` (settings and why), `nets` (the networks), `ppo` (the loop and
its run folder), `tune` (the budgeted optuna search); `gru_kernel`, `allocator` and `weights_npz` are what make it
fast and its files plain."""
