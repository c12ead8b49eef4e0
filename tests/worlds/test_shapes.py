"""temp_gym.worlds.shapes: the point worlds' family of rotated boxes, spheres and cylinders."""

from __future__ import annotations

from functools import cache

import gymnasium as gym
import numpy as np
import pytest

from temp_gym.problem import Problem, Workspace
from temp_gym.problem.obstacles import BOX, CYLINDER, SPHERE
from temp_gym.worlds.checkers import make_checker
from temp_gym.worlds.generators import generate_task, generate_workspace
from temp_gym.worlds.point_world import DEFAULT_POINT_WORLDS
from temp_gym.worlds.robots import POINT2D, POINT3D
from temp_gym.worlds.shapes import SHAPES
from temp_gym.worlds.splits import split_workspace
from temp_gym.worlds.structured import (
    CONNECTED_FRACTION,
    WORKSPACE_FAMILIES,
    draw_family,
    largest_region_share,
    obstacles_free_raster,
)

POINT_ROBOTS = [POINT2D.name, POINT3D.name]


@cache
def sample(robot: str, count: int, seed: int = 0) -> tuple[Workspace, ...]:
    return tuple(
        generate_workspace(robot, np.random.default_rng([seed, i]), SHAPES) for i in range(count)
    )


@pytest.mark.parametrize("robot", POINT_ROBOTS)
def test_a_turned_mix_of_every_kind_of_the_boxes_familys_count_and_size(robot):
    dim = 2 if robot == POINT2D.name else 3
    config = DEFAULT_POINT_WORLDS[dim]
    kinds = {BOX, SPHERE} if dim == 2 else {BOX, SPHERE, CYLINDER}
    seen = set()
    for workspace in sample(robot, 10):
        assert not workspace.axis_aligned
        assert config.min_boxes <= workspace.num_obstacles <= config.max_boxes
        halves = workspace.obstacle_half_extents
        assert halves.min() >= config.min_half_extent and halves.max() <= config.max_half_extent
        assert np.all((workspace.obstacle_centers >= 0) & (workspace.obstacle_centers <= 20))
        boxes = workspace.obstacle_kinds == BOX
        assert not np.any(workspace.unrotated[boxes])  # every box is turned
        seen |= set(workspace.obstacle_kinds.tolist())
    assert seen == kinds


@pytest.mark.parametrize("robot", POINT_ROBOTS)
def test_workspaces_keep_to_the_occupancy_limit_and_are_connected(robot):
    dim = 2 if robot == POINT2D.name else 3
    config = DEFAULT_POINT_WORLDS[dim]
    for workspace in sample(robot, 6):
        checker = make_checker(workspace)
        states = np.random.default_rng(0).uniform(0.0, 20.0, (50_000, dim))
        assert 0.05 < 1.0 - checker.states_free(states).mean() <= config.max_occupancy
        assert largest_region_share(obstacles_free_raster(workspace)) >= CONNECTED_FRACTION


@pytest.mark.parametrize("robot", POINT_ROBOTS)
def test_tasks_have_free_starts_and_goals_and_are_solved_by_the_reference(robot):
    from temp_gym.worlds.point_world import classify_task, reference_planner

    rng = np.random.default_rng(5)
    for workspace in sample(robot, 3, seed=11):
        checker = make_checker(workspace)
        for difficulty in ("any", "easy"):
            problem = generate_task(workspace, rng, difficulty)
            assert checker.states_free(np.stack([problem.start, problem.goal])).all()
            reference = reference_planner(workspace).solve(problem.start, problem.goal)
            assert reference.path is not None and checker.path_free(reference.path)
            if difficulty == "easy":
                assert classify_task(reference_planner(workspace), problem.start,
                                     problem.goal)[0] == "easy"  # fmt: skip
            assert Problem.from_dict(problem.to_dict()) == problem  # version 2 round trip


def test_the_family_has_pools_and_an_env_of_its_own():
    pool = split_workspace(POINT2D.name, "val", 0, SHAPES)
    assert pool == split_workspace(POINT2D.name, "val", 0, SHAPES)
    assert not pool.axis_aligned
    env = gym.make("TEMP-3D-v0", split="val", workspace_family=SHAPES)
    observation, _ = env.reset(seed=1)
    assert not env.unwrapped.problem.workspace.axis_aligned
    observation, *_ = env.step(env.action_space.sample())
    env.close()


def test_shapes_stays_out_of_mixed_and_away_from_arms():
    assert SHAPES not in WORKSPACE_FAMILIES
    assert {draw_family(np.random.default_rng(i)) for i in range(300)} == set(WORKSPACE_FAMILIES)
    with pytest.raises(ValueError, match=r"^family: 'shapes' is drawn for 2D and 3D point robots"):
        generate_workspace("kuka_iiwa14", np.random.default_rng(0), SHAPES)
    with pytest.raises(ValueError, match="workspace_family: 'shapes' is drawn for 2D and 3D"):
        gym.make("TEMP-7D-v0", workspace_family=SHAPES)
