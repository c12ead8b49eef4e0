"""`torchrun --nproc_per_node=2 trainers/bc.py` (gloo, CPU) equals a single-process run."""

import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

ROOT = Path(__file__).resolve().parents[2]


def train(tmp_path: Path, name: str, launcher: list[str]) -> dict:
    command = [
        *launcher,
        str(ROOT / "trainers" / "bc.py"),
        "--config", str(ROOT / "configs" / "tiny.yaml"),
        "--no-progress", "--skip-eval",
        f"data.dir={tmp_path / 'data'}", "data.workers=1",
        f"logger.dir={tmp_path / 'runs'}", "logger.backend=",
        f"train.exp_name={name}", "train.max_epochs=3", "train.path_noise=0.02",
        "train.threads=1", "train_eval.every=0",
    ]  # fmt: skip
    env = dict(os.environ, OMP_NUM_THREADS="1")
    done = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return torch.load(tmp_path / "runs" / f"TEMP-2D-v0__{name}__0" / "last.pt", weights_only=True)


@pytest.mark.skipif(not torch.distributed.is_available(), reason="torch without distributed")
def test_two_process_ddp_matches_single_process(tmp_path):
    single = train(tmp_path, "single", [sys.executable])
    ddp = train(
        tmp_path, "ddp",
        [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node=2"],
    )  # fmt: skip
    assert len(single["history"]) == len(ddp["history"]) == 3
    for one, two in zip(single["history"], ddp["history"]):
        assert two["train_loss"] == pytest.approx(one["train_loss"], rel=1e-5)
        assert two["val_loss"] == pytest.approx(one["val_loss"], rel=1e-5)
        assert two["lr"] == one["lr"]
    for key, value in single["state_dict"].items():
        torch.testing.assert_close(ddp["state_dict"][key], value, rtol=1e-3, atol=1e-4)
    # Only rank 0 wrote: one run directory per run, no stray files from rank 1.
    assert sorted(p.name for p in (tmp_path / "runs").iterdir()) == [
        "TEMP-2D-v0__ddp__0",
        "TEMP-2D-v0__single__0",
    ]
