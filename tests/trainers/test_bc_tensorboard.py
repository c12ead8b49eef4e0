"""The trainer's TensorBoard run explains itself: descriptions, layout, HParams, aligned steps."""

from tensorboard.backend.event_processing.plugin_event_accumulator import EventAccumulator
from tensorboard.util import tensor_util
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


def test_a_rerun_replaces_the_events_of_the_steps_it_logs_again(tmp_path):
    """A killed run may have logged an epoch its ``last.pt`` does not hold; the rerun logs it
    again with ``purge_step``, and TensorBoard shows each step once, the rerun's value."""
    from temp_gym.training.logs import Logger

    first = Logger("tensorboard", tmp_path, purge_step=0)  # as a new run starts
    for step in (1, 2):
        first.scalars({"train/loss": float(step)}, step)
    first.close()
    rerun = Logger("tensorboard", tmp_path, purge_step=2)
    for step in (2, 3):
        rerun.scalars({"train/loss": 10.0 * step}, step)
    rerun.close()
    events = EventAccumulator(str(tmp_path))
    events.Reload()
    points = [(event.step, float(tensor_util.make_ndarray(event.tensor_proto)))
              for event in events.Tensors("train/loss")]  # fmt: skip
    assert points == [(1, 1.0), (2, 20.0), (3, 30.0)]


def test_the_final_comparison_is_logged_once_however_often_the_command_runs(tmp_path):
    """A rerun of a finished run (or one killed in its comparison) compares again; its events
    go to ``final/``, emptied first, so TensorBoard shows each once."""
    for _ in range(2):
        run_bc(tmp_path, "train.max_epochs=1", "train_eval.tasks=2")
    events = EventAccumulator(str(tmp_path / "runs" / "TEMP-2D-v0__bc__0" / "final"))
    events.Reload()
    assert [event.step for event in events.Tensors("eval/final/temp/nodes_mean")] == [0]
