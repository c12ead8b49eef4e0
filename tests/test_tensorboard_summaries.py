from tensorboard.backend.event_processing.plugin_event_accumulator import EventAccumulator
from tensorboard.plugins.hparams import metadata
from torch.utils.tensorboard import SummaryWriter

from temp_gym.tensorboard_summaries import add_hparams, add_scalar, flatten


def test_described_scalars_and_hparams_land_in_the_same_run(tmp_path, hparam_values):
    writer = SummaryWriter(log_dir=str(tmp_path))
    add_scalar(writer, "val/recons", 0.5, 1, description="does not generalize: not divergence")
    add_scalar(writer, "val/recons", 0.6, 2)
    add_scalar(writer, "train/loss", 1.0, 1)
    add_hparams(writer, {"optim": {"lr": 1e-3, "betas": [0.9, 0.99]}, "seed": None}, ["val/loss"])
    writer.close()
    assert len(list(tmp_path.iterdir())) == 1  # no second run directory
    events = EventAccumulator(str(tmp_path))
    events.Reload()
    assert events.SummaryMetadata("val/recons").summary_description == (
        "does not generalize: not divergence"
    )
    assert [event.step for event in events.Tensors("val/recons")] == [1, 2]
    assert events.SummaryMetadata("train/loss").summary_description == ""
    content = events.PluginTagToContent("hparams")
    values = hparam_values(content)
    assert values["optim.lr"].number_value == 1e-3
    assert values["seed"].string_value == "null"
    experiment = metadata.parse_experiment_plugin_data(content[metadata.EXPERIMENT_TAG])
    assert [info.name.tag for info in experiment.metric_infos] == ["val/loss"]


def test_flatten_keeps_every_key_in_a_type_the_dashboard_takes():
    flat = flatten({"optim": {"lr": 1e-3, "betas": [0.9, 0.99]}, "seed": None, "on": True})
    assert flat == {"optim.lr": 1e-3, "optim.betas": "[0.9, 0.99]", "seed": "null", "on": True}
