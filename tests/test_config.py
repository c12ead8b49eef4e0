import pytest

from temp_gym.config import apply_overrides, load_config


def test_overrides_parse_values_and_reject_typos():
    config = load_config("configs/2d.yaml", ["env.max_path_length=32", "data.seed=7"])
    assert config["env"]["max_path_length"] == 32 and config["data"]["seed"] == 7
    assert apply_overrides({"a": {"b": 1}}, ["a.b=1e-3"])["a"]["b"] == 1e-3
    assert apply_overrides({"a": {"b": 1}}, ["a.b=null"])["a"]["b"] is None
    assert apply_overrides({"a": {}}, ["+a.c=[1, 2]"])["a"]["c"] == [1, 2]
    with pytest.raises(ValueError, match="unknown key"):
        apply_overrides({"a": {"b": 1}}, ["a.c=1"])
    with pytest.raises(ValueError, match="expected key.sub=value"):
        apply_overrides({"a": {"b": 1}}, ["a.b"])


@pytest.mark.parametrize("name", ["2d", "3d", "7d", "tiny"])
def test_shipped_configs_load(name):
    config = load_config(f"configs/{name}.yaml")
    assert {
        "env",
        "data",
        "model",
        "optim",
        "loss",
        "train",
        "eval",
        "evaluation",
        "logger",
    } <= set(config)


def test_config_errors_are_one_line_job_errors(tmp_path, capsys):
    from temp_gym.config import ConfigError
    from temp_gym.jobs import run_script

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
    assert config["train"]["max_epochs"] == 1 and config["data"]["seed"] == 7
    assert config["data"]["workspaces"] == {"train": 2, "val": 1}
    monkeypatch.setenv("TEMP_GYM_OVERRIDES", "train.max_epoch=1")
    with pytest.raises(ValueError, match=r"\$TEMP_GYM_OVERRIDES: .*unknown key train.max_epoch"):
        load_config("configs/2d.yaml")
    monkeypatch.delenv("TEMP_GYM_OVERRIDES")
    assert load_config("configs/2d.yaml")["train"]["max_epochs"] > 1


def test_the_module_docstring_example_runs(monkeypatch):
    import doctest

    import temp_gym.config

    monkeypatch.delenv("TEMP_GYM_OVERRIDES", raising=False)
    outcome = doctest.testmod(temp_gym.config)
    assert outcome.attempted >= 3 and outcome.failed == 0
