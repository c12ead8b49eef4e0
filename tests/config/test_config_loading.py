"""temp_gym.config.loading: YAML files, overrides, the environment's, older stored configs."""

from __future__ import annotations

import doctest
import json
import re
from dataclasses import asdict
from pathlib import Path

import pytest

import temp_gym.config
from temp_gym.config import (
    MOVED_KEYS,
    ConfigError,
    TEMPConfig,
    apply_overrides,
    differing_keys,
    load_config,
    upgrade_stored,
)
from temp_gym.jobs import run_script

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).with_name("data")


@pytest.fixture(autouse=True)
def no_environment_overrides(monkeypatch):
    monkeypatch.delenv("TEMP_GYM_OVERRIDES", raising=False)


@pytest.mark.parametrize("name", ["2d", "3d", "7d", "tiny", "quick"])
def test_shipped_configs_load(name):
    config = load_config(f"configs/{name}.yaml")
    assert config.env.id.startswith("TEMP-") and config.data.dir.startswith("datasets/")


def test_overrides_are_parsed_and_checked_against_the_types():
    config = load_config("configs/2d.yaml", ["env.max_path_length=32", "data.seed=7"])
    assert config.env.max_path_length == 32 and config.data.seed == 7
    config = apply_overrides(config, ["optim.lr=1e-4", "env.step_size=null", "train.threads=2"])
    assert config.optim.lr == 1e-4 and config.env.step_size is None and config.train.threads == 2
    config = apply_overrides(config, ["data.workspaces={train: 2, val: 1}", "logger.backend="])
    assert (config.data.workspaces.train, config.data.workspaces.val) == (2, 1)
    assert config.logger.backend == ""
    # A mapping merges into its section: the keys it leaves out keep their values.
    config = apply_overrides(config, ["data.workspaces={train: 5}"])
    assert (config.data.workspaces.train, config.data.workspaces.val) == (5, 1)
    # Every declared key can be set, listed in the file or not; "+" is accepted and the same.
    assert "horizon" not in (ROOT / "configs" / "2d.yaml").read_text()
    assert apply_overrides(config, ["evaluation.horizon=2"]).evaluation.horizon == 2
    assert apply_overrides(config, ["+evaluation.horizon=3"]).evaluation.horizon == 3
    # Text that reads as a number is one only where a number is declared.
    config = apply_overrides(config, ["train.exp_name=1e5", "optim.lr=2e-4"])
    assert config.train.exp_name == "1e5" and config.optim.lr == 2e-4


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("train.max_epoch=3", "unknown key train.max_epoch (did you mean train.max_epochs?)"),
        ("+train.nothing=3", "unknown key train.nothing"),
        ("trian.max_epochs=3", "unknown key trian (did you mean train?)"),
        ("eval.tasks=2", "unknown key eval (the eval section is now train_eval)"),
        ("train.max_epochs=ten", "train.max_epochs: expected an integer, got 'ten'"),
        ("train.augment=2", "train.augment: expected true or false, got 2"),
        ("optim.betas=0.9", "optim.betas: expected a list of numbers, got 0.9"),
        ("optim.lr=nan", "optim.lr: expected a number, got 'nan'"),
        ("train.max_epochs.x=1", "unknown key train.max_epochs.x (train.max_epochs is a value"),
        ("train.max_epochs", "expected key.sub=value"),
    ],
)
def test_a_bad_override_is_named(override, message):
    with pytest.raises(ConfigError) as error:
        load_config("configs/2d.yaml", [override])
    assert str(error.value).startswith(f"override {override!r}: ")
    assert message in str(error.value)


def test_a_bad_file_is_named_with_the_key(tmp_path):
    text = (ROOT / "configs" / "tiny.yaml").read_text()
    cases = {
        "typo.yaml": (text.replace("max_epochs:", "max_epoch:"), "train.max_epoch (did you mean"),
        "type.yaml": (text.replace("batch_size: 64", "batch_size: many"),
                      "train.batch_size: expected an integer, got 'many'"),
        "old.yaml": (text.replace("train_eval:", "eval:"),
                     "unknown key eval (the eval section is now train_eval)"),
        "nodir.yaml": (text.replace("  dir: datasets/tiny", "  seed_: 1"), "data.seed_"),
        "list.yaml": ("- 1\n- 2\n", "a config must be a YAML mapping"),
    }  # fmt: skip
    for name, (content, message) in cases.items():
        (tmp_path / name).write_text(content)
        with pytest.raises(ConfigError) as error:
            load_config(tmp_path / name)
        assert str(error.value).startswith(f"{tmp_path / name}: "), name
        assert message in str(error.value), (name, str(error.value))
    (tmp_path / "missing_dir.yaml").write_text(re.sub(r"(?m)^  dir: datasets/tiny.*\n", "", text))
    with pytest.raises(ConfigError, match=r"data\.dir: missing \(it has no default\)"):
        load_config(tmp_path / "missing_dir.yaml")


def test_config_errors_are_one_line_job_errors(tmp_path, capsys):
    def main(argv):
        load_config(tmp_path / "missing.yaml")

    assert run_script("x.py", main) == 2
    assert capsys.readouterr().err.strip() == (
        f"x.py: error: {tmp_path / 'missing.yaml'}: cannot read the config (No such file or "
        "directory)"
    )
    (tmp_path / "bad.yaml").write_text("a: [1, 2")
    with pytest.raises(ConfigError, match="bad.yaml: not valid YAML"):
        load_config(tmp_path / "bad.yaml")


def test_environment_overrides_apply_after_the_callers(monkeypatch):
    monkeypatch.setenv(
        "TEMP_GYM_OVERRIDES", "train.max_epochs=1 'data.workspaces={train: 2, val: 1}'"
    )
    config = load_config("configs/2d.yaml", ["train.max_epochs=5", "data.seed=7"])
    assert config.train.max_epochs == 1 and config.data.seed == 7
    assert (config.data.workspaces.train, config.data.workspaces.val) == (2, 1)
    monkeypatch.setenv("TEMP_GYM_OVERRIDES", "train.max_epoch=1")
    with pytest.raises(ValueError, match=r"\$TEMP_GYM_OVERRIDES: .*unknown key train.max_epoch"):
        load_config("configs/2d.yaml")
    with pytest.raises(ConfigError) as error:  # the caller's own typo is not blamed on it
        load_config("configs/2d.yaml", ["train.seeed=1"])
    assert not str(error.value).startswith("$TEMP_GYM_OVERRIDES")
    monkeypatch.delenv("TEMP_GYM_OVERRIDES")
    assert load_config("configs/2d.yaml").train.max_epochs > 1


def test_the_package_docstring_example_runs():
    outcome = doctest.testmod(temp_gym.config)
    assert outcome.attempted >= 4 and outcome.failed == 0


MAIN_JOB_OVERRIDES = [
    "data.dir=datasets/2d-quick",
    "data.workspaces.train=30",
    "data.workspaces.val=5",
    "data.tasks_per_workspace=40",
    "train.exp_name=quick",
    "train.max_epochs=30",
    "train.threads=1",
    "train.path_noise=0.03",
    "train.monitor=semantic",
    "model.dropout=0.1",
    "train_eval.tasks=40",
]
"""What trainers/bc.py applied to configs/2d.yaml for its main job before configs/quick.yaml
(its DEFAULT_OVERRIDES, with eval.tasks renamed)."""


def test_the_main_job_is_configs_2d_with_the_overrides_bc_py_once_built_in():
    quick = load_config("configs/quick.yaml").to_dict()
    merged = load_config("configs/2d.yaml", MAIN_JOB_OVERRIDES).to_dict()
    assert quick == merged
    assert json.dumps(quick) == json.dumps(merged)  # the same types and key order too


def test_bc_py_runs_the_main_job_without_a_config_flag():
    import sys

    sys.path.insert(0, str(ROOT / "trainers"))
    import bc

    config, args = bc.read_command_line([])
    assert config == load_config("configs/quick.yaml") and not args.overrides
    config, _ = bc.read_command_line(["train.max_epochs=2"])
    assert config.train.max_epochs == 2 and config.train.exp_name == "quick"


def test_a_config_stored_before_the_rename_upgrades_to_the_same_config():
    # A last.pt of a run started before the eval section was renamed (a 3D run's config).
    stored = json.loads((DATA / "stored_before_rename.json").read_text())
    assert "eval" in stored and "train_eval" not in stored
    assert "horizon" not in stored["evaluation"]
    upgraded = upgrade_stored(stored)
    flat = {key: value for key, value in stored["eval"].items() if key != "attention_nodes"}
    assert upgraded["train_eval"] == {**flat, "temp": {**asdict(TEMPConfig()),
                                                       "attention_nodes": None}}  # fmt: skip
    assert upgraded["evaluation"]["horizon"] is None and "eval" not in upgraded
    # The command that started that run gives the same config today, key for key.
    today = load_config("configs/3d.yaml", [
        "data.dir=datasets/3d_paper", "data.workspaces.train=320", "data.tasks_per_workspace=64",
        "model.chunk=4", "train.exp_name=paper_chunk4", "train.threads=2",
        "train.monitor=semantic", "train.max_epochs=6", "train_eval.every=0",
    ])  # fmt: skip
    assert differing_keys(upgraded, today.to_dict()) == []
    # ... and a real difference still shows.
    changed = apply_overrides(today, ["model.num_layers=2"]).to_dict()
    assert differing_keys(upgraded, changed) == ["model.num_layers"]


def test_temp_settings_stored_flat_move_into_their_section_and_old_keys_name_the_new():
    # Configs stored before TEMP's settings had their own section held them flat.
    stored = load_config("configs/2d.yaml").to_dict()
    stored["train_eval"].pop("temp")
    stored["train_eval"].update(attention_patience=30, goal_tree=False)
    upgraded = upgrade_stored(stored)
    assert "attention_patience" not in upgraded["train_eval"]
    assert upgraded["train_eval"]["temp"] == {**asdict(TEMPConfig()), "attention_patience": 30,
                                              "goal_tree": False}  # fmt: skip
    assert MOVED_KEYS["evaluation.attention_rounds"] == "evaluation.temp.attention_rounds"
    with pytest.raises(
        ConfigError, match=r"\(the key is now train_eval.temp.attention_patience\)$"
    ):
        load_config("configs/2d.yaml", ["train_eval.attention_patience=30"])


def test_upgrading_keeps_keys_that_are_gone():
    stored = json.loads((DATA / "stored_before_rename.json").read_text())
    stored["train"]["split_size"] = 3
    assert upgrade_stored(stored)["train"]["split_size"] == 3
