"""Run folders cannot be silently corrupted: checksummed checkpoints, clear messages for malformed files, no
overwriting of another run, resumable after a kill before the first checkpoint, stray temporary files removed,
configuration and state that must agree, one process per folder, and CLI paths refused in one line."""
import csv
import json
import subprocess
import sys

import pytest

from mahn_evo.cli import main
from mahn_evo.training.champion import Champion
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer, train


def small(**kw):
    base = dict(generations=3, init="minimal", seed=3)
    base.update(kw)
    pop = base.pop("pop", 16)
    return EvolutionConfig(**base).with_overrides(pop=pop)


def _log(path):
    with open(path / "log.csv") as f:
        return [{k: v for k, v in r.items() if k != "seconds"} for r in csv.DictReader(f)]


# ------------------------------------------------------------------ checkpoint integrity
def _one_digit_changed(value):
    text = repr(value)
    i = max(k for k, ch in enumerate(text) if ch.isdigit())
    return type(value)(text[:i] + ("1" if text[i] != "1" else "2") + text[i + 1:])


@pytest.mark.parametrize("where", [lambda pop: (pop["genomes"][0]["connections"][0], 3),  # a genome weight
                                   lambda pop: (pop["rng"]["state"], "state"),  # the RNG state
                                   lambda pop: (pop["threshold"], "threshold")])  # a species threshold
def test_one_changed_digit_in_a_checkpoint_is_refused_naming_the_file(tmp_path, where):
    train(small(generations=2), tmp_path)
    ck = json.loads((tmp_path / "checkpoint.json").read_text())
    holder, key = where(ck["population"])
    holder[key] = _one_digit_changed(holder[key])
    (tmp_path / "checkpoint.json").write_text(json.dumps(ck))
    with pytest.raises(ValueError, match=r"checkpoint\.json.*does not match its sha256"):
        Trainer(small(), tmp_path, resume=True)


def test_a_checkpoint_without_checksum_still_resumes_bit_identically(tmp_path):
    """Checkpoints written before checksums existed (no sha256 key, format version 1) resume as before; from
    version 2 on the checksum is required (tests/trainer/test_migrate.py)."""
    train(small(generations=4), tmp_path / "full")
    train(small(generations=2), tmp_path / "old")
    ck = json.loads((tmp_path / "old" / "checkpoint.json").read_text())
    assert "sha256" in ck
    del ck["sha256"]
    ck["version"] = ck["population"]["version"] = 1
    (tmp_path / "old" / "checkpoint.json").write_text(json.dumps(ck, separators=(",", ":")))
    train(small(generations=4), tmp_path / "old", resume=True)
    assert _log(tmp_path / "old") == _log(tmp_path / "full")


@pytest.mark.parametrize("damage", [
    lambda ck: ck.pop("trainer"), lambda ck: ck["trainer"].pop("wall_seconds"), lambda ck: ck.pop("population"),
    lambda ck: ck["population"].pop("genomes"), lambda ck: ck.update(config=[1, 2]),
    lambda ck: ck["trainer"].update(log="x" * 3) or ck["trainer"].update(best_fitness="high")])
def test_malformed_checkpoints_give_a_message_not_a_traceback(tmp_path, damage):
    train(small(generations=1), tmp_path)
    ck = json.loads((tmp_path / "checkpoint.json").read_text())
    del ck["sha256"]  # as an old file, so the field checks (not the checksum) must catch it
    ck["version"] = 1
    damage(ck)
    (tmp_path / "checkpoint.json").write_text(json.dumps(ck))
    with pytest.raises(ValueError, match=r"checkpoint\.json"):
        Trainer(small(), tmp_path, resume=True)


def test_population_size_edited_in_checkpoint_and_config_is_refused(tmp_path):
    train(small(generations=1), tmp_path)
    for name in ("checkpoint.json", "config.json"):
        data = json.loads((tmp_path / name).read_text())
        if data.pop("sha256", None) is not None:
            data["version"] = 1  # a checkpoint without its checksum is an old file
        (data["config"] if name == "checkpoint.json" else data)["neat"]["population_size"] = 40
        (tmp_path / name).write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"population_size = 16 in the state"):
        Trainer(small(generations=3, pop=40), tmp_path, resume=True)
    assert main(["train", "--out", str(tmp_path), "--resume", "--generations", "3", "--quiet"]) == 2


# ------------------------------------------------------------------ malformed summaries and champions
def test_malformed_summary_of_an_experiment_run_is_rewritten(tmp_path):
    from mahn_evo.experiment.backends import run_one

    cfg = small(generations=2)
    first = run_one(cfg.to_dict(), str(tmp_path))
    (tmp_path / "summary.json").write_text("[1, 2]")  # valid JSON, not a summary
    assert run_one(cfg.to_dict(), str(tmp_path)) == first


@pytest.fixture(scope="module")
def champion_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("champ")
    train(small(generations=2), d)
    return json.loads((d / "champion.json").read_text())


def _write(tmp_path, data):
    p = tmp_path / "c.json"
    p.write_text(json.dumps(data))
    return p


@pytest.mark.parametrize("edit, match", [
    (lambda c: c.update(mode="heroic"), "field 'mode' must be one of"),
    (lambda c: c.update(mode="standard"), "controllers are a situational team"),
    (lambda c: c["controllers"]["b_o"][0][0].__setitem__(0, 0.123), "does not match what field 'cppn' decodes"),
    (lambda c: c["controllers"].update(w_ho=json.loads(json.dumps(c["controllers"]["w_ho"]).replace("0.", "1."))),
     "does not match"),
    (lambda c: c["controllers"]["b_h"][0][0].__setitem__(0, "1.5"), "field 'b_h' must hold numbers"),
    (lambda c: c.update(controllers=json.loads(json.dumps(c["controllers"], default=str).replace(
        '"w_ih": [', '"w_ih": ["0", '))), "w_ih"),
    (lambda c: c.update(fitness="12.5"), "field 'fitness' must be a number"),
    (lambda c: c.pop("cppn"), "'cppn'"),
    (lambda c: c.update(cppn=[]), "malformed field"),
])
def test_malformed_champions_name_the_problem(tmp_path, champion_file, edit, match):
    data = json.loads(json.dumps(champion_file))
    Champion.load(_write(tmp_path, data))  # the untouched file loads
    edit(data)
    with pytest.raises(ValueError, match=match):
        Champion.load(_write(tmp_path, data))


@pytest.mark.parametrize("decoding", [dict(cppn_activation="relax"), dict(evaluate_modules=False, init="iros2011"),
                                      dict(evaluate_modules=True, init="iros2011")])
def test_champions_of_every_decoding_load(tmp_path, decoding):
    train(small(generations=2, **decoding), tmp_path)
    Champion.load(tmp_path / "champion.json")


def test_controllers_of_another_cppn_are_refused(tmp_path, champion_file):
    other = tmp_path / "other"
    train(small(generations=2, seed=11), other)
    data = json.loads(json.dumps(champion_file))
    data["controllers"] = json.loads((other / "champion.json").read_text())["controllers"]
    with pytest.raises(ValueError, match="does not match"):
        Champion.load(_write(tmp_path, data))


# ------------------------------------------------------------------ another run in --out, overwrite, kills
def test_a_fresh_run_refuses_a_folder_holding_another_run_without_checkpoint(tmp_path):
    out = tmp_path / "run"
    train(small(generations=2), out)
    (out / "checkpoint.json").unlink()  # e.g. copied without it, or made by an older release
    (out / "archive").mkdir()
    (out / "archive" / "solution_g00001_i0003.json").write_text("{}")
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    with pytest.raises(ValueError, match=r"'.*run' already holds another run .*--resume.*--overwrite"):
        Trainer(small(seed=9), out)
    assert main(["train", "--out", str(out), "--seed", "9", "--generations", "2", "--quiet"]) == 2
    assert before == {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}  # nothing touched
    # --overwrite clears the old run first: no stale archive left to confuse the generalisation ranking
    assert main(["train", "--out", str(out), "--seed", "9", "--generations", "2", "--init", "minimal", "--pop",
                 "16", "--overwrite", "--quiet"]) == 0
    assert not (out / "archive" / "solution_g00001_i0003.json").exists()
    assert json.loads((out / "summary.json").read_text())["seed"] == 9
    train(small(generations=2), tmp_path / "fresh")
    with pytest.raises(ValueError, match="--resume.*--overwrite"):
        Trainer(small(generations=2), tmp_path / "fresh")  # a run with a checkpoint: refused too, naming both
    with pytest.raises(ValueError, match="one of --resume"):
        Trainer(small(generations=2), tmp_path / "fresh", resume=True, overwrite=True)


def test_a_run_killed_before_its_first_checkpoint_can_be_resumed(tmp_path):
    """Killed before the first checkpoint: config.json (and maybe a champion) but no checkpoint.  --resume
    starts the same run over; the result equals an uninterrupted run."""
    cfg = small(generations=3, checkpoint_every=3)
    train(cfg, tmp_path / "full")
    t = Trainer(cfg, tmp_path / "killed")
    t.step()  # writes champion.json, no checkpoint yet: the process dies here
    assert (tmp_path / "killed" / "champion.json").exists() and not (tmp_path / "killed" / "checkpoint.json").exists()
    with pytest.raises(ValueError, match="--resume"):
        Trainer(cfg, tmp_path / "killed")
    with pytest.raises(ValueError, match="seed"):
        Trainer(small(generations=3, checkpoint_every=3, seed=4), tmp_path / "killed", resume=True)
    train(cfg, tmp_path / "killed", resume=True)
    assert _log(tmp_path / "killed") == _log(tmp_path / "full")


def test_stray_temporary_files_are_removed_on_the_next_start(tmp_path):
    train(small(generations=1), tmp_path)
    strays = [tmp_path / ".checkpoint.json.k2j4_x.tmp", tmp_path / "archive" / ".solution_g00001_i0001.json.abc.tmp"]
    strays[1].parent.mkdir(exist_ok=True)
    for p in strays:
        p.write_text('{"half": ')
    keep = tmp_path / "notes.tmp"
    keep.write_text("mine")
    train(small(generations=2), tmp_path, resume=True)
    assert not any(p.exists() for p in strays) and keep.exists()


# ------------------------------------------------------------------ one process per folder
_HOLD = ("import sys, time; from mahn_evo.storage.folder_lock import folder_lock\n"
         "with folder_lock(sys.argv[1], 'run folder'):\n    print('held', flush=True); time.sleep(60)")


def test_a_folder_in_use_by_a_live_process_is_refused_and_a_dead_ones_lock_taken_over(tmp_path, capsys):
    out = tmp_path / "run"
    holder = subprocess.Popen([sys.executable, "-c", _HOLD, str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        assert main(["train", "--out", str(out), "--generations", "1", "--pop", "16", "--quiet"]) == 2
        assert f"in use by process {holder.pid}" in capsys.readouterr().err
        assert not (out / "config.json").exists()
    finally:
        holder.kill()
        holder.wait()
    # the holder died by SIGKILL: its lock file (naming its pid) is left behind and taken over
    assert (out / ".mahn.lock").read_text().strip() == str(holder.pid)
    assert main(["train", "--out", str(out), "--generations", "1", "--pop", "16", "--init", "minimal",
                 "--quiet"]) == 0
    assert not (out / ".mahn.lock").exists()


# ------------------------------------------------------------------ CLI paths: one line, nothing half-written
@pytest.mark.parametrize("case", ["out_is_file", "out_under_a_file", "out_unwritable", "seed_too_big",
                                  "seed_negative", "config_is_dir", "config_not_utf8", "champion_is_dir",
                                  "eval_seed_too_big", "video_is_dir"])
def test_cli_bad_paths_and_values_give_one_line_errors(tmp_path, champion_file, capsys, case):
    a_file = tmp_path / "file.txt"
    a_file.write_text("x")
    champ = _write(tmp_path, champion_file)
    (tmp_path / "latin.json").write_bytes(b'{"seed": "\xff\xfe"}')
    new = tmp_path / "new"
    train_args = ["train", "--generations", "1", "--pop", "16", "--quiet", "--out"]
    args = {
        "out_is_file": train_args + [str(a_file)],
        "out_under_a_file": train_args + [str(a_file / "run")],
        "out_unwritable": train_args + ["/proc/mahn_run"],
        "seed_too_big": train_args + [str(new), "--seed", str(2**64)],
        "seed_negative": train_args + [str(new), "--seed", "-1"],
        "config_is_dir": train_args + [str(new), "--config", str(tmp_path)],
        "config_not_utf8": train_args + [str(new), "--config", str(tmp_path / "latin.json")],
        "champion_is_dir": ["eval", str(tmp_path)],
        "eval_seed_too_big": ["eval", str(champ), "--seed", str(2**70)],
        "video_is_dir": ["eval", str(champ), "--video", str(tmp_path)],
    }[case]
    assert main(args) == 2  # returned, not raised: no traceback
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("mahn-evo: error:"), err
    assert not new.exists()  # no half-written folder


def test_seed_limits_in_the_config():
    assert small(seed=2**64 - 1).seed == 2**64 - 1
    for bad in (2**64, -1):
        with pytest.raises(ValueError, match=r"seed must be an integer in \[0, 2\*\*64\)"):
            small(seed=bad)
    for bad in (1.5, "3", True):
        with pytest.raises((TypeError, ValueError), match="seed"):
            small(seed=bad)
    from mahn_evo.experiment import ExperimentPlan

    with pytest.raises(ValueError, match=r"seed of the last run"):
        ExperimentPlan(seed=2**64 - 1, runs=2)  # run 2 would get seed 2**64
