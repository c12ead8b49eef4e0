"""trainers/evaluate.py and docs/make_results.py end to end, on a tiny untrained policy."""

import json
import sys
from pathlib import Path

import pytest
import torch

from temp_gym.config.errors import ConfigError
from temp_gym.evaluation.runner import ManifestMismatchError
from temp_gym.models.temp import TEMPModel, weights_digest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "docs"))

import make_results  # noqa: E402

from temp_gym.evaluation import command as evaluate  # noqa: E402

SMALL = {"token_dim": 16, "num_heads": 2, "num_layers": 1, "ffn_dim": 32, "num_sei_tokens": 2,
         "eise_hidden": 32}  # fmt: skip


def test_evaluate_then_make_results(tmp_path, monkeypatch):
    torch.manual_seed(0)
    model = TEMPModel.from_config(SMALL, "point2d", 16, 64)
    model.save(tmp_path / "best.pt")
    monkeypatch.chdir(tmp_path)
    out = Path("results") / "TEMP-2D-v0"
    table = evaluate.main([
        "--config", str(ROOT / "configs" / "tiny.yaml"), "--checkpoint", str(tmp_path / "best.pt"),
        "--workers", "1", "--no-progress", "evaluation.tasks=1", "evaluation.max_nodes=3000",
        "evaluation.baselines=[rrt_star]", "evaluation.curve_tasks=1",
        "evaluation.curve_nodes=300", f"evaluation.out={out}",
    ])  # fmt: skip
    assert "| 2D easy |" in table and "| 2D challenging |" in table
    results = json.loads((out / "results.json").read_text())
    assert results["checkpoint_digest"] == weights_digest(model.state_dict())
    assert results["settings"]["temp"]["attention_nodes"] is None  # none carried: all of it
    for name in ("results.md", "success_vs_time.png", "cost_vs_nodes.png", "attention.png"):
        assert (out / name).is_file()
    page = make_results.main(
        ["--worlds", "2d", "--skip-evaluation", "--docs-dir", str(tmp_path / "docs")]
    )
    text = page.read_text()
    assert "## Acceptance checks" in text and "## TEMP-2D-v0" in text
    assert (
        "| 2D easy |" in text and (tmp_path / "docs" / "results" / "2d" / "attention.png").is_file()
    )


def test_evaluate_refuses_a_checkpoint_for_another_robot(tmp_path):
    TEMPModel.from_config(SMALL, "point3d", 8, 64).save(tmp_path / "best.pt")
    with pytest.raises(ConfigError, match="--checkpoint: .*point3d"):
        evaluate.main(["--config", str(ROOT / "configs" / "tiny.yaml"),
                       "--checkpoint", str(tmp_path / "best.pt")])  # fmt: skip


def test_config_is_required_and_every_flag_shows_its_default(capsys):
    with pytest.raises(SystemExit):
        evaluate.main([])
    assert "--config" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        evaluate.main(["--help"])
    text = capsys.readouterr().out
    assert "(default: local)" in text and "(default: None)" in text


@pytest.mark.parametrize(
    ("override", "message"),
    [("evaluation.tasks=0", "evaluation.tasks: must be at least 1"),  # ran the full 100
     ("evaluation.curve_tasks=-1", "evaluation.curve_tasks: must be at least 0"),  # ran
     # these failed in the workers, with a traceback:
     ("evaluation.time_limit=-1", "evaluation.time_limit: must be positive"),
     ("evaluation.max_nodes=0", "evaluation.max_nodes: must be at least 1"),
     ("evaluation.baselines=[foo]", "evaluation.baselines: unknown planner 'foo'"),
     ("evaluation.baselines=[rrt_star,rrt_star]",
      "evaluation.baselines: 'rrt_star' is listed twice"),  # ran, with one column
     ("evaluation.noise_std=-1", "evaluation.noise_std: must be at least 0"),
     ("evaluation.horizon=9", "evaluation.horizon: expected an integer in 1.."),
     ("evaluation.workspace_family=nope", "evaluation.workspace_family: expected one of"),
     ("evaluation.workspace_family=manipulation",
      "evaluation.workspace_family: 'manipulation' is drawn for arms only")],
)  # fmt: skip
def test_bad_evaluation_settings_are_refused_by_name_before_any_task(tmp_path, override, message):
    TEMPModel.from_config(SMALL, "point2d", 16, 64).save(tmp_path / "best.pt")
    args = ["--config", str(ROOT / "configs" / "tiny.yaml"),
            "--checkpoint", str(tmp_path / "best.pt"),
            f"evaluation.out={tmp_path / 'results'}"]  # fmt: skip
    with pytest.raises(ConfigError, match=message):
        evaluate.main([*args, override])
    assert not (tmp_path / "results").exists()


def test_zero_workers_are_refused_not_replaced(tmp_path, capsys):
    with pytest.raises(SystemExit):
        evaluate.main(["--config", str(ROOT / "configs" / "tiny.yaml"), "--workers", "0"])
    assert "--workers: expected a positive integer" in capsys.readouterr().err


def test_the_goal_tree_setting_reaches_the_evaluation_and_is_type_checked():
    from temp_gym.config import load_config

    tiny = ROOT / "configs" / "tiny.yaml"
    assert "goal_tree" not in evaluate.settings_from(load_config(tiny, []))[0].temp  # default
    off = load_config(tiny, ["evaluation.temp.goal_tree=false"])
    assert evaluate.settings_from(off)[0].temp["goal_tree"] is False
    with pytest.raises(ConfigError, match="evaluation.temp.goal_tree"):
        load_config(tiny, ["evaluation.temp.goal_tree=3"])
    with pytest.raises(ConfigError, match=r"\(the key is now evaluation.temp.goal_tree\)"):
        load_config(tiny, ["evaluation.goal_tree=false"])
    both = load_config(
        tiny, ["evaluation.temp.goal_tree=false", "evaluation.temp.attention_rounds=2"]
    )
    with pytest.raises(ConfigError, match="^evaluation.temp.attention_rounds: "):
        evaluate.settings_from(both)


def test_a_checkpoints_path_window_joins_the_manifest(tmp_path, monkeypatch):
    """Records made with another window are not mixed in: the rerun refuses the directory."""
    torch.manual_seed(0)
    TEMPModel.from_config(SMALL, "point2d", 16, 64).save(tmp_path / "best.pt")
    monkeypatch.chdir(tmp_path)
    args = [
        "--config", str(ROOT / "configs" / "tiny.yaml"), "--checkpoint", str(tmp_path / "best.pt"),
        "--workers", "1", "--no-progress", "evaluation.tasks=1", "evaluation.max_nodes=300",
        "evaluation.baselines=[rrt_star]", "evaluation.curve_tasks=0", "evaluation.out=out",
    ]  # fmt: skip
    evaluate.main(args)
    assert "path_window" not in json.loads(Path("out/run.json").read_text())
    checkpoint = torch.load(tmp_path / "best.pt", weights_only=True)
    checkpoint["planner"] = {**checkpoint.get("planner", {}), "path_window": 3}
    torch.save(checkpoint, tmp_path / "best.pt")
    with pytest.raises(ManifestMismatchError):
        evaluate.main(args)
    evaluate.main([*args[:-1], "evaluation.out=windowed"])
    assert json.loads(Path("windowed/run.json").read_text())["path_window"] == 3
    assert json.loads(Path("windowed/results.json").read_text())["settings"]["path_window"] == 3


def test_the_workspace_family_reaches_the_evaluation():
    """The Panda's config measures its policy on the family it was trained on."""
    from temp_gym.config import load_config

    panda = load_config(ROOT / "configs" / "panda.yaml", [])
    assert panda.evaluation.workspace_family == panda.data.workspace_family == "manipulation"
    assert evaluate.settings_from(panda)[0].workspace_family == "manipulation"
    tiny = load_config(ROOT / "configs" / "tiny.yaml", [])
    assert evaluate.settings_from(tiny)[0].workspace_family == "boxes"
