"""A benchmark's outputs: OMPL benchmark logs, their database, a summary table and plots.

From the run records of `temp_gym.evaluation.benchmark`, per experiment:

* ``logs/{experiment}.log``: OMPL's benchmark log (`temp_gym.evaluation.ompl_log`). Run
  properties: ``time`` (the whole run), ``solved`` (a path the exact checker certified),
  ``status`` (OMPL's enum: exact solution, timeout, crash), ``best cost`` and ``solution
  length`` (the path's length), ``solution segments``, ``correct solution``, ``approximate
  solution``, ``first solution time``, ``first solution cost``, ``first solution nodes``,
  ``graph states`` (tree nodes), ``iterations`` (samples), ``collision checks``, ``sampling
  failures``, ``certification failures``, ``problem`` (the problem's index in the setup
  block's list), ``run`` and ``seed``; progress properties ``time``, ``best cost`` and
  ``graph states`` at every improvement of a solved run.
* ``benchmark.db``: every log read into SQLite (`temp_gym.evaluation.ompl_database`), for
  Planner Arena.
* ``summary.md`` and ``summary.csv``: per experiment and planner, the share of runs solved
  within `SOLVED_WITHIN` seconds and within the time limit, the median and mean time to a
  first solution and the median first-solution cost (over the solved runs), and the problems
  skipped.
* ``plots/{experiment}.png``: the share of runs solved against time, and the median best cost
  over the experiment's runs against time (drawn once more than half the runs have a
  solution, where the median is a cost), on a logarithmic time axis.
"""

from __future__ import annotations

import csv
import math
import os
import socket
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.evaluation.benchmark import BenchmarkSettings
from temp_gym.evaluation.benchmark_problems import NamedProblem, problem_digest
from temp_gym.evaluation.ompl_database import logs_to_database
from temp_gym.evaluation.ompl_log import (
    CRASH,
    EXACT_SOLUTION,
    TIMEOUT,
    LogExperiment,
    LogPlanner,
    boolean,
    real,
    write_log,
)
from temp_gym.files import atomic_write

SOLVED_WITHIN = 1.0
"""Seconds of the summary's first success column."""
TIME_AXIS_SPAN = 1e-3
"""The plots' time axis is logarithmic, from this share of the time limit to the limit."""
SUMMARY_COLUMNS = (
    "experiment",
    "planner",
    "runs",
    "solved_within_1s",
    "solved",
    "median_first_time",
    "mean_first_time",
    "median_first_cost",
    "median_simplified_cost",
)
"""The columns of ``summary.csv`` (shares in [0, 1], times in seconds, empty: no solved run)."""


def cpu_info() -> str:
    """The CPU's model and the number of logical CPUs, as far as ``/proc/cpuinfo`` says."""
    try:
        text = Path("/proc/cpuinfo").read_text(errors="replace")
    except OSError:
        return ""
    models = [line.partition(":")[2].strip() for line in text.splitlines()
              if line.startswith("model name")]  # fmt: skip
    return f"{models[0]} ({len(models)} logical CPUs)\n" if models else ""


def _first_time(record: dict[str, Any]) -> float:
    """A solved run's seconds to its first solution.

    A record without it (a time-limited run of an earlier version could drop the improvement
    its last slice found) counts the run's whole time, an upper bound.
    """
    first = record.get("first_time")
    return float(record["time"] if first is None else first)


def _first_cost(record: dict[str, Any]) -> float:
    """A solved run's first solution cost (its final cost when the record lacks it)."""
    first = record.get("first_cost")
    return float(record["cost"] if first is None else first)


def _int(value: Any) -> str:
    return "" if value is None else str(int(value))


def _run_properties(record: dict[str, Any], index: int) -> dict[str, str]:
    solved = bool(record.get("solved"))
    status = record.get("status")
    run = {
        "time REAL": real(record["time"]),
        "solved BOOLEAN": boolean(solved),
        "status ENUM": str(EXACT_SOLUTION if solved else CRASH if status == "crash" else TIMEOUT),
        "best cost REAL": real(record.get("cost") if solved else math.inf),
        "problem INTEGER": str(index),
        "run INTEGER": str(record["run"]),
        "seed INTEGER": str(record["seed"]),
    }
    if status == "crash":
        return run
    run.update({
        "graph states INTEGER": _int(record["nodes"]),
        "iterations INTEGER": _int(record["samples"]),
        "collision checks INTEGER": _int(record["collision_checks"]),
        "sampling failures INTEGER": _int(record["sampling_failures"]),
        "certification failures INTEGER": _int(record["certification_failures"]),
    })  # fmt: skip
    if solved:
        run.update({
            "solution length REAL": real(record["cost"]),
            "solution segments INTEGER": _int(record["path_states"] - 1),
            "correct solution BOOLEAN": boolean(True),
            "approximate solution BOOLEAN": boolean(False),
            "first solution time REAL": real(record["first_time"]),
            "first solution cost REAL": real(record["first_cost"]),
            "first solution nodes INTEGER": _int(record["first_nodes"]),
        })  # fmt: skip
    if solved and "simplified_cost" in record:  # the names OMPL's Benchmark writes
        run.update({
            "simplification time REAL": real(record["simplification_time"]),
            "simplified solution length REAL": real(record["simplified_cost"]),
            "simplified solution segments INTEGER": _int(record["simplified_states"] - 1),
            "simplified correct solution BOOLEAN": boolean(True),
        })  # fmt: skip
    return run


def _progress(record: dict[str, Any]) -> list[dict[str, str]]:
    """A solved run's improvements; one sample per distinct time (the table's key)."""
    history = record.get("history") or {}
    samples: dict[str, dict[str, str]] = {}
    for moment, cost, nodes in zip(
        history.get("time", ()), history.get("best_cost", ()), history.get("nodes", ())
    ):
        stamp = real(moment)
        samples[stamp] = {"time REAL": stamp, "best cost REAL": real(cost),
                          "graph states INTEGER": _int(nodes)}  # fmt: skip
    return list(samples.values())


def _planner_settings(planner: str, settings: BenchmarkSettings) -> dict[str, str]:
    """The planner's settings of every run but the seed, as text (the common properties)."""
    import dataclasses

    from temp_gym.planning.registry import settings_for

    chosen = settings_for(planner, None, time_limit=settings.time_limit,
                          max_nodes=settings.max_nodes)  # fmt: skip
    return {
        field.name: " ".join(str(getattr(chosen, field.name)).split())
        for field in dataclasses.fields(chosen)
        if field.name != "seed"
    }


def experiment_log(
    name: str,
    problems: Sequence[NamedProblem],
    records: Sequence[dict[str, Any]],
    settings: BenchmarkSettings,
) -> LogExperiment:
    """The log of experiment ``name``: its problems' records, planner by planner."""
    import temp_gym

    index = {problem: k for k, (problem, _) in enumerate(problems)}
    mine = [record for record in records if record["problem"] in index]
    robots = sorted({problem.robot for _, problem in problems})
    setup = [
        f"temp-gym benchmark: {len(problems)} problems, {settings.runs} runs per planner and "
        f"problem; the problem INTEGER of a run is its problem's index below",
        f"robots: {', '.join(robots)}",
        *(f"{k}: {problem} ({problem_digest(p)})" for k, (problem, p) in enumerate(problems)),
        "planners: " + ", ".join(settings.planners),
    ]
    planners = []
    for planner in settings.planners:
        runs = [record for record in mine if record["planner"] == planner]
        planners.append(LogPlanner(
            planner,
            _planner_settings(planner, settings),
            [_run_properties(record, index[record["problem"]]) for record in runs],
            [_progress(record) for record in runs],
        ))  # fmt: skip
    starts = [record["finished"] - record["time"] for record in mine if "finished" in record]
    hosts = sorted({record["host"] for record in mine if record.get("host")})
    return LogExperiment(
        name=name,
        planners=planners,
        properties={"robot STRING": "+".join(robots), "problems INTEGER": str(len(problems))},
        version=f"temp-gym {temp_gym.__version__}",
        host=",".join(hosts) or socket.gethostname(),
        start=datetime.fromtimestamp(min(starts)) if starts else datetime.now(),
        setup="\n".join(setup) + "\n",
        cpu_info=cpu_info(),
        seed=settings.seed,
        time_limit=settings.time_limit,
        run_count=max((len(p.runs) for p in planners), default=0),
        total_time=float(sum(record["time"] for record in mine)),
    )


def summary_rows(
    experiments: dict[str, Sequence[NamedProblem]],
    records: Sequence[dict[str, Any]],
    settings: BenchmarkSettings,
) -> list[dict[str, Any]]:
    """Per experiment and planner, the figures of `SUMMARY_COLUMNS` (None: no solved run)."""
    rows = []
    for experiment, problems in experiments.items():
        names = {name for name, _ in problems}
        for planner in settings.planners:
            runs = [r for r in records if r["problem"] in names and r["planner"] == planner]
            times = np.array([_first_time(r) for r in runs if r.get("solved")], dtype=float)
            costs = np.array([_first_cost(r) for r in runs if r.get("solved")], dtype=float)
            simplified = [r for r in runs if r.get("solved") and "simplified_cost" in r]
            shorter = np.array([r["simplified_cost"] for r in simplified], dtype=float)
            total = max(len(runs), 1)
            rows.append({
                "experiment": experiment,
                "planner": planner,
                "runs": len(runs),
                "solved_within_1s": float(np.sum(times <= SOLVED_WITHIN)) / total,
                "solved": len(times) / total,
                "median_first_time": float(np.median(times)) if len(times) else None,
                "mean_first_time": float(np.mean(times)) if len(times) else None,
                "median_first_cost": float(np.median(costs)) if len(costs) else None,
                "median_simplified_cost": float(np.median(shorter)) if len(shorter) else None,
            })  # fmt: skip
    return rows


def _cell(value: Any, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def summary_markdown(
    rows: Sequence[dict[str, Any]], settings: BenchmarkSettings, skipped: Sequence[tuple[str, str]]
) -> str:
    """The summary as Markdown: a table per experiment, then the problems skipped."""
    limit = f"{settings.time_limit:g}"
    lines = [
        "# Benchmark summary",
        "",
        f"{settings.runs} runs per planner and problem, {limit} s per run, seed {settings.seed}."
        " Solved: a path the exact checker certified. Times and costs: the first solution, "
        "over the solved runs."
        + (
            " Simplified cost: the length of the run's last path after simplification."
            if settings.simplify
            else ""
        ),
    ]
    for experiment in dict.fromkeys(row["experiment"] for row in rows):
        lines += [
            "",
            f"## {experiment}",
            "",
            f"| planner | runs | solved within {SOLVED_WITHIN:g} s | solved (limit {limit} s) | "
            "median time (s) | mean time (s) | median first cost |"
            + (" median simplified cost |" if settings.simplify else ""),
            "|---|---:|---:|---:|---:|---:|---:|" + ("---:|" if settings.simplify else ""),
        ]
        for row in rows:
            if row["experiment"] == experiment:
                lines.append(
                    f"| {row['planner']} | {row['runs']} | {100 * row['solved_within_1s']:.0f}% "
                    f"| {100 * row['solved']:.0f}% | {_cell(row['median_first_time'])} "
                    f"| {_cell(row['mean_first_time'])} | {_cell(row['median_first_cost'])} |"
                    + (f" {_cell(row['median_simplified_cost'])} |" if settings.simplify else "")
                )
    lines += ["", f"## Skipped problems ({len(skipped)})", ""]
    lines += [f"- `{name}`: {reason}" for name, reason in skipped] or ["None."]
    return "\n".join(lines) + "\n"


def plot_experiment(
    name: str, runs: Sequence[dict[str, Any]], settings: BenchmarkSettings, path: Path
) -> None:
    """Share of runs solved against time, and median best cost against time, per planner."""
    from matplotlib.figure import Figure

    limit = settings.time_limit
    grid = np.geomspace(limit * TIME_AXIS_SPAN, limit, 400)  # first solutions come early
    figure = Figure(figsize=(9.0, 3.6))
    solved_axes = figure.add_subplot(1, 2, 1)
    cost_axes = figure.add_subplot(1, 2, 2)
    for planner in settings.planners:
        mine = [r for r in runs if r["planner"] == planner]
        if not mine:
            continue
        first = np.array([_first_time(r) if r.get("solved") else np.inf for r in mine])
        solved_axes.plot(grid, (first[None, :] <= grid[:, None]).mean(axis=1), label=planner)
        best = np.full((len(grid), len(mine)), np.inf)
        for column, run in enumerate(mine):
            history = run.get("history") or {}
            times = np.asarray(history.get("time", []), dtype=float)
            costs = np.asarray(history.get("best_cost", []), dtype=float)
            if len(times):  # costs only fall: the last improvement at or before each time
                at = np.searchsorted(times, grid, side="right") - 1
                best[at >= 0, column] = np.minimum.accumulate(costs)[at[at >= 0]]
        median = np.median(best, axis=1)
        cost_axes.plot(grid[np.isfinite(median)], median[np.isfinite(median)], label=planner)
    solved_axes.set(title=f"{name}: runs solved", xlabel="time (s)", ylabel="share of runs",
                    ylim=(0, 1.02))  # fmt: skip
    cost_axes.set(title=f"{name}: median best cost", xlabel="time (s)", ylabel="path length")
    for axes in (solved_axes, cost_axes):
        axes.set_xscale("log")
        axes.set_xlim(grid[0], grid[-1])
    for axes in (solved_axes, cost_axes):
        if axes.get_legend_handles_labels()[0]:
            axes.legend(fontsize=8)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)


def write_outputs(
    experiments: dict[str, Sequence[NamedProblem]],
    records: Sequence[dict[str, Any]],
    settings: BenchmarkSettings,
    out: str | Path,
    skipped: Sequence[tuple[str, str]] = (),
) -> str:
    """Write the logs, the database, the summary and the plots under ``out``.

    A log or plot of an experiment not in ``experiments`` (left by a run on other problems,
    whose records ``runs.jsonl`` keeps) is removed: ``logs/*.log`` is then exactly the
    database's content, as `ompl_benchmark_statistics` would read it. Returns the summary's
    Markdown.
    """
    out = Path(out)
    for folder, suffix in (("logs", ".log"), ("plots", ".png")):
        for stale in sorted((out / folder).glob(f"*{suffix}")):
            if stale.stem not in experiments:
                stale.unlink()
    logs = []
    for name, problems in experiments.items():
        logs.append(write_log(experiment_log(name, problems, records, settings),
                              out / "logs" / f"{name}.log"))  # fmt: skip
        names = {problem for problem, _ in problems}
        runs = [record for record in records if record["problem"] in names]
        plot_experiment(name, runs, settings, out / "plots" / f"{name}.png")
    database = out / "benchmark.db"
    building = out / ".benchmark.db.tmp"
    building.unlink(missing_ok=True)
    os.replace(logs_to_database(logs, building), database)
    rows = summary_rows(experiments, records, settings)
    with atomic_write(out / "summary.csv", "w") as handle:
        writer = csv.DictWriter(handle, fieldnames=SUMMARY_COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    text = summary_markdown(rows, settings, skipped)
    with atomic_write(out / "summary.md", "w") as handle:
        handle.write(text)
    return text


__all__ = [
    "SOLVED_WITHIN",
    "SUMMARY_COLUMNS",
    "experiment_log",
    "plot_experiment",
    "summary_markdown",
    "summary_rows",
    "write_outputs",
]
