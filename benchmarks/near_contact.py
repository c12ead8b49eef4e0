"""Reach poses near surfaces: do they load, do planners solve them, does pybullet agree?

    python benchmarks/near_contact.py --robot kuka_iiwa14 [--tasks 1000] [--max-nodes 10000]
    python benchmarks/near_contact.py --robot franka_panda --refusals 20000

Tasks: in the robot's test workspaces (`temp_gym.worlds.splits`), start and goal are both drawn
2-10 mm from a box, by the exact checker, the hand nearest
(`temp_gym.worlds.arm_world.generate_arm_task` with ``near="both"``). Each is written to JSON
and loaded back (`Problem.from_dict`: the loader must accept a start and goal the exact checker
calls free), then planned by each planner up to its first solution within the node budget.
Every returned path is certified by the exact checker inside `plan`; it is then densified and
handed to pybullet (`temp_gym.worlds.collision.pybullet_reference`: the URDF's own shapes,
posed by pybullet's kinematics) and checked against the joint limits. Prints per planner: tasks
solved, paths pybullet finds in collision, paths outside the limits.

``--refusals N``: the fast model on N random free states per kind, in the same workspaces: the
share it refuses of uniform states the exact checker calls free, of those pybullet calls free
too, and of those within 2 cm of a box (by pybullet).
"""

from __future__ import annotations

import argparse
import functools
import time

import numpy as np

from temp_gym.config import parse_args, script_parser
from temp_gym.distributed import map_units


def _workspace(robot: str, index: int):
    from temp_gym.worlds.splits import split_workspace

    return split_workspace(robot, "test", index % 40, "boxes")


def solve_task(index: int, args: argparse.Namespace) -> dict:
    """Draw task ``index``, load it back, plan it with every planner, referee the paths."""
    from temp_gym import Problem, plan
    from temp_gym.worlds.arm.model import load_arm
    from temp_gym.worlds.arm_world import generate_arm_task
    from temp_gym.worlds.collision.pybullet_reference import PybulletArm, densify
    from temp_gym.worlds.robots import robot_spec

    spec = robot_spec(args.robot)
    workspace = _workspace(args.robot, index)
    rng = np.random.default_rng([args.seed, index])
    drawn = generate_arm_task(workspace, rng, "any", spec.goal_radius, near="both")
    problem = Problem.from_dict(drawn.to_dict())  # must load: both ends are exact-free
    arm = load_arm(spec.description)
    limits = arm.joint_limits()
    out = {"loaded": True}
    with PybulletArm(arm, problem) as bullet:
        for name in args.planners:
            result = plan(problem, planner=name, seed=index, max_nodes=args.max_nodes,
                          stop_at_first=True)  # fmt: skip
            entry = {"solved": bool(result.success), "nodes": int(result.nodes)}
            if result.success:
                states = densify(result.path, args.max_step)
                entry["pybullet_collisions"] = int(np.sum(~bullet.states_free(states)))
                entry["outside_limits"] = int(np.sum(
                    np.any((states < limits[0] - 1e-12) | (states > limits[1] + 1e-12), axis=1)
                ))  # fmt: skip
            out[name] = entry
    return out


def refusals(args: argparse.Namespace) -> None:
    """The fast model's refusals of free states, uniform and near surfaces.

    "Free" is asked of the exact checker (fcl on the link meshes) and, separately, of both it
    and pybullet (the URDF's shapes: each mesh as its convex hull, which the fast model
    covers). A mesh with a concave side is free of a box in that hollow for the exact checker
    and not for pybullet, so the second row is the fair measure of the fast model.
    """
    from temp_gym.worlds.arm.model import load_arm
    from temp_gym.worlds.collision.pybullet_reference import PybulletArm
    from temp_gym.worlds.robots import robot_spec

    spec = robot_spec(args.robot)
    arm = load_arm(spec.description)
    rng = np.random.default_rng(args.seed)
    kinds = ("uniform, exact-free", "uniform, exact- and pybullet-free",
             "within 2 cm, exact- and pybullet-free")  # fmt: skip
    counts = {kind: [0, 0] for kind in kinds}
    per_workspace = max(1, args.refusals // 20)
    for index in range(20):
        workspace = _workspace(args.robot, index)
        fast, exact = spec.make_checker(workspace), spec.make_checker(workspace, exact=True)
        lower, upper = workspace.bounds
        states = rng.uniform(lower, upper, size=(per_workspace * 8, spec.dim))
        free = states[exact.states_free(states)]
        with PybulletArm(arm, workspace) as bullet:
            both = free[bullet.states_free(free)]
            nearest = np.array([min(bullet.obstacle_distances(s, moving_only=True), default=np.inf)
                                for s in both])  # fmt: skip
        samples = {kinds[0]: free[:per_workspace], kinds[1]: both[:per_workspace],
                   kinds[2]: both[nearest <= 0.02][:per_workspace]}  # fmt: skip
        for kind, chosen in samples.items():
            if len(chosen):
                counts[kind][0] += len(chosen)
                counts[kind][1] += int(np.sum(~fast.states_free(chosen)))
    print(f"\n{args.robot}: free states the fast checker refuses (seed {args.seed})\n")
    print("| states | free | refused by the fast checker |")
    print("|---|---:|---:|")
    for kind, (total, refused) in counts.items():
        print(f"| {kind} | {total} | {refused} ({refused / max(total, 1):.2%}) |")


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--robot", default="kuka_iiwa14", help="a registered arm")
    parser.add_argument("--tasks", type=int, default=1000, help="near-contact tasks (0: none)")
    parser.add_argument("--max-nodes", type=int, default=10000, help="node budget per plan")
    parser.add_argument("--max-step", type=float, default=0.005,
                        help="radians between the states pybullet checks")  # fmt: skip
    parser.add_argument("--planners", nargs="+", default=["temp", "informed_rrt_star"],
                        help="planners to run")  # fmt: skip
    parser.add_argument(
        "--refusals",
        type=int,
        default=0,
        help="random states per kind for the fast model's refusals (0: none)",
    )
    parser.add_argument("--workers", type=int, default=2, help="processes")
    parser.add_argument("--seed", type=int, default=0, help="seed of the task draws")
    args = parse_args(parser, argv)
    if args.refusals:
        refusals(args)
    if not args.tasks:
        return
    started = time.perf_counter()
    results = [r for _, r in map_units(functools.partial(solve_task, args=args),
                                       range(args.tasks), "local", args.workers)]  # fmt: skip
    print(f"\n{args.robot}: {len(results)} tasks, start and goal 2-10 mm from a box, all loaded "
          f"({time.perf_counter() - started:.0f} s)\n")  # fmt: skip
    print("| planner | solved | paths pybullet finds in collision | paths outside the limits |")
    print("|---|---:|---:|---:|")
    for name in args.planners:
        runs = [r[name] for r in results]
        solved = [r for r in runs if r["solved"]]
        colliding = sum(1 for r in solved if r["pybullet_collisions"])
        outside = sum(1 for r in solved if r["outside_limits"])
        print(
            f"| {name} | {len(solved)} / {len(runs)} ({len(solved) / len(runs):.1%}) | "
            f"{colliding} | {outside} |"
        )


if __name__ == "__main__":
    main()
