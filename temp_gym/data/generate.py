"""Generate expert demonstrations: RRT* paths over the train/val workspace pools.

Work is split into **units**, one per (split, workspace): its ``tasks_per_workspace`` tasks are
drawn and solved, and the unit is written atomically (temporary file, then `os.replace`) to
``{dir}/{split}/units/{workspace:03d}.npz``. Units run in worker processes; a rerun skips the
units already on disk. When all units exist, each split is assembled from its units in a fixed
order (`temp_gym.data.assemble`), and ``dataset_card.json`` is written last: its presence marks
a complete dataset. A kill at any moment followed by the same command therefore completes the
dataset, with no demonstration lost or duplicated, identical to an uninterrupted run.

Seeds: task ``t`` of workspace ``w`` of split ``s`` uses
``SeedSequence([data.seed, code(s), w, t])``, spawned into one child that draws the task
(`temp_gym.worlds.generators.generate_task`) and one that seeds the planner; any unit, or any
single task, can be recomputed alone. Workspaces are the fixed pools of
`temp_gym.worlds.splits`, of the family ``data.workspace_family`` (default ``boxes``, the
robot's own generator; see `temp_gym.worlds.structured`).

The expert is ``data.planner`` (default Informed RRT*: RRT* whose samples, once a solution
exists, come from the prolate hyperspheroid of the best cost, so it refines to near-optimal
paths in fewer nodes) run for exactly ``data.max_nodes`` tree nodes (with ``data.attempts``
above 1, a task it fails is planned again with a new seed and `RETRY_BUDGET_GROWTH` times the
budget, up to that many attempts; with ``data.expert_reverse``, each failed attempt is planned
again from the goal to the start, and the path reversed: `expert_plan`), steering with
``data.planner_step_size`` (null: the env's step). `temp_gym.plan` certifies every returned
path with the exact checker; a plan without a certified path counts as failed and is not
stored.

Budgets (``configs/*.yaml``) are sized so a paper-scale dataset (about 20,000 plans) takes
at most 20 min (2D, 3D) or about 80 min (7D) on 2 cores: 2D 2000 nodes with a 2.0 step,
3D 1500 nodes with a 3.0 step (a longer expert step refines much faster in 3D: mean cost
within ~2% of a 10,000-node run), 7D 1500 nodes with the env's 0.5 rad step and 3 attempts
(1500, 6000, 24,000 nodes; the arm's trees scan every node, so a fourth attempt's 96,000
nodes would cost minutes on each task no attempt solves).
``benchmarks/demonstrations.py`` measures the per-plan cost of a config.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.config import Config, ConfigError, differing_keys
from temp_gym.config.checks import check_output_dir
from temp_gym.data.dataset import (
    CARD,
    SETTINGS,
    data_dir,
    data_settings,
    incomplete_reason,
    upgraded_settings,
    workspace_family,
)
from temp_gym.data.format import SPLITS
from temp_gym.data.units import (  # noqa: F401  (re-exported: where they lived)
    RECOMPUTE_UNIT,
    STATUS,
    UNIT_KEYS,
    read_unit,
    unit_path,
    write_unit,
)
from temp_gym.files import (
    DirectoryLock,
    LockedError,
    read_json,
    remove_leftovers,
    write_json_atomic,
)
from temp_gym.jobs import estimate_line, progress_line, report
from temp_gym.planning.plan import plan
from temp_gym.planning.result import PlanResult
from temp_gym.planning.tree import default_step_size
from temp_gym.problem import Problem
from temp_gym.worlds.checkers import certify_path
from temp_gym.worlds.generators import generate_task
from temp_gym.worlds.splits import split_workspace

SPLIT_CODES = {split: code for code, split in enumerate(SPLITS)}
RETRY_SEED_STRIDE = 1_000_003
"""Attempt a of a task plans with the task's seed plus a times this (``data.attempts``)."""
RETRY_BUDGET_GROWTH = 4
"""Attempt a of a task gets ``data.max_nodes`` times this to the power a: a task the expert
failed is hard, and a new seed alone rarely solves it."""


def task_seeds(seed: int, split: str, workspace: int, task: int) -> tuple[np.random.Generator, int]:
    """The task generator and planner seed of one task (independent of every other task)."""
    sequence = np.random.SeedSequence([seed, SPLIT_CODES[split], workspace, task])
    task_sequence, plan_sequence = sequence.spawn(2)
    plan_seed = int(plan_sequence.generate_state(1, dtype=np.uint32)[0])
    return np.random.default_rng(task_sequence), plan_seed


def expert_plan(
    problem: Problem,
    settings: dict[str, Any],
    seed: int,
    max_nodes: int,
    step_size: float,
    backwards: bool = False,
) -> tuple[PlanResult, np.ndarray | None, float]:
    """One run of the expert on ``problem``: its result, its certified path and that path's cost.

    The path is None when the run failed (the cost is then inf). ``backwards`` plans from the
    goal to the start (start and goal swapped, the same goal radius) and reverses the path;
    when that path ends short of the start (in its goal ball), the start is put in front (the
    cost grows by that segment) and the whole path certified again by the exact checker, or
    the run counts as failed. A forward tree fails on tasks whose goal lies in a pocket (a bin,
    a compartment, a trap) that its samples rarely enter; a tree rooted there reaches the open
    start easily.
    """
    planned = replace(problem, start=problem.goal, goal=problem.start) if backwards else problem
    result = plan(planned, planner=settings["planner"], seed=seed, max_nodes=max_nodes,
                  step_size=step_size, goal_bias=settings["goal_bias"])  # fmt: skip
    if not result.success or result.path is None:
        return result, None, float("inf")
    path, cost = np.asarray(result.path, dtype=np.float64), float(result.cost)
    if not backwards:
        return result, path, cost
    path = path[::-1]
    if not np.array_equal(path[0], problem.start):
        cost += float(np.linalg.norm(path[0] - problem.start))
        path = np.concatenate([problem.start[None], path])
        if not certify_path(problem, path):
            return result, None, float("inf")
    return result, np.ascontiguousarray(path), cost


def solve_unit(settings: dict[str, Any], split: str, workspace: int) -> dict[str, np.ndarray]:
    """Draw and solve every task of one workspace; return the unit's arrays.

    Paths of the solved tasks are concatenated in ``path_points`` (world units) and delimited
    by ``path_offsets``; ``status`` holds a `STATUS` code per task.
    """
    started, started_cpu = time.perf_counter(), time.process_time()
    if settings.get("robot_description"):  # a worker process meets this arm for the first time
        from temp_gym.worlds.arm.spec import ensure_registered

        ensure_registered(settings["robot_description"])
    space = split_workspace(settings["robot"], split, workspace, workspace_family(settings))
    count, dim = settings["tasks_per_workspace"], space.dim
    status = np.full(count, STATUS["no_task"], dtype=np.int64)
    starts = np.zeros((count, dim))
    goals = np.zeros((count, dim))
    radii = np.zeros(count)
    costs = np.full(count, np.inf)
    nodes = np.zeros(count, dtype=np.int64)
    first = np.full(count, -1, dtype=np.int64)
    times = np.zeros(count)
    plan_seeds = np.zeros(count, dtype=np.int64)
    steps = np.zeros(count)
    paths: list[np.ndarray] = []
    lengths = np.zeros(count, dtype=np.int64)
    reversed_plans = np.zeros(count, dtype=bool)
    for task in range(count):
        rng, plan_seeds[task] = task_seeds(settings["seed"], split, workspace, task)
        try:
            problem = generate_task(space, rng, settings["difficulty"])
        except RuntimeError:  # no task of that difficulty in this workspace
            continue
        starts[task], goals[task], radii[task] = problem.start, problem.goal, problem.goal_radius
        steps[task] = settings["step_size"] or default_step_size(problem)
        directions = (False, True) if settings.get("expert_reverse", False) else (False,)
        path = None
        for attempt in range(settings.get("attempts", 1)):  # a new seed and a larger budget
            for backwards in directions:
                result, path, cost = expert_plan(
                    problem,
                    settings,
                    seed=(int(plan_seeds[task]) + RETRY_SEED_STRIDE * attempt) % 2**32,
                    max_nodes=settings["max_nodes"] * RETRY_BUDGET_GROWTH**attempt,
                    step_size=settings["planner_step_size"] or steps[task],
                    backwards=backwards,
                )
                times[task] += result.wall_time
                if path is not None:
                    break
            if path is not None:
                reversed_plans[task] = backwards
                break
        nodes[task] = result.nodes
        if result.nodes_to_first_solution is not None:
            first[task] = result.nodes_to_first_solution
        if path is None:
            status[task] = STATUS["no_solution"]
            continue
        status[task], costs[task] = STATUS["ok"], cost
        paths.append(path)
        lengths[task] = len(path)
    return {
        "status": status,
        "start": starts,
        "goal": goals,
        "goal_radius": radii,
        "bounds": space.bounds,
        "step_size": steps,
        "cost": costs,
        "nodes": nodes,
        "nodes_to_first_solution": first,
        "plan_time": times,
        "plan_seed": plan_seeds,
        "path_offsets": np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
        "path_points": np.concatenate(paths) if paths else np.zeros((0, dim)),
        "unit_time": np.array(time.perf_counter() - started),
        "unit_cpu_time": np.array(time.process_time() - started_cpu),
        "reversed": reversed_plans,
    }


def _solve_job(job: tuple[dict[str, Any], str, int]) -> dict[str, np.ndarray]:
    settings, split, workspace = job
    return solve_unit(settings, split, workspace)


def _prepare(root: Path, settings: dict[str, Any]) -> None:
    root.mkdir(parents=True, exist_ok=True)
    settings_path = root / SETTINGS
    if settings_path.is_file():
        stored = read_json(
            settings_path,
            "it records which settings made this dataset; if you know it was made with "
            "this config, delete it and rerun, else delete the directory",
        )
        upgraded = upgraded_settings(stored, settings)
        if upgraded != settings:
            changed = differing_keys(upgraded, settings)
            if changed == ["robot_digest"]:
                raise ConfigError(
                    f"{root} holds a dataset of {settings['robot']} as it was before its "
                    "description, URDF or meshes were edited; delete it or choose another "
                    "data.dir"
                )
            raise ConfigError(
                f"{root} holds a dataset made with other settings ({', '.join(changed)}); "
                "delete it or choose another data.dir"
            )
        if upgraded != stored:
            report(f"{settings_path}: made before robot digests were recorded; its robot is "
                   "taken to be the description as it is now")  # fmt: skip
            write_json_atomic(settings_path, upgraded)
    else:
        write_json_atomic(settings_path, settings)
    for split in SPLITS:
        units = root / split / "units"
        units.mkdir(parents=True, exist_ok=True)
        remove_leftovers(units)  # units whose writer was killed


def _solve_units(
    root: Path,
    jobs: list[tuple[dict[str, Any], str, int]],
    workers: int,
    progress: bool,
    tasks: int,
    done: int = 0,
    backend: str = "local",
    address: str | None = None,
) -> None:
    """Solve the units on the backend; the driver writes each unit file as it arrives.

    The bar counts plans and starts at the ``done`` units already on disk.
    """
    from tqdm import tqdm

    from temp_gym.distributed import map_units

    total = (len(jobs) + done) * tasks
    bar = tqdm(
        total=total, initial=done * tasks, desc="demonstrations", unit="plan", disable=not progress
    )
    with bar:
        for index, arrays in map_units(_solve_job, jobs, backend, workers, address):
            _, split, workspace = jobs[index]
            write_unit(unit_path(root, split, workspace), arrays)
            bar.update(len(arrays["status"]))


def _estimate(
    root: Path, settings: dict[str, Any], jobs: list, workers: int, probe: bool
) -> str | None:
    """The time the missing units should take, from units already solved, else a probe.

    Stored units give the median time per plan once there are at least three of them;
    otherwise, with ``probe``, two plans are timed (None without).
    The probe plans the first two tasks of the first missing unit here (the workers plan
    them again: a unit is written whole), after the per-process warm-up of `temp_gym.plan`.
    """
    stored = [path for split in SPLITS for path in sorted((root / split / "units").glob("*.npz"))]
    times = []
    for path in stored[:20]:
        unit = read_unit(path)
        times.append(float(unit["unit_time"]) / max(len(unit["status"]), 1))
    if len(times) >= 3:  # a worker's first unit includes its warm-up: take the median
        per_plan, basis = float(np.median(times)), f"measured on {len(times)} stored units"
    elif not probe:
        return None
    else:
        _, split, workspace = jobs[0]
        probes = min(2, settings["tasks_per_workspace"])
        solve_unit(settings | {"tasks_per_workspace": 1}, split, workspace)  # warm-up
        probe = solve_unit(settings | {"tasks_per_workspace": probes}, split, workspace)
        per_plan, basis = float(probe["unit_time"]) / probes, f"measured on {probes} plans"
    per_unit = per_plan * settings["tasks_per_workspace"]
    return estimate_line(len(jobs), per_unit, workers, "units", basis)


def generate_dataset(
    config: Config,
    workers: int | None = None,
    progress: bool = True,
    backend: str = "local",
    address: str | None = None,
    wait: bool = False,
) -> Path:
    """Generate (or finish, or repair) the demonstration dataset of ``config``; return its dir.

    A no-op when the dataset is complete. Otherwise solves the missing units with ``workers``
    processes (default ``data.workers``) on the ``backend`` (``local`` processes or ``ray``
    tasks on the cluster at ``address`` / ``$RAY_ADDRESS``, see `temp_gym.distributed`),
    assembles each split's replay buffer, workspace table and task table, and writes
    ``dataset_card.json``. Both backends give the same dataset. A card whose tables are
    missing or of another size is not complete: the tables are rebuilt from the units.

    The directory is locked while this runs (`temp_gym.files.DirectoryLock`): a second run
    on the same ``data.dir`` stops with a message naming the first (or, with ``wait``, waits
    for it and then finds the dataset complete).

    Examples:
        >>> config = load_config("configs/tiny.yaml", ["data.dir=/tmp/tiny"])
        >>> rb, workspaces = load_split(generate_dataset(config), "train")

    Raises:
        temp_gym.config.ConfigError: a bad ``data`` or ``env`` value, or a ``data.dir`` that
            cannot be a folder (a file, ``/dev/null``, ``/proc/x``), before anything is written.
        temp_gym.files.LockedError: another run holds the directory (without ``wait``).
        temp_gym.files.StoredFileError: a stored file is damaged (named, with the fix).
    """
    settings = data_settings(config)
    root = check_output_dir(data_dir(config), "data.dir")
    lock = DirectoryLock(root, "generating demonstrations")
    try:
        lock.acquire()
    except LockedError:
        if not wait:
            raise
        report(f"waiting: {root} is in use by another run ({lock.holder()})")
        lock.acquire(wait=True)
    try:
        _prepare(root, settings)  # raises if the settings differ
        reason = incomplete_reason(root, settings)
        if reason is None:
            return root
        if (root / CARD).is_file():
            report(f"{root}: the dataset is incomplete ({reason}); rebuilding its tables")
        _generate(root, settings, config, workers, progress, backend, address)
    finally:
        lock.release()
    return root


def _generate(root, settings, config, workers, progress, backend, address) -> None:
    from temp_gym.data.assemble import MARKER, assemble_split, write_card

    (root / CARD).unlink(missing_ok=True)
    for split in SPLITS:
        (root / split / MARKER).unlink(missing_ok=True)  # rebuild every table
    started = time.perf_counter()
    workers = int(workers or config.data.workers or 1)
    total = sum(settings["workspaces"].values())
    jobs = [
        (settings, split, workspace)
        for split in SPLITS
        for workspace in range(settings["workspaces"][split])
        if not unit_path(root, split, workspace).is_file()
    ]
    resumed = total - len(jobs)
    if jobs and backend == "ray":
        from temp_gym.distributed import init_ray

        init_ray(address, workers)  # fail fast: no planning before a missing cluster is found
    report(progress_line(resumed, total, "units"))
    estimate = _estimate(root, settings, jobs, workers, probe=progress) if jobs else None
    if estimate:  # the probe (two plans) only runs when progress is shown
        report(estimate)
    _solve_units(
        root, jobs, workers, progress, settings["tasks_per_workspace"], resumed, backend, address
    )
    planned = time.perf_counter() - started
    summaries = {split: assemble_split(root, split, settings) for split in SPLITS}
    write_card(
        root,
        settings,
        summaries,
        wall_time=time.perf_counter() - started,
        planning_wall_time=planned,
        workers=workers,
        resumed_units=resumed,
    )
