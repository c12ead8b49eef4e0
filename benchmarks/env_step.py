"""Env overhead: one `PlanningEnv.step` against one bare `Tree.extend`, side by side.

    python benchmarks/env_step.py [--steps 3000] [--repeats 3]

Both consume the same sample stream (goal-biased uniform, as RRT*) on the same generated
problems, so they grow identical trees; the difference is the env's own work: action checks,
denormalization, the observation (fresh arrays, the path so far) and info. Reported per world:
microseconds per extension for each and the overhead ratio env/bare (target: <= 1.25, set
when `Tree.extend` drove its kernels from Python; the env's own work is about 4 us a step).

Best of repeats, taken per chunk of ``--chunk`` consecutive steps: every repeat grows the
same tree from the same samples, so chunk k is the same work in every repeat, and its best
time is the one least disturbed by other processes (a whole run of a few thousand steps is
rarely undisturbed on a shared machine, and the longer run, the env's, less often so). The
repeats of the bare core and the env are interleaved, and both are timed the same way.
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

import temp_gym  # noqa: F401  (registers the envs)
from temp_gym.config import parse_args, script_parser
from temp_gym.planning.samplers import GoalBiasedSampler, UniformSampler
from temp_gym.planning.tree import Tree
from temp_gym.worlds.generators import generate_problem
from temp_gym.worlds.normalization import normalize
from temp_gym.worlds.robots import robot_specs

WORLDS = {spec.short_name: (spec.env_id, spec.name) for spec in robot_specs()}


def samples_for(problem, count, seed):
    rng = np.random.default_rng(seed)
    sampler = GoalBiasedSampler(UniformSampler(problem.bounds), problem.goal, 0.05)
    return np.array([sampler.sample(rng) for _ in range(count)])


def chunks(count: int, size: int) -> list[slice]:
    """Consecutive slices of at most ``size`` covering ``range(count)``."""
    return [slice(begin, min(begin + size, count)) for begin in range(0, count, size)]


def chunk_times(step, items, size):
    """Seconds per chunk of ``size`` consecutive ``step(item)`` calls over ``items``."""
    times = []
    for part in chunks(len(items), size):
        chunk = items[part]
        start = time.perf_counter()
        for item in chunk:
            step(item)
        times.append(time.perf_counter() - start)
    return np.array(times)


def time_bare(problem, samples, size):
    """Seconds per chunk of ``Tree.extend`` over ``samples``, and the nodes grown."""
    tree = Tree(problem)
    return chunk_times(tree.extend, samples, size), tree.num_nodes


def time_env(env, problem, actions, size):
    """Seconds per chunk of ``env.step`` over ``actions``, and the nodes grown."""
    env.reset(seed=0, options={"problem": problem})
    return chunk_times(env.step, actions, size), env.unwrapped.tree.num_nodes


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000, help="extensions per problem")
    parser.add_argument("--problems", type=int, default=3, help="generated problems per world")
    parser.add_argument("--repeats", type=int, default=3, help="interleaved timing rounds")
    parser.add_argument("--chunk", type=int, default=100, help="steps per best-of chunk")
    parser.add_argument("--worlds", nargs="+", default=list(WORLDS), help="worlds to measure")
    args = parse_args(parser, argv)
    header = ["world", "bare extend (us)", "env.step unwrapped (us)", "ratio"]
    print("| " + " | ".join(header + ["gym.make stack (us)", "ratio"]) + " |")
    print("|---|---:|---:|---:|---:|---:|")
    for world in args.worlds:
        env_id, robot = WORLDS[world]
        rng = np.random.default_rng(0)
        # target_cost=0: anytime refinement, so the episode never ends during the timing.
        options = {"fallback": "none", "max_nodes": 10**9, "target_cost": 0.0}
        raw_env = gym.make(env_id, **options).unwrapped
        made_env = gym.make(env_id, **options)
        totals = {"bare": 0.0, "env": 0.0, "made": 0.0}
        steps = 0
        for _ in range(args.problems):
            problem = generate_problem(robot, rng)
            samples = samples_for(problem, args.steps, seed=1)
            actions = normalize(samples, problem.bounds).astype(np.float64)
            time_bare(problem, samples[:50], args.chunk)  # warm-up (numba)
            best = {"bare": np.inf, "env": np.inf, "made": np.inf}
            for _ in range(args.repeats):  # interleaved, best of per chunk: the machine is shared
                elapsed, nodes_bare = time_bare(problem, samples, args.chunk)
                best["bare"] = np.minimum(best["bare"], elapsed)
                elapsed, nodes_env = time_env(raw_env, problem, actions, args.chunk)
                best["env"] = np.minimum(best["env"], elapsed)
                elapsed, _ = time_env(made_env, problem, actions, args.chunk)
                best["made"] = np.minimum(best["made"], elapsed)
                assert nodes_bare == nodes_env, "env and bare core grew different trees"
            for key in totals:
                totals[key] += float(np.sum(best[key]))
            steps += len(samples)
        bare, env, made = (1e6 * totals[k] / steps for k in ("bare", "env", "made"))
        print(
            f"| {world} | {bare:.1f} | {env:.1f} | {env / bare:.2f} | {made:.1f} | "
            f"{made / bare:.2f} |"
        )


if __name__ == "__main__":
    main()
