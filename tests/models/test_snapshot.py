"""Inference snapshots: the same kernels without PyTorch, used only when they fit the checkpoint."""

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
import torch

from temp_gym import Problem, plan
from temp_gym.models import registry
from temp_gym.models import snapshot as snapshots
from temp_gym.models.fast_eise import FastEISE, eise_arrays
from temp_gym.models.fast_mpt import FastMPT, mpt_arrays
from temp_gym.models.policy import TEMPPolicy
from temp_gym.models.snapshot import file_digest, read_snapshot, snapshot_path, write_snapshot
from temp_gym.models.temp import TEMPModel, load_checkpoint

PROBLEM = Problem.load("examples/point2d.json")
SHIPPED = ["point2d", "point3d", "kuka_iiwa14", "franka_panda"]


@pytest.fixture(autouse=True)
def fresh_cache():
    registry.clear_cache()
    yield
    registry.clear_cache()


def _saved_model(tmp_path, robot="point3d", chunk=2):
    torch.manual_seed(3)
    sizes = {"token_dim": 32, "num_heads": 4, "num_layers": 2, "ffn_dim": 64}
    model = TEMPModel(robot, 8, 16, num_sei_tokens=4, eise_hidden=32, chunk=chunk, **sizes)
    path = tmp_path / "best.pt"
    model.save(path, planner={"noise_std": 0.05, "horizon": 1})
    return model.eval(), path


def test_a_snapshot_runs_exactly_what_the_model_runs(tmp_path):
    model, path = _saved_model(tmp_path)
    written = write_snapshot(path)
    assert written == snapshot_path(path) == tmp_path / "best.kernels.npz"
    snapshot = read_snapshot(path, file_digest(path))
    assert snapshot.info.robot == "point3d" and snapshot.info.chunk == 2
    assert snapshot.meta["planner"] == {"noise_std": 0.05, "horizon": 1}
    fast, stored = FastMPT(model.mpt), FastMPT.from_arrays(snapshot.mpt)
    rng = np.random.default_rng(0)
    sei = rng.normal(size=(4, 32)).astype(np.float32)
    goal, start = rng.uniform(-1, 1, (2, 3)).astype(np.float32)
    path_rows = rng.uniform(-1, 1, (16, 3)).astype(np.float32)
    for length in (1, 5, 16):
        expected = fast.predict(fast.prefix(sei, goal, 0.1, start), path_rows, length)
        got = stored.predict(stored.prefix(sei, goal, 0.1, start), path_rows, length)
        np.testing.assert_array_equal(got, expected)  # bit for bit: the same arrays
    grid = np.random.default_rng(1).random((8, 8, 8)) > 0.7
    np.testing.assert_array_equal(
        FastEISE.from_arrays(snapshot.eise)(grid), FastEISE(model.eise)(grid)
    )


@pytest.mark.parametrize("robot", SHIPPED)
def test_each_shipped_checkpoint_has_its_own_snapshot_beside_it(robot):
    """Fails when a policy is shipped without writing its snapshot, or with a stale one."""
    path = registry.shipped_checkpoint(robot)
    snapshot = read_snapshot(path, file_digest(path))
    assert snapshot is not None, f"write_snapshot({path}) after shipping it"
    model, checkpoint = load_checkpoint(path)
    for name, value in mpt_arrays(model.mpt).items():
        np.testing.assert_array_equal(snapshot.mpt[name], value, err_msg=name)
    for name, value in eise_arrays(model.eise).items():
        np.testing.assert_array_equal(snapshot.eise[name], value, err_msg=name)
    meta = {key: value for key, value in checkpoint.items() if key != "state_dict"}
    assert snapshot.meta == json.loads(json.dumps(meta))
    with np.load(snapshot_path(path), allow_pickle=False) as stored:
        assert "content" in stored.files  # its own arrays' digest, checked when read


def test_a_snapshot_of_other_bytes_is_ignored(tmp_path):
    path = tmp_path / "policy.pt"
    shutil.copy(registry.shipped_checkpoint("point2d"), path)
    shutil.copy(snapshot_path(registry.shipped_checkpoint("point3d")), snapshot_path(path))
    assert read_snapshot(path, file_digest(path)) is None
    loaded = registry.load_cached(path)
    assert loaded.core.info.robot == "point2d" and loaded.core.holds(loaded.core.model)


def test_a_damaged_snapshot_is_a_clear_error(tmp_path):
    path = tmp_path / "policy.pt"
    shutil.copy(registry.shipped_checkpoint("point2d"), path)
    snapshot_path(path).write_bytes(b"not a zip file")
    with pytest.raises(ValueError, match="damaged inference snapshot.*delete it"):
        registry.load_cached(path)


def test_an_empty_folder_or_digestless_snapshot_is_a_clear_error(tmp_path):
    """An empty file was numpy's EOFError, a folder a bare IsADirectoryError, and a snapshot
    without its digest was read unchecked."""
    path = tmp_path / "policy.pt"
    shutil.copy(registry.shipped_checkpoint("point2d"), path)
    snapshot_path(path).write_bytes(b"")
    with pytest.raises(ValueError, match="policy.kernels.npz: a damaged inference snapshot"):
        registry.load_cached(path)
    snapshot_path(path).unlink()
    snapshot_path(path).mkdir()
    with pytest.raises(ValueError, match="policy.kernels.npz: an unreadable inference snapshot"):
        registry.load_cached(path)
    snapshot_path(path).rmdir()
    with np.load(snapshot_path(registry.shipped_checkpoint("point2d"))) as stored:
        arrays = {name: stored[name] for name in stored.files if name != "content"}
    np.savez(snapshot_path(path), **arrays)
    with pytest.raises(ValueError, match="holds no digest of its arrays"):
        registry.load_cached(path)


def test_a_snapshot_core_loads_its_model_when_asked_and_only_from_the_same_bytes(tmp_path):
    path = tmp_path / "policy.pt"
    shutil.copy(registry.shipped_checkpoint("point2d"), path)
    write_snapshot(path)
    policy = registry.policy_from_checkpoint(path, noise_std=0.0)
    assert policy.core._model is None  # nothing asked for the model yet
    policy.reset(PROBLEM)
    rows = np.zeros((policy.max_path_length, 2), np.float32)
    rows[0] = [-0.5, 0.2]
    numba_chunk = policy.propose_chunk(rows, 1)
    torch_policy = policy.fresh(backend="torch")
    torch_policy.reset(PROBLEM)
    np.testing.assert_allclose(torch_policy.propose_chunk(rows, 1), numba_chunk, atol=1e-5)
    assert isinstance(policy.model, TEMPModel) and not policy.model.training

    registry.clear_cache()
    late = registry.policy_from_checkpoint(path)
    shutil.copy(registry.shipped_checkpoint("point3d"), path)  # replaced before the model loads
    with pytest.raises(RuntimeError, match="changed since its policy was loaded"):
        _ = late.model


def test_a_default_plan_imports_no_torch_and_equals_the_torch_built_policys(monkeypatch):
    script = (
        "import sys, json; from temp_gym import Problem, plan; "
        "r = plan(Problem.load('examples/point2d.json'), seed=2, stop_at_first=True); "
        "print(json.dumps(['torch' in sys.modules, r.path.tolist()]))"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    imported, path = json.loads(done.stdout.splitlines()[-1])
    assert not imported
    monkeypatch.setattr(snapshots, "read_snapshot", lambda *args: None)  # the PyTorch route
    expected = plan(PROBLEM, seed=2, stop_at_first=True)
    assert isinstance(registry.shipped_policy("point2d").core.model, TEMPModel)
    assert registry.shipped_policy("point2d").core.holds(registry.shipped_policy("point2d").model)
    np.testing.assert_array_equal(np.array(path), expected.path)


def test_a_policy_needs_a_model_or_a_core():
    with pytest.raises(ValueError, match="give a model, or a core"):
        TEMPPolicy()


def test_a_snapshot_missing_an_array_or_of_wrong_shapes_is_refused(tmp_path):
    model, _ = _saved_model(tmp_path)
    arrays = mpt_arrays(model.mpt)
    with pytest.raises(ValueError, match=r"MPT snapshot: missing arrays \['head_w'\]"):
        FastMPT.from_arrays({k: v for k, v in arrays.items() if k != "head_w"})
    with pytest.raises(ValueError, match="do not fit"):
        FastMPT.from_arrays({**arrays, "chunk": np.array(3)})
    eise = eise_arrays(model.eise)
    with pytest.raises(ValueError, match="do not fit"):
        FastEISE.from_arrays({**eise, "grid_shape": np.array([8, 8])})
