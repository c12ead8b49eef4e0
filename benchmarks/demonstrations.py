"""Per-plan cost of demonstration generation, and the extrapolated paper-scale wall time.

    python benchmarks/demonstrations.py --config configs/3d.yaml --workspaces 2

Solves the first ``--workspaces`` training units of the config (all their tasks) in one
process, splitting the time into task drawing, planning (certification included) and the rest,
and extrapolates to the config's full dataset on ``--workers`` processes.
"""

from __future__ import annotations

import time

import numpy as np

from temp_gym.config import load_config, parse_args, script_parser
from temp_gym.data.dataset import data_settings
from temp_gym.data.generate import STATUS, solve_unit


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--config", default="configs/2d.yaml", help="YAML config")
    parser.add_argument("--workspaces", type=int, default=1, help="training units to solve")
    parser.add_argument(
        "--tasks", type=int, default=None, help="tasks per unit (None: data.tasks_per_workspace)"
    )
    parser.add_argument(
        "--workers", type=int, default=2, help="processes the extrapolation assumes"
    )
    parser.add_argument("overrides", nargs="*", help="key.sub=value config overrides")
    args = parse_args(parser, argv)
    settings = data_settings(load_config(args.config, args.overrides))
    full = sum(settings["workspaces"].values()) * settings["tasks_per_workspace"]
    if args.tasks:
        settings["tasks_per_workspace"] = args.tasks
    solve_unit(settings | {"tasks_per_workspace": 1}, "train", 0)  # compile and cache
    units, total, cpu = [], 0.0, 0.0
    for workspace in range(args.workspaces):
        started, started_cpu = time.perf_counter(), time.process_time()
        units.append(solve_unit(settings, "train", workspace))
        total += time.perf_counter() - started
        cpu += time.process_time() - started_cpu
    plans = sum(len(u["status"]) for u in units)
    planning = sum(float(u["plan_time"].sum()) for u in units)
    ok = np.concatenate([u["status"] == STATUS["ok"] for u in units])
    per_plan = total / plans
    print(f"{settings['robot']}: {plans} plans, {ok.mean():.1%} solved")
    print(
        f"  per plan: {per_plan * 1e3:.1f} ms ({planning / plans * 1e3:.1f} ms in plan(), "
        f"{(total - planning) / plans * 1e3:.1f} ms drawing tasks and bookkeeping)"
    )
    print(f"  cpu per plan: {cpu / plans * 1e3:.1f} ms (wall above is inflated on shared cores)")
    for name, seconds in (("wall", per_plan), ("cpu", cpu / plans)):
        minutes = full * seconds / args.workers / 60
        print(f"  {full} plans on {args.workers} workers ({name}-based): ~{minutes:.1f} min")


if __name__ == "__main__":
    main()
