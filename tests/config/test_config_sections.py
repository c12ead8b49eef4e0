"""temp_gym.config.sections: one documented dataclass per YAML section, the home of defaults."""

from __future__ import annotations

import ast
import dataclasses
import inspect
from pathlib import Path

import pytest
import torch

import temp_gym.config.sections as sections
from temp_gym.config import Config, ModelConfig, config_from_dict, load_config
from temp_gym.config.typed import field_types

SECTION_CLASSES = [
    value
    for value in vars(sections).values()
    if dataclasses.is_dataclass(value) and value.__module__ == sections.__name__
]
CONFIGS = sorted((Path(__file__).resolve().parents[2] / "configs").glob("*.yaml"))


def _field_docstrings(cls: type) -> dict[str, str]:
    """Field name -> the string literal right under its annotation in the class body."""
    body = ast.parse(inspect.getsource(cls)).body[0].body
    docs = {}
    for statement, following in zip(body, body[1:]):
        if isinstance(statement, ast.AnnAssign) and isinstance(following, ast.Expr):
            if isinstance(following.value, ast.Constant) and isinstance(following.value.value, str):
                docs[statement.target.id] = following.value.value
    return docs


@pytest.mark.parametrize("cls", SECTION_CLASSES, ids=lambda cls: cls.__name__)
def test_every_field_has_a_docstring_and_a_type(cls):
    assert cls.__doc__ and dataclasses.fields(cls)
    docs = _field_docstrings(cls)
    for field in dataclasses.fields(cls):
        assert docs.get(field.name, "").strip(), f"{cls.__name__}.{field.name}: no docstring"


def test_every_section_of_the_yaml_files_has_its_dataclass():
    assert [field.name for field in dataclasses.fields(Config)] == [
        "env", "data", "model", "optim", "loss", "train", "train_eval", "evaluation", "logger",
    ]  # fmt: skip
    for path in CONFIGS:
        config = load_config(path)
        assert config_from_dict(config.to_dict()) == config, path.name  # a lossless round trip


def test_only_a_robot_or_a_place_has_no_default():
    required = {
        f"{name}.{field.name}"
        for name, section in field_types(Config).items()
        for field in dataclasses.fields(section)
        if field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING
    }
    assert required == {"env.id", "env.robot", "data.dir"}
    minimal = config_from_dict({"env": {"id": "TEMP-2D-v0", "robot": "point2d"},
                                "data": {"dir": "d"}})  # fmt: skip
    assert minimal.train.max_epochs == sections.TrainConfig.max_epochs


def test_defaults_that_other_layers_also_know_agree_with_them():
    from temp_gym.planning.observation import DEFAULT_MAX_PATH_LENGTH
    from temp_gym.worlds.structured import BOXES

    assert sections.EnvConfig.max_path_length == DEFAULT_MAX_PATH_LENGTH
    assert sections.DataConfig.workspace_family == BOXES  # the pools datasets were made from


@pytest.mark.parametrize("name", ["2d", "3d", "7d"])
def test_shipped_checkpoints_build_the_model_they_were_trained_as(name):
    from temp_gym.models.registry import CHECKPOINT_DIR
    from temp_gym.models.temp import load_checkpoint

    path = CHECKPOINT_DIR / f"{name}.pt"
    stored = torch.load(path, weights_only=True)["model_config"]
    model, _ = load_checkpoint(path)
    # Keys a checkpoint predates take their defaults; every stored key is kept as it was.
    assert model.config == dataclasses.asdict(ModelConfig(**stored))
    assert {key: model.config[key] for key in stored} == stored
    assert list(model.config) == [field.name for field in dataclasses.fields(ModelConfig)]
    assert model.mpt.chunk == stored.get("chunk", ModelConfig.chunk)
