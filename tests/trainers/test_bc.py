"""Smoke tests of trainers/bc.py: the real script in a subprocess, tiny budgets."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from temp_gym.models.snapshot import file_digest, read_snapshot

ROOT = Path(__file__).resolve().parents[2]


def run_bc(tmp_path: Path, *overrides: str, flags: tuple[str, ...] = ()) -> str:
    command = [
        sys.executable,
        str(ROOT / "trainers" / "bc.py"),
        "--config",
        str(ROOT / "configs" / "tiny.yaml"),
        "--no-progress",
        *flags,
        f"data.dir={tmp_path / 'data'}",
        "data.workers=1",
        f"logger.dir={tmp_path / 'runs'}",
        *overrides,
    ]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    done = subprocess.run(
        command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return done.stdout + done.stderr


def test_trains_evaluates_and_resumes(tmp_path):
    # Epoch 1 of a run without logging, then the same command with 2 epochs resumes it.
    run_bc(tmp_path, "train.max_epochs=1", "logger.backend=", flags=("--skip-eval",))
    run_dir = tmp_path / "runs" / "TEMP-2D-v0__bc__0"
    assert (run_dir / "last.pt").exists() and (run_dir / "best.pt").exists()
    assert not list(run_dir.glob("events.out.tfevents*"))
    output = run_bc(tmp_path, "train.max_epochs=2")
    assert "resuming: 1/2 epochs done" in output
    assert "| TEMP" in output and "| RRT*" in output
    assert list(run_dir.glob("events.out.tfevents*"))
    assert (run_dir / "results.yaml").exists()
    best = run_dir / "best.pt"  # its snapshot, of these very bytes, beside it
    assert read_snapshot(best, file_digest(best)) is not None
    last = torch.load(run_dir / "last.pt", weights_only=True)
    assert last["epoch"] == 2 and last["finished"]

    # An uninterrupted 2-epoch run ends with the same weights: a resumed run loses nothing.
    run_bc(
        tmp_path,
        "train.max_epochs=2",
        "train.exp_name=straight",
        "logger.backend=",
        "train_eval.every=0",
        flags=("--skip-eval",),
    )
    straight = torch.load(
        tmp_path / "runs" / "TEMP-2D-v0__straight__0" / "last.pt", weights_only=True
    )
    # With a fixed thread count (OMP_NUM_THREADS=1 here), resuming is bit-exact.
    for key, value in last["state_dict"].items():
        assert torch.equal(straight["state_dict"][key], value), key

    # A second run into a run folder in use is refused in one line, and writes nothing there.
    from temp_gym.files import DirectoryLock

    before = sorted(path.name for path in run_dir.iterdir())
    with DirectoryLock(run_dir, "training"):
        with pytest.raises(AssertionError, match="is in use by another run"):
            run_bc(tmp_path, "train.max_epochs=3", flags=("--skip-eval",))
    assert sorted(path.name for path in run_dir.iterdir()) == before


def test_symmetry_augmentation_keeps_occupied_cells_occupied():
    from temp_gym import training

    resolution = 8
    grid = torch.zeros(1, resolution, resolution)
    grid[0, 1, 6] = 1.0
    center = torch.tensor([[1.5, 6.5]]) / resolution * 2 - 1  # normalized center of that cell
    batch = {
        "occupancy": grid,
        "start": center,
        "goal": center,
        "path": center[:, None],
        "target": center,
        "path_length": torch.ones(1, 1, dtype=torch.long),
    }
    generator = torch.Generator().manual_seed(0)
    for _ in range(16):
        out = training.augment_symmetry(batch, generator)
        cell = ((out["start"][0] + 1) / 2 * resolution).long()
        assert out["occupancy"][0, cell[0], cell[1]] == 1
        torch.testing.assert_close(out["goal"], out["start"])
    noisy = training.perturb_path(batch, 0.1, generator)
    assert not torch.equal(noisy["path"], batch["path"])
    assert torch.equal(noisy["target"], batch["target"])


def test_paired_nodes_compares_task_by_task_with_failures_at_the_budget():
    from temp_gym import training

    def runs(nodes):
        return [{"success": float(n is not None), "nodes": n or 0} for n in nodes]

    temp = runs([10, 20, None, 40])  # the failure counts as the budget, 100
    rrt = runs([30, 20, 50, 60])
    paired = training.paired_nodes(temp, rrt, max_nodes=100)
    assert paired["fewer"] == 0.5  # tasks 0 and 3; task 1 is a tie
    assert paired["difference"] == (-20 + 0 + 50 - 20) / 4
    assert paired["low"] <= paired["difference"] <= paired["high"]
    assert paired["low"] < paired["high"]
    shifted = training.paired_nodes(runs([5, 15, 25]), runs([10, 20, 30]), max_nodes=100)
    assert shifted == {"fewer": 1.0, "difference": -5.0, "low": -5.0, "high": -5.0}
    with pytest.raises(ValueError, match="same non-empty task list"):
        training.paired_nodes(temp, rrt[:2], max_nodes=100)


def bc_module():
    sys.path.insert(0, str(ROOT / "trainers"))
    import bc

    return bc


def write_last(tmp_path, config, stored: dict | None = None) -> Path:
    """A last.pt of epoch 1 under ``config``, storing ``stored`` as its config if given."""
    from temp_gym import training

    model = training.make_model(config)
    optimizer, scheduler = training.make_optimizer(config, model)
    path = tmp_path / "last.pt"
    model.save(
        path, optimizer=optimizer.state_dict(), scheduler=scheduler.state_dict(),
        rng=torch.get_rng_state(), config=config.to_dict() if stored is None else stored,
        epoch=1, history=[],
    )  # fmt: skip
    return path


def tiny_config(*overrides):
    from temp_gym.config import load_config

    return load_config(ROOT / "configs" / "tiny.yaml", list(overrides))


def test_resuming_under_a_changed_training_config_is_refused_naming_the_keys(tmp_path):
    bc = bc_module()
    path = write_last(tmp_path, tiny_config())
    changed = tiny_config("optim.lr=5e-4", "loss.semantic_weight=2.0")
    with pytest.raises(bc.ResumeMismatchError) as error:
        bc.resume_checkpoint(path, changed, "point2d")
    message = str(error.value)
    assert "loss.semantic_weight: 1.0 -> 2.0" in message and "optim.lr: 0.001 -> 0.0005" in message
    assert "--no-resume" in message
    # When to stop, where it runs, what is evaluated and logged may change.
    allowed = tiny_config(
        "train.max_epochs=9", "train.threads=2", "train_eval.every=0", "logger.dir=x"
    )
    assert bc.resume_checkpoint(path, allowed, "point2d")["epoch"] == 1


def test_a_run_started_before_the_eval_section_was_renamed_resumes(tmp_path):
    # The layout last.pt stored before: an "eval" section, and none of the keys added since.
    bc = bc_module()
    config = tiny_config()
    old_layout = config.to_dict()
    old_layout["eval"] = old_layout.pop("train_eval")
    for section, key in [
        ("eval", "temp"),  # TEMP's settings were flat then: attention_nodes alone
        ("evaluation", "horizon"),
        ("evaluation", "temp"),
    ]:
        del old_layout[section][key]  # fmt: skip
    old_layout["eval"]["attention_nodes"] = old_layout["evaluation"]["attention_nodes"] = None
    path = write_last(tmp_path, config, stored=old_layout)
    assert bc.resume_checkpoint(path, config, "point2d")["epoch"] == 1
    assert bc.resume_checkpoint(path, tiny_config("train_eval.every=0"), "point2d")
    with pytest.raises(bc.ResumeMismatchError, match=r"\(optim.lr: 0.001 -> 0.0005\)"):
        bc.resume_checkpoint(path, tiny_config("optim.lr=5e-4"), "point2d")
    old_layout["model"]["num_heads"] = 1  # a key that shapes training, stored differently
    path = write_last(tmp_path, config, stored=old_layout)
    with pytest.raises(bc.ResumeMismatchError, match=r"model.num_heads: 1 -> 2"):
        bc.resume_checkpoint(path, config, "point2d")


@pytest.mark.parametrize("damage", ["truncate", "empty"])
def test_a_damaged_last_checkpoint_is_named_with_what_to_do(tmp_path, damage):
    from temp_gym.files import StoredFileError

    bc = bc_module()
    config = tiny_config()
    path = write_last(tmp_path, config)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2] if damage == "truncate" else b"")
    with pytest.raises(StoredFileError, match=r"last\.pt: cannot resume from it.*--no-resume"):
        bc.resume_checkpoint(path, config, "point2d")


def test_chunk_targets_are_the_next_nodes_of_the_same_path():
    from temp_gym import training

    # Two tasks of 3 and 2 samples, stored in path order.
    task_id = torch.tensor([0, 0, 0, 1, 1])
    step = torch.tensor([0, 1, 2, 0, 1])
    rows, mask = training.chunk_rows(task_id, step, 3)
    assert rows.tolist() == [[0, 1, 2], [1, 2, 1], [2, 2, 2], [3, 4, 3], [4, 4, 4]]
    assert mask.tolist() == [
        [True, True, True], [True, True, False], [True, False, False],
        [True, True, False], [True, False, False],
    ]  # fmt: skip
    single, single_mask = training.chunk_rows(task_id, step, 1)
    assert single.tolist() == [[0], [1], [2], [3], [4]] and bool(single_mask.all())
    with pytest.raises(ValueError, match="path order"):
        training.chunk_rows(torch.tensor([0, 1, 0, 1]), torch.tensor([0, 0, 1, 1]), 2)


def test_trains_a_chunked_mpt_that_plans(tmp_path):
    from temp_gym import plan
    from temp_gym.models.policy import TEMPPolicy
    from temp_gym.worlds.generators import generate_problem

    run_bc(tmp_path, "train.max_epochs=1", "model.chunk=3", "logger.backend=", "train_eval.every=0",
           flags=("--skip-eval",))  # fmt: skip
    best = tmp_path / "runs" / "TEMP-2D-v0__bc__0" / "best.pt"
    policy = TEMPPolicy.from_checkpoint(best)
    assert policy.chunk == 3
    problem = generate_problem("point2d", __import__("numpy").random.default_rng(0), "easy")
    result = plan(problem, policy=policy, seed=0, max_nodes=2000, stop_at_first=True)
    assert result.success and result.attention["compiled"]
    assert result.attention["policy_calls"] <= result.attention["policy_samples"]


@pytest.mark.parametrize(
    ("override", "message"),
    [("train.max_epochs=0", "train.max_epochs: must be at least 1"),
     ("train.batch_size=0", "train.batch_size: must be at least 1"),
     ("optim.lr=0", "optim.lr: must be positive"),
     ("train_eval.tasks=0", "train_eval.tasks: must be at least 1"),
     # found only after the dataset was built, with a traceback, before 2026-11-24:
     ("train.monitor=foo", "train.monitor: expected one of"),
     ("model.num_heads=3", "model.token_dim: 32 is not a multiple of model.num_heads (3)"),
     ("model.prediction=foo", "model: prediction: expected"),
     ("model.dropout=2", "model.dropout: must be at most"),
     ("train.device=foo", "train.device:"),
     ("logger.backend=foo", "logger.backend: expected"),
     ("train_eval.max_nodes=1", "train_eval.max_nodes: must be at least 2"),  # crashed in the env
     ("data.workspaces={train: 1, val: 0}", "data.workspaces.val: training needs at least one")],
)  # fmt: skip
def test_settings_that_would_train_or_compare_on_nothing_are_refused(tmp_path, override, message):
    command = [sys.executable, str(ROOT / "trainers" / "bc.py"), "--config",
               str(ROOT / "configs" / "tiny.yaml"), f"data.dir={tmp_path / 'data'}",
               f"logger.dir={tmp_path / 'runs'}", override]  # fmt: skip
    done = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and message in done.stderr, done.stderr[-2000:]
    assert not (tmp_path / "data").exists() and not (tmp_path / "runs").exists()  # before any work


def test_divergence_and_a_tampered_dataset_stop_in_one_line(tmp_path):
    """optim.lr=1e30 makes the loss NaN: no checkpoint is kept. Edited columns are refused."""
    import numpy as np

    from temp_gym.data.tables import file_digest as table_digest

    def bc(*overrides: str) -> subprocess.CompletedProcess:
        command = [sys.executable, str(ROOT / "trainers" / "bc.py"), "--config",
                   str(ROOT / "configs" / "tiny.yaml"), "--no-progress", "--skip-eval",
                   f"data.dir={tmp_path / 'data'}", "data.workers=1",
                   f"logger.dir={tmp_path / 'runs'}", "logger.backend=", *overrides]  # fmt: skip
        env = dict(os.environ, OMP_NUM_THREADS="1")
        return subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=300)  # fmt: skip

    diverged = bc("optim.lr=1e30", "train.max_epochs=2")
    assert diverged.returncode == 2, diverged.stderr[-2000:]
    assert diverged.stderr.strip().splitlines()[-1].startswith("bc.py: error: training diverged")
    run_dir = tmp_path / "runs" / "TEMP-2D-v0__bc__0"
    assert not (run_dir / "best.pt").exists() and not (run_dir / "last.pt").exists()

    target = tmp_path / "data" / "train" / "buffer" / "target.npy"
    values = np.load(target)
    values[0, 0] = np.nan
    np.save(target, values)
    card_path = tmp_path / "data" / "dataset_card.json"
    card = json.loads(card_path.read_text())
    card["files"]["train/buffer/target.npy"] = table_digest(target)  # the card rewritten to match
    card_path.write_text(json.dumps(card))
    refused = bc("train.max_epochs=1", "train.exp_name=tampered", "--no-resume")
    assert refused.returncode == 2
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and "target.npy: holds NaN or inf" in lines[0], refused.stderr
    assert not (tmp_path / "runs" / "TEMP-2D-v0__tampered__0").exists()


def test_an_empty_split_is_refused_in_one_line(tmp_path):
    command = [sys.executable, str(ROOT / "trainers" / "bc.py"), "--config",
               str(ROOT / "configs" / "tiny.yaml"), "--no-progress", "--skip-eval",
               f"data.dir={tmp_path / 'data'}", "data.workers=1",
               f"logger.dir={tmp_path / 'runs'}", "data.workspaces={train: 0, val: 1}"]  # fmt: skip
    done = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, OMP_NUM_THREADS="1"))  # fmt: skip
    error = done.stderr.strip().splitlines()[-1]
    assert done.returncode == 2, done.stderr[-2000:]
    assert "data.workspaces.train: training needs at least one train workspace" in error
    assert not (tmp_path / "data").exists()  # refused before the dataset was generated


def test_a_split_whose_expert_plans_all_failed_says_so(tmp_path, monkeypatch):
    import temp_gym.data
    from temp_gym.config import load_config
    from temp_gym.config.errors import ConfigError
    from temp_gym.training.batches import make_replay_buffer

    config = load_config(ROOT / "configs" / "tiny.yaml", [f"data.dir={tmp_path}"])
    monkeypatch.setattr(temp_gym.data, "load_split", lambda directory, split: ([], []))
    card = {"splits": {"val": {"plans_attempted": 3, "plans_stored": 0}}}
    (tmp_path / "dataset_card.json").write_text(json.dumps(card))
    with pytest.raises(ConfigError, match=r"holds no samples: 0 of its 3 expert plans succeeded"):
        make_replay_buffer(config, "val")
    # No task could be drawn at all: the node budget is not what to change.
    card["splits"]["val"]["tasks_not_drawn"] = 3
    (tmp_path / "dataset_card.json").write_text(json.dumps(card))
    with pytest.raises(ConfigError, match=r"none of its 3 tasks could be drawn \(no free start"):
        make_replay_buffer(config, "val")
    (tmp_path / "dataset_card.json").unlink()  # no card: no count to give
    with pytest.raises(ConfigError, match=r"holds no samples; training needs at least one"):
        make_replay_buffer(config, "val")
