"""TensorBoard summaries that explain themselves: described scalars and HParams.

* `add_scalar` writes a scalar like ``SummaryWriter.add_scalar``, and the first time a tag is
  written it attaches a description; TensorBoard shows it beside the chart, so a curve that
  looks alarming (a rising validation term, say) carries its explanation on the dashboard.
* `add_hparams` puts a run's configuration in the HParams dashboard of *the same run*
  (``SummaryWriter.add_hparams`` would start a new one), with the metrics to compare runs by.
* `remove_events` empties a folder of event files before a summary that is written whole
  again on a rerun (a report, a final comparison), so TensorBoard shows each step once.

Examples:
    >>> add_scalar(writer, "val/recons", 0.41, step=3, description="EISE reconstruction ...")
    >>> add_hparams(writer, {"optim": {"lr": 1e-3}}, metrics=["val/semantic"])
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any


def remove_events(folder: str | Path) -> None:
    """Delete the TensorBoard event files directly in ``folder`` (none: nothing to do)."""
    folder = Path(folder)
    if folder.is_dir():
        for path in folder.glob("events.out.tfevents.*"):
            path.unlink(missing_ok=True)


def _file_writer(writer: Any):
    return writer._get_file_writer()  # torch's SummaryWriter keeps one per run directory


def add_scalar(
    writer: Any, tag: str, value: float, step: int, description: str | None = None
) -> None:
    """Write ``tag = value`` at ``step``, with ``description`` in the tag's metadata if given.

    TensorBoard reads a tag's description from its first summary, so callers pass it once
    (``writer`` is a ``torch.utils.tensorboard.SummaryWriter``).
    """
    if not description:
        writer.add_scalar(tag, float(value), step)
        return
    from tensorboard.compat.proto.summary_pb2 import Summary, SummaryMetadata

    metadata = SummaryMetadata(
        summary_description=description,
        plugin_data=SummaryMetadata.PluginData(plugin_name="scalars"),
    )
    summary = Summary(value=[Summary.Value(tag=tag, simple_value=float(value), metadata=metadata)])
    _file_writer(writer).add_summary(summary, step)


def flatten(config: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"optim": {"lr": 1e-3}}`` -> ``{"optim.lr": 1e-3}``; values the HParams plugin takes.

    Numbers, strings and booleans stay; None becomes ``"null"`` and anything else (lists) its
    text, so every key shows up in the dashboard.
    """
    flat: dict[str, Any] = {}
    for key, value in config.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            flat.update(flatten(value, f"{name}."))
        elif value is None:
            flat[name] = "null"
        elif isinstance(value, (bool, int, float, str)):
            flat[name] = value
        else:
            flat[name] = str(value)
    return flat


def add_hparams(writer: Any, config: Mapping[str, Any], metrics: Iterable[str]) -> None:
    """Record ``config`` (nested sections allowed) in the HParams dashboard of this run.

    ``metrics`` are scalar tags that the run writes anyway (e.g. ``val/semantic``); the
    dashboard shows their latest values beside the hyperparameters of each run.
    """
    from torch.utils.tensorboard.summary import hparams

    experiment, start, end = hparams(flatten(config), {tag: 0.0 for tag in metrics})
    file_writer = _file_writer(writer)
    for summary in (experiment, start, end):
        file_writer.add_summary(summary)
