"""Fixtures shared across the test packages, and the CPU the suite's numba kernels target."""

import importlib.util
import os
import sys
from pathlib import Path

import pytest


def _compile_for_the_golden_cpu() -> None:
    """Have numba compile for the CPU the golden fingerprints are computed under.

    `tests/golden` recomputes its sample in child processes whose numba targets a named CPU
    (``golden.PINNED_ENV``), and numba keeps one on-disk cache per target CPU. With the rest
    of the suite compiling for the host, a fresh clone compiled every planner kernel twice
    (the golden plans alone took about 5 minutes of the suite). Set before numba is imported
    here or in any worker or child process, the same target makes both share one cache. A
    variable the caller set wins; a CPU the fingerprints are not kept for keeps the host.
    """
    spec = importlib.util.spec_from_file_location(
        "golden", Path(__file__).with_name("golden") / "golden.py"
    )
    golden = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("golden", golden)  # the module test_golden.py imports
    spec.loader.exec_module(golden)
    if golden.pinned_kernel_supported():
        os.environ.setdefault("NUMBA_CPU_NAME", golden.PINNED_ENV["NUMBA_CPU_NAME"])


_compile_for_the_golden_cpu()


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
