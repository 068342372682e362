"""Load your own arena from a JSON file (schema in docs/architecture.md; y up, centimetres).

This one is a plus with a longer top arm.  A malformed file is rejected with a message naming the field.
"""
import json
import tempfile
from pathlib import Path

from mahn_envs import load_map, patrol_return_v0
from mahn_envs.policies.scripted import run_scripted_episode

arena = load_map("plus").to_dict()
arena["name"] = "tall_plus"
stretch = 30.0
for wall in arena["walls"]:  # push the top arm's walls up
    for k in (1, 3):
        if wall[k] > 150:
            wall[k] += stretch
arena["pois"][1][1] += stretch
with tempfile.TemporaryDirectory() as folder:  # your map would live anywhere you like
    path = Path(folder) / "tall_plus.json"
    path.write_text(json.dumps(arena, indent=1))

    env = patrol_return_v0.parallel_env(map=str(path))
    fitness, solved, _ = run_scripted_episode(env)
    print(f"{env.world.name}: scripted team fitness {fitness:.2f}, solved {solved}")

    arena["walls"][0] = [0, 0, 1]  # a broken wall
    path.write_text(json.dumps(arena))
    try:
        load_map(str(path))
    except ValueError as err:
        print("rejected as expected:", err)
