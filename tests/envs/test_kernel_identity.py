"""The optimised hot paths against straightforward references: results must be bit-identical, not close.

Evolution runs are reproducible from their seed only while every float operation stays the same, so the
fast network (`network_action_9`), the wall-outer ray cast and the fused episode loop are checked here with
exact equality against plain formulations of the same rules.
"""
import math
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from mahn_envs.core import BatchSim, TaskParams, kernels
from mahn_envs.core.controller import (
    LANES,
    OUT_LANE,
    PENDING,
    _sigmoid,
    network_action,
    pack_networks,
    remembered_action_16,
    remembered_actions_16,
    transposed,
    winner_take_all,
)
from mahn_envs.core.geometry import cast_rays, ray_circle, ray_wall, sensor_directions, wall_boxes
from mahn_envs.maps import load_map

from .helpers import random_team


@njit(error_model="numpy")
def reference_network(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp):
    """Two synchronous steps as written first: every node's sum from 0, inputs then hidden, outputs included."""
    n_hidden = wt_hh.shape[3]
    n_in = wt_ih.shape[3]
    wanted = 1 if (wt_ih.shape[2] == 2 and rflag_signal != 0) else 0
    if wanted != brain[b, r]:
        brain[b, r] = wanted
        for i in range(n_hidden):
            hid[b, r, i] = 0.0
        for o in range(3):
            out[b, r, o] = 0.0
    k = brain[b, r]
    for _ in range(2):
        for q in range(3):
            acc = np.float32(0.0)
            for m in range(n_hidden):
                acc += wt_ho[b, r, k, m, q] * hid[b, r, m]
            tmp[n_hidden + q] = acc
        for i in range(n_hidden):
            acc = np.float32(0.0)
            for j in range(n_in):
                acc += wt_ih[b, r, k, j, i] * obs[b, r, j]
            for m in range(n_hidden):
                acc += wt_hh[b, r, k, m, i] * hid[b, r, m]
            tmp[i] = acc
        for q in range(3):
            out[b, r, q] = _sigmoid(tmp[n_hidden + q] + b_o[b, r, k, q])
        for i in range(n_hidden):
            hid[b, r, i] = _sigmoid(tmp[i] + b_h[b, r, k, i])
    return winner_take_all(out[b, r, 0], out[b, r, 1], out[b, r, 2])


@njit(error_model="numpy")
def reference_cast_rays(cx, cy, heading, dirs, max_range, walls, others, n_others, robot_radius, out):
    """Every ray against every wall (no culling) through `ray_wall`, then the other robots."""
    ch = math.cos(heading)
    sh = math.sin(heading)
    for j in range(dirs.shape[0]):
        ux = ch * dirs[j, 0] - sh * dirs[j, 1]
        uy = sh * dirs[j, 0] + ch * dirs[j, 1]
        best = max_range
        for w in range(walls.shape[0]):
            r = ray_wall(cx, cy, ux * max_range, uy * max_range, walls[w, 0], walls[w, 1], walls[w, 2], walls[w, 3])
            if r < 1.0:
                d = r * max_range
                if d < best:
                    best = d
        for k in range(n_others):
            qx = others[k, 0]
            qy = others[k, 1]
            if abs(qx - cx) > max_range + robot_radius or abs(qy - cy) > max_range + robot_radius:
                continue
            d = ray_circle(cx, cy, ux, uy, qx, qy, robot_radius)
            if d < best:
                best = d
        out[j] = best


@njit(error_model="numpy")
def packed_network(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp, by_net=False):
    """`network_action` through the episode loop's packed path: `pack_networks`, then `remembered_action_16` with
    an empty memo (so it always computes), its state copied from and back to hid and out (`by_net`: deciding by
    the outputs' net inputs)."""
    wpack = np.empty(wt_ih.shape[:3] + (LANES, LANES), np.float32)
    bpack = np.empty(wt_ih.shape[:3] + (LANES,), np.float32)
    pack_networks(wt_ih, wt_hh, wt_ho, b_h, b_o, wpack, bpack)
    state = np.zeros((hid.shape[0], hid.shape[1], LANES), np.float32)
    state[:, :, :9] = hid
    state[:, :, OUT_LANE:OUT_LANE + 3] = out
    memo_obs = np.zeros((hid.shape[1], 7), np.float32)
    memo = np.zeros((hid.shape[1], 3), np.int64)
    action = remembered_action_16(b, r, obs, rflag_signal, wt_ih.shape[2], wpack, bpack, state, brain,
                                  np.zeros(9, np.float32), memo_obs, memo, by_net)
    hid[:] = state[:, :, :9]
    out[:] = state[:, :, OUT_LANE:OUT_LANE + 3]
    return action


def _run_networks(fn, weights, obs_seq, sig_seq):
    B, R = obs_seq.shape[1], obs_seq.shape[2]
    n_hidden = weights[1].shape[-1]
    hid = np.zeros((B, R, n_hidden), np.float32)
    out = np.zeros((B, R, 3), np.float32)
    brain = np.zeros((B, R), np.int64)
    tmp = np.zeros(n_hidden + 3, np.float32)
    acts, hids, outs = [], [], []
    for t in range(obs_seq.shape[0]):
        obs = np.ascontiguousarray(obs_seq[t])
        for b in range(B):
            for r in range(R):
                acts.append(fn(b, r, obs, sig_seq[t, b, r], *weights, hid, out, brain, tmp))
        hids.append(hid.copy())
        outs.append(out.copy())
    return np.array(acts), np.array(hids), np.array(outs)


@pytest.mark.parametrize("fast_network", [network_action, packed_network])
@pytest.mark.parametrize("brains", [1, 2])
@pytest.mark.parametrize("scale", [0.2, 1.5, 6.0])
def test_network_matches_reference_bitwise(brains, scale, fast_network):
    rng = np.random.default_rng(brains * 10 + int(scale * 10))
    teams = [random_team(s, n_brains=brains, scale=scale) for s in range(6)]
    ctrl = type(teams[0])(*(np.stack([getattr(t, f) for t in teams]) for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o")))
    weights = transposed(ctrl)
    T = 120
    obs_seq = rng.uniform(-0.2, 1.0, (T, 6, 3, 7)).astype(np.float32)
    obs_seq[:, :, :, :6][obs_seq[:, :, :, :6] < 0.25] = 0.0
    sig_seq = np.zeros((T, 6, 3), np.int64)
    sig_seq[60:] = 1
    sig_seq[90:100, :, 1] = 0  # an operator clearing one robot's signal switches its brain back
    obs_seq[:, :, :, 6] = sig_seq
    fast = _run_networks(fast_network, weights, obs_seq, sig_seq)
    ref = _run_networks(reference_network, weights, obs_seq, sig_seq)
    for a, b in zip(fast, ref):
        assert np.array_equal(a, b)
    assert len(np.unique(fast[0])) > 1  # the teams do act differently


@njit(error_model="numpy")
def _memo_networks(together, wpack, bpack, n_brains, obs_seq, sig_seq, by_net, acts, states):
    """T ticks of every robot's `remembered_action_16`, robot by robot or (`together`) through
    `remembered_actions_16`; actions and the packed states after every tick into acts, states."""
    T, B, R = obs_seq.shape[0], obs_seq.shape[1], obs_seq.shape[2]
    state = np.zeros((B, R, LANES), np.float32)
    brain = np.zeros((B, R), np.int64)
    rflag = np.zeros((B, R, 2), np.int64)
    prev = np.zeros((R, 9), np.float32)
    pending = np.zeros((R, PENDING), np.int64)
    for b in range(B):
        memo_obs = np.zeros((R, 7), np.float32)
        memo = np.zeros((R, 3), np.int64)
        for t in range(T):
            obs = obs_seq[t]
            for r in range(R):
                rflag[b, r, 1] = sig_seq[t, b, r]
            if together:
                remembered_actions_16(b, obs, rflag, 1, n_brains, wpack, bpack, state, brain, prev, memo_obs, memo,
                                      pending, by_net)
                for r in range(R):
                    acts[t, b, r] = memo[r, 2]
            else:
                for r in range(R):
                    acts[t, b, r] = remembered_action_16(b, r, obs, rflag[b, r, 1], n_brains, wpack, bpack, state,
                                                         brain, prev[0], memo_obs, memo, by_net)
            states[t, b] = state[b]


@pytest.mark.parametrize("n_robots", [3, 1, 5])  # 5: the robots step three, then two, at a time
@pytest.mark.parametrize("by_net", [False, True])
def test_all_robots_networks_match_one_by_one_bitwise(n_robots, by_net):
    """The tick's networks stepped together (`remembered_actions_16`) give the bits of stepping them one by one,
    through memo hits (inputs held still: some robots' steps answered by the memo, others computed) and brain
    switches."""
    teams = [random_team(s, n_brains=2, scale=1.0, n_robots=n_robots) for s in range(4)]
    ctrl = type(teams[0])(*(np.stack([getattr(t, f) for t in teams]) for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o")))
    wt = transposed(ctrl)
    wpack = np.empty(wt[0].shape[:3] + (LANES, LANES), np.float32)
    bpack = np.empty(wt[0].shape[:3] + (LANES,), np.float32)
    pack_networks(*wt, wpack, bpack)
    rng = np.random.default_rng(n_robots)
    T, B = 160, len(teams)
    obs_seq = rng.uniform(0.0, 1.0, (T, B, n_robots, 7)).astype(np.float32)
    for t in range(1, T):  # long stretches of unchanged inputs for some robots, as at a post
        still = rng.random((B, n_robots)) < 0.7
        obs_seq[t][still] = obs_seq[t - 1][still]
    obs_seq[..., 6] = 0.0
    sig_seq = np.zeros((T, B, n_robots), np.int64)
    sig_seq[80:] = 1
    sig_seq[120:130, :, 0] = 0
    got = [np.zeros((T, B, n_robots), np.int64), np.zeros((T, B, n_robots, LANES), np.float32)]
    want = [np.zeros((T, B, n_robots), np.int64), np.zeros((T, B, n_robots, LANES), np.float32)]
    _memo_networks(True, wpack, bpack, 2, obs_seq, sig_seq, by_net, *got)
    _memo_networks(False, wpack, bpack, 2, obs_seq, sig_seq, by_net, *want)
    assert np.array_equal(got[0], want[0])
    assert np.array_equal(got[1].view(np.int32), want[1].view(np.int32))
    assert len(np.unique(got[0])) > 1


@pytest.mark.parametrize("n_rays", [6, 1, 8, 11])  # 1-8 rays run side by side in one vector, more one by one
def test_ray_cast_matches_reference_bitwise(n_rays):
    rng = np.random.default_rng(3)
    plus = np.ascontiguousarray(load_map("plus").walls)
    random_walls = rng.uniform(-20, 60, (40, 4))
    random_walls[::4, 3] = random_walls[::4, 1]  # some horizontal
    random_walls[1::4, 2] = random_walls[1::4, 0]  # some vertical
    dirs = sensor_directions([1.3398 - j * 0.53592 for j in range(6)] if n_rays == 6
                             else list(rng.uniform(-math.pi, math.pi, n_rays)))
    for walls in (plus, np.ascontiguousarray(random_walls)):
        boxes = wall_boxes(walls)
        cand = np.zeros(walls.shape[0], np.int64)
        lo, hi = walls[:, :2].min() - 20, walls[:, 2:].max() + 20
        hits = 0
        for _ in range(3000):
            cx, cy = rng.uniform(lo, hi, 2)
            h = rng.choice([rng.uniform(-7, 7), rng.integers(-4, 5) * math.pi / 2])  # axis-parallel rays too
            others = rng.uniform(-12, 12, (2, 2)) + [cx, cy]
            n_others = int(rng.integers(0, 3))
            got = np.zeros(n_rays)
            want = np.zeros(n_rays)
            cast_rays(cx, cy, h, dirs, 16.66, walls, boxes, others, n_others, 6.5, got, cand)
            reference_cast_rays(cx, cy, h, dirs, 16.66, walls, others, n_others, 6.5, want)
            assert np.array_equal(got, want), (cx, cy, h)
            hits += int(np.sum(got < 16.66))
        assert hits > 1000 * n_rays // 6


@njit(error_model="numpy")
def _reference_episodes(sim_groups, weights, hid, out, brain, n_ticks, traj):
    state, arena, task, work, scores = sim_groups
    pose, raw, obs, racc, rflag, goto, est = state
    wt_ih, wt_hh, wt_ho, b_h, b_o = weights
    B, R = pose.shape[0], pose.shape[1]
    actions = np.zeros((B, R), np.int64)
    tmp = np.zeros(wt_hh.shape[3] + 3, np.float32)
    for t in range(1, n_ticks + 1):
        for b in range(B):
            for r in range(R):
                actions[b, r] = reference_network(b, r, obs, rflag[b, r, 0], wt_ih, wt_hh, wt_ho, b_h, b_o,
                                                  hid, out, brain, tmp)
        kernels.forget_rays(work)  # no memos: every ray cast and every cos and sin computed again
        kernels.step_all(actions, state, arena, task, work, scores)
        traj[:, t, :, :3] = pose[:, :, :3]
        traj[:, t, :, 3] = actions


@pytest.mark.parametrize("brains", [1, 2])
@pytest.mark.parametrize("noisy", [False, True])
def test_fused_episode_loop_matches_step_by_step_reference(brains, noisy):
    params = TaskParams(max_cycles=240, signal_tick=120, robots_see_each_other=noisy,
                        **(dict(sensor_noise=5.0, effector_noise=10.0, heading_noise=0.005, start_jitter_xy=2.0,
                                start_jitter_heading=0.1) if noisy else {}))
    teams = [random_team(s + 40, n_brains=brains) for s in range(5)]
    ctrl = type(teams[0])(*(np.stack([getattr(t, f) for t in teams]) for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o")))
    fast = BatchSim("plus", 5, params).run_controllers(ctrl, seed=3, record=True)
    sim = BatchSim("plus", 5, params)
    sim.reset(seed=3)
    traj = np.zeros_like(fast.trajectories)
    traj[:, 0, :, :3] = sim.pose[:, :, :3]
    traj[:, 0, :, 3] = -1.0
    state = (sim._state, sim._geometry, sim._task(), sim._work, sim._scores)
    hid = np.zeros((5, 3, 9), np.float32)
    out = np.zeros((5, 3, 3), np.float32)
    brain = np.zeros((5, 3), np.int64)
    _reference_episodes(state, transposed(ctrl), hid, out, brain, params.max_cycles, traj)
    assert np.array_equal(fast.trajectories, traj)
    assert np.array_equal(fast.fitness, sim.prev_fit)
    assert np.array_equal(fast.collisions, sim.racc[:, :, 3].astype(np.int64))


#: mahn 0.1's published champions, whose exact fitness is pinned
PUBLISHED = Path(__file__).parents[2] / "docs" / "results" / "experiment_mahn_0.1" / "champions"
CHAMPIONS = sorted(PUBLISHED.glob("*.json"))


def _champion_batch(kind: str):
    from mahn_evo.training.champion import Champion

    champs = [Champion.load(p) for p in CHAMPIONS if p.name.startswith(kind)]
    teams = [c.controllers for c in champs]
    ctrl = type(teams[0])(*(np.stack([getattr(t, f) for t in teams]) for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o")))
    return champs, ctrl


def test_published_champions_keep_their_exact_fitness():
    """The experiment's champions (docs/results) were scored before the episode loop's memos existed."""
    assert len(CHAMPIONS) >= 10
    for kind in ("situational", "standard"):
        champs, ctrl = _champion_batch(kind)
        res = BatchSim("plus", len(champs)).run_controllers(ctrl, seed=0)
        assert res.fitness.tolist() == [c.fitness for c in champs]
        assert res.solved.tolist() == [c.solved for c in champs]


@pytest.mark.parametrize("kind", ["situational", "standard"])
@pytest.mark.parametrize("noisy", [False, True])
def test_memos_match_the_step_by_step_reference_with_evolved_teams(kind, noisy):
    """Evolved teams sit in the states the memos skip (network fixed points, straight runs, robots at rest), which
    random teams rarely reach: whole episodes, every pose and action, against the reference without memos."""
    params = TaskParams(**(dict(sensor_noise=5.0, effector_noise=10.0, heading_noise=0.005, start_jitter_xy=2.0,
                                start_jitter_heading=0.1) if noisy else {}))
    champs, ctrl = _champion_batch(kind)
    n = len(champs)
    fast = BatchSim("plus", n, params).run_controllers(ctrl, seed=7, record=True)
    sim = BatchSim("plus", n, params)
    sim.reset(seed=7)
    traj = np.zeros_like(fast.trajectories)
    traj[:, 0, :, :3] = sim.pose[:, :, :3]
    traj[:, 0, :, 3] = -1.0
    state = (sim._state, sim._geometry, sim._task(), sim._work, sim._scores)
    hid = np.zeros((n, 3, 9), np.float32)
    out = np.zeros((n, 3, 3), np.float32)
    brain = np.zeros((n, 3), np.int64)
    _reference_episodes(state, transposed(ctrl), hid, out, brain, params.max_cycles, traj)
    assert np.array_equal(fast.trajectories, traj)
    assert np.array_equal(fast.fitness, sim.prev_fit)
    assert np.array_equal(fast.collisions, sim.racc[:, :, 3].astype(np.int64))
    if not noisy:  # the memos had much to skip: robots at rest (same rays), straight runs (same heading)
        at_rest = np.all(traj[:, 1:, :, :3] == traj[:, :-1, :, :3], axis=-1)
        straight = traj[:, 1:, :, 2] == traj[:, :-1, :, 2]
        assert at_rest.mean() > 0.1 and straight.mean() > 0.5
