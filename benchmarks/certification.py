"""What certifying a returned arm path costs: the exact checker on planners' paths, per path.

    python benchmarks/certification.py [--tasks 60] [--paths paths.json] [--repeats 3]
    python benchmarks/certification.py --mbm problems.tar.bz2 [--per-scene 6] [--paths ...]

`temp_gym.plan` certifies every path it returns with the exact checker (fcl on the iiwa's
meshes and hulls, `temp_gym.worlds.collision.arm_exact`); on the arm that certification can
be most of a plan call. This plans ``--tasks`` validation tasks of ``configs/7d.yaml`` with
TEMP (the shipped policy) and Informed RRT* up to their first solutions, then times
`certify_path`'s work on each returned path (a new exact checker and its ``path_free``, as
`plan` certifies; best of ``--repeats``) and reports per planner the mean and median
milliseconds per path, the edges per path, the poses the exact checker measures per edge
(deterministic, so comparable across machines and runs), and the mean whole `plan` call for
scale.

``--mbm ARCHIVE`` plans MotionBenchMaker's Panda problems instead (the first ``--per-scene`` of
each scene whose start and goal are valid; `temp_gym.benchmarks.motionbenchmaker`), with TEMP
and RRT-Connect; ``--planners`` picks other planners for either set.

``--paths FILE`` stores the problems and paths the first time and reads them afterwards, so
that two checkouts (say, before and after a change to the checker, run alternately) certify
the very same paths.
"""

from __future__ import annotations

import json
import statistics
import time
from pathlib import Path

import numpy as np

from temp_gym import plan, training
from temp_gym.config import load_config, parse_args, script_parser
from temp_gym.problem import Problem
from temp_gym.worlds.checkers import certify_path, make_checker

PLANNERS = ("temp", "informed_rrt_star")
MBM_PLANNERS = ("temp", "rrt_connect")


def validation_problems(tasks: int) -> list[Problem]:
    config = load_config("configs/7d.yaml")
    return training.draw_problems(config, "val", tasks, config.train_eval.seed + 20_000)


def mbm_problems(archive: Path, per_scene: int) -> list[Problem]:
    """The first ``per_scene`` problems of each MotionBenchMaker scene whose start and goal are
    free (`motionbenchmaker.invalid` lists the others; only the problems looked at are tested).
    """
    from temp_gym.benchmarks import motionbenchmaker

    taken: dict[str, int] = {}
    problems = []
    for name, problem in motionbenchmaker.load(archive):
        scene = name.split("/")[0]
        if taken.get(scene, 0) < per_scene and not motionbenchmaker.invalid([(name, problem)]):
            taken[scene] = taken.get(scene, 0) + 1
            problems.append(problem)
    return problems


def chosen_problems(mbm: str | Path | None, per_scene: int, tasks: int) -> list[Problem]:
    """MotionBenchMaker's problems (`mbm_problems`) when an archive is given, else ``tasks``
    7D validation tasks; no problem at all is a `SystemExit`."""
    problems = mbm_problems(mbm, per_scene) if mbm is not None else validation_problems(tasks)
    if not problems:
        raise SystemExit("no problems to plan")
    return problems


def _planned(problems: list[Problem], planners: tuple[str, ...], max_nodes: int) -> list[dict]:
    """``[{planner, problem, path, plan_s}]`` for the problems each planner solved."""
    for planner in planners:  # load kernels and the policy
        plan(problems[0], planner=planner, seed=0, max_nodes=50)
    runs = []
    for seed, problem in enumerate(problems):
        for planner in planners:
            result = plan(problem, planner=planner, seed=seed, max_nodes=max_nodes,
                          stop_at_first=True)  # fmt: skip
            if result.success:
                runs.append({"planner": planner, "problem": problem, "path": result.path,
                             "plan_s": result.wall_time})  # fmt: skip
    return runs


def _save(runs: list[dict], path: Path) -> None:
    records = [
        {"planner": r["planner"], "problem": r["problem"].to_dict(), "path": r["path"].tolist(),
         "plan_s": r["plan_s"]}
        for r in runs
    ]  # fmt: skip
    path.write_text(json.dumps(records))


def _load(path: Path) -> list[dict]:
    records = json.loads(path.read_text())
    return [
        {"planner": r["planner"], "problem": Problem.from_dict(r["problem"]),
         "path": np.asarray(r["path"]), "plan_s": r["plan_s"]}
        for r in records
    ]  # fmt: skip


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    """Run the benchmark; returns per planner its paths and mean and median milliseconds."""
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=int, default=60, help="7D validation tasks")
    parser.add_argument("--max-nodes", type=int, default=10_000, help="node budget per plan")
    parser.add_argument("--paths", type=Path, default=None, help="store or reuse the paths")
    parser.add_argument("--repeats", type=int, default=3, help="timed certifications per path")
    parser.add_argument(
        "--mbm", type=Path, default=None, help="MotionBenchMaker's archive, instead of 7D tasks"
    )
    parser.add_argument("--per-scene", type=int, default=6, help="--mbm: problems per scene")
    parser.add_argument("--planners", nargs="+", default=None,
                        help=f"planners (default: {' '.join(PLANNERS)}; with --mbm "
                             f"{' '.join(MBM_PLANNERS)})")  # fmt: skip
    args = parse_args(parser, argv)
    planners = tuple(args.planners or (MBM_PLANNERS if args.mbm else PLANNERS))
    if args.paths is not None and args.paths.exists():
        runs = _load(args.paths)
    else:
        problems = chosen_problems(args.mbm, args.per_scene, args.tasks)
        runs = _planned(problems, planners, args.max_nodes)
        if args.paths is not None:
            _save(runs, args.paths)
    if not runs:
        raise SystemExit("no planner solved a problem: no path to certify")
    certify_path(runs[0]["problem"], runs[0]["path"])  # geometry and kernels loaded
    seconds = [np.inf] * len(runs)
    poses = [0] * len(runs)  # motion poses measured per path: deterministic, unlike time
    for _ in range(args.repeats):
        for k, run in enumerate(runs):
            started = time.perf_counter()
            checker = make_checker(run["problem"], exact=True)  # as certify_path does
            if not checker.path_free(run["path"]):
                raise SystemExit(f"path {k} ({run['planner']}) is no longer certified")
            seconds[k] = min(seconds[k], time.perf_counter() - started)
            poses[k] = checker.poses_measured
    print(f"{len(runs)} paths, certification best of {args.repeats}\n")
    print("| planner | paths | edges per path | poses per edge | certify mean / median (ms) "
          "| plan() mean (ms) |")  # fmt: skip
    print("|---|---:|---:|---:|---:|---:|")
    table = {}
    for planner in dict.fromkeys(run["planner"] for run in runs):
        mine = [k for k, run in enumerate(runs) if run["planner"] == planner]
        if not mine:
            continue
        ms = [1e3 * seconds[k] for k in mine]
        edges = statistics.mean(len(runs[k]["path"]) - 1 for k in mine)
        whole = statistics.mean(1e3 * runs[k]["plan_s"] for k in mine)
        per_edge = sum(poses[k] for k in mine) / sum(len(runs[k]["path"]) - 1 for k in mine)
        mean, median = statistics.mean(ms), statistics.median(ms)
        print(f"| {planner} | {len(mine)} | {edges:.1f} | {per_edge:.1f} | {mean:.2f} / "
              f"{median:.2f} | {whole:.1f} |")  # fmt: skip
        table[planner] = {"paths": len(mine), "mean_ms": mean, "median_ms": median,
                          "poses_per_edge": per_edge}  # fmt: skip
    return table


if __name__ == "__main__":
    main()
