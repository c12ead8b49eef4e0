"""The trainer's TensorBoard run explains itself: descriptions, layout, HParams, aligned steps."""

from tensorboard.backend.event_processing.plugin_event_accumulator import EventAccumulator
from test_bc import run_bc  # the trainer in a subprocess, tiny config


def test_dashboard_describes_tags_and_lines_up_evaluations_with_epochs(tmp_path, hparam_values):
    run_bc(
        tmp_path,
        "train.max_epochs=2",
        "train_eval.every=1",
        "train_eval.periodic_tasks=1",
        flags=("--skip-eval",),
    )
    events = EventAccumulator(str(tmp_path / "runs" / "TEMP-2D-v0__bc__0"))
    events.Reload()
    recons = events.SummaryMetadata("val/recons").summary_description
    assert "unseen" in recons and "not divergence" in recons
    assert "val/recons" in events.SummaryMetadata("val/loss").summary_description
    # One step per completed epoch, for training, validation and planning alike.
    for tag in ("train/loss", "val/loss", "eval/success", "eval/nodes"):
        assert [event.step for event in events.Tensors(tag)] == [1, 2], tag
    content = events.PluginTagToContent("hparams")
    values = hparam_values(content)
    assert values["train.max_epochs"].number_value == 2
    assert values["env.id"].string_value == "TEMP-2D-v0"
    (layout,) = events.Tensors("custom_scalars__config__")
    charts = layout.tensor_proto.string_val[0]  # a serialized Layout
    assert b"val/recons" in charts and b"not divergence" in charts
