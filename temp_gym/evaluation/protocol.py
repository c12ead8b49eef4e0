"""The paper's evaluation protocol (its Section IV, Eq. 6), as pure functions over results.

For each test task:

1. TEMP gives time ``t``, nodes ``N`` and cost ``J`` of its first solution. That is the
   attention phase's, as in the paper, unless the attention phase stalled (the stall rule,
   `temp_gym.planning.attention`) and classical planning on the same tree found it: TEMP is
   timed as a user calls it, and ``attention_solved`` records which phase it was.
2. Every baseline (RRT*, Informed RRT*, OMPL's) runs until its cost is at most
   ``(1 + tau) * J`` with ``tau = 0.05`` (``plan(..., target_cost=...)``) or its budget ends; its
   time and nodes are read off its anytime history at the first entry within tolerance
   (`reach_tolerance`).

Aggregates (`aggregate_rows`): mean time and nodes per planner, over the tasks each planner
solved within tolerance (the paper's "best values that conform to the criteria"), with the
success rate beside them; mean sampling failures; success rate against time
(`success_curve`); and average cost against nodes (`cost_curve`), where a task not yet solved
at a node count is charged 1.5 times the largest cost any planner recorded on that task.

Medians and means with bootstrap intervals (`distribution_rows`, and the per-task ratios of
`paired_ratio_statistics`) sit beside the means: planning times have heavy tails on a shared
machine, and an interval tells a difference from a stall.

"Success" means two things here, and labels say which (`success_label`): TEMP *solved* the
task (its first solution within the budget, from either phase); a baseline *reached
(1 + tau) J*, TEMP's cost within the tolerance, which is harder than solving it.

Records are plain dictionaries (JSON-able, one per task and planner), so evaluation can be
resumed and merged across processes or machines.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from temp_gym.evaluation.statistics import describe, format_interval

TAU = 0.05
"""Cost tolerance of the paper's Eq. 6."""
UNSOLVED_PENALTY = 1.5
"""A not-yet-solved task costs this times the task's largest recorded cost (cost curves)."""


def tolerance_target(temp_cost: float, tau: float = TAU) -> float:
    """The cost a baseline must reach: ``(1 + tau) * J_TEMP``."""
    if not temp_cost > 0 or not math.isfinite(temp_cost):
        raise ValueError(f"temp_cost: expected a positive finite cost, got {temp_cost}")
    if tau < 0:
        raise ValueError(f"tau: must be non-negative, got {tau}")
    return (1.0 + tau) * temp_cost


def reach_tolerance(history: dict[str, Sequence[float]], target: float) -> dict[str, Any]:
    """Time, nodes and cost of the first anytime entry with cost at most ``target``.

    ``history`` is `PlanResult.history` (``nodes``, ``time``, ``best_cost``, one entry per
    improvement). Returns ``{"success": False}`` with None fields when it never gets there.
    """
    costs = np.asarray(history.get("best_cost", []), dtype=np.float64)
    within = np.flatnonzero(costs <= target)
    if len(within) == 0:
        return {"success": False, "time": None, "nodes": None, "cost": None}
    first = int(within[0])
    return {
        "success": True,
        "time": float(history["time"][first]),
        "nodes": int(history["nodes"][first]),
        "cost": float(costs[first]),
    }


def _by_planner(records: Iterable[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    grouped: dict[str, list[dict[str, Any]]] = {}
    for record in records:
        grouped.setdefault(record["planner"], []).append(record)
    return grouped


def aggregate_rows(records: Iterable[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """Per planner: success rate, mean time and nodes over successes, mean sampling failures.

    Each record has ``planner``, ``success``, ``time``, ``nodes`` and ``sampling_failures``.
    """
    rows = {}
    for planner, group in _by_planner(records).items():
        solved = [r for r in group if r["success"]]
        rows[planner] = {
            "tasks": len(group),
            "success_rate": len(solved) / len(group),
            "time": float(np.mean([r["time"] for r in solved])) if solved else math.nan,
            "nodes": float(np.mean([r["nodes"] for r in solved])) if solved else math.nan,
            "sampling_failures": float(np.mean([r["sampling_failures"] for r in group])),
        }
    return rows


def distribution_rows(records: Iterable[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per planner: `temp_gym.evaluation.statistics.describe` of time and of nodes.

    Over the records each planner solved (as the means of `aggregate_rows`): medians and
    means with 95% bootstrap intervals.
    """
    rows = {}
    for planner, group in _by_planner(records).items():
        solved = [r for r in group if r["success"]]
        rows[planner] = {
            "time": describe([r["time"] for r in solved]),
            "nodes": describe([r["nodes"] for r in solved]),
        }
    return rows


def success_label(planner: str, tau: float = TAU) -> str:
    """What "success" means for ``planner``: TEMP solved the task, a baseline reached 1.05 J."""
    return "solved" if planner == "temp" else f"reached {1.0 + tau:g}·J_TEMP"


def success_curve(records: Iterable[dict[str, Any]], times: np.ndarray) -> dict[str, np.ndarray]:
    """Per planner, the fraction of its tasks solved (within tolerance) by each time."""
    curves = {}
    for planner, group in _by_planner(records).items():
        solve_times = np.array([r["time"] if r["success"] else np.inf for r in group])
        curves[planner] = np.mean(solve_times[None, :] <= np.asarray(times)[:, None], axis=1)
    return curves


def cost_curve(
    histories: dict[str, dict[str, dict[str, Sequence[float]]]], nodes: np.ndarray
) -> dict[str, np.ndarray]:
    """Average best cost against node count, per planner, with the unsolved-task penalty.

    Args:
        histories: ``{task_id: {planner: history}}`` of fixed-budget runs.
        nodes: node counts to evaluate.

    A task not yet solved by a planner at a node count is charged
    ``UNSOLVED_PENALTY * (largest cost any planner recorded on that task)``.
    """
    nodes = np.asarray(nodes)
    sums: dict[str, np.ndarray] = {}
    counts: dict[str, int] = {}
    for per_planner in histories.values():
        recorded = [
            c for h in per_planner.values() for c in np.asarray(h["best_cost"]) if np.isfinite(c)
        ]
        if not recorded:
            continue  # nobody solved it: no scale to charge against
        penalty = UNSOLVED_PENALTY * max(recorded)
        for planner, history in per_planner.items():
            hist_nodes = np.asarray(history["nodes"])
            hist_costs = np.asarray(history["best_cost"], dtype=np.float64)
            if len(hist_nodes) == 0:  # this planner never solved the task
                values = np.full(nodes.shape, penalty)
            else:
                index = np.searchsorted(hist_nodes, nodes, side="right") - 1
                values = np.where(index >= 0, hist_costs[np.maximum(index, 0)], penalty)
            sums[planner] = sums.get(planner, 0.0) + values
            counts[planner] = counts.get(planner, 0) + 1
    return {planner: sums[planner] / counts[planner] for planner in sums}


def paired_ratios(
    records: Iterable[dict[str, Any]], planner: str, baseline: str
) -> dict[str, float] | None:
    """TEMP-style ratios on the tasks both planners solved: sum of times (nodes) over sums.

    Each record has ``planners[name]`` with ``success``, ``time`` and ``nodes``. Means over each
    planner's own successes (`aggregate_rows`, the paper's table) compare different task sets
    when one planner fails often; pairing compares the same tasks. Returns ``time``, ``nodes``
    and ``tasks`` (the number of pairs), or None when no task was solved by both.
    """
    pairs = _pairs(records, planner, baseline)
    if not pairs:
        return None
    return {
        "time": sum(a["time"] for a, _ in pairs) / sum(b["time"] for _, b in pairs),
        "nodes": sum(a["nodes"] for a, _ in pairs) / sum(b["nodes"] for _, b in pairs),
        "tasks": len(pairs),
    }


def paired_ratio_statistics(
    records: Iterable[dict[str, Any]], planner: str, baseline: str
) -> dict[str, dict[str, float]] | None:
    """Per-task ratios ``planner / baseline`` of time and nodes on the tasks both solved.

    Returns `temp_gym.evaluation.statistics.describe` of each (``time``, ``nodes``): the
    median ratio with its 95% bootstrap interval is the figure that survives a stall, which
    moves a ratio of sums (`paired_ratios`) as much as it moves a mean. None when no task was
    solved by both.
    """
    pairs = [(a, b) for a, b in _pairs(records, planner, baseline) if b["time"] > 0]
    if not pairs:
        return None
    return {
        "time": describe([a["time"] / b["time"] for a, b in pairs]),
        "nodes": describe([a["nodes"] / b["nodes"] for a, b in pairs]),
    }


def _pairs(
    records: Iterable[dict[str, Any]], planner: str, baseline: str
) -> list[tuple[dict[str, Any], dict[str, Any]]]:
    """The two planners' figures on each task that both solved."""
    return [
        (r["planners"][planner], r["planners"][baseline])
        for r in records
        if r["planners"].get(planner, {}).get("success")
        and r["planners"].get(baseline, {}).get("success")
    ]


def markdown_table(
    rows_by_group: dict[str, dict[str, dict[str, float]]], planners: list[str]
) -> str:
    """The paper's Table 1 layout: one row per task group, time and nodes per planner.

    ``rows_by_group`` maps a group name (e.g. ``"2D easy"``) to `aggregate_rows` output.
    Success rates are given beside each planner's nodes, labelled with what they count
    (`success_label`). Times and nodes are means; `distribution_table` has the medians.
    """
    header = "| Planning tasks | " + " | ".join(
        f"{p} time (s) | {p} nodes | {p} {success_label(p)}" for p in planners
    )
    rule = "|---|" + "---:|---:|---:|" * len(planners)
    lines = [header + " |", rule]
    for group, rows in rows_by_group.items():
        cells = []
        for planner in planners:
            row = rows.get(planner)
            if row is None:
                cells += ["-", "-", "-"]
                continue
            cells += [
                f"{row['time']:.3f}" if math.isfinite(row["time"]) else "-",
                f"{row['nodes']:.0f}" if math.isfinite(row["nodes"]) else "-",
                f"{100 * row['success_rate']:.0f}%",
            ]
        lines.append(f"| {group} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def distribution_table(
    distributions_by_group: dict[str, dict[str, dict[str, Any]]], planners: list[str]
) -> str:
    """Medians and means of time and nodes with 95% bootstrap intervals, one row per planner.

    ``distributions_by_group`` maps a group name to `distribution_rows` output.
    """
    lines = [
        "| Planning tasks | planner | tasks counted | time median (s) [95%] | time mean (s) [95%] "
        "| nodes median [95%] | nodes mean [95%] |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for group, rows in distributions_by_group.items():
        for planner in planners:
            row = rows.get(planner)
            if row is None:
                continue
            time, nodes = row["time"], row["nodes"]
            lines.append(
                f"| {group} | {planner} | {time['n']} | {format_interval(time, 'median')} | "
                f"{format_interval(time, 'mean')} | {format_interval(nodes, 'median', 0)} | "
                f"{format_interval(nodes, 'mean', 0)} |"
            )
    return "\n".join(lines)
