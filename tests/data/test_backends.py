"""`--backend ray` gives the same demonstrations as `--backend local` (tiny config)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from test_generate import SCRIPT, TINY, assert_same

from temp_gym.distributed import map_units


def square(x: int) -> int:
    return x * x


@pytest.mark.parametrize("workers", [1, 2])
def test_local_map_units_returns_every_result_once(workers):
    results = dict(map_units(square, range(7), "local", workers))
    assert results == {i: i * i for i in range(7)}


def test_unknown_backend():
    with pytest.raises(ValueError, match="backend"):
        map_units(square, [1], "dask")


def test_generate_with_ray_backend_equals_local(tmp_path):
    pytest.importorskip("ray")
    common = [sys.executable, str(SCRIPT), "--config", str(TINY), "--no-progress"]
    local = subprocess.run(
        [*common, "--workers", "2", f"data.dir={tmp_path / 'local'}"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert local.returncode == 0, local.stderr
    env_ray = subprocess.run(
        [*common, "--backend", "ray", "--workers", "2", f"data.dir={tmp_path / 'ray'}"],
        capture_output=True, text=True, timeout=300,
        env={**os.environ, "RAY_ADDRESS": ""},  # a local instance, whatever the shell says
    )  # fmt: skip
    assert env_ray.returncode == 0, env_ray.stderr[-3000:]
    assert_same(tmp_path / "local", tmp_path / "ray")


def test_ray_address_auto_without_a_cluster_is_one_line_saying_how_to_start_one(
    tmp_path, monkeypatch, capsys
):
    ray = pytest.importorskip("ray")

    def no_cluster(*args, **kwargs):  # what ray.init(address="auto") raises without one
        raise ConnectionError("Could not find any running Ray instance.")

    monkeypatch.setattr(ray, "init", no_cluster)
    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    sys.path.insert(0, str(SCRIPT.parent))
    import generate

    from temp_gym.jobs import run_script

    argv = ["--config", str(TINY), "--no-progress", "--backend", "ray", "--ray-address", "auto"]
    code = run_script("generate.py", generate.main, [*argv, f"data.dir={tmp_path}"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err[-1].startswith("generate.py: error: no Ray cluster at --ray-address 'auto'")
    assert "ray start --head" in err[-1] and "leave out --ray-address" in err[-1]
    assert not any("Traceback" in line for line in err)


def test_without_an_address_ray_starts_an_instance_of_its_own(monkeypatch):
    """A cluster already running on the machine (``ray start --head``) is not joined: the
    local instance gets the workers asked for."""
    ray = pytest.importorskip("ray")
    calls = []
    monkeypatch.setattr(ray, "init", lambda *args, **kwargs: calls.append(kwargs))
    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    from temp_gym.distributed import init_ray

    init_ray(None, 3)
    assert calls[0]["address"] == "local" and calls[0]["num_cpus"] == 3
    init_ray("auto", 3)
    assert calls[1]["address"] == "auto" and "num_cpus" not in calls[1]
