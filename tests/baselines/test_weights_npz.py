"""baselines/lean/weights_npz.py: state dicts and an optimiser's state as plain NPZ, back bit for bit; a foreign or
damaged file is a clear error; runs written in torch's format before it still load."""
from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from baselines.lean.config import LeanConfig  # noqa: E402
from baselines.lean.ppo import load_actor, train  # noqa: E402
from baselines.lean.weights_npz import load_weights, save_weights  # noqa: E402


def test_weights_and_adam_state_come_back_bit_for_bit(tmp_path):
    torch.manual_seed(0)
    net = torch.nn.GRU(3, 4)
    optim = torch.optim.Adam(net.parameters(), lr=1e-3)
    net(torch.randn(5, 1, 3))[0].sum().backward()
    optim.step()
    save_weights(tmp_path / "w.npz", {"actor": net.state_dict()}, optim.state_dict())
    back = load_weights(tmp_path / "w.npz")
    for k, v in net.state_dict().items():
        assert torch.equal(back["actor"][k], v) and back["actor"][k].dtype == v.dtype
    fresh = torch.optim.Adam(net.parameters(), lr=5.0)
    fresh.load_state_dict(back["optim"])
    assert fresh.param_groups[0]["lr"] == 1e-3
    for p in net.parameters():
        for k, v in optim.state[p].items():
            assert torch.equal(fresh.state[p][k], v), k
    with np.load(tmp_path / "w.npz", allow_pickle=False) as f:  # plain arrays, no pickle
        assert "optim/param_groups" in f.files


def test_foreign_and_damaged_files_are_named(tmp_path):
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="not a mahn-lean-weights/1 file"):
        load_weights(tmp_path / "other.npz")
    (tmp_path / "bad.npz").write_bytes(b"garbage")
    with pytest.raises(ValueError, match="missing or damaged"):
        load_weights(tmp_path / "bad.npz")


def test_a_run_written_in_torchs_format_still_loads(tmp_path):
    cfg = LeanConfig(method="ppo_ff", seed=0, max_cycles=60, signal_tick=30, n_episodes=2, bptt=60, hidden=8,
                     eval_maps=["plus"], steps=360)
    train(cfg, tmp_path / "run")
    _, actor = load_actor(tmp_path / "run", "best")
    (tmp_path / "run" / "best_actor.npz").unlink()
    torch.save(actor.state_dict(), tmp_path / "run" / "best_actor.pt")  # as runs before the NPZ format
    _, old = load_actor(tmp_path / "run", "best")
    for k, v in actor.state_dict().items():
        assert torch.equal(old.state_dict()[k], v)
