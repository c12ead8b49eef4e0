"""The loaded-policy cache: one load per checkpoint content, shared cores, fresh policies."""

import shutil
import threading

import numpy as np
import pytest
import torch

from temp_gym import Problem, files, plan
from temp_gym.models import checkpoint_file, registry, snapshot
from temp_gym.models.registry import (
    load_cached,
    load_policy,
    policy_from_checkpoint,
    shipped_policy,
)
from temp_gym.worlds.generators import generate_problem

PROBLEM = Problem.load("examples/point2d.json")


@pytest.fixture
def count_reads(monkeypatch):
    """Counts checkpoint file reads (the digest's and torch.load's) and snapshot reads."""
    reads = {"bytes": 0, "torch": 0, "snapshot": 0}
    read_capped, torch_load = files.read_capped, torch.load

    def counted_read_capped(path, *args, **kwargs):
        data = read_capped(path, *args, **kwargs)  # a missing snapshot is not a read
        reads["snapshot" if str(path).endswith(".kernels.npz") else "bytes"] += 1
        return data

    def counted_torch_load(*args, **kwargs):
        reads["torch"] += 1
        return torch_load(*args, **kwargs)

    monkeypatch.setattr(checkpoint_file, "read_capped", counted_read_capped)
    monkeypatch.setattr(snapshot, "read_capped", counted_read_capped)
    monkeypatch.setattr(torch, "load", counted_torch_load)
    registry.clear_cache()
    yield reads
    registry.clear_cache()


def test_a_second_plan_reads_nothing_from_disk(count_reads):
    first = plan(PROBLEM, seed=0, stop_at_first=True)
    # the checkpoint's digest; the weights: the snapshot's, read once
    assert count_reads == {"bytes": 1, "torch": 0, "snapshot": 1}
    second = plan(PROBLEM, seed=0, stop_at_first=True)
    assert count_reads == {"bytes": 1, "torch": 0, "snapshot": 1}
    np.testing.assert_array_equal(first.path, second.path)  # fresh policy state per call


def test_policies_share_the_core_but_not_their_state(count_reads):
    a, b = load_policy("point2d", seed=1), load_policy("TEMP-2D-v0", seed=1)
    assert a is not b and a.core is b.core and a.rng is not b.rng
    assert not any(p.requires_grad for p in a.model.parameters())  # shared: not trainable


def test_a_changed_file_is_reloaded_an_identical_one_is_not(count_reads, tmp_path):
    path = tmp_path / "policy.pt"
    shutil.copy(registry.shipped_checkpoint("point2d"), path)
    first = load_cached(path)
    path.touch()  # new modification time, same bytes: hashed again, not loaded again
    again = load_cached(path)
    assert again is first and count_reads == {"bytes": 2, "torch": 1, "snapshot": 0}
    shutil.copy(registry.shipped_checkpoint("point3d"), path)  # new content
    other = load_cached(path)
    assert other is not first and other.core.model.robot == "point3d"
    assert count_reads["torch"] == 2


def test_shipped_settings_apply_and_a_wrong_robot_is_refused(count_reads):
    policy = policy_from_checkpoint(registry.shipped_checkpoint("point2d"), noise_std=0.2)
    assert policy.noise_std == 0.2
    with pytest.raises(ValueError, match="point3d"):
        policy_from_checkpoint(registry.shipped_checkpoint("point2d"), robot="point3d")


def test_planner_settings_given_by_keyword_replace_the_checkpoints(count_reads):
    path = registry.shipped_checkpoint("point2d")
    shipped = policy_from_checkpoint(path)
    policy = policy_from_checkpoint(path, attention_rounds=7, path_window=5)
    assert (policy.attention_rounds, policy.window) == (7, 5)
    assert policy.attention_patience == shipped.attention_patience  # the rest as carried
    with pytest.raises(ValueError, match=r"unknown \['rounds'\]"):
        policy_from_checkpoint(path, rounds=2)


def test_a_missing_shipped_checkpoint_says_how_to_get_one(monkeypatch, tmp_path):
    monkeypatch.setattr(registry, "CHECKPOINT_DIR", tmp_path)  # a build that ships none
    registry.clear_cache()
    with pytest.raises(FileNotFoundError, match="no pretrained policy for TEMP-2D-v0"):
        load_policy("point2d")
    with pytest.raises(FileNotFoundError, match="no pretrained policy for TEMP-2D-v0") as error:
        registry.shipped_checkpoint("TEMP-2D-v0")
    # Both ways to pass a trained one, and a planner that needs none.
    for advice in ("trainers/bc.py", "TEMPPolicy.from_checkpoint", "--checkpoint", "rrt_connect"):
        assert advice in str(error.value)


def test_a_relative_path_and_its_absolute_twin_share_one_load(count_reads, tmp_path, monkeypatch):
    path = tmp_path / "policy.pt"
    shutil.copy(registry.shipped_checkpoint("point2d"), path)
    monkeypatch.chdir(tmp_path)
    assert load_cached("policy.pt") is load_cached(path)
    assert count_reads == {"bytes": 1, "torch": 1, "snapshot": 0}


def test_the_default_policy_is_kept_per_thread_and_per_digest(count_reads, monkeypatch, tmp_path):
    first = shipped_policy("point2d")
    assert shipped_policy("TEMP-2D-v0") is first
    elsewhere = []
    thread = threading.Thread(target=lambda: elsewhere.append(shipped_policy("point2d")))
    thread.start()
    thread.join()
    assert elsewhere[0] is not first and elsewhere[0].core is first.core
    shipped = registry.shipped_checkpoint("point2d")
    monkeypatch.setattr(registry, "CHECKPOINT_DIR", tmp_path)
    # another file, the same bytes and the same snapshot beside it: the same policy
    shutil.copy(shipped, tmp_path / "2d.pt")
    shutil.copy(snapshot.snapshot_path(shipped), tmp_path / "2d.kernels.npz")
    assert shipped_policy("point2d") is first
    (tmp_path / "2d.kernels.npz").unlink()
    checkpoint = torch.load(shipped, weights_only=True)
    checkpoint["note"] = "changed"
    torch.save(checkpoint, tmp_path / "2d.pt")  # a new digest: a new policy on new weights
    changed = shipped_policy("point2d")
    assert changed is not first and changed.core is not first.core
    # The shipped file and its copy are read by their snapshot (no torch.load); the changed
    # copy has none beside it; one torch.load is this test's own.
    assert count_reads == {"bytes": 3, "torch": 2, "snapshot": 2}


def test_plans_with_the_kept_default_policy_equal_plans_with_a_fresh_one(count_reads):
    other = generate_problem("point2d", np.random.default_rng(4), "challenging")
    kept = plan(PROBLEM, seed=3, stop_at_first=True)
    plan(other, seed=5, stop_at_first=True)  # the kept policy holds another problem ...
    again = plan(PROBLEM, seed=3, stop_at_first=True)  # ... and is reset back
    fresh = plan(PROBLEM, seed=3, stop_at_first=True, policy=load_policy("point2d"))
    for result in (again, fresh):
        np.testing.assert_array_equal(result.path, kept.path)
        assert result.nodes == kept.nodes


@pytest.mark.parametrize(
    "kwargs, name",
    [({"noise_std": float("inf")}, "noise_std"), ({"noise_std": float("nan")}, "noise_std"),
     ({"noise_std": True}, "noise_std"), ({"noise_std": -0.1}, "noise_std"),
     ({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"), ({"seed": "abc"}, "seed")],
)  # fmt: skip
def test_a_bad_noise_or_seed_is_refused_when_the_policy_is_made(kwargs, name):
    # inf noise gave box corners for every action; a bad seed failed at the first sample
    with pytest.raises(ValueError, match=f"^{name}: expected"):
        load_policy("TEMP-2D-v0", **kwargs)
    policy = load_policy("TEMP-2D-v0")
    if name == "seed":
        with pytest.raises(ValueError, match="^seed: expected"):
            policy.reset(generate_problem("point2d", np.random.default_rng(0)), seed=kwargs["seed"])


def test_a_tampered_snapshot_beside_a_copy_serves_neither_the_copy_nor_the_original(tmp_path):
    registry.clear_cache()
    shipped = registry.shipped_checkpoint("point2d")
    copy = tmp_path / "2d.pt"
    shutil.copy(shipped, copy)
    with np.load(snapshot.snapshot_path(shipped), allow_pickle=False) as stored:
        arrays = {name: stored[name] for name in stored.files}
    name = next(name for name in sorted(arrays) if name.startswith("mpt."))
    original = arrays[name]
    for value, reason in [
        (0.5, "its arrays do not match their stored digest"),  # plausible weights, edited
        (np.nan, "holds NaN or inf"),  # and with the digest rewritten: values no model has
        (1e30, "beyond"),
    ]:
        arrays[name] = np.full_like(original, value)
        if value != 0.5:
            arrays["content"] = np.array(snapshot.content_digest(arrays))
        np.savez(tmp_path / "2d.kernels.npz", **arrays)
        with pytest.raises(ValueError, match=r"2d\.kernels\.npz: a damaged inference snapshot"):
            load_cached(copy)
        with pytest.raises(ValueError, match=reason):
            load_cached(copy)
    result = plan(PROBLEM, seed=0, stop_at_first=True)  # the shipped policy, unharmed
    assert result.success
    registry.clear_cache()


@pytest.mark.parametrize("source", ["/dev/zero", "/dev/null"])
def test_a_device_is_refused_as_a_checkpoint_before_it_is_read(source):
    with pytest.raises(ValueError, match="not a regular file"):
        load_cached(source)
