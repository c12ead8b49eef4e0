"""torchrun on a fresh checkout: the dataset is built before the process group starts.

A slow fake generator takes longer than the process group's timeout. If a rank generated the
dataset inside the group while the others waited at a barrier, the barrier would time out. The
timeout (10 s) also bounds every collective of the short training that follows: at 3 s, a
backward all-reduce timed out on a 2-core machine busy with another training run.
"""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import torch

ROOT = Path(__file__).resolve().parents[2]

FAKE = textwrap.dedent(
    """
    # Loaded at start-up by every process of the test's torchrun (sitecustomize).
    import datetime, time
    import torch.distributed as dist
    _init = dist.init_process_group

    def init_process_group(*args, **kwargs):
        kwargs["timeout"] = datetime.timedelta(seconds=10)
        return _init(*args, **kwargs)

    dist.init_process_group = init_process_group

    import temp_gym.data.generate as generate
    _generate = generate._generate

    def slow_generate(*args, **kwargs):
        time.sleep(16)  # longer than the 10 s timeout
        return _generate(*args, **kwargs)

    generate._generate = slow_generate
    """
)


@pytest.mark.skipif(not torch.distributed.is_available(), reason="torch without distributed")
def test_torchrun_outlives_a_dataset_slower_than_the_process_group_timeout(tmp_path):
    fake = tmp_path / "fake"
    fake.mkdir()
    (fake / "sitecustomize.py").write_text(FAKE)
    command = [
        sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node=2",
        str(ROOT / "trainers" / "bc.py"), "--config", str(ROOT / "configs" / "tiny.yaml"),
        "--no-progress", "--skip-eval", f"data.dir={tmp_path / 'data'}", "data.workers=1",
        "data.workspaces.train=1", "data.tasks_per_workspace=2",
        f"logger.dir={tmp_path / 'runs'}", "logger.backend=", "train.max_epochs=1",
        "train.threads=1", "train_eval.every=0",
    ]  # fmt: skip
    path = os.pathsep.join([str(fake), str(ROOT), os.environ.get("PYTHONPATH", "")])
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=path)
    done = subprocess.run(
        command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    last = torch.load(tmp_path / "runs" / "TEMP-2D-v0__bc__0" / "last.pt", weights_only=True)
    assert last["epoch"] == 1
    assert (tmp_path / "data" / "dataset_card.json").is_file()
