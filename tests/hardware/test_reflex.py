"""The hardware reflex (kinematics.reflex_motion over core.api.steer) decides as the simulator's decide_robot."""
from __future__ import annotations

import numpy as np
import pytest

from mahn_envs.core import TaskParams
from mahn_envs.core import task as T
from mahn_envs.hardware.kinematics import Motion, reflex_motion
from mahn_envs.khepera import DEFAULT_MODEL


def _sim_motion(action: int, raw: np.ndarray, moving: bool, reflex: bool, arc: bool = False) -> Motion:
    params = TaskParams(reflex=reflex, reflex_arc=arc).vector(DEFAULT_MODEL)
    pose = np.zeros((1, 1, 4))
    pose[0, 0, 3] = DEFAULT_MODEL.speed if moving else 0.0
    raws = raw.reshape(1, 1, 6).astype(np.float64)
    T.decide_robot(0, 0, action, 1, pose, raws, np.ones((1, 1, 7), np.float32), params, 0, np.uint64(0))
    dh, v = pose[0, 0, 2], pose[0, 0, 3]
    if dh > 0:
        return Motion.ARC_LEFT if v > 0 else Motion.LEFT
    if dh < 0:
        return Motion.ARC_RIGHT if v > 0 else Motion.RIGHT
    return Motion.FORWARD if v > 0 else Motion.STOP


def _q(raw: np.ndarray) -> np.ndarray:
    """The simulator's un-floored reading, float32 as in decide_robot."""
    return (raw.astype(np.float32) - np.float32(6.5)) / np.float32(10.16)


@pytest.mark.parametrize("reflex, arc", [(True, False), (False, False), (True, True)])
def test_matches_decide_robot_on_identical_inputs(reflex, arc):
    rng = np.random.default_rng(7)
    threshold = 6.5 + 0.25 * 10.16  # centre distance 9.04
    n = 0
    for _ in range(3000):
        # mostly near the threshold, where an off-by-one comparison would show
        raw = np.where(rng.random(6) < 0.7, threshold + rng.normal(0, 0.3, 6), rng.uniform(6.5, 16.66, 6))
        raw = np.clip(raw, 6.5, 16.66)
        action = int(rng.integers(0, 3))
        moving = bool(rng.integers(0, 2))
        expected = _sim_motion(action, raw, moving, reflex, arc)
        got = reflex_motion(action, _q(raw), moving, floor=0.25, enabled=reflex, arc=arc)
        assert got == expected, (action, raw.tolist(), moving)
        n += got in (Motion.ARC_LEFT, Motion.ARC_RIGHT, Motion.STOP)
    if reflex:
        assert n > 300  # the reflex branches were really exercised


def test_exact_threshold_and_branch_order():
    free = [1.0] * 6
    assert reflex_motion(1, free, moving=True) is Motion.FORWARD
    assert reflex_motion(1, [0.25, 1, 0.1, 1, 1, 0.1], moving=True) is Motion.ARC_RIGHT  # left wins
    assert reflex_motion(1, [1, 1, 0.25, 1, 1, 0.1], moving=True) is Motion.STOP  # front before right
    assert reflex_motion(1, [1, 1, 1, 1, 1, 0.25], moving=True) is Motion.ARC_LEFT
    assert reflex_motion(1, [1, 1, 1, 1, 1, 0.25], moving=False) is Motion.LEFT
    assert reflex_motion(1, [1, 1, 1, 1, 1, 0.2501], moving=False) is Motion.FORWARD
    assert reflex_motion(0, [0.0] * 6, moving=True) is Motion.LEFT  # turning ignores the reflex
    assert reflex_motion(2, [0.0] * 6, moving=True) is Motion.RIGHT
    assert Motion.FORWARD.moving and Motion.ARC_LEFT.moving and not Motion.STOP.moving
    with pytest.raises(ValueError, match="action"):
        reflex_motion(3, free, True)


def test_arcing_reflex_moves_a_standing_robot_beside_a_wall():
    """The deadlock the arcing reflex removes: with the original's, a standing robot asked forward beside a wall
    turns back in place and stays standing; with reflex_arc it arcs away (a blocked front still stops it)."""
    left_wall, right_wall, front_wall = [0.2, 1, 1, 1, 1, 1], [1, 1, 1, 1, 1, 0.2], [1, 1, 0.2, 1, 1, 1]
    assert reflex_motion(1, left_wall, moving=False) is Motion.RIGHT
    assert reflex_motion(1, left_wall, moving=False, arc=True) is Motion.ARC_RIGHT
    assert reflex_motion(1, right_wall, moving=False, arc=True) is Motion.ARC_LEFT
    assert reflex_motion(1, right_wall, moving=True, arc=True) is Motion.ARC_LEFT
    assert reflex_motion(1, front_wall, moving=True, arc=True) is Motion.STOP
    assert reflex_motion(1, left_wall, moving=False, enabled=False, arc=True) is Motion.FORWARD
