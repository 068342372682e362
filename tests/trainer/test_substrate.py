"""CPPN -> substrate decoding against the original's rules (docs/original-system.md section 6)."""
import numpy as np
import pytest

from mahn_envs import BatchSim
from mahn_envs.core.api import policy_coordinates
from mahn_evo.cppn import compile_cppn
from mahn_evo.hyperneat.substrate import INPUT_X, decode_outputs, decode_population, query_layout
from mahn_evo.neat.initial import iros2011_seed_genome


def test_substrate_coordinates():
    assert INPUT_X.tolist() == pytest.approx([-1, -0.6000000238, -0.2000000179, 0.1999999881, 0.6000000238, 1.0],
                                             abs=1e-9)
    assert policy_coordinates(3).tolist() == [-1.0, 0.0, 1.0]
    sit, std = query_layout("situational"), query_layout("standard")
    assert sit.queries.shape == (3 * 2 * (162 + 12), 6)  # 162 pairs + 12 bias queries per agent and brain
    assert std.queries.shape == (3 * 1 * (171 + 12), 5)
    assert np.all(sit.q_ih[..., 6] == -1)  # no signal input in situational mode
    assert set(np.unique(sit.queries[:, 5])) == {-1.0, 1.0}


@pytest.mark.parametrize("mode", ["situational", "standard"])
def test_seed_genome_team_drives_straight_and_scores_reference(mode):
    genome = iros2011_seed_genome(6 if mode == "situational" else 5)
    team = decode_population([compile_cppn(genome)], mode).team(0)
    # x1, x2 and z are inert in the seed: every robot has the same brain and equal outputs
    assert np.array_equal(team.w_ih[0], team.w_ih[1]) and np.array_equal(team.b_o[0], team.b_o[2])
    res = BatchSim("plus", 1).run_controllers(team)
    assert res.fitness[0] == pytest.approx(2.0232671157474424, abs=1e-10)


def test_threshold_scale_and_normalisation():
    layout = query_layout("situational")
    Q = layout.queries.shape[0]
    rng = np.random.default_rng(0)
    out = rng.uniform(-1, 1, size=(2, Q, 2)).astype(np.float32)
    raw = decode_outputs(out, layout, normalise=False)
    norm = decode_outputs(out, layout, normalise=True)
    o = out[0, layout.q_hh[0, 0, 3, 5], 0]
    w = raw.w_hh[0, 0, 0, 3, 5]
    if abs(o) <= 0.2:
        assert w == 0
    else:
        assert w == pytest.approx(np.sign(o) * 3 * (abs(o) - 0.2) / 0.8, rel=1e-6)
    # every hidden node: positive incoming weights sum to 3 and negative to -3 (input and recurrent together)
    inc = np.concatenate([norm.w_ih[0], norm.w_hh[0]], axis=-1)  # (R, K, 9, 16)
    pos = np.where(inc > 0, inc, 0).sum(-1)
    neg = np.where(inc < 0, inc, 0).sum(-1)
    assert np.allclose(pos[pos > 0], 3, atol=1e-5) and np.allclose(neg[neg < 0], -3, atol=1e-5)
    assert np.allclose(norm.b_h[0], 3 * out[0, layout.q_bh, 1], atol=1e-6)  # biases: 3 * out1, not normalised


def test_non_finite_cppn_outputs_express_nothing():
    """The relaxation activation can overflow a CPPN to NaN (seen at generation 343 of situational seed 18, which it
    stopped with 'controller array b_h contains NaN'): such an output gives no connection and no bias, in the
    compiled decoder and its array reference alike, and the other outputs decode as they would otherwise."""
    from mahn_evo.hyperneat.substrate import decode_outputs_numpy

    layout = query_layout("situational")
    Q = layout.queries.shape[0]
    out = np.random.default_rng(1).uniform(-1, 1, size=(2, Q, 2)).astype(np.float32)
    clean = decode_outputs(out, layout)
    bad = out.copy()
    bad[0, layout.q_bh[0, 0, 2], 1] = np.nan
    bad[0, layout.q_bo[1, 1, 0], 1] = np.inf
    bad[0, layout.q_hh[2, 0, 4, 1], 0] = np.nan
    bad[0, layout.q_ho[0, 1, 2, 3], 0] = -np.inf
    for decode in (decode_outputs, decode_outputs_numpy):
        team = decode(bad, layout)  # TeamControllers refuses non-finite arrays, so this alone checks finiteness
        assert team.b_h[0, 0, 0, 2] == 0 and team.b_o[0, 1, 1, 0] == 0
        assert team.w_hh[0, 2, 0, 4, 1] == 0 and team.w_ho[0, 0, 1, 2, 3] == 0
        assert np.array_equal(team.b_h[1], clean.b_h[1]) and np.array_equal(team.w_ih[1], clean.w_ih[1])
        assert np.array_equal(team.b_h[0, 1], clean.b_h[0, 1])
