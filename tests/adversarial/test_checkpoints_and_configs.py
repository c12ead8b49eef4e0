"""Hostile checkpoints, snapshots and configs through the commands and the API.

A crafted checkpoint asks for a model of billions of weights, a snapshot beside a copy of the
shipped policy is tampered with, a checkpoint belongs to another robot, a YAML alias bomb of
a few kB hides in an override, a config nests 50,000 deep: each is refused in one line,
within the memory cap, before anything is allocated or written.
"""

from __future__ import annotations

import resource
import shutil
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import torch
from harness import ROOT, assert_refused, files_under, run

from temp_gym.config import ConfigError, load_config
from temp_gym.models.temp import CheckpointError, load_checkpoint

TINY = str(ROOT / "configs" / "tiny.yaml")
SHIPPED = ROOT / "temp_gym" / "checkpoints"
PROBLEM = ROOT / "examples" / "point2d.json"


def crafted(tmp_path: Path) -> Path:
    """The shipped 2D checkpoint whose model_config asks for 48 layers of width 4096."""
    checkpoint = torch.load(SHIPPED / "2d.pt", weights_only=True)
    sizes = {"num_layers": 48, "token_dim": 4096, "ffn_dim": 4096, "num_heads": 4}
    checkpoint["model_config"] = {**checkpoint["model_config"], **sizes}
    path = tmp_path / "crafted.pt"
    torch.save(checkpoint, path)
    return path


def test_a_checkpoint_asking_for_a_huge_model_is_refused_before_allocating(tmp_path):
    path = crafted(tmp_path)
    assert path.stat().st_size < 2**20
    outcome = run("temp-plan", PROBLEM, "--checkpoint", path, cwd=tmp_path)
    assert_refused(outcome, "crafted.pt", "weights, at most")
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(CheckpointError, match="unsupported model sizes"):
        load_checkpoint(path)
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before  # kB
    assert grown < 200 * 1024


@pytest.mark.parametrize(
    "change, message",
    [({"planner": [1, 2]}, "planner: expected a mapping of settings, got [1, 2]"),
     ({"planner": None}, "planner: expected a mapping of settings"),
     ({"planner": {"attention_patience": -3}}, "planner.attention_patience: expected an integer"),
     ({"planner": {"attention_patiense": 30}}, "planner: unknown settings ['attention_patiense']"),
     ({"planner": {"path_window": "16"}}, "planner.path_window: expected a non-negative int"),
     ({"version": True}, "checkpoint version True, expected 1")],
)  # fmt: skip
def test_a_checkpoint_entry_of_the_wrong_shape_is_named_with_the_file(tmp_path, change, message):
    """A planner entry that is no mapping used to crash deep in the registry, naming no file."""
    checkpoint = torch.load(SHIPPED / "2d.pt", weights_only=True)
    checkpoint.update(change)
    path = tmp_path / "changed.pt"
    torch.save(checkpoint, path)
    with pytest.raises(CheckpointError, match="^" + str(path).replace(".", r"\.") + ": "):
        load_checkpoint(path)
    outcome = run("temp-plan", PROBLEM, "--checkpoint", path, cwd=tmp_path)
    assert_refused(outcome, "changed.pt: " + message)


def test_a_flipped_bit_in_a_weight_is_refused_by_its_crc(tmp_path):
    """PyTorch reads a zip checkpoint without checking its CRCs: one flipped mantissa bit
    loaded as another policy."""
    import struct
    import zipfile

    data = bytearray((SHIPPED / "2d.pt").read_bytes())
    with zipfile.ZipFile(SHIPPED / "2d.pt") as archive:
        member = max(archive.infolist(), key=lambda info: info.file_size)
    name_length, extra_length = struct.unpack("<HH", data[member.header_offset + 26 :][:4])
    start = member.header_offset + 30 + name_length + extra_length
    data[start + member.file_size // 2] ^= 0x01
    path = tmp_path / "flipped.pt"
    path.write_bytes(bytes(data))
    with pytest.raises(CheckpointError, match=f"damaged \\({member.filename} fails its CRC-32"):
        load_checkpoint(path)
    assert_refused(run("temp-plan", PROBLEM, "--checkpoint", path, cwd=tmp_path), "flipped.pt")


def test_a_tampered_snapshot_beside_a_copy_is_named(tmp_path):
    copy = tmp_path / "policy.pt"
    shutil.copy(SHIPPED / "2d.pt", copy)
    with np.load(SHIPPED / "2d.kernels.npz", allow_pickle=False) as stored:
        arrays = {name: stored[name] for name in stored.files}
    name = next(name for name in sorted(arrays) if name.startswith("mpt."))
    arrays[name] = np.full_like(arrays[name], 3e38)
    np.savez(tmp_path / "policy.kernels.npz", **arrays)
    outcome = run("temp-plan", PROBLEM, "--checkpoint", copy, "--stop-at-first", cwd=tmp_path)
    assert_refused(outcome, "policy.kernels.npz: a damaged inference snapshot")


@pytest.mark.parametrize("command", ["evaluate.py", "bc.py", "temp-plan"])
def test_another_robots_policy_is_refused_in_one_line(tmp_path, command):
    other = SHIPPED / "3d.pt"
    args = {
        "evaluate.py": ("--config", TINY, "--checkpoint", other, "evaluation.out=out"),
        "bc.py": ("--config", TINY, "--skip-eval", "data.dir=data", "logger.dir=runs",
                  f"train.init_from={other}"),
        "temp-plan": (PROBLEM, "--checkpoint", other, "--out", "r.json"),
    }[command]  # fmt: skip
    before = files_under(tmp_path)
    outcome = run(command, *args, cwd=tmp_path)
    assert_refused(outcome, "point3d")
    assert files_under(tmp_path) == before


def test_a_yaml_alias_bomb_is_refused_without_expanding(tmp_path):
    levels = ["&a [lol,lol,lol,lol,lol,lol,lol,lol,lol]"] + [
        f"&{chr(98 + i)} [{','.join([f'*{chr(97 + i)}'] * 9)}]" for i in range(8)
    ]
    bomb = "[" + ", ".join(levels) + "]"
    assert len(bomb) < 5000  # 9^9 strings once expanded
    outcome = run("bc.py", "--config", TINY, f"train.exp_name={bomb}", cwd=tmp_path)
    assert_refused(outcome, "anchors and aliases")
    assert len(outcome.err) < 1000 and outcome.peak_rss < 2**30


@pytest.mark.parametrize("depth", [50_000])
def test_a_config_nested_thousands_deep_is_one_line(tmp_path, depth):
    config = tmp_path / "deep.yaml"
    config.write_text("env:\n  id: " + "[" * depth + "]" * depth + "\n")
    outcome = run("bc.py", "--config", config, cwd=tmp_path)
    assert_refused(outcome, "deep.yaml", "nested more than")


def test_the_api_bounds_every_size_a_user_sets():
    with pytest.raises(ValueError, match="encoding_resolution: 100000 cells per axis"):
        gymnasium.make("TEMP-2D-v0", encoding_resolution=10**5)
    with pytest.raises(ConfigError, match="data.tasks_per_workspace: must be at most"):
        load_config(TINY, ["data.tasks_per_workspace=1000000000000"])
    with pytest.raises(CheckpointError, match="not a regular file"):
        load_checkpoint("/dev/zero")
