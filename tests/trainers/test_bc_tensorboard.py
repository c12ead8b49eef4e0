"""The trainer's TensorBoard run explains itself: descriptions, layout, HParams, aligned steps."""

import os
import subprocess
import sys
from pathlib import Path

from tensorboard.backend.event_processing.plugin_event_accumulator import EventAccumulator
from tensorboard.plugins.hparams import metadata

ROOT = Path(__file__).resolve().parents[2]


def test_dashboard_describes_tags_and_lines_up_evaluations_with_epochs(tmp_path):
    command = [
        sys.executable,
        str(ROOT / "trainers" / "bc.py"),
        "--config",
        str(ROOT / "configs" / "tiny.yaml"),
        "--no-progress",
        "--skip-eval",
        f"data.dir={tmp_path / 'data'}",
        "data.workers=1",
        f"logger.dir={tmp_path / 'runs'}",
        "train.max_epochs=2",
        "eval.every=1",
        "eval.periodic_tasks=1",
    ]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    done = subprocess.run(
        command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    events = EventAccumulator(str(tmp_path / "runs" / "TEMP-2D-v0__bc__0"))
    events.Reload()
    recons = events.SummaryMetadata("val/recons").summary_description
    assert "unseen" in recons and "not divergence" in recons
    assert "val/recons" in events.SummaryMetadata("val/loss").summary_description
    # One step per completed epoch, for training, validation and planning alike.
    for tag in ("train/loss", "val/loss", "eval/success", "eval/nodes"):
        assert [event.step for event in events.Tensors(tag)] == [1, 2], tag
    content = events.PluginTagToContent("hparams")
    start = metadata.parse_session_start_info_plugin_data(content[metadata.SESSION_START_INFO_TAG])
    assert start.hparams["train.max_epochs"].number_value == 2
    assert start.hparams["env.id"].string_value == "TEMP-2D-v0"
    (layout,) = events.Tensors("custom_scalars__config__")
    charts = layout.tensor_proto.string_val[0]  # a serialized Layout
    assert b"val/recons" in charts and b"not divergence" in charts
