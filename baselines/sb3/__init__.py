"""Stable-Baselines3 on the task: PPO, RecurrentPPO and DQN with parameter sharing over the vector env
(`algos`), one run in a folder (`train`), a trained model as a team policy (`policy`), and the whole team as one
gymnasium env for single-agent libraries (`gym_env`).  The first baselines; the lean PPO family (`baselines.lean`)
superseded them for the budget runs, since their rollouts are shorter than an episode."""
