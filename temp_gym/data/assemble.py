"""Assemble a split's replay buffer, workspace and task tables from its units; the card.

Assembly reads the units in workspace order and the tasks of each unit in task order, so the
buffer is the same whatever order the workers finished in. It is built in
``{split}/.assembly/`` and then renamed into place; ``{split}/assembled.json`` is written
after the renames. An assembly interrupted at any point is redone from the units.
"""

from __future__ import annotations

import datetime
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.data.dataset import CARD, FORMAT_VERSION, TABLES, workspace_family
from temp_gym.data.demonstrations import resample_path, task_samples
from temp_gym.data.format import SAMPLE_KEYS, SPLITS, TASK_KEYS, sample_shapes
from temp_gym.data.tables import close_table, create_table, file_manifest, write_table
from temp_gym.data.units import STATUS, read_unit, unit_path
from temp_gym.files import write_json_atomic
from temp_gym.worlds.encoding import occupancy_grid
from temp_gym.worlds.robots import robot_spec
from temp_gym.worlds.splits import split_workspace

MARKER = "assembled.json"


def _stats(values: np.ndarray) -> dict[str, float | None]:
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        return {"mean": None, "median": None, "p95": None, "min": None, "max": None}
    return {
        "mean": float(values.mean()),
        "median": float(np.median(values)),
        "p95": float(np.percentile(values, 95)),
        "min": float(values.min()),
        "max": float(values.max()),
    }


def _expert_paths(unit: dict[str, np.ndarray]) -> dict[int, np.ndarray]:
    """Task index -> resampled expert path, for the unit's solved tasks."""
    offsets = unit["path_offsets"]
    resampled = {}
    for task in np.flatnonzero(unit["status"] == STATUS["ok"]):
        path = unit["path_points"][offsets[task] : offsets[task + 1]]
        resampled[int(task)] = resample_path(path, float(unit["step_size"][task]))
    return resampled


def _unit_samples(
    unit: dict[str, np.ndarray], paths: dict[int, np.ndarray], workspace: int, settings: dict
) -> dict[str, np.ndarray]:
    per_task = settings["tasks_per_workspace"]
    parts = [
        task_samples(
            path,
            unit["start"][task],
            unit["goal"][task],
            float(unit["goal_radius"][task]),
            unit["bounds"],
            settings["max_path_length"],
            workspace,
            workspace * per_task + task,
        )
        for task, path in paths.items()
    ]
    return {key: np.concatenate([part[key] for part in parts]) for key in SAMPLE_KEYS}


def _task_table(units: list[dict[str, np.ndarray]], paths: list[dict], settings: dict):
    per_task = settings["tasks_per_workspace"]
    columns: dict[str, list[np.ndarray]] = {key: [] for key in TASK_KEYS}
    for workspace, (unit, resampled) in enumerate(zip(units, paths)):
        samples = np.zeros(per_task, dtype=np.int64)
        for task, path in resampled.items():
            samples[task] = len(path) - 1
        columns["task_id"].append(workspace * per_task + np.arange(per_task, dtype=np.int64))
        columns["workspace_id"].append(np.full(per_task, workspace, dtype=np.int64))
        columns["success"].append(unit["status"] == STATUS["ok"])
        columns["samples"].append(samples)
        columns["waypoints"].append(np.diff(unit["path_offsets"]).astype(np.int64))
        for key in ("status", "start", "goal", "goal_radius", "cost", "nodes", "plan_seed"):
            columns[key].append(unit[key])
        columns["nodes_to_first_solution"].append(unit["nodes_to_first_solution"])
        columns["plan_time"].append(unit["plan_time"])
    if not units:  # an empty split (e.g. data.workspaces.val=0): empty columns
        dim = robot_spec(settings["robot"]).dim
        floats = {"start": (0, dim), "goal": (0, dim), "goal_radius": (0,), "cost": (0,)}
        floats["plan_time"] = (0,)
        return {
            key: np.zeros(floats[key]) if key in floats else np.zeros(0, np.int64)
            for key in columns
        } | {"success": np.zeros(0, bool)}
    return {key: np.concatenate(value) for key, value in columns.items()}


def _build(root: Path, split: str, settings: dict, units: list, paths: list) -> None:
    staging = root / split / ".assembly"
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    dim = robot_spec(settings["robot"]).dim
    total = sum(len(path) - 1 for resampled in paths for path in resampled.values())
    shapes = sample_shapes(dim, settings["max_path_length"])
    buffer = create_table(
        staging / "buffer",
        {key: (dtype, (total, *shape)) for key, (dtype, shape) in shapes.items()},
    )
    row = 0
    for workspace, (unit, resampled) in enumerate(zip(units, paths)):
        if resampled:
            arrays = _unit_samples(unit, resampled, workspace, settings)
            count = len(arrays["step"])
            for key, value in arrays.items():
                buffer[key][row : row + count] = value
            row += count
    close_table(staging / "buffer", buffer)
    del buffer
    robot, resolution = settings["robot"], settings["encoding_resolution"]
    family = workspace_family(settings)
    grids = [
        occupancy_grid(split_workspace(robot, split, index, family), resolution)
        for index in range(len(units))
    ]
    wdim = robot_spec(robot).workspace_dim
    occupancy = np.stack(grids) if grids else np.zeros((0,) + (resolution,) * wdim, np.float32)
    write_table(
        staging / "workspaces",
        {"workspace_id": np.arange(len(units), dtype=np.int64), "occupancy": occupancy},
    )
    tasks = _task_table(units, paths, settings)
    write_table(staging / "tasks", {k: np.ascontiguousarray(v) for k, v in tasks.items()})
    for name in TABLES:
        shutil.rmtree(root / split / name, ignore_errors=True)
        (staging / name).replace(root / split / name)
    shutil.rmtree(staging)


def assemble_split(root: Path, split: str, settings: dict[str, Any]) -> dict[str, Any]:
    """Build the split's tables from its units (unless already done); return its summary."""
    count = settings["workspaces"][split]
    units = [read_unit(unit_path(root, split, index)) for index in range(count)]
    paths = [_expert_paths(unit) for unit in units]
    marker = root / split / MARKER
    done = marker.is_file() and all((root / split / name).is_dir() for name in TABLES)
    if not done:
        marker.unlink(missing_ok=True)
        _build(root, split, settings, units, paths)
        write_json_atomic(marker, {"workspaces": count})
    return summarize(units, paths)


def summarize(units: list[dict[str, np.ndarray]], paths: list[dict]) -> dict[str, Any]:
    """Counts and statistics of one split (the card's per-split entry)."""
    status = np.concatenate([u["status"] for u in units]) if units else np.zeros(0, int)
    ok = status == STATUS["ok"]

    def column(key: str) -> np.ndarray:
        return np.concatenate([u[key] for u in units]) if units else np.zeros(0)

    cost, start, goal = column("cost"), column("start"), column("goal")
    straight = np.linalg.norm(goal - start, axis=-1) if units else np.zeros(0)
    first = column("nodes_to_first_solution")
    resampled = np.array([len(p) for r in paths for p in r.values()], dtype=np.int64)
    return {
        "workspaces": len(units),
        "plans_attempted": int(len(status)),
        "plans_stored": int(ok.sum()),
        "plans_failed": int((status == STATUS["no_solution"]).sum()),
        "tasks_not_drawn": int((status == STATUS["no_task"]).sum()),
        "plans_reversed": _reversed_total(units),
        "samples": int(np.sum(resampled - 1)) if len(resampled) else 0,
        "cost": _stats(cost[ok]),
        "cost_over_straight_line": _stats(cost[ok] / np.maximum(straight[ok], 1e-12)),
        "nodes": _stats(column("nodes")[status != STATUS["no_task"]]),
        "nodes_to_first_solution": _stats(first[first >= 0]),
        "plan_time_s": _stats(column("plan_time")[status != STATUS["no_task"]]),
        "expert_waypoints": _stats(_waypoints(units)),
        "resampled_nodes": _stats(resampled),
        "unit_time_s_total": float(sum(float(u["unit_time"]) for u in units)),
        "unit_cpu_time_s_total": _cpu_total(units),
    }


def _reversed_total(units: list[dict[str, np.ndarray]]) -> int | None:
    """Stored plans the expert found from the goal (``data.expert_reverse``); None: unknown."""
    if any("reversed" not in u for u in units):  # units written before it was recorded
        return None
    return int(sum(int(np.sum(u["reversed"] & (u["status"] == STATUS["ok"]))) for u in units))


def _cpu_total(units: list[dict[str, np.ndarray]]) -> float | None:
    if any("unit_cpu_time" not in u for u in units):  # units written before it was recorded
        return None
    return float(sum(float(u["unit_cpu_time"]) for u in units))


def _waypoints(units: list[dict[str, np.ndarray]]) -> np.ndarray:
    counts = [np.diff(u["path_offsets"])[u["status"] == STATUS["ok"]] for u in units]
    return np.concatenate(counts) if counts else np.zeros(0)


def write_card(
    root: Path,
    settings: dict[str, Any],
    summaries: dict[str, dict[str, Any]],
    wall_time: float,
    planning_wall_time: float,
    workers: int,
    resumed_units: int,
) -> dict[str, Any]:
    """Write ``dataset_card.json`` (last: its presence marks a complete dataset).

    ``files`` lists the size and SHA-256 of every table file; loading verifies them.
    """
    keys = ("plans_attempted", "plans_stored", "plans_failed", "tasks_not_drawn", "samples")
    card = {
        "format": FORMAT_VERSION,
        "robot": settings["robot"],
        "splits": summaries,
        "totals": {key: sum(s[key] for s in summaries.values()) for key in keys},
        "planner": {
            "name": settings["planner"],
            "max_nodes": settings["max_nodes"],
            "budget": f"up to {settings['max_nodes']} tree nodes (100x as many samples) per task",
            "step_size": settings["planner_step_size"] or "the env's step (below)",
            "goal_bias": settings["goal_bias"],
            "difficulty": settings["difficulty"],
            "certified_by": "temp_gym.worlds.collision.certify_path (exact), inside temp_gym.plan",
        },
        "resampling": {
            "step_size": settings["step_size"] or "temp_gym.planning.tree.default_step_size",
            "rule": "every expert edge split into ceil(length / step) equal pieces",
        },
        "seeds": {
            "data_seed": settings["seed"],
            "task": "SeedSequence([data.seed, split code, workspace, task]).spawn(2): "
            "task generator, planner seed",
            "split_codes": {"train": 0, "val": 1},
            "workspaces": "temp_gym.worlds.splits.split_workspace (fixed pools)",
        },
        "settings": settings,
        "timing": {
            "wall_time_s": wall_time,
            "planning_wall_time_s": planning_wall_time,
            "workers": workers,
            "resumed_units": resumed_units,
            "unit_time_s_total": sum(s["unit_time_s_total"] for s in summaries.values()),
            "unit_cpu_time_s_total": None
            if any(s["unit_cpu_time_s_total"] is None for s in summaries.values())
            else sum(s["unit_cpu_time_s_total"] for s in summaries.values()),
        },
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "files": file_manifest(
            root, [root / split / table for split in SPLITS for table in TABLES]
        ),
    }
    write_json_atomic(root / CARD, card)
    return card
