"""Fixtures shared across the test packages."""

import pytest


@pytest.fixture
def wall() -> dict:
    """A 2D problem (as a dict) whose straight line is blocked by a tall thin wall."""
    return {
        "robot": "point2d",
        "bounds": [[0, 0], [20, 20]],
        "obstacles": [{"center": [10, 10], "half_extents": [0.5, 8]}],
        "start": [2, 10],
        "goal": [18, 10],
        "goal_radius": 0.5,
    }


@pytest.fixture
def hparam_values():
    """A reader of a run's hyperparameter values from its HParams plugin entries.

    The plugin writes three entries per run (the experiment's declared hparams and metrics,
    the run's start, the run's end); only the start entry carries values, in ``hparams``.
    """
    from tensorboard.plugins.hparams import plugin_data_pb2

    def read(content: dict[str, bytes]):
        for payload in content.values():
            data = plugin_data_pb2.HParamsPluginData.FromString(payload)
            entry = getattr(data, data.WhichOneof("data"))
            if "hparams" in entry.DESCRIPTOR.fields_by_name:
                return entry.hparams
        raise AssertionError(f"no hparam values among the entries {sorted(content)}")

    return read
