"""temp_gym.config.checks and the YAML loader: bounds, names, env ids, aliases, depth, folders."""

from __future__ import annotations

from pathlib import Path

import pytest

from temp_gym.config import ConfigError, load_config
from temp_gym.config.checks import RANGES, check_output_dir
from temp_gym.limits import MAX_CONFIG_DEPTH, MAX_MESSAGE_LENGTH, MAX_TASKS_PER_WORKSPACE

TINY = Path(__file__).resolve().parents[2] / "configs" / "tiny.yaml"


@pytest.fixture(autouse=True)
def no_environment_overrides(monkeypatch):
    monkeypatch.delenv("TEMP_GYM_OVERRIDES", raising=False)


def refused(*overrides: str) -> str:
    with pytest.raises(ConfigError) as caught:
        load_config(TINY, list(overrides))
    return str(caught.value)


@pytest.mark.parametrize("name", ["../../..", "a/b", ".hidden", "x y", "é", "a\\b", "", "a" * 101])
def test_a_run_name_is_one_safe_path_component(name):
    message = refused(f"train.exp_name={name}")
    assert message.startswith("train.exp_name:")
    assert "letters, digits" in message or "at most 100" in message


@pytest.mark.parametrize("name", ["bc", "sc320r", "tiny_mixed-2.v1", "1e5"])
def test_usual_run_names_pass(name):
    assert load_config(TINY, [f"train.exp_name={name}"]).train.exp_name == name


def test_an_alias_bomb_is_refused_before_it_expands_and_is_not_echoed_whole():
    levels = ["&a [x,x,x,x,x,x,x,x,x]"] + [
        f"&{chr(98 + i)} [{','.join([f'*{chr(97 + i)}'] * 9)}]" for i in range(8)
    ]
    bomb = "[" + ", ".join(levels) + "]"
    message = refused(f"train.exp_name={bomb}")
    assert "anchors and aliases" in message
    assert len(message) < MAX_MESSAGE_LENGTH


def test_an_alias_in_a_config_file_is_refused(tmp_path):
    text = TINY.read_text().replace("exp_name:", "exp_name: &name")
    (tmp_path / "aliased.yaml").write_text(text)
    with pytest.raises(ConfigError, match="anchors and aliases"):
        load_config(tmp_path / "aliased.yaml")


@pytest.mark.parametrize("depth", [MAX_CONFIG_DEPTH + 1, 50_000])
def test_deep_nesting_is_refused_without_recursion_error(tmp_path, depth):
    (tmp_path / "deep.yaml").write_text("env: " + "[" * depth + "]" * depth + "\n")
    with pytest.raises(ConfigError, match="nested more than"):
        load_config(tmp_path / "deep.yaml")
    assert "nested more than" in refused("train.exp_name=" + "[" * depth + "]" * depth)


def test_an_oversized_or_endless_config_file_is_refused(tmp_path):
    (tmp_path / "big.yaml").write_text("# " + "x" * 2**21 + "\n")
    with pytest.raises(ConfigError, match="larger than"):
        load_config(tmp_path / "big.yaml")
    with pytest.raises(ConfigError, match="larger than"):
        load_config("/dev/zero")


def test_a_number_of_thousands_of_digits_is_one_error():
    assert "YAML cannot hold" in refused("data.seed=" + "9" * 5000)


@pytest.mark.parametrize(
    "override, key",
    [
        ("data.tasks_per_workspace=1000000000000", "data.tasks_per_workspace"),
        ("env.encoding_resolution=100000", "env.encoding_resolution"),
        ("env.max_path_length=1000000", "env.max_path_length"),
        ("model.num_layers=100000", "model.num_layers"),
        ("model.token_dim=100000", "model.token_dim"),
        ("train.batch_size=0", "train.batch_size"),
        ("optim.lr=.nan", "optim.lr"),
        ("optim.lr=-1", "optim.lr"),
        ("optim.betas=[0.9, 1.5]", "optim.betas[1]"),
        ("train.path_noise=-0.1", "train.path_noise"),
        ("evaluation.time_limit=.inf", "evaluation.time_limit"),
        ("data.seed=-1", "data.seed"),
        ("train_eval.max_nodes=0", "train_eval.max_nodes"),
        ("train_eval.max_nodes=1", "train_eval.max_nodes"),  # passed, then the env refused it
        ("train_eval.difficulty=foo", "train_eval.difficulty"),
    ],
)
def test_every_size_and_rate_is_bounded(override, key):
    message = refused(override)
    assert message.startswith(f"{key}:"), message


def test_the_bound_of_tasks_per_workspace_is_the_limits_module():
    assert RANGES["data.tasks_per_workspace"] == (1, MAX_TASKS_PER_WORKSPACE)
    assert "at most 100000, got 1000000000000" in refused("data.tasks_per_workspace=1000000000000")


def test_an_env_id_must_be_registered_and_match_the_robot():
    assert "did you mean TEMP-2D-v0?" in refused("env.id=TEMP-2d-v0")
    assert refused("env.id=TEMP-3D-v0").startswith("env.robot: 'point2d' is not the robot")


def test_a_robot_file_that_is_no_description_gets_the_loaders_reason(tmp_path, monkeypatch):
    import temp_gym  # noqa: F401  (sets the description loader)

    (tmp_path / "notes").write_text("# Notes\n\nSee: the *readme*: here\n")
    (tmp_path / "point2d").write_text("a file named like a robot\n")
    monkeypatch.chdir(tmp_path)
    for robot in ("notes", str(tmp_path / "notes"), "notes.yaml"):
        message = refused("env.id=TEMP-2D-v0", f"env.robot={robot}")
        assert message.startswith("env.robot: ") and "robot of" not in message, message
        assert "not valid YAML" in message or "no such robot description file" in message
    # A registered robot's name stays a name, even beside a file of that name.
    assert load_config(TINY, ["env.robot=point2d"]).env.robot == "point2d"


def test_output_folders(tmp_path):
    (tmp_path / "file").write_text("x")
    assert check_output_dir(tmp_path / "new" / "deeper", "data.dir") == tmp_path / "new/deeper"
    for path, reason in [
        ("/dev/null", "is a file, not a folder"),
        (tmp_path / "file", "is a file, not a folder"),
        (tmp_path / "file" / "below", "is a file"),
        ("/proc/x", "system folder"),
        ("", "empty"),
    ]:
        with pytest.raises(ConfigError, match=reason):
            check_output_dir(path, "data.dir")
    assert not (tmp_path / "new").exists()  # nothing is created


def test_a_cuda_device_this_pytorch_cannot_see_is_refused_in_one_line(monkeypatch):
    import torch

    from temp_gym.training.parallel import Distributed

    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    for name in ("cuda", "cuda:7"):
        with pytest.raises(ConfigError, match=rf"^train.device: '{name}', but this PyTorch"):
            Distributed(name)
    assert Distributed("auto").device.type == "cpu"
