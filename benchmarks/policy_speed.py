"""TEMP with different policies (model sizes, training runs) against RRT*, side by side.

    python benchmarks/policy_speed.py --world 2d [--checkpoints runs/.../best.pt ...]
        [--tasks 50] [--seeds 2] [--budget 10000] [--split test|val] [--fresh-encoding]
    python benchmarks/policy_speed.py --checkpoints runs/.../best.pt@noise_std=0.03,horizon=4
    python benchmarks/policy_speed.py --split val --fresh-encoding \
        --checkpoints runs/.../best.pt@path_window=16,attention_patience=30,attention_rounds=2

Whether a smaller or otherwise cheaper model pays is a trade: each MPT call costs less, but a
weaker policy may need more nodes. This measures both in one run. On ``--tasks`` easy and
``--tasks`` challenging test tasks (unseen workspaces), each policy (the shipped one first,
then each ``--checkpoints`` entry with the planner settings it carries, or those written after
an ``@``: ``noise_std``, ``horizon`` or any other planner setting a shipped policy carries
(`temp_gym.models.checkpoint_settings.CHECKPOINT_SETTINGS`), as `trainers/tune_planner.py`
chose them for a run not yet shipped, or as the shipped policy has them) and RRT* and Informed
RRT* are called as users call them, ``plan(problem, policy=..., stop_at_first=True)``, seed by
seed with the order of the planners alternating, so all see the same machine load. Per row
and planner: successes, mean and median wall time of the whole call, mean and median nodes to
the first solution (a failure counts as the budget) and the paired time ratio against RRT*
and Informed RRT* (sum over the runs, as in `docs/results.md`), of the whole call and of the
search alone (the time to the first solution, which the paper's protocol compares; the whole
call adds the exact certification of the returned path, most of a 7D call). Then, per policy,
the mean time of one MPT call from Python (`TEMPPolicy.propose_chunk` on the numba MPT, noise
off) on random paths of 1 to L/4 rows, its first call (which loads the kernel) untimed.

``--split val`` measures on ``2 x --tasks`` validation tasks instead (the `boxes` workspaces
`trainers/tune_planner.py` draws from, with its seeds), so that choosing between policies by
time, like choosing by nodes, reads no test task. ``--fresh-encoding`` makes each TEMP call
encode its workspace again (`PolicyCore.clear_encodings`), as every call of the paper's
protocol does, where each test task has its own workspace; without it a workspace met before
reuses its encoding, which favours the larger encoders.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np

from temp_gym import plan, training
from temp_gym.config import load_config, parse_args, script_parser
from temp_gym.evaluation.runner import evaluation_problem
from temp_gym.models.checkpoint_settings import checkpoint_entry
from temp_gym.models.registry import policy_from_checkpoint, shipped_checkpoint
from temp_gym.worlds.robots import robot_spec, robot_specs

ROBOTS = {spec.short_name: spec.name for spec in robot_specs()}
BASELINES = ("rrt_star", "informed_rrt_star")


def test_rows(robot: str, tasks: int) -> dict[str, list]:
    """The first ``tasks`` test tasks of each evaluation row (easy, challenging; 7D: any)."""
    return {
        difficulty: [evaluation_problem(robot, difficulty, i) for i in range(tasks)]
        for difficulty in robot_spec(robot).evaluation_rows.values()
    }


def parse_entry(entry: str) -> tuple[Path, dict[str, float | int]]:
    """A ``--checkpoints`` entry (`temp_gym.models.checkpoint_settings.checkpoint_entry`).

    A bad one exits.
    """
    try:
        return checkpoint_entry(entry)
    except ValueError as error:
        raise SystemExit(str(error)) from None


def val_rows(world: str, tasks: int) -> dict[str, list]:
    """``tasks`` validation tasks of configs/{world}.yaml, as `trainers/tune_planner.py` draws."""
    config = load_config(f"configs/{world}.yaml", [])
    seed = config.train_eval.seed + 20_000
    return {"val": training.draw_problems(config, "val", tasks, seed)}


def run_all(robot: str, rows: dict[str, list], checkpoints: dict[str, tuple], seeds: int,
            budget: int, fresh_encoding: bool = False,
            ) -> dict[str, dict[str, list[tuple[float, float, int, bool]]]]:  # fmt: skip
    """Per row and planner: ``(seconds, search seconds, nodes to the first solution,
    success)`` per run (`_call`)."""
    names = list(checkpoints) + list(BASELINES)
    warm = next(iter(rows.values()))[0]
    for name in names:  # compile and load before the clock
        _call(warm, name, checkpoints, robot, 0, budget)
    runs: dict[str, dict[str, list]] = {row: {n: [] for n in names} for row in rows}
    for seed in range(seeds):
        for row, problems in rows.items():
            for problem in problems:
                order = names if seed % 2 == 0 else names[::-1]
                for name in order:
                    runs[row][name].append(
                        _call(problem, name, checkpoints, robot, seed, budget, fresh_encoding)
                    )
    return runs


def _call(problem, name: str, checkpoints: dict[str, tuple], robot: str, seed: int,
          budget: int, fresh_encoding: bool = False) -> tuple[float, float, int, bool]:  # fmt: skip
    """One run: the whole call's seconds, the search's (`PlanResult.time_to_first_solution`,
    what the paper's protocol times: certifying the path comes after it; a failed run's whole
    call), nodes to the first solution (the budget if none) and success."""
    if name in checkpoints:
        path, settings = checkpoints[name]
        policy = policy_from_checkpoint(path, robot, **settings)
        if fresh_encoding:
            policy.core.clear_encodings()
        began = time.perf_counter()
        result = plan(problem, policy=policy, seed=seed, max_nodes=budget, stop_at_first=True)
    else:
        began = time.perf_counter()
        result = plan(problem, planner=name, seed=seed, max_nodes=budget, stop_at_first=True)
    seconds = time.perf_counter() - began
    nodes = result.nodes_to_first_solution if result.success else budget
    search = result.time_to_first_solution if result.success else seconds
    return seconds, float(search), int(nodes), bool(result.success)


def mpt_call_seconds(checkpoint: Path, robot: str, problems: list, calls: int = 2000) -> float:
    """Mean seconds of one `TEMPPolicy.propose_chunk` (the numba MPT) on paths of 1..L/4 rows."""
    policy = policy_from_checkpoint(checkpoint, robot, noise_std=0.0)
    rng = np.random.default_rng(0)
    lengths = rng.integers(1, max(2, policy.max_path_length // 4), size=calls)
    path = rng.uniform(-1, 1, (policy.max_path_length, policy.dim)).astype(np.float32)
    policy.reset(problems[0])
    policy.propose_chunk(path, 1)  # the first call from Python loads the kernel: untimed
    total = 0.0
    for index, length in enumerate(lengths):
        policy.reset(problems[index % len(problems)])
        began = time.perf_counter()
        policy.propose_chunk(path, int(length))
        total += time.perf_counter() - began
    return total / calls


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--world", default="2d", choices=list(ROBOTS), help="the world")
    parser.add_argument("--checkpoints", nargs="*", default=[],
                        help="bc.py checkpoints to compare with the shipped policy, each "
                             "PATH[@noise_std=X,horizon=K,...]: any planner setting of "
                             "temp_gym.models.checkpoint_settings.CHECKPOINT_SETTINGS")  # fmt: skip
    parser.add_argument("--tasks", type=int, default=50, help="test tasks per row")
    parser.add_argument("--seeds", type=int, default=2, help="planner seeds per task")
    parser.add_argument("--budget", type=int, default=10_000, help="node budget per run")
    parser.add_argument(
        "--split",
        default="test",
        choices=["test", "val"],
        help="test tasks per evaluation row, or 2 x --tasks validation tasks",
    )
    parser.add_argument(
        "--fresh-encoding",
        action="store_true",
        help="each TEMP call encodes its workspace again, as in the protocol",
    )
    args = parse_args(parser, argv)
    for flag in ("tasks", "seeds", "budget"):
        if getattr(args, flag) < 1:
            parser.error(f"--{flag}: must be positive, got {getattr(args, flag)}")
    robot = ROBOTS[args.world]
    checkpoints = {"shipped": (shipped_checkpoint(robot), {})}
    for entry in args.checkpoints:
        path, settings = parse_entry(entry)
        if not path.is_file():
            raise SystemExit(f"--checkpoints: no file {path}")
        checkpoints[entry] = (path, settings)
    if args.split == "val":
        rows = val_rows(args.world, 2 * args.tasks)
    else:
        rows = test_rows(robot, args.tasks)
    runs = run_all(robot, rows, checkpoints, args.seeds, args.budget, args.fresh_encoding)
    encoding = (
        "each TEMP call encoding its workspace again"
        if args.fresh_encoding
        else "encodings kept per workspace"
    )
    for row, planners in runs.items():
        print(f"\n**{args.world} {row}**, {len(rows[row])} tasks x {args.seeds} seeds, to the "
              f"first solution (whole `plan` call; {encoding})\n")  # fmt: skip
        print("| planner | solved | time mean / median (ms) | search mean / median (ms) | "
              "nodes mean / median | time / RRT* | time / IRRT* | search / RRT* | "
              "search / IRRT* |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|")  # fmt: skip
        totals = {b: sum(r[0] for r in planners[b]) for b in BASELINES}
        searched = {b: sum(r[1] for r in planners[b]) for b in BASELINES}
        for name, results in planners.items():
            times = [r[0] for r in results]
            searches = [r[1] for r in results]
            nodes = [r[2] for r in results]
            solved = sum(r[3] for r in results)
            print(f"| {name} | {solved}/{len(results)} | {1e3 * statistics.mean(times):.2f} / "
                  f"{1e3 * statistics.median(times):.2f} | "
                  f"{1e3 * statistics.mean(searches):.2f} / "
                  f"{1e3 * statistics.median(searches):.2f} | {statistics.mean(nodes):.1f} / "
                  f"{statistics.median(nodes):.0f} | {sum(times) / totals['rrt_star']:.3f} | "
                  f"{sum(times) / totals['informed_rrt_star']:.3f} | "
                  f"{sum(searches) / searched['rrt_star']:.3f} | "
                  f"{sum(searches) / searched['informed_rrt_star']:.3f} |")  # fmt: skip
    problems = [p for row in rows.values() for p in row]
    print("\n| policy | one MPT call (us) |\n|---|---:|")
    for name, (path, _) in checkpoints.items():
        print(f"| {name} | {1e6 * mpt_call_seconds(path, robot, problems):.1f} |")


if __name__ == "__main__":
    main()
