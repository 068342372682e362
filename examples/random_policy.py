"""A random team in the PettingZoo parallel API: the loop every multi-agent RL user writes first."""
from mahn_envs import patrol_return_v0

env = patrol_return_v0.parallel_env(map="plus")
observations, infos = env.reset(seed=42)
total = 0.0
while env.agents:
    actions = {agent: env.action_space(agent).sample() for agent in env.agents}
    observations, rewards, terminations, truncations, infos = env.step(actions)
    total += rewards["robot_0"]
print(f"random team: team fitness {infos['robot_0']['team_fitness']:.4f} (sum of rewards {total:.4f}), "
      f"solved {infos['robot_0']['solved']}")
env.close()
