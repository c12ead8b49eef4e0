"""The rewiring tolerance is relative: tiny worlds plan as well as normal ones, same trees."""

from __future__ import annotations

import types

import numba
import numpy as np
import pytest

from temp_gym.planning import _kernels
from temp_gym.planning.samplers import GoalBiasedSampler, UniformSampler
from temp_gym.planning.tree import Tree
from temp_gym.problem import Problem
from temp_gym.worlds.generators import generate_problem

KERNELS = ("near_and_parent_candidates", "insert_node", "apply_rewires")


@numba.njit(inline="always")
def _absolute(candidate, current):
    return candidate < current - 1e-10  # the former rule: an absolute tolerance


@pytest.fixture(scope="module")
def absolute_kernels() -> dict:
    """The tree kernels recompiled with the former absolute tolerance."""
    out = {}
    for name in KERNELS:
        function = getattr(_kernels, name).py_func
        names = dict(function.__globals__, lowers=_absolute)
        code = types.FunctionType(function.__code__, names, name, function.__defaults__)
        out[name] = numba.njit(nogil=True)(code)
    return out


def grow(problem: Problem, seed: int, nodes: int) -> Tree:
    rng = np.random.default_rng(seed)
    tree = Tree(problem, compiled_extend=False)  # the Python path, whose kernels are patched
    sampler = GoalBiasedSampler(UniformSampler(problem.bounds), problem.goal, 0.05)
    while tree.num_nodes < nodes and tree.samples < 100 * nodes:
        tree.extend(sampler.sample(rng))
    return tree


def scaled(problem: Problem, scale: float) -> Problem:
    data = problem.to_dict()
    return Problem.from_dict(
        {
            **data,
            "bounds": (np.array(data["bounds"]) * scale).tolist(),
            "obstacles": [
                {key: (np.array(value) * scale).tolist() for key, value in box.items()}
                for box in data["obstacles"]
            ],
            "start": (problem.start * scale).tolist(),
            "goal": (problem.goal * scale).tolist(),
            "goal_radius": problem.goal_radius * scale,
        }
    )


def test_normal_scale_trees_are_identical_to_the_absolute_rule(absolute_kernels, monkeypatch):
    for robot, count in (("point2d", 3), ("point3d", 3), ("kuka_iiwa14", 1)):
        for index in range(count):
            problem = generate_problem(robot, np.random.default_rng(index), "any")
            relative = grow(problem, index, 1200)
            with monkeypatch.context() as patch:
                for name, kernel in absolute_kernels.items():
                    patch.setattr(_kernels, name, kernel)
                absolute = grow(problem, index, 1200)
            n = relative.num_nodes
            assert absolute.num_nodes == n
            assert np.array_equal(absolute.parents, relative.parents), (robot, index)
            assert np.array_equal(absolute.costs[:n], relative.costs[:n]), (robot, index)


def test_a_world_1e11_times_smaller_plans_as_well(absolute_kernels, monkeypatch, problem_2d):
    # [0, 2e-10]^2: the former absolute tolerance (1e-10) was a tenth of an edge there.
    problem, scale = problem_2d, 1e-11
    tiny = scaled(problem, scale)
    ratios, former = [], []
    for seed in range(3):
        normal = grow(problem, seed, 1500).best_cost
        ratios.append(grow(tiny, seed, 1500).best_cost / scale / normal)
        with monkeypatch.context() as patch:
            for name, kernel in absolute_kernels.items():
                patch.setattr(_kernels, name, kernel)
            former.append(grow(tiny, seed, 1500).best_cost / scale / normal)
    assert max(abs(ratio - 1) for ratio in ratios) < 1e-3, ratios  # the same tree, scaled
    assert min(former) > 1.1, former  # what the absolute tolerance did there
