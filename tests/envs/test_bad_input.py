"""Bad input gets a ValueError that names the problem, never a numba crash or a silent clamp."""
import json

import numpy as np
import pytest

from mahn_envs import BatchSim, TaskParams, load_map, patrol_return_v0


@pytest.fixture
def env():
    e = patrol_return_v0.parallel_env()
    e.reset(seed=0)
    return e


@pytest.mark.parametrize("bad, match", [(3, "robot_0"), (-1, "robot_0"), (1.5, "integer"), ("1", "integer"),
                                        (None, "integer"), (True, "integer"), (np.float32(1), "integer")])
def test_wrong_action_values(env, bad, match):
    with pytest.raises(ValueError, match=match):
        env.step({"robot_0": bad, "robot_1": 1, "robot_2": 1})


def test_unknown_and_missing_agents(env):
    with pytest.raises(ValueError, match="unknown agent 'robot_9'"):
        env.step({"robot_0": 1, "robot_1": 1, "robot_2": 1, "robot_9": 1})
    with pytest.raises(ValueError, match="robot_2"):
        env.step({"robot_0": 1, "robot_1": 1})
    with pytest.raises(ValueError, match="dict"):
        env.step([1, 1, 1])


def test_numpy_integer_actions_are_fine(env):
    env.step({"robot_0": np.int64(0), "robot_1": np.array(1), "robot_2": 2})


@pytest.mark.parametrize("pose, match", [((np.nan, 50.0, 0.0), "not finite"), ((500.0, 50.0, 0.0), "outside"),
                                         ((80.0, 50.0, 0.0), "overlaps a wall"), ((1.0, 2.0), "x, y, heading")])
def test_bad_poses(pose, match):
    env = patrol_return_v0.parallel_env()
    with pytest.raises(ValueError, match=match):
        env.reset(seed=0, options={"poses": {"robot_1": pose}})
    with pytest.raises(ValueError, match="unknown agent"):
        env.reset(seed=0, options={"poses": {"robot_7": (93.5, 40.0, 0.0)}})


def _map(tmp_path, **override):
    data = load_map("plus").to_dict()
    data.update(override)
    path = tmp_path / "m.json"
    path.write_text(json.dumps(data))
    return str(path)


@pytest.mark.parametrize("override, match", [
    ({"walls": [[0, 0, 1]]}, r"walls\[0\]"), ({"walls": []}, "walls"), ({"home": [1, "a"]}, "home"),
    ({"pois": [[1000.0, 5.0]] * 3}, r"pois\[0\]"), ({"starts": [[1, 2]]}, r"starts\[0\]"),
    ({"name": ""}, "name"), ({"walls": [[0, 0, 0, 0]]}, "zero length"), ({"colour": "red"}, "colour"),
    ({"pois": [[10, 94]]}, "POIs"),
])
def test_malformed_maps_name_the_field(tmp_path, override, match):
    with pytest.raises(ValueError, match=match):
        patrol_return_v0.parallel_env(map=_map(tmp_path, **override))


def test_missing_field_and_bad_json(tmp_path):
    data = load_map("plus").to_dict()
    del data["home"]
    p = tmp_path / "a.json"
    p.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="missing field 'home'"):
        load_map(str(p))
    p.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        load_map(str(p))
    with pytest.raises(ValueError, match="unknown map"):
        load_map("no_such_map")


def test_bad_settings():
    with pytest.raises(ValueError, match="sensor_noise"):
        TaskParams(sensor_noise=-1)
    with pytest.raises(ValueError, match="signal_tick"):
        TaskParams(signal_tick=691)
    with pytest.raises(ValueError, match="engine"):
        patrol_return_v0.parallel_env(engine="box2d")
    with pytest.raises(ValueError, match="pymunk"):
        patrol_return_v0.parallel_env(robots_collide=True)
    with pytest.raises(ValueError, match="render_mode"):
        patrol_return_v0.parallel_env(render_mode="ansi")


def test_core_actions_validated():
    sim = BatchSim("plus", 2)
    sim.reset(0)
    with pytest.raises(ValueError, match="shape"):
        sim.step(np.ones((3,), dtype=int))
    with pytest.raises(ValueError, match="0 \\(left\\)"):
        sim.step(np.full((2, 3), 7))
    with pytest.raises(ValueError, match="integers"):
        sim.step(np.full((2, 3), 0.5))


# ------------------------------------------------------------------ issue 14: inputs accepted silently before
@pytest.mark.parametrize("starts, match", [
    ([[93.5, 68.9, 0.0], [78.74, 38.9, 0.0], [93.55, 8.9, 0.0]], r"starts\[1\].*on or inside the wall"),  # on a wall
    ([[93.5, 68.9, 0.0], [93.5, 38.9, 0.0], [93.55, 3.0, 0.0]], r"starts\[2\].*on or inside the wall"),  # overlapping
    ([[93.5, 68.9, 0.0], [20.0, 20.0, 0.0], [93.55, 8.9, 0.0]], r"starts\[1\].*outside every corridor"),  # dead corner
])
def test_start_poses_must_lie_in_a_corridor_clear_of_walls(tmp_path, starts, match):
    with pytest.raises(ValueError, match=match):
        load_map(_map(tmp_path, starts=starts))


@pytest.mark.parametrize("walls, match", [
    ([[0, 0, 1e308, 0]], r"walls\[12\].*within"), ([[0, 0, 10**400, 0]], r"walls\[12\]"),
    ([[0, 0, 3e7, 0]], r"walls\[12\].*within"),
])
def test_absurd_or_overflowing_wall_coordinates(tmp_path, walls, match):
    data = load_map("plus").to_dict()
    data["walls"] = data["walls"] + walls
    path = tmp_path / "m.json"
    path.write_text(json.dumps(data).replace("1e+308", "1e308"))
    with pytest.raises(ValueError, match=match):
        load_map(str(path))


def test_map_paths_that_are_empty_folders_undecodable_or_too_deep(tmp_path):
    with pytest.raises(ValueError, match="empty path"):
        load_map("")
    with pytest.raises(ValueError, match="folder"):
        load_map(str(tmp_path))
    p = tmp_path / "latin1.json"
    p.write_bytes(b'{"name": "caf\xe9"}')
    with pytest.raises(ValueError, match="not UTF-8"):
        load_map(str(p))
    p.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ValueError, match="nested too deeply"):
        load_map(str(p))


@pytest.mark.parametrize("flag", ["robots_see_each_other", "reflex", "auto_signal", "robots_collide"])
@pytest.mark.parametrize("value", ["no", "False", 1, None])
def test_boolean_flags_must_be_booleans(flag, value):
    with pytest.raises(TypeError, match=flag):
        patrol_return_v0.parallel_env(**{flag: value})


def test_true_flags_still_work():
    env = patrol_return_v0.parallel_env(robots_see_each_other=True, reflex=np.bool_(True), auto_signal=False)
    assert env.params.robots_see_each_other and not env.params.auto_signal


@pytest.mark.parametrize("jitter", [40.0, 3.0])
def test_start_jitter_that_puts_robots_into_walls_is_refused(jitter):
    with pytest.raises(ValueError, match="start_jitter_xy"):
        patrol_return_v0.parallel_env(start_jitter_xy=jitter)
    with pytest.raises(ValueError, match="start_jitter_xy"):
        BatchSim("plus", 2).set_params(start_jitter_xy=jitter)
    patrol_return_v0.parallel_env(start_jitter_xy=2.0)  # the generalisation test's level fits every start


@pytest.mark.parametrize("seed, error", [(-1, ValueError), (2**64, ValueError), (2**70, ValueError),
                                         (1.5, TypeError), ("3", TypeError), (True, TypeError)])
def test_seeds_negative_non_integer_or_wider_than_64_bits(env, seed, error):
    with pytest.raises(error, match="seed"):
        env.reset(seed=seed)
    with pytest.raises(error, match="seed"):
        BatchSim("plus", 1).reset(seed)


def test_seeds_of_2_to_the_63_and_above_run_and_draw_their_own_noise():
    """The kernels take the seed as a signed 64-bit integer; the upper half of the allowed range must run too (it
    overflowed once), with noise of its own."""
    from mahn_evo.evaluation.task_setup import task_params

    fits = []
    for seed in (5, 2**63 + 5, 2**64 - 1):
        sim = BatchSim("plus", 2, task_params("generalization"))
        fits.append(sim.run_random(seed=seed).fitness.tolist())
    assert fits[0] != fits[1] != fits[2]
    again = BatchSim("plus", 2, task_params("generalization")).run_random(seed=2**63 + 5).fitness.tolist()
    assert again == fits[1]
