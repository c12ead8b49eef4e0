"""The first timed plan of a process compiles nothing: the warm-up ran before the clock."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from temp_gym.planning.warmup import WARM_UP_NODES

ROOT = Path(__file__).resolve().parents[2]
PROBLEMS = {
    "point2d": json.loads((ROOT / "examples" / "point2d.json").read_text()),
    "kuka_iiwa14": {  # bounds: the joint limits
        "robot": "kuka_iiwa14",
        "obstacles": [{"center": [0, 0, -0.06], "half_extents": [1.5, 1.5, 0.05]}],
        "start": [0, 0, 0, 0, 0, 0, 0],
        "goal": [0.6, 0.4, 0, -0.6, 0, 0.4, 0],
        "goal_radius": 0.1,
    },
}

# In a fresh process: wrap every planner so that each call records how many numba
# specializations (compiled, or loaded from numba's cache) appeared during it.
SCRIPT = textwrap.dedent(
    """
    import dataclasses, importlib, json, sys
    import numba
    from temp_gym import Problem, plan
    registry = importlib.import_module("temp_gym.planning.plan").PLANNERS

    def specializations():
        total = 0
        for name, module in list(sys.modules.items()):
            if name.startswith("temp_gym"):
                for value in list(vars(module).values()):
                    if isinstance(value, numba.core.dispatcher.Dispatcher):
                        total += len(value.overloads)
        return total

    calls = []
    for name, entry in list(registry.items()):
        def counted(problem, settings, function=entry.function, name=name):
            before = specializations()
            result = function(problem, settings)
            calls.append([name, settings.max_nodes, specializations() - before])
            return result
        registry[name] = dataclasses.replace(entry, function=counted)

    problems, options = json.loads(sys.argv[1]), json.loads(sys.argv[2])
    problems = problems if isinstance(problems, list) else [problems]
    options = options if isinstance(options, list) else [options] * len(problems)
    for problem, kwargs in zip(problems, options):
        for planner in sys.argv[3:]:
            plan(Problem.from_dict(problem), planner, seed=0, max_nodes=300, **kwargs)
    print(json.dumps(calls))
    """
)


def _calls_in_a_fresh_process(problems, planners, options=None):
    """SCRIPT's ``[planner, max_nodes, new specializations]`` per planner call.

    ``options`` are keyword arguments of every timed `plan` call, or a list of them, one per
    problem.
    """
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, json.dumps(problems), json.dumps(options or {}), *planners],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("robot", sorted(PROBLEMS))
def test_the_timed_run_compiles_nothing(robot):
    planners = ["rrt_star", "informed_rrt_star", "rrt_connect", "temp"]
    calls = _calls_in_a_fresh_process(PROBLEMS[robot], planners)
    timed = [call for call in calls if call[1] == 300]
    warm_ups = [call for call in calls if call[1] == WARM_UP_NODES]
    assert [call[0] for call in timed] == planners
    assert sum(call[2] for call in warm_ups) > 0  # a fresh process does compile or load
    assert all(call[2] == 0 for call in timed), timed


@pytest.mark.parametrize("robot", sorted(PROBLEMS))
def test_a_timed_run_that_grows_a_goal_tree_compiles_nothing(robot):
    """The warm-up's attention phase solves these problems, so the goal tree (built when an
    attention phase stops unsolved, as one attention node does here) is met first by a timed
    run; the warm-up's third plan joined a goal tree before it."""
    calls = _calls_in_a_fresh_process(PROBLEMS[robot], ["temp"], {"attention_nodes": 1})
    timed = [call for call in calls if call[1] == 300]
    assert [call[0] for call in timed] == ["temp"]
    assert all(call[2] == 0 for call in timed), timed


def test_a_timed_run_that_stalls_compiles_nothing():
    """The first plan (and its warm-up) run with the shipped settings in free space, where
    the policy walks to the goal without a stall; the second stalls (a patience of one node
    on uniform samples), so the phases after a stall run, from the goal and in rounds: a
    compiled sequence of their own, which the warm-up's fourth plan met first."""
    free = {"robot": "point2d", "bounds": [[0, 0], [20, 20]], "obstacles": [],
            "start": [2, 2], "goal": [18, 18], "goal_radius": 0.5}  # fmt: skip
    stalls = {"attention_patience": 1, "attention_uniform": 1.0, "stop_at_first": True}
    calls = _calls_in_a_fresh_process([free, free], ["temp"], [{"stop_at_first": True}, stalls])
    timed = [call for call in calls if call[1] == 300]
    assert [call[0] for call in timed] == ["temp", "temp"]
    assert all(call[2] == 0 for call in timed), timed


def test_a_workspace_that_needs_the_exact_free_volume_compiles_nothing_either():
    """The warm-up ran on a workspace whose cheap volume bound sufficed; the next one's does
    not (its boxes overlap, so their summed volume exceeds the bounds): its trees compute the
    exact free volume, whose kernel the warm-up loaded too."""
    overlapping = dict(PROBLEMS["point2d"])
    overlapping["obstacles"] = [{"center": [10, 10], "half_extents": [6, 6]}] * 4
    overlapping["start"], overlapping["goal"] = [1, 1], [19, 19]
    problems = [PROBLEMS["point2d"], overlapping]
    planners = ["temp", "rrt_star"]
    calls = _calls_in_a_fresh_process(problems, planners)
    timed = [call for call in calls if call[1] == 300]
    assert [call[0] for call in timed] == planners * 2
    assert all(call[2] == 0 for call in timed), timed


def test_ompl_warms_up_through_our_planner_and_keeps_its_seed():
    pytest.importorskip("ompl")
    calls = _calls_in_a_fresh_process(PROBLEMS["point2d"], ["ompl_rrt_star"])
    # OMPL itself runs once, timed: its process-wide seed stays the caller's.
    assert [call[0] for call in calls] == ["rrt_star", "rrt_star", "ompl_rrt_star"]
    assert calls[-1][2] == 0


def test_the_warm_up_never_calls_the_callers_policy(monkeypatch, wall):
    import temp_gym.planning.warmup as warmup
    from temp_gym import Problem, plan
    from temp_gym.models.registry import load_policy

    class Counting:
        def __init__(self, policy):
            self.policy, self.calls = policy, 0
            self.encoding_resolution = policy.encoding_resolution
            self.max_path_length = policy.max_path_length

        def reset(self, problem, seed=None):
            self.policy.reset(problem, seed=seed)

        def __call__(self, observation):
            self.calls += 1
            return self.policy(observation)

    problem = Problem.from_dict(wall)
    monkeypatch.setattr(warmup, "_WARMED", set())  # as in a fresh process
    counting = Counting(load_policy("point2d"))
    plan(problem, policy=counting, seed=0, max_nodes=300, stop_at_first=True)
    first = counting.calls
    plan(problem, policy=counting, seed=0, max_nodes=300, stop_at_first=True)
    assert first > 0 and counting.calls == 2 * first  # the first plan made no extra calls
    # A TEMPPolicy warms up through a fresh copy of itself (same model and settings).
    monkeypatch.setattr(warmup, "_WARMED", set())
    policy = load_policy("point2d", seed=4)
    copies = []
    original = type(policy).fresh

    def spy(self):
        copies.append(original(self))
        return copies[-1]

    monkeypatch.setattr(type(policy), "fresh", spy)
    plan(problem, policy=policy, seed=0, max_nodes=10)
    assert len(copies) == 1 and copies[0] is not policy and copies[0].core is policy.core
    assert copies[0].noise_std == policy.noise_std and copies[0].horizon == policy.horizon


def test_the_joinable_query_is_a_free_motion_one_step_and_two_radii_away(wall):
    from temp_gym import Problem
    from temp_gym.planning.tree import default_step_size
    from temp_gym.planning.warmup import _joinable_problem
    from temp_gym.worlds.checkers import make_checker

    problem = Problem.from_dict(wall)
    near = _joinable_problem(problem, make_checker(problem), None)
    distance = default_step_size(problem) + 2 * problem.goal_radius
    assert near is not None and near.workspace == problem.workspace
    assert np.allclose(near.start, problem.start)
    assert np.isclose(np.linalg.norm(near.goal - near.start), distance)
    assert near.goal[0] > problem.start[0]  # towards the goal first
    # Blocked towards the goal: away from it. Blocked both ways: none, and plans still run.
    walled = dict(wall, obstacles=[{"center": [2.5, 10], "half_extents": [0.1, 3]}])
    near = _joinable_problem(
        Problem.from_dict(walled), make_checker(Problem.from_dict(walled)), 1.0
    )
    assert near is not None and near.goal[0] < 2
    boxed = dict(
        walled, obstacles=[*walled["obstacles"], {"center": [1.5, 10], "half_extents": [0.1, 3]}]
    )
    boxed_problem = Problem.from_dict(boxed)
    assert _joinable_problem(boxed_problem, make_checker(boxed_problem), 1.0) is None


def test_the_warm_up_plans_a_query_it_cannot_join_without_failing(monkeypatch, wall):
    import temp_gym.planning.warmup as warmup
    from temp_gym import Problem, plan

    boxed = dict(wall, obstacles=[{"center": [2.5, 10], "half_extents": [0.1, 3]},
                                  {"center": [1.5, 10], "half_extents": [0.1, 3]}])  # fmt: skip
    monkeypatch.setattr(warmup, "_WARMED", set())  # as in a fresh process
    result = plan(Problem.from_dict(boxed), seed=0, max_nodes=300, step_size=1.0)
    assert result.nodes > 1


def test_a_compilation_during_the_warm_up_is_said_once_with_an_estimate(monkeypatch, caplog):
    """numba's compile event, not a cache load, triggers one line per robot and process."""
    import logging

    import numba

    from temp_gym import Problem
    from temp_gym.planning import warmup
    from temp_gym.planning.plan import PLANNERS
    from temp_gym.planning.settings import PlanSettings

    monkeypatch.setattr(warmup, "_WARMED", set())
    monkeypatch.setattr(warmup, "_ANNOUNCED", set())
    problem = Problem.from_dict(PROBLEMS["point2d"])
    calls = []

    def compiling_planner(problem, settings):
        @numba.njit  # a new function on every call: compiled, never loaded from a cache
        def fresh(x):
            return x + 1

        fresh(len(calls))
        calls.append(settings)
        return PLANNERS["rrt_star"](problem, settings)

    planners = {"rrt_star": compiling_planner}
    with caplog.at_level(logging.WARNING, logger="temp_gym"):
        assert warmup.warm_up(problem, "rrt_star", PlanSettings(), planners)
        assert not warmup.warm_up(problem, "rrt_star", PlanSettings(), planners)  # done
    lines = [record.getMessage() for record in caplog.records if record.name == "temp_gym"]
    assert len(calls) >= 2 and lines == [
        "compiling the planner's kernels for point2d (first use, about a minute; cached afterwards)"
    ]


def test_a_warm_cache_says_nothing(tmp_path):
    """Once the kernels are in numba's cache, a new process loads them: no line on stderr."""
    problem = tmp_path / "problem.json"
    problem.write_text(json.dumps(PROBLEMS["point2d"]))
    command = [sys.executable, "-m", "temp_gym.cli", str(problem), "--planner", "rrt_star",
               "--max-nodes", "100"]  # fmt: skip
    for _ in range(2):  # the first run fills the cache if this is the suite's first plan
        done = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=ROOT)
        assert done.returncode in (0, 3), done.stderr
    assert done.stderr == ""


def test_a_workspace_of_other_obstacle_kinds_is_warmed_up_on_its_own(monkeypatch):
    """Its checker has compiled loops of its own, which the box worlds' warm-up never reached."""
    from temp_gym import Problem
    from temp_gym.planning import warmup
    from temp_gym.planning.settings import PlanSettings
    from temp_gym.problem.obstacles import Sphere

    monkeypatch.setattr(warmup, "_WARMED", set())
    boxes = Problem.from_dict(PROBLEMS["point2d"])
    disc = Problem.from_dict(
        dict(
            PROBLEMS["point2d"],
            version=2,
            obstacles=[{"type": "sphere", "center": [10, 10], "radius": 2.0}],
        )
    )
    assert disc.workspace.obstacles == [Sphere((10.0, 10.0), 2.0)]
    calls = []
    planners = {"rrt_star": lambda problem, settings: calls.append(problem.workspace)}
    assert warmup.warm_up(boxes, "rrt_star", PlanSettings(), planners)
    assert warmup.warm_up(disc, "rrt_star", PlanSettings(), planners)
    assert not warmup.warm_up(disc, "rrt_star", PlanSettings(), planners)
    assert disc.workspace in calls


def test_a_start_in_the_goal_region_still_warms_up_a_tree(monkeypatch):
    """A cost-0 solution stops a timed run at once; the warm-up grows its nodes regardless."""
    from temp_gym import Problem
    from temp_gym.planning import warmup
    from temp_gym.planning.plan import PLANNERS
    from temp_gym.planning.settings import PlanSettings

    monkeypatch.setattr(warmup, "_WARMED", set())
    trivial = Problem.from_dict(dict(PROBLEMS["point2d"], goal=PROBLEMS["point2d"]["start"]))
    grown = []
    run = PLANNERS["rrt_star"].function
    planners = {"rrt_star": lambda problem, settings: grown.append(run(problem, settings).nodes)}
    assert warmup.warm_up(trivial, "rrt_star", PlanSettings(), planners)
    assert grown[0] == WARM_UP_NODES


def test_a_trivial_first_problem_leaves_nothing_to_compile_for_the_next():
    """Start at the goal in an empty world: the warm-up still reaches what a real problem
    needs (a grown tree's grid, the union of boxes' volume, a first join), which a timed run
    on the next problem met first (7 s of a 1 s limit with an empty cache)."""
    trivial = {"robot": "point2d", "bounds": [[0, 0], [10, 10]], "obstacles": [],
               "start": [5, 5], "goal": [5, 5], "goal_radius": 0.5}  # fmt: skip
    real = {**trivial, "obstacles": [{"center": [5, 5], "half_extents": [1, 1]}],
            "start": [3, 5], "goal": [8, 8]}  # fmt: skip
    planners = ["rrt_star", "informed_rrt_star", "rrt_connect", "temp"]
    calls = _calls_in_a_fresh_process([trivial, real], planners)
    timed = [call for call in calls if call[1] == 300]
    assert [call[0] for call in timed] == planners * 2
    assert all(call[2] == 0 for call in timed[len(planners) :]), timed
