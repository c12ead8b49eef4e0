"""A tree's set-up on a new workspace and on a known one, with the free volume put off or not.

    python benchmarks/tree_setup.py [--worlds 2d 3d 7d] [--workspaces 40] [--repeats 3]

Every planner of ours starts with `Tree(problem)`: the world's checker and the rewiring
radius's ``gamma``, which needs the free volume. `Tree` puts the volume off while a cheap floor
already holds the radius at its cap (`temp_gym.planning.tree.free_volume_floor`). Per world,
on the first ``--workspaces`` test tasks (each on its own workspace), this times:

* **lazy, new workspace**: `Tree(problem)` with the per-workspace caches emptied first, as a
  plan on a scene the process has not seen;
* **eager, new workspace**: `Tree(problem)` and its volume at once, as `Tree` did before the
  floor held for every checker (the iiwa's 4096-state Monte Carlo estimate, a point world's
  exact volume), with the tree's own checker;
* **lazy, known workspace**: `Tree(problem)` again, its caches warm.

The sides alternate per pass, so they see the same machine load; prints the best pass's
mean per tree, in microseconds, and the ratios.
"""

from __future__ import annotations

import time

from temp_gym.config import parse_args, script_parser
from temp_gym.evaluation.runner import evaluation_problem
from temp_gym.planning import tree as tree_module

ROBOTS = {"2d": "point2d", "3d": "point3d", "7d": "kuka_iiwa14"}


def _forget_workspaces() -> None:
    """Empty the tree module's per-workspace caches (free volume and its floor)."""
    tree_module._FREE_VOLUME_CACHE.clear()
    tree_module._FREE_VOLUME_FLOOR_CACHE.clear()


def _new(problems, eager: bool) -> float:
    """Mean seconds of `Tree(problem)` on workspaces the caches have not seen.

    ``eager`` also reads ``gamma``, which computes the free volume with the tree's own checker
    (`workspace_free_volume`), as `Tree` did at construction before the floor held for every
    checker.
    """
    total = 0.0
    for problem in problems:
        _forget_workspaces()
        began = time.perf_counter()
        tree = tree_module.Tree(problem)
        if eager:
            tree.gamma  # noqa: B018 (the property computes and remembers the volume)
        total += time.perf_counter() - began
    return total / len(problems)


def _lazy_known(problems) -> float:
    for problem in problems:
        tree_module.Tree(problem)
    began = time.perf_counter()
    for problem in problems:
        tree_module.Tree(problem)
    return (time.perf_counter() - began) / len(problems)


SIDES = {
    "lazy, new": lambda problems: _new(problems, eager=False),
    "eager, new": lambda problems: _new(problems, eager=True),
    "lazy, known": _lazy_known,
}


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", choices=sorted(ROBOTS), default=sorted(ROBOTS),
                        help="worlds to time")  # fmt: skip
    parser.add_argument("--workspaces", type=int, default=40, help="test tasks per world")
    parser.add_argument("--repeats", type=int, default=3, help="passes per side (best kept)")
    args = parse_args(parser, argv)
    if args.workspaces < 1 or args.repeats < 1:
        parser.error("--workspaces and --repeats must be at least 1")
    print("| world | lazy, new (us) | eager, new (us) | lazy, known (us) | lazy/eager, new |")
    print("|---|---:|---:|---:|---:|")
    for world in args.worlds:
        robot = ROBOTS[world]
        difficulty = "any" if robot == "kuka_iiwa14" else "challenging"
        problems = [evaluation_problem(robot, difficulty, i) for i in range(args.workspaces)]
        for side in SIDES.values():  # load the kernels and the robot's geometry untimed
            side(problems[:2])
        best = {name: float("inf") for name in SIDES}
        for _ in range(args.repeats):
            for name, side in SIDES.items():
                best[name] = min(best[name], side(problems))
        lazy, eager, known = (1e6 * best[name] for name in SIDES)
        print(f"| {world} | {lazy:.1f} | {eager:.1f} | {known:.1f} | {lazy / eager:.2f} |")
    _forget_workspaces()


if __name__ == "__main__":
    main()
