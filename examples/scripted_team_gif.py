"""The hand-written team that solves patrol-and-return, rendered to a GIF.

Each robot drives through the junction to its own POI, waits for the come-home signal, and drives back.
Usage: python examples/scripted_team_gif.py [out.gif]   (default runs/examples/scripted_team.gif)
"""
import sys

from mahn_envs import patrol_return_v0
from mahn_envs.policies.scripted import WaypointTeam
from mahn_evo.plots import save_gif

out = sys.argv[1] if len(sys.argv) > 1 else "runs/examples/scripted_team.gif"  # save_gif makes the folder
env = patrol_return_v0.parallel_env(render_mode="rgb_array")
observations, infos = env.reset(seed=0)
team = WaypointTeam(env.world, env.possible_agents)
frames = [env.render()]
while env.agents:
    observations, rewards, terminations, truncations, infos = env.step(team.act(infos))
    if env.sim.tick % 6 == 0:
        frames.append(env.render())
save_gif(frames, out, fps=20)
print(f"fitness {infos['robot_0']['team_fitness']:.2f}, solved {infos['robot_0']['solved']} -> {out}")
