"""trainers/ship.py: a slim shipped checkpoint, its model card, and load_policy's settings."""

import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from temp_gym.config import ConfigError
from temp_gym.models import registry
from temp_gym.models.snapshot import file_digest, read_snapshot
from temp_gym.models.temp import TEMPModel, load_checkpoint, weights_digest
from temp_gym.planning.plan import plan
from temp_gym.worlds.generators import generate_problem

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from trainers import ship  # noqa: E402

SMALL = {"token_dim": 16, "num_heads": 2, "num_layers": 1, "ffn_dim": 32, "num_sei_tokens": 2,
         "eise_hidden": 32}  # fmt: skip
TRAINED_WITH = [f"model.{key}={value}" for key, value in SMALL.items()]
"""The overrides of tiny.yaml that make the config the small model's (ship.py checks them)."""


@pytest.fixture
def shipped(tmp_path, monkeypatch):
    torch.manual_seed(0)
    model = TEMPModel.from_config(SMALL, "point2d", 16, 64)
    best = tmp_path / "best.pt"
    model.save(best, epoch=7, val_loss=0.5, optimizer_state={"lr": 1e-3})
    out = tmp_path / "checkpoints"
    monkeypatch.chdir(tmp_path)  # no results/ here: the card says "not evaluated yet"
    path = ship.main([
        "--config", str(ROOT / "configs" / "tiny.yaml"), "--checkpoint", str(best),
        "--attention-nodes", "40", "--noise-std", "0.02", "--out-dir", str(out),
        f"data.dir={tmp_path / 'no-data'}", *TRAINED_WITH,
    ])  # fmt: skip
    monkeypatch.setattr(registry, "CHECKPOINT_DIR", out)
    return model, path


def test_ship_writes_a_slim_checkpoint_and_a_card(shipped):
    model, path = shipped
    assert path.name == "2d.pt" and path.stat().st_size < ship.MAX_BYTES
    loaded, checkpoint = load_checkpoint(path, robot="point2d")  # weights_only=True inside
    assert "optimizer_state" not in checkpoint
    assert checkpoint["planner"]["attention_nodes"] == 40
    assert checkpoint["provenance"]["digest"] == weights_digest(model.state_dict())
    for name, tensor in model.state_dict().items():
        assert torch.equal(loaded.state_dict()[name], tensor)
    snapshot = read_snapshot(path, file_digest(path))  # beside it, and of these very bytes
    assert snapshot is not None and snapshot.meta["planner"]["attention_nodes"] == 40
    card = path.with_suffix(".md").read_text()
    assert "Attention-phase budget n (Algorithm 1): 40 nodes" in card
    assert "Not evaluated yet" in card and "Dataset card unavailable" in card


def test_refresh_evaluation_rewrites_only_that_section_for_the_same_weights(shipped, tmp_path):
    model, path = shipped
    card = path.with_suffix(".md")
    head = card.read_text().split("\n## Evaluation\n")[0]
    results = tmp_path / "results" / "TEMP-2D-v0"  # the fixture's working directory
    results.mkdir(parents=True)
    (results / "results.md").write_text("| a table |\n")
    (results / "results.json").write_text('{"checkpoint_digest": "other weights"}')
    refresh = ["--refresh-evaluation", "TEMP-2D-v0", "--out-dir", str(path.parent)]
    with pytest.raises(ConfigError, match="made with other weights"):
        ship.main(refresh)
    assert "Not evaluated yet" in card.read_text()
    digest = weights_digest(model.state_dict())
    (results / "results.json").write_text(f'{{"checkpoint_digest": "{digest}"}}')
    assert ship.main(refresh) == path
    text = card.read_text()
    assert text.startswith(head + "\n## Evaluation\nThe paper's protocol")
    assert text.endswith("| a table |\n") and "Not evaluated yet" not in text
    with pytest.raises(ConfigError, match="expected one of"):
        ship.main(["--refresh-evaluation", "TEMP-9D-v0"])


def test_load_policy_applies_the_shipped_planner_settings(shipped):
    policy = registry.load_policy("TEMP-2D-v0", seed=0)
    assert policy.attention_nodes == 40 and policy.noise_std == pytest.approx(0.02)
    assert registry.load_policy("point2d", noise_std=0.0).noise_std == 0.0
    problem = generate_problem("point2d", np.random.default_rng(3), "challenging")
    result = plan(problem, planner="temp", policy=policy, seed=0, max_nodes=3000)
    assert result.attention["nodes"] <= 40 and result.success  # CP finishes what AP did not
    explicit = plan(problem, planner="temp", policy=policy, seed=0, max_nodes=3000,
                    attention_nodes=10, stop_at_first=True)  # fmt: skip
    assert explicit.attention["nodes"] <= 10


def test_without_a_budget_the_attention_phase_gets_all_of_max_nodes(shipped, tmp_path):
    model, path = shipped
    out = tmp_path / "whole-budget"
    again = ship.main([
        "--config", str(ROOT / "configs" / "tiny.yaml"), "--checkpoint", str(path),
        "--out-dir", str(out), f"data.dir={tmp_path / 'no-data'}", *TRAINED_WITH,
    ])  # fmt: skip
    _, checkpoint = load_checkpoint(again, robot="point2d")
    assert checkpoint["planner"]["attention_nodes"] is None
    assert "all of the planner's `max_nodes`" in again.with_suffix(".md").read_text()


def test_a_near_goal_factor_is_shipped_carried_and_applied(shipped, tmp_path):
    model, path = shipped
    args = ["--config", str(ROOT / "configs" / "tiny.yaml"), "--checkpoint", str(path),
            f"data.dir={tmp_path / 'no-data'}", *TRAINED_WITH]  # fmt: skip
    out = tmp_path / "near-goal"
    again = ship.main([*args, "--attention-near-goal-factor", "5", "--out-dir", str(out)])
    _, checkpoint = load_checkpoint(again, robot="point2d")
    assert checkpoint["planner"]["attention_near_goal_factor"] == 5.0
    assert "5 times longer once the tree's closest approach" in again.with_suffix(".md").read_text()
    policy = registry.policy_from_checkpoint(again)
    assert policy.attention_near_goal_factor == 5.0
    assert registry.load_policy("TEMP-2D-v0").attention_near_goal_factor is None  # the fixture's
    with pytest.raises(SystemExit):  # argparse: one line, exit status 2
        ship.main([*args, "--attention-near-goal-factor", "0.5", "--out-dir", str(out)])


def test_ship_refuses_a_checkpoint_for_another_robot(tmp_path):
    model = TEMPModel.from_config(SMALL, "point3d", 8, 64)
    model.save(tmp_path / "best.pt")
    with pytest.raises(ValueError, match="point3d"):
        ship.main([
            "--config", str(ROOT / "configs" / "tiny.yaml"),
            "--checkpoint", str(tmp_path / "best.pt"), "--attention-nodes", "10",
            "--out-dir", str(tmp_path),
        ])  # fmt: skip


def test_update_planner_changes_settings_keeps_weights_and_rewrites_the_card(shipped):
    model, path = shipped
    out = str(path.parent)
    card_before = path.with_suffix(".md").read_text()
    ship.main(["--update-planner", "TEMP-2D-v0", "attention_follow_fallback=0.25",
               "chosen_by=on validation", "--out-dir", out])  # fmt: skip
    _, checkpoint = load_checkpoint(path, robot="point2d")
    assert checkpoint["planner"]["attention_follow_fallback"] == 0.25
    assert checkpoint["planner"]["attention_nodes"] == 40  # the others stay
    assert checkpoint["provenance"]["digest"] == weights_digest(model.state_dict())
    snapshot = read_snapshot(path, file_digest(path))  # rewritten for the new bytes
    assert snapshot is not None and snapshot.meta["planner"]["attention_follow_fallback"] == 0.25
    card = path.with_suffix(".md").read_text()
    assert "with probability 0.25, else from the path it read before" in card
    assert "How they were chosen: on validation." in card
    assert card.split("## Data")[1] == card_before.split("## Data")[1]  # the rest stays
    assert registry.policy_from_checkpoint(path).attention_follow_fallback == 0.25
    assert "(the planner's default, `temp_gym.planning.attention.RESUME_AFTER`)" in card
    ship.main(["--update-planner", "TEMP-2D-v0", "attention_resume=0", "--out-dir", out])
    assert registry.policy_from_checkpoint(path).attention_resume == 0.0
    assert "After a stall, classical planning keeps the rest of the budget." in (
        path.with_suffix(".md").read_text()
    )
    assert (
        "1 more round(s) of the two (the planner's default" in path.with_suffix(".md").read_text()
    )
    ship.main(["--update-planner", "TEMP-2D-v0", "attention_resume=1", "--out-dir", out])
    assert "the first solution." in path.with_suffix(".md").read_text()
    ship.main(["--update-planner", "TEMP-2D-v0", "attention_resume_growth=4", "--out-dir", out])
    assert registry.policy_from_checkpoint(path).attention_resume_growth == 4.0
    assert "each later classical turn is 4 x the one before" in path.with_suffix(".md").read_text()
    ship.main(["--update-planner", "TEMP-2D-v0", "attention_rounds=2", "--out-dir", out])
    assert registry.policy_from_checkpoint(path).attention_rounds == 2
    assert "2 more round(s) of the two, a resumed" in path.with_suffix(".md").read_text()
    assert "the whole path the model was trained on" in path.with_suffix(".md").read_text()
    ship.main(["--update-planner", "TEMP-2D-v0", "path_window=3", "--out-dir", out])
    assert registry.policy_from_checkpoint(path).window == 3
    assert "the newest 3 nodes (`path_window`)" in path.with_suffix(".md").read_text()
    assert "uniform, not the policy's" not in path.with_suffix(".md").read_text()
    ship.main(["--update-planner", "TEMP-2D-v0", "attention_uniform=0.1", "--out-dir", out])
    assert registry.policy_from_checkpoint(path).attention_uniform == 0.1
    assert "A share of 0.1 of the attention phase's samples is uniform" in (
        path.with_suffix(".md").read_text()
    )
    ship.main(["--update-planner", "TEMP-2D-v0", "attention_uniform=0", "--out-dir", out])
    ship.main(["--update-planner", "TEMP-2D-v0", "attention_local_fallback=20", "--out-dir", out])
    assert registry.policy_from_checkpoint(path).attention_local_fallback == 20
    assert "its first 20 replacements are drawn near it" in path.with_suffix(".md").read_text()
    ship.main(["--update-planner", "TEMP-2D-v0", "attention_local_fallback=0", "--out-dir", out])
    assert "replacements are drawn near it" not in path.with_suffix(".md").read_text()
    for bad, message in [
        ("path_window=0", "path_window"),
        ("path_window=1000", "path_window"),
        ("attention_rounds=-1", "attention_rounds"),
        ("attention_rounds=1.5", "attention_rounds"),
        ("attention_resume=-1", "attention_resume"),
        ("attention_resume_growth=0.5", "attention_resume_growth"),
        ("attention_follow_fallback=2", "attention_follow_fallback"),
        ("attention_uniform=1.5", "attention_uniform"),
        ("attention_local_fallback=-1", "attention_local_fallback"),
        ("noise_std=-1", "noise_std"),
        ("colour=red", "key=value"),
        ("attention_follow_fallback", "key=value"),
    ]:
        with pytest.raises(ConfigError, match=message):
            ship.main(["--update-planner", "TEMP-2D-v0", bad, "--out-dir", out])
    _, unchanged = load_checkpoint(path, robot="point2d")  # refused: nothing was written
    assert unchanged["planner"] == {**checkpoint["planner"], "attention_resume": 1,
                                    "attention_resume_growth": 4, "attention_rounds": 2,
                                    "path_window": 3, "attention_uniform": 0,
                                    "attention_local_fallback": 0}  # fmt: skip
    with pytest.raises(ConfigError, match="expected one of"):
        ship.main(["--update-planner", "TEMP-9D-v0", "noise_std=0", "--out-dir", out])


def test_ship_refuses_a_config_the_checkpoint_was_not_trained_with(shipped, tmp_path):
    """The card showed the config given beside the checkpoint's own sizes, contradicting them."""
    _, path = shipped
    best = path.parent.parent / "best.pt"
    args = ["--config", str(ROOT / "configs" / "tiny.yaml"), "--checkpoint", str(best),
            "--out-dir", str(tmp_path / "other"), f"data.dir={tmp_path / 'no-data'}"]  # fmt: skip
    with pytest.raises(ValueError, match=r"model.token_dim: 16 in best.pt, 32 given"):
        ship.main([*args, *TRAINED_WITH[1:]])
    assert not (tmp_path / "other").exists()


def test_ship_refuses_a_config_other_than_the_runs_stored_one(shipped, tmp_path):
    """Beside a run's ``last.pt``, the whole config is compared: keys that shape training must
    be the run's; where it ran and what it logged may differ."""
    from temp_gym.config import load_config

    _, path = shipped
    best = path.parent.parent / "best.pt"
    base = ["--config", str(ROOT / "configs" / "tiny.yaml"), f"data.dir={tmp_path / 'no-data'}",
            *TRAINED_WITH]  # fmt: skip
    trained = load_config(base[1], base[2:]).to_dict()
    torch.save({"config": trained}, best.with_name("last.pt"))
    args = [*base, "--checkpoint", str(best)]
    with pytest.raises(ValueError, match=r"optim.lr: 0.001 in last.pt, 0.5 given"):
        ship.main([*args, "--out-dir", str(tmp_path / "a"), "optim.lr=0.5"])
    shipped_again = ship.main([*args, "--out-dir", str(tmp_path / "b"), "logger.backend="])
    assert shipped_again.is_file()


def test_ship_updates_every_setting_a_checkpoint_entry_may_give():
    from temp_gym.models.checkpoint_settings import CHECKPOINT_SETTINGS

    assert set(CHECKPOINT_SETTINGS) <= set(ship.PLANNER_KEYS)
