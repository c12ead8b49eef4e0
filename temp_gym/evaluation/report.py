"""Turning task records into the paper's outputs: Table 1, plots, TensorBoard, raw JSON."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.evaluation.protocol import (
    TAU,
    aggregate_rows,
    cost_curve,
    distribution_rows,
    distribution_table,
    markdown_table,
    paired_ratio_statistics,
    paired_ratios,
    success_curve,
    success_label,
)
from temp_gym.evaluation.statistics import format_interval

PLANNER_ORDER = ("temp", "rrt_star", "informed_rrt_star", "rrt_connect", "ompl_rrt_star",
                 "ompl_informed_rrt_star", "ompl_rrt_connect", "ompl_bit_star")  # fmt: skip


def _planner_records(records: list[dict[str, Any]], group: str) -> list[dict[str, Any]]:
    rows = []
    for record in records:
        if record["group"] != group:
            continue
        for planner, figures in record["planners"].items():
            rows.append({"planner": planner, **figures})
    return rows


def summarize(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Per group: Table 1 rows, their distributions and TEMP/baseline ratios.

    ``rows`` are the paper's means (`aggregate_rows`); ``distributions`` the medians and means
    with bootstrap intervals (`distribution_rows`). ``temp_over`` holds, per baseline, the
    ratio of the row means (each planner's mean over its own successes, as in the paper's
    table), ``paired``: the ratios of sums over the tasks both solved
    (`temp_gym.evaluation.protocol.paired_ratios`), and ``per_task``: the median and mean
    per-task ratio with intervals (`paired_ratio_statistics`), which is what the acceptance
    checks read: a baseline that rarely reaches the tolerance averages over its easiest tasks
    only in the row means, and one stalled task moves a ratio of sums.
    """
    groups = list(dict.fromkeys(record["group"] for record in records))
    summary: dict[str, Any] = {"groups": {}}
    for group in groups:
        group_records = [record for record in records if record["group"] == group]
        planner_records = _planner_records(records, group)
        rows = aggregate_rows(planner_records)
        ratios = {}
        temp = rows.get("temp")
        for planner, row in rows.items():
            if planner != "temp" and temp and row["time"] and math.isfinite(row["time"]):
                ratios[planner] = {
                    "time": temp["time"] / row["time"],
                    "nodes": temp["nodes"] / row["nodes"],
                    "paired": paired_ratios(group_records, "temp", planner),
                    "per_task": paired_ratio_statistics(group_records, "temp", planner),
                }
        summary["groups"][group] = {
            "rows": rows,
            "distributions": distribution_rows(planner_records),
            "temp_over": ratios,
        }
    return summary


def planners_in(records: list[dict[str, Any]]) -> list[str]:
    """The planners present, in the table's order."""
    present = {p for record in records for p in record["planners"]}
    return [p for p in PLANNER_ORDER if p in present] + sorted(present - set(PLANNER_ORDER))


def write_report(
    records: list[dict[str, Any]],
    out_dir: str | Path,
    tensorboard: bool = True,
    attention: dict[str, Any] | None = None,
    metadata: dict[str, Any] | None = None,
):
    """Write ``results.md``, ``results.json``, PNG plots and (optionally) TensorBoard events.

    ``attention`` is an example plan's attention read-out
    (`temp_gym.evaluation.runner.attention_example`); with it, ``attention.png`` (the
    normalized weights per token group along the plan) and ``attention.json`` are written too.
    ``metadata`` (e.g. the checkpoint and its weights digest) goes into ``results.json``.
    Returns the markdown table.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = summarize(records)
    planners = planners_in(records)
    table = markdown_table(
        {group: data["rows"] for group, data in summary["groups"].items()}, planners
    )
    distributions = distribution_table(
        {group: data["distributions"] for group, data in summary["groups"].items()}, planners
    )
    ratio_lines = []
    for group, data in summary["groups"].items():
        for planner, ratio in data["temp_over"].items():
            paired, per_task = ratio["paired"], ratio["per_task"]
            both = (
                f"{paired['time']:.3f} | {paired['nodes']:.3f} | {paired['tasks']}"
                if paired
                else "n/a | n/a | 0"
            )
            medians = (
                f"{format_interval(per_task['time'], 'median')} | "
                f"{format_interval(per_task['nodes'], 'median')}"
                if per_task
                else "- | -"
            )
            ratio_lines.append(
                f"| {group} | {planner} | {ratio['time']:.3f} | {ratio['nodes']:.3f} | {both} "
                f"| {medians} |"
            )
    ratios = "\n".join(
        [
            "TEMP/baseline ratios: of the row means above; paired, over the tasks both solved "
            "(sums of TEMP's figures over sums of the baseline's); and the median of the "
            "per-task ratios with its 95% bootstrap interval, which one stalled task does not "
            "move. A baseline that rarely reaches the tolerance is averaged over its easiest "
            "tasks only in the row means.",
            "",
            "| group | baseline | time (means) | nodes (means) | time (paired) | nodes (paired) "
            "| pairs | time, median per task [95%] | nodes, median per task [95%] |",
            "|---|---|---:|---:|---:|---:|---:|---:|---:|",
        ]
        + ratio_lines
    )
    labels = (
        "Success columns: TEMP's counts the tasks it solved; a baseline's counts the tasks "
        f"where it reached (1 + {TAU:g}) J_TEMP, TEMP's cost within the tolerance, within its "
        "budget."
    )
    spread = (
        "Medians and means over the tasks each planner solved (for a baseline: reached "
        f"(1 + {TAU:g}) J_TEMP), with 95% percentile bootstrap intervals over the tasks."
    )
    (out / "results.md").write_text(
        f"{table}\n\n{labels}\n\n{spread}\n\n{distributions}\n\n{ratios}\n"
    )
    (out / "results.json").write_text(
        json.dumps(
            {**(metadata or {}), "summary": summary, "records": records}, default=float, indent=1
        )
    )
    _plots(records, summary, planners, out)
    if attention is not None:
        _attention_plot(attention, out)
    if tensorboard:
        _tensorboard(records, planners, out / "tensorboard")
    return table


def _time_grid(records: list[dict[str, Any]]) -> np.ndarray:
    times = [
        f["time"] for r in records for f in r["planners"].values() if f.get("time") is not None
    ]
    top = max(times) if times else 1.0
    return np.linspace(0.0, top * 1.05, 200)


def _plots(records, summary, planners, out: Path) -> None:
    from matplotlib.figure import Figure

    groups = list(summary["groups"])
    figure = Figure(figsize=(4.5 * len(groups), 3.6))
    for k, group in enumerate(groups):
        axes = figure.add_subplot(1, len(groups), k + 1)
        group_records = _planner_records(records, group)
        times = _time_grid([r for r in records if r["group"] == group])
        for planner, curve in success_curve(group_records, times).items():
            axes.plot(times, curve, label=f"{planner} ({success_label(planner)})")
        axes.set(
            title=f"{group}: share of tasks by time",
            xlabel="time (s)",
            ylabel=f"TEMP solved / baseline reached {1 + TAU:g}·J_TEMP",
            ylim=(0, 1.02),
        )
        _legend(axes)
    figure.tight_layout()
    figure.savefig(out / "success_vs_time.png", dpi=110)

    figure = Figure(figsize=(4.5 * len(groups), 3.6))
    for k, group in enumerate(groups):
        axes = figure.add_subplot(1, len(groups), k + 1)
        histories = {
            r["index"]: r["curves"] for r in records if r["group"] == group and "curves" in r
        }
        if histories:
            top = max(max(h["nodes"], default=1) for c in histories.values() for h in c.values())
            grid = np.linspace(1, max(top, 2), 200)
            for planner, curve in cost_curve(histories, grid).items():
                axes.plot(grid, curve, label=planner)
        axes.set(title=group, xlabel="nodes", ylabel="average path cost")
        _legend(axes)
    figure.tight_layout()
    figure.savefig(out / "cost_vs_nodes.png", dpi=110)

    figure = Figure(figsize=(1.2 + 1.4 * len(planners), 3.4))
    axes = figure.add_subplot(1, 1, 1)
    width = 0.8 / max(len(groups), 1)
    for k, group in enumerate(groups):
        rows = summary["groups"][group]["rows"]
        values = [rows.get(p, {}).get("sampling_failures", np.nan) for p in planners]
        axes.bar(np.arange(len(planners)) + k * width, values, width, label=group)
    axes.set_xticks(np.arange(len(planners)) + 0.4 - width / 2, planners, fontsize=7)
    axes.set(ylabel="average sampling failures")
    _legend(axes)
    figure.tight_layout()
    figure.savefig(out / "sampling_failures.png", dpi=110)


def _legend(axes) -> None:
    """A legend when something was drawn with a label (matplotlib warns on an empty one)."""
    if axes.get_legend_handles_labels()[0]:
        axes.legend(fontsize=7)


def _attention_plot(attention: dict[str, Any], out: Path) -> None:
    from temp_gym.models.attention import attention_figure

    normalized = {group: np.asarray(values) for group, values in attention["normalized"].items()}
    phase = attention["attention_phase"]
    title = (
        f"{attention['group']} task {attention['index']}: normalized attention per group "
        f"({phase['nodes']} nodes)"
    )
    attention_figure(normalized, title=title).savefig(out / "attention.png", dpi=110)
    (out / "attention.json").write_text(json.dumps(attention, indent=1))


def _tensorboard(records, planners, log_dir: Path) -> None:
    from torch.utils.tensorboard import SummaryWriter

    from temp_gym.tensorboard_summaries import remove_events

    remove_events(log_dir)  # the report is written whole from its records, on a rerun too
    writer = SummaryWriter(log_dir=str(log_dir))
    groups = list(dict.fromkeys(r["group"] for r in records))
    solved = f"TEMP solved, baselines reached {1 + TAU:g} J_TEMP, vs time"
    layout: dict[str, dict[str, list]] = {solved: {}, "cost vs nodes": {}}
    for group in groups:
        slug = group.replace(" ", "_")
        group_records = _planner_records(records, group)
        times = _time_grid([r for r in records if r["group"] == group])
        for planner, curve in success_curve(group_records, times).items():
            for step, value in enumerate(curve):  # step = index on the time grid
                writer.add_scalar(f"success_vs_time/{slug}/{planner}", value, step)
        histories = {
            r["index"]: r["curves"] for r in records if r["group"] == group and "curves" in r
        }
        if histories:
            grid = np.arange(
                1,
                1 + max(max(h["nodes"], default=1) for c in histories.values() for h in c.values()),
                10,
            )
            for planner, curve in cost_curve(histories, grid).items():
                for nodes, value in zip(grid, curve):
                    writer.add_scalar(f"cost_vs_nodes/{slug}/{planner}", value, int(nodes))
        layout[solved][group] = [
            "Multiline",
            [f"success_vs_time/{slug}/{p}" for p in planners],
        ]
        layout["cost vs nodes"][group] = [
            "Multiline",
            [f"cost_vs_nodes/{slug}/{p}" for p in planners],
        ]
    writer.add_custom_scalars(layout)
    writer.close()
