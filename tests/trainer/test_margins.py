"""Decision margins: exact ties are counted as ties, clear preferences as clear, and the CLI reports both."""
import json

import numpy as np

from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.cli import main
from mahn_evo.evaluation.margins import decision_margins
from mahn_evo.neat.initial import iros2011_seed_genome
from mahn_evo.training.champion import Champion


def _team(b_o) -> TeamControllers:
    """No weights at all: the outputs are sigmoid(bias), the same on every tick."""
    R, K = 3, 2
    return TeamControllers(np.zeros((R, K, 9, 7)), np.zeros((R, K, 9, 9)), np.zeros((R, K, 3, 9)),
                           np.zeros((R, K, 9)), np.broadcast_to(np.asarray(b_o, dtype=np.float32), (R, K, 3)))


def _champion(team: TeamControllers) -> Champion:
    return Champion(mode="situational", fitness=0.0, solved=False, generation=0, genome=iros2011_seed_genome(),
                    controllers=team)


def test_all_equal_outputs_are_all_ties():
    m = decision_margins(_champion(_team([0.0, 0.0, 0.0])))
    assert m["decisions"] > 3 * 1000
    assert m["tied_fraction"] == 1.0 and m["near_tie_fraction"] == 1.0
    assert m["median_margin"] == 0.0 and m["median_top_output"] == 0.5
    assert m["flipped"] == 0  # no weights: inputs cannot reach the outputs


def test_a_clear_preference_is_no_tie():
    m = decision_margins(_champion(_team([-1.0, 1.0, -1.0])))
    assert m["tied_fraction"] == 0.0 and m["near_tie_fraction"] == 0.0
    sig = lambda x: 1.0 / (1.0 + np.exp(-4.9 * x))  # noqa: E731
    assert abs(m["median_margin"] - (sig(1.0) - sig(-1.0))) < 1e-6


def test_near_ties_count_separately_from_exact_ties():
    # forward ahead of left by a hair: never an exact tie, always a near-tie
    m = decision_margins(_champion(_team([0.0, 1e-4, -1.0])))
    assert m["tied_fraction"] == 0.0 and m["near_tie_fraction"] == 1.0


def test_the_probe_flips_decisions_that_ride_on_the_inputs():
    # hidden 0 reads the front-left IR input; left and forward are built to tie exactly when it reads 1.0 (free
    # space, forward wins the tie) and to prefer left for any smaller reading, so jitter flips those decisions
    R, K = 3, 2
    w_ih = np.zeros((R, K, 9, 7), dtype=np.float32)
    w_ih[..., 0, 2] = 1.0
    a = np.float32(50.0)
    h_free = np.float32(1.0) / (np.float32(1.0) + np.float32(np.exp(-np.float32(4.9))))  # hidden 0 at input 1.0
    w_ho = np.zeros((R, K, 3, 9), dtype=np.float32)
    w_ho[..., 0, 0], w_ho[..., 1, 0] = -a, a
    b_o = np.zeros((R, K, 3), dtype=np.float32)
    b_o[..., 0], b_o[..., 1] = a * h_free, -(a * h_free)
    team = TeamControllers(w_ih, np.zeros((R, K, 9, 9)), w_ho, np.zeros((R, K, 9)), b_o)
    steady = decision_margins(_champion(team), probe=0.0)
    fragile = decision_margins(_champion(team), probe=1e-2)
    assert steady["flipped"] == 0 and steady["tied_fraction"] > 0
    assert fragile["flipped"] > 0 and fragile["fitness"] == steady["fitness"]  # the probe never steers


def test_cli_eval_margins(tmp_path, capsys):
    path = tmp_path / "champion.json"
    _champion(_team([0.0, 0.0, 0.0])).save(path)
    assert main(["eval", str(path), "--margins", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["margins"]["tied_fraction"] == 1.0 and out["margins"]["fitness"] == out["fitness"]
    assert main(["eval", str(path), "--margins"]) == 0
    assert "100.0% exact ties" in capsys.readouterr().out
