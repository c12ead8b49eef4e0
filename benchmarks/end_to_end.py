"""TEMP against every baseline as users call `plan`: first solution, anytime, completeness.

    python benchmarks/end_to_end.py [--worlds 2d 3d 7d] [--tasks 20] [--seeds 3]
        [--sections user first anytime complete split] [--out results/end_to_end.json]
        [--variants temp_no_goal_tree temp_no_from_goal temp_no_rounds temp_equal_turns]
        [--worlds 2d --checkpoints runs/.../best.pt@path_window=16,attention_rounds=2 ...]

Per world, on ``--tasks`` test tasks of the evaluation (half easy, half challenging, unseen
workspaces) and on the world's out-of-distribution family (`temp_gym.evaluation.ood`), side by
side in one run, each planner called exactly as a user calls it (``plan(problem, planner=...)``,
TEMP with its shipped policy from the process-wide cache):

* ``user``: a fresh process's first ``plan(problem)`` and the median of its next calls, against
  ``plan(problem, planner="informed_rrt_star")`` (the start-up a new user sees).
* ``first``: wall time of the whole ``plan`` call to a first solution (``stop_at_first``), its
  median per planner and the paired TEMP/baseline ratio (sum over the runs both solved).
* ``anytime``: time to reach 1.05x the cost of a long reference run (Informed RRT* with
  ``--reference-nodes`` nodes, the best of its seeds) read off each planner's anytime history;
  median over tasks and seeds, a run that never gets there counting as infinite.
* ``complete``: how often each planner solves each out-of-distribution problem within
  ``--budget`` nodes over ``--complete-seeds`` seeds.
* ``split``: TEMP's attention phase per node: the compiled loop, the MPT's share (the inputs of
  its calls, recorded on the same trees grown by the Python loop, replayed through the MPT
  kernel from compiled code), the Python loop, and RRT* per node.

``--checkpoints`` adds TEMP with other policies as columns beside the shipped one (a training
run not yet shipped, or the policy a shipped one replaced), each with the planner settings
written after its ``@``: the anytime and completeness bounds of a candidate are then measured
in the same run as the shipped policy's.

Runs are interleaved per task and seed, so every planner sees the same machine load. Nodes and
successes do not depend on the load; times do, so read the ratios.
"""

from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np

from temp_gym import plan
from temp_gym.config import parse_args, script_parser
from temp_gym.evaluation.ood import WORLD_DIRS, load_ood_family
from temp_gym.evaluation.protocol import reach_tolerance
from temp_gym.evaluation.runner import evaluation_problem
from temp_gym.models.checkpoint_settings import checkpoint_entry
from temp_gym.models.registry import load_policy, policy_from_checkpoint
from temp_gym.planning.mpt_kernel import forward_kernel
from temp_gym.worlds.robots import robot_spec, robot_specs

ROBOTS = {spec.short_name: spec.name for spec in robot_specs()}
BASELINES = ("rrt_star", "informed_rrt_star", "ompl_rrt_star", "ompl_informed_rrt_star")
PLANNERS = ("temp", *BASELINES)
VARIANTS = {
    "temp_no_goal_tree": ("temp", {"goal_tree": False}),
    "temp_no_from_goal": ("temp", {"attention_from_goal": False}),
    "temp_no_rounds": ("temp", {"attention_rounds": 0}),
    "temp_equal_turns": ("temp", {"attention_resume_growth": 1.0}),
}
"""Extra columns (``--variants``): a planner with other settings, as ``plan`` takes them."""
POLICIES: dict[str, object] = {}
"""Extra columns (``--checkpoints``): TEMP with another policy, by column name."""
TOLERANCE = 1.05


def test_tasks(robot: str, count: int) -> dict[str, object]:
    """``count`` evaluation test tasks, half easy and half challenging (the 7D row: any)."""
    if list(robot_spec(robot).evaluation_rows.values()) == ["any"]:
        return {f"test-{i}": evaluation_problem(robot, "any", i) for i in range(count)}
    easy = {f"easy-{i}": evaluation_problem(robot, "easy", i) for i in range(count // 2)}
    hard = {
        f"challenging-{i}": evaluation_problem(robot, "challenging", i)
        for i in range(count - count // 2)
    }
    return easy | hard


def problem_sets(robot: str, count: int) -> dict[str, dict[str, object]]:
    """The world's test tasks and, when it has one, its out-of-distribution family."""
    sets = {"test": test_tasks(robot, count)}
    if robot in WORLD_DIRS:
        sets["ood"] = load_ood_family(robot)
    return sets


def plan_as(problem, name: str, **kwargs):
    """``plan`` with the planner ``name``: a key of `temp_gym.PLANNERS`, `VARIANTS` or
    `POLICIES`."""
    if name in POLICIES:
        return plan(problem, planner="temp", policy=POLICIES[name], **kwargs)
    planner, settings = VARIANTS.get(name, (name, {}))
    return plan(problem, planner=planner, **settings, **kwargs)


def checkpoint_policies(entries: list[str], robot: str) -> dict[str, object]:
    """Column name -> `TEMPPolicy`, one per ``PATH[@key=value,...]`` entry (`checkpoint_entry`).

    The column is ``temp:`` and the checkpoint's folder (``runs/<run>/best.pt``), or its file
    name when two entries share a folder; the same checkpoint with other settings gets a
    number.

    Raises:
        ValueError: a malformed entry, a checkpoint of another robot.
        OSError: a missing or unreadable file.
    """
    policies: dict[str, object] = {}
    for entry in entries:
        path, settings = checkpoint_entry(entry)
        name = f"temp:{path.parent.name or path.stem}"
        if name in policies:
            name = f"temp:{path.parent.name}/{path.name}"
        base, count = name, 2
        while name in policies:
            name, count = f"{base}#{count}", count + 1
        policies[name] = policy_from_checkpoint(path, robot, **settings)
    return policies


def timed_plan(problem, planner: str, **kwargs):
    """``plan`` timed around the call, as a user sees it: ``(seconds, result)``."""
    began = time.perf_counter()
    result = plan_as(problem, planner, **kwargs)
    return time.perf_counter() - began, result


def warm_up(problem) -> None:
    """Compile and load everything once, outside any timed run."""
    for planner in PLANNERS:
        plan(problem, planner=planner, max_nodes=50, seed=0)


def median(values) -> float:
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else math.nan


def paired_ratio(mine: list, theirs: list) -> tuple[float, int]:
    """Sum of TEMP's values over the sum of the baseline's, over runs both finished."""
    pairs = [(a, b) for a, b in zip(mine, theirs) if a is not None and b is not None]
    if not pairs:
        return math.nan, 0
    return sum(a for a, _ in pairs) / sum(b for _, b in pairs), len(pairs)


# ---- sections ---------------------------------------------------------------------------------
_USER_SCRIPT = """
import json, sys, time
began = time.perf_counter()
from temp_gym import Problem, plan
problem = Problem.load(sys.argv[1])
imported = time.perf_counter() - began
out = {"import": imported}
for planner in ("temp", "informed_rrt_star"):
    times = []
    for seed in range(11):
        t = time.perf_counter()
        plan(problem, planner=planner, seed=seed, stop_at_first=True)
        times.append(time.perf_counter() - t)
    out[planner] = times
print(json.dumps(out))
"""


def user_section(robot: str, problem, scratch: Path) -> dict:
    """A fresh process: the first ``plan`` call of each planner, then the median of ten more."""
    path = scratch / f"user_{robot}.json"
    problem.save(path)
    done = subprocess.run(
        [sys.executable, "-c", _USER_SCRIPT, str(path)], capture_output=True, text=True, check=True
    )
    times = json.loads(done.stdout.strip().splitlines()[-1])
    return {
        "import": times["import"],
        **{
            planner: {"first": times[planner][0], "later": statistics.median(times[planner][1:])}
            for planner in ("temp", "informed_rrt_star")
        },
    }


def first_section(problems: dict, seeds: int, budget: int, planners=PLANNERS) -> dict:
    """Whole-call time and nodes to a first solution, per planner (None: not solved)."""
    runs = {planner: {"time": [], "nodes": []} for planner in planners}
    for problem in problems.values():
        for seed in range(seeds):
            for planner in planners:
                seconds, result = timed_plan(
                    problem, planner, seed=seed, max_nodes=budget, stop_at_first=True
                )
                runs[planner]["time"].append(seconds if result.success else None)
                runs[planner]["nodes"].append(
                    result.nodes_to_first_solution if result.success else None
                )
    return runs


def reference_cost(problem, nodes: int, seeds: int = 2) -> float:
    """The best cost of ``seeds`` Informed RRT* runs of ``nodes`` nodes."""
    costs = [
        plan(problem, planner="informed_rrt_star", seed=1000 + s, max_nodes=nodes).cost
        for s in range(seeds)
    ]
    return min(costs)


def anytime_section(
    problems: dict, seeds: int, nodes: int, time_limit: float, planners=PLANNERS
) -> dict:
    """Time (from each planner's own clock) to reach 1.05x the reference cost."""
    runs = {planner: [] for planner in planners}
    references = {}
    for name, problem in problems.items():
        references[name] = reference_cost(problem, nodes)
        target = TOLERANCE * references[name]
        for seed in range(seeds):
            for planner in planners:
                began = time.perf_counter()
                result = plan_as(problem, planner, seed=seed, max_nodes=nodes,
                                 time_limit=time_limit, target_cost=target)  # fmt: skip
                overhead = time.perf_counter() - began - result.wall_time
                reached = reach_tolerance(result.history, target)
                # the planner's clock starts inside plan(): add what the call spent before it
                runs[planner].append(reached["time"] + overhead if reached["success"] else None)
    return {"runs": runs, "references": references}


def complete_section(
    problems: dict, seeds: int, budget: int, planners=("temp", "informed_rrt_star")
) -> dict:
    """Per problem, how many of ``seeds`` runs of TEMP and Informed RRT* (and ``planners``'
    others) solve it."""
    solved = {}
    for name, problem in problems.items():
        solved[name] = {
            planner: sum(
                plan_as(problem, planner, seed=s, max_nodes=budget, stop_at_first=True).success
                for s in range(seeds)
            )
            for planner in planners
        }
    return solved


class RecordingProposer:
    """The shipped policy through the Python loop (the same trees), its MPT inputs recorded."""

    def __init__(self, policy) -> None:
        self.policy = policy
        self.encoding_resolution = policy.encoding_resolution
        self.max_path_length = policy.max_path_length
        self.attention_nodes = policy.attention_nodes
        self.inputs: list[tuple[np.ndarray, int]] = []

    def reset(self, problem, seed=None) -> None:
        self.policy.reset(problem, seed=seed)

    def propose_chunk(self, path, length):
        self.inputs.append((np.array(path), int(length)))
        return self.policy.propose_chunk(path, length)

    def __call__(self, observation):
        return self.policy(observation)


@numba.njit(cache=True)
def _forward_calls(paths, lengths, goal, z, qkv, weights, out) -> None:
    for i in range(lengths.shape[0]):
        forward_kernel(paths[i], lengths[i], goal, z, qkv, *weights, out)


def mpt_seconds(policy, inputs: list[tuple[np.ndarray, int]], repeats: int = 5) -> float:
    """Seconds the compiled MPT kernel spends on ``inputs``, called from compiled code."""
    paths = np.stack([path for path, _ in inputs])
    lengths = np.array([length for _, length in inputs], dtype=np.int64)
    weights, goal, z, qkv = policy.compiled_proposer()[:4]
    out = np.empty((policy.chunk, paths.shape[-1]), np.float32)
    best = math.inf
    for _ in range(repeats):
        began = time.perf_counter()
        _forward_calls(paths, lengths, goal, z, qkv, weights, out)
        best = min(best, time.perf_counter() - began)
    return best


def split_section(robot: str, problems: dict, repeats: int, budget: int) -> dict:
    """Per node of the attention phase: compiled, MPT share, Python loop; RRT* per node."""
    totals = {"compiled": 0.0, "python": 0.0, "mpt": 0.0, "rrt": 0.0}
    nodes = rrt_nodes = calls = 0
    for seed, problem in enumerate(problems.values()):
        best = dict.fromkeys(totals, math.inf)
        recorder = RecordingProposer(load_policy(robot))
        for _ in range(repeats):
            fast = plan(problem, seed=seed, max_nodes=budget, stop_at_first=True)
            recorder.inputs.clear()
            slow = plan(problem, seed=seed, max_nodes=budget, stop_at_first=True, policy=recorder)
            rrt = plan(problem, planner="rrt_star", seed=seed, max_nodes=budget, stop_at_first=True)
            best["compiled"] = min(best["compiled"], fast.attention["time"])
            best["python"] = min(best["python"], slow.attention["time"])
            best["rrt"] = min(best["rrt"], rrt.time_to_first_solution or rrt.wall_time)
        best["mpt"] = mpt_seconds(recorder.policy, recorder.inputs) if recorder.inputs else 0.0
        nodes += fast.attention["nodes"]
        calls += fast.attention["policy_calls"]
        rrt_nodes += rrt.nodes
        for key in totals:
            totals[key] += best[key]
    per_node = {key: totals[key] / nodes * 1e6 for key in ("compiled", "python", "mpt")}
    per_node["rrt"] = totals["rrt"] / rrt_nodes * 1e6
    per_node["calls_per_node"] = calls / nodes
    return per_node


# ---- report -----------------------------------------------------------------------------------
def print_first(world: str, kind: str, runs: dict) -> None:
    planners = list(runs)
    print(f"\n**{world} {kind}: to a first solution** (whole `plan` call)\n")
    print("| planner | solved | median time (ms) | median nodes | TEMP/planner time, paired |")
    print("|---|---:|---:|---:|---:|")
    for planner in planners:
        times, nodes = runs[planner]["time"], runs[planner]["nodes"]
        solved = sum(t is not None for t in times)
        ratio, pairs = paired_ratio(runs["temp"]["time"], times)
        print(f"| {planner} | {solved}/{len(times)} | {1e3 * median(times):.2f} | "
              f"{median(nodes):.0f} | {ratio:.2f} ({pairs}) |")  # fmt: skip


def print_anytime(world: str, kind: str, section: dict) -> None:
    runs = section["runs"]
    print(f"\n**{world} {kind}: time to 1.05x the reference cost**\n")
    print("| planner | reached | median time (ms) | TEMP median / planner median |")
    print("|---|---:|---:|---:|")
    temp = [math.inf if t is None else t for t in runs["temp"]]
    for planner in runs:
        times = [math.inf if t is None else t for t in runs[planner]]
        reached = sum(math.isfinite(t) for t in times)
        mid = statistics.median(times)
        ratio = statistics.median(temp) / mid if math.isfinite(mid) and mid > 0 else math.nan
        print(f"| {planner} | {reached}/{len(times)} | {1e3 * mid:.1f} | {ratio:.2f} |")


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", default=list(ROBOTS), choices=list(ROBOTS),
                        help="worlds to run")  # fmt: skip
    parser.add_argument("--tasks", type=int, default=20, help="test tasks per world")
    parser.add_argument("--seeds", type=int, default=3, help="planner seeds per task")
    parser.add_argument("--budget", type=int, default=5000, help="node budget of a first solution")
    parser.add_argument("--reference-nodes", type=int, default=50_000,
                        help="nodes of the reference runs and of the anytime runs")  # fmt: skip
    parser.add_argument("--time-limit", type=float, default=60.0, help="seconds per anytime run")
    parser.add_argument("--complete-seeds", type=int, default=10, help="seeds per OOD problem")
    parser.add_argument("--sections", nargs="+", default=["user", "first", "anytime", "complete",
                        "split"], choices=["user", "first", "anytime", "complete", "split"],
                        help="what to measure")  # fmt: skip
    parser.add_argument("--out", type=Path, default=None, help="also write the raw figures here")
    parser.add_argument("--variants", nargs="*", default=[], choices=sorted(VARIANTS),
                        help="also run TEMP with other settings, side by side: without its goal "
                        "tree (temp_no_goal_tree), or with the goal tree grown by Informed "
                        "RRT*'s samples alone (temp_no_from_goal), or without more rounds of the "
                        "attention phase after it stalled both ways (temp_no_rounds), or with "
                        "equal classical turns between resumed attention phases "
                        "(temp_equal_turns)")  # fmt: skip
    parser.add_argument("--checkpoints", nargs="*", default=[],
                        help="also run TEMP with other policies, side by side (one world): "
                        "each PATH[@key=value,...], a bc.py or shipped checkpoint with any "
                        "setting of temp_gym.models.checkpoint_settings.CHECKPOINT_SETTINGS, "
                        "a column "
                        "'temp:<its folder>'")  # fmt: skip
    args = parse_args(parser, argv)
    if args.checkpoints and len(args.worlds) != 1:
        parser.error("--checkpoints: give the one world they were trained for (--worlds)")
    POLICIES.clear()  # this run's columns only
    try:
        POLICIES.update(checkpoint_policies(args.checkpoints, ROBOTS[args.worlds[0]]))
    except (OSError, ValueError) as error:
        parser.error(f"--checkpoints: {error}")
    planners = PLANNERS + tuple(args.variants) + tuple(POLICIES)
    complete = ("temp", *args.variants, *POLICIES, "informed_rrt_star")
    report: dict = {}
    for world in args.worlds:
        robot = ROBOTS[world]
        sets = problem_sets(robot, args.tasks)
        warm_up(next(iter(sets["test"].values())))
        report[world] = figures = {}
        if "user" in args.sections:
            scratch = Path(args.out).parent if args.out else Path("/tmp")
            scratch.mkdir(parents=True, exist_ok=True)
            figures["user"] = user = user_section(robot, next(iter(sets["test"].values())), scratch)
            print(f"\n**{world}: a new process** (import {user['import']:.2f} s)\n")
            print("| call | first (s) | later, median (ms) |\n|---|---:|---:|")
            for planner in ("temp", "informed_rrt_star"):
                print(f"| plan(problem, planner={planner!r}) | {user[planner]['first']:.3f} | "
                      f"{1e3 * user[planner]['later']:.2f} |")  # fmt: skip
        for kind, problems in sets.items():
            if "first" in args.sections:
                runs = first_section(problems, args.seeds, args.budget, planners)
                figures[f"first_{kind}"] = runs
                print_first(world, kind, runs)
            if "anytime" in args.sections:
                section = anytime_section(problems, args.seeds, args.reference_nodes,
                                          args.time_limit, planners)  # fmt: skip
                figures[f"anytime_{kind}"] = section
                print_anytime(world, kind, section)
        if "complete" in args.sections and "ood" in sets:
            figures["complete"] = solved = complete_section(
                sets["ood"], args.complete_seeds, args.budget, complete
            )
            print(f"\n**{world} OOD: solved within {args.budget} nodes, of "
                  f"{args.complete_seeds} seeds**\n")  # fmt: skip
            print(f"| problem | {' | '.join(complete)} |\n|---|{'---:|' * len(complete)}")
            for name, counts in solved.items():
                print(f"| {name} | {' | '.join(str(counts[p]) for p in complete)} |")
        if "split" in args.sections:
            figures["split"] = split = split_section(robot, sets["test"], 3, args.budget)
            print(
                f"\n**{world}: per attention-phase node (us)**: compiled {split['compiled']:.1f}"
                f", of which the MPT {split['mpt']:.1f} ({split['calls_per_node']:.2f} calls "
                f"per node); Python loop {split['python']:.1f}; RRT* {split['rrt']:.1f}"
            )
        sys.stdout.flush()
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(report, indent=1, default=float))


if __name__ == "__main__":
    main()
