"""Collision-checking throughput: fast vs exact checker, per world, in one run.

    python benchmarks/collision.py [--states 100000] [--edges 5000] [--exact-states 2000]

For each world (2D, 3D, 7D) it draws generated workspaces, times ``states_free`` on random
configurations and ``edges_free`` on random edges (edge length ~ the planners' step size), for
the fast checker and the exact one, and prints states/s, edges/s and the fast/exact ratio.
Point robots have one checker that is both fast and exact (analytic), so their ratio is 1.
For an arm it also times both checkers without self-collision (``self_collision=False``),
the fast checker without its distance fields (``distance_fields=False``: the same
verdicts, found by walking both bodies' sphere trees), and the fast checker with its spheres
alone near surfaces (``near_surfaces=False``: more refusals, no convex pieces), alternating
with the full checkers on the same states and edges, so the cost of self-collision, the
fields' speed-up and the pieces' cost are measured side by side. A variant that shares the
exact checker reports its one measurement. Single-threaded: numba kernels run on one core; set
NUMBA_NUM_THREADS=1 to be sure.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from temp_gym.config import parse_args, script_parser
from temp_gym.worlds.checkers import make_checker
from temp_gym.worlds.generators import generate_workspace
from temp_gym.worlds.robots import robot_spec, robot_specs


def _rates(functions, *args, repeats: int = 3) -> list[float]:
    """Calls per second of each ``function(*args)`` (rows of the first argument), best of
    ``repeats``, the functions timed in turn so that machine drift hits them alike."""
    count = len(args[0])
    best = [float("inf")] * len(functions)
    for function in functions:
        function(*args)  # warm-up: numba compilation, caches
    for _ in range(repeats):
        for k, function in enumerate(functions):
            start = time.perf_counter()
            function(*args)
            best[k] = min(best[k], time.perf_counter() - start)
    return [count / seconds for seconds in best]


def _random_edges(rng, bounds, step, count):
    starts = rng.uniform(bounds[0], bounds[1], size=(count, bounds.shape[1]))
    direction = rng.normal(size=starts.shape)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    ends = np.clip(starts + step * direction, bounds[0], bounds[1])
    return starts, ends


def _variants(workspace) -> dict[str, tuple]:
    """``{name: (fast, exact)}``: the checkers; for an arm also without self-collision, and
    the fast one without distance fields and with its spheres alone near surfaces."""
    variants = {"": (make_checker(workspace), make_checker(workspace, exact=True))}
    from temp_gym.worlds.collision.arm_exact import ArmExactChecker
    from temp_gym.worlds.collision.arm_fast import ArmSphereChecker

    fast = variants[""][0]
    if isinstance(fast, ArmSphereChecker):
        args = (fast.arm, workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper)
        variants[", no self-collision"] = (
            ArmSphereChecker(*args, self_collision=False),
            ArmExactChecker(*args, self_collision=False),
        )
        variants[", no distance fields"] = (
            ArmSphereChecker(*args, distance_fields=False),
            variants[""][1],
        )
        variants[", spheres only near surfaces"] = (
            ArmSphereChecker(*args, near_surfaces=False),
            variants[""][1],
        )
    return variants


def bench_world(robot: str, args: argparse.Namespace) -> dict[str, float]:
    rng = np.random.default_rng(args.seed)
    rows: dict[str, list[float]] = {}
    for _ in range(args.workspaces):
        workspace = generate_workspace(robot, rng)
        bounds = workspace.bounds
        states = rng.uniform(bounds[0], bounds[1], size=(args.states, workspace.dim))
        starts, ends = _random_edges(
            rng, bounds, robot_spec(robot).default_step_size(bounds), args.edges
        )
        few_starts, few_ends = starts[: args.exact_edges], ends[: args.exact_edges]
        variants = _variants(workspace)
        fast, exact = zip(*variants.values())
        # Each exact checker is timed once, however many variants share it.
        unique = list({id(c): c for c in exact}.values())
        slot = [unique.index(c) for c in exact]
        exact_states = _rates([c.states_free for c in unique], states[: args.exact_states],
                              repeats=1)  # fmt: skip
        exact_edges = _rates([c.edges_free for c in unique], few_starts, few_ends, repeats=1)
        measured = {
            "fast_states": _rates([c.states_free for c in fast], states),
            "fast_edges": _rates([c.edges_free for c in fast], starts, ends),
            "exact_states": [exact_states[k] for k in slot],
            "exact_edges": [exact_edges[k] for k in slot],
            "free_fraction": [c.states_free(states).mean() for c in fast],
        }
        for key, values in measured.items():
            for variant, value in zip(variants, values):
                rows.setdefault(key + variant, []).append(value)
    return {key: float(np.mean(value)) for key, value in rows.items()}


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=100_000, help="random states per workspace")
    parser.add_argument("--edges", type=int, default=5_000, help="random edges per workspace")
    parser.add_argument(
        "--exact-states", type=int, default=2_000, help="of those, for the exact checker"
    )
    parser.add_argument(
        "--exact-edges", type=int, default=200, help="of those, for the exact checker"
    )
    parser.add_argument("--workspaces", type=int, default=3, help="generated workspaces per robot")
    parser.add_argument("--seed", type=int, default=0, help="seed of workspaces, states, edges")
    parser.add_argument(
        "--robots",
        nargs="+",
        default=[spec.name for spec in robot_specs()],
        help="robots to measure",
    )
    args = parse_args(parser, argv)
    for robot in args.robots:
        result = bench_world(robot, args)
        print(
            f"\n## {robot}  ({args.workspaces} generated workspaces, "
            f"{100 * result['free_fraction']:.0f}% of random states free)"
        )
        print("| check | fast (/s) | exact (/s) | fast / exact |")
        print("|---|---:|---:|---:|")
        variants = sorted({key.removeprefix("fast_states") for key in result if
                           key.startswith("fast_states")})  # fmt: skip
        for variant in variants:
            for kind in ("states", "edges"):
                fast, exact = result[f"fast_{kind}{variant}"], result[f"exact_{kind}{variant}"]
                print(f"| {kind}{variant} | {fast:,.0f} | {exact:,.0f} | {fast / exact:,.1f}x |")
        if len(variants) > 1:
            cost = {
                kind: result[kind] / result[kind + ", no self-collision"]
                for kind in ("fast_states", "fast_edges", "exact_states", "exact_edges")
            }
            fields = {kind: result[f"fast_{kind}"] / result[f"fast_{kind}, no distance fields"]
                      for kind in ("states", "edges")}  # fmt: skip
            print(
                "\ndistance fields, speed-up of the fast checker: "
                + ", ".join(f"{kind} {ratio:.2f}x" for kind, ratio in fields.items())
            )
            pieces = {kind: result[f"fast_{kind}"]
                      / result[f"fast_{kind}, spheres only near surfaces"]
                      for kind in ("states", "edges")}  # fmt: skip
            print(
                "convex pieces near surfaces, throughput with / without: "
                + ", ".join(f"{kind} {ratio:.2f}" for kind, ratio in pieces.items())
                + f"; free states {100 * result['free_fraction']:.2f}% with, "
                f"{100 * result['free_fraction, spheres only near surfaces']:.2f}% without"
            )
            print(
                "with / without self-collision (throughput): "
                + ", ".join(f"{kind.replace('_', ' ')} {ratio:.2f}" for kind, ratio in cost.items())
                + f"; free states {100 * result['free_fraction, no self-collision']:.0f}% "
                "without it"
            )


if __name__ == "__main__":
    main()
