"""Adding a robot is one file and one registry line: a toy robot defined in this file alone.

The robot is a disc of radius `RADIUS` in a ``[0, 10]^2`` room with round pillars: a world no
built-in robot has, with its own (pure Python) checker, generators and renderer. Registered,
it is known to problems, the planners, the env and the drawing code, and nothing else of the
library had to change.
"""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest

from temp_gym import Problem, plan
from temp_gym.envs import register_envs
from temp_gym.problem import Workspace
from temp_gym.worlds.generators import generate_workspace
from temp_gym.worlds.robots import RobotSpec, forget_robot, register_robot, robot_spec

RADIUS = 0.3
SIZE = 10.0


class DiscChecker:
    """A disc among boxes, checked by distance; motions by steps of a tenth of the radius."""

    dim = 2
    description = "toy disc checker (test)"

    def __init__(self, workspace: Workspace) -> None:
        self.bounds = workspace.bounds
        self.lower = workspace.obstacle_lower
        self.upper = workspace.obstacle_upper

    def states_free(self, states: np.ndarray) -> np.ndarray:
        states = np.atleast_2d(np.asarray(states, dtype=np.float64))
        inside = np.all((states >= self.bounds[0]) & (states <= self.bounds[1]), axis=1)
        nearest = np.clip(states[:, None, :], self.lower[None], self.upper[None])
        distance = np.linalg.norm(states[:, None, :] - nearest, axis=2)
        clear = np.all(distance > RADIUS, axis=1) if len(self.lower) else np.ones(len(states), bool)
        return inside & clear

    def edge_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        steps = max(2, int(np.ceil(np.linalg.norm(np.subtract(end, start)) / (0.1 * RADIUS))) + 1)
        return bool(self.states_free(np.linspace(start, end, steps)).all())

    def edges_free(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        return np.array([self.edge_free(a, b) for a, b in zip(starts, ends)], dtype=bool)

    def path_free(self, path: np.ndarray) -> bool:
        return all(self.edge_free(a, b) for a, b in zip(path[:-1], path[1:]))


def _workspace(robot: str, rng: np.random.Generator) -> Workspace:
    centers = rng.uniform(2.0, 8.0, size=(3, 2))
    return Workspace(robot, [[0.0, 0.0], [SIZE, SIZE]], centers, np.full((3, 2), 0.5))


def _task(workspace: Workspace, rng, difficulty: str, goal_radius: float) -> Problem:
    checker = DiscChecker(workspace)
    for _ in range(1000):
        start, goal = rng.uniform(0.5, SIZE - 0.5, size=(2, 2))
        if np.linalg.norm(goal - start) > SIZE / 2 and checker.states_free([start, goal]).all():
            if difficulty == "any" or (difficulty == "easy") == checker.edge_free(start, goal):
                return Problem(workspace, start, goal, goal_radius)
    raise RuntimeError(f"no {difficulty} task")


class BlankRenderer:
    def draw_tree(self, problem, positions, parents, num_nodes, path=None, path_so_far=None):
        return np.full((32, 32, 3), 255, dtype=np.uint8)

    def close(self) -> None:
        pass


DISC = RobotSpec(
    name="toy_disc",
    env_id="TEMP-ToyDisc-v0",
    short_name="disc",
    seed_code=99,
    dim=2,
    workspace_dim=2,
    encoding_resolution=8,
    goal_radius=0.4,
    max_nodes=300,
    evaluation_rows={"disc": "any"},
    evaluation_tasks=2,
    checker_factory=lambda workspace, exact: DiscChecker(workspace),
    workspace_generator=_workspace,
    task_generator=_task,
    renderer_factory=BlankRenderer,
)


@pytest.fixture
def disc():
    register_robot(DISC)  # the one registry line
    register_envs()
    yield DISC
    forget_robot(DISC.name)


def test_a_robot_defined_in_a_test_plans_steps_and_draws(disc):
    assert robot_spec("toy_disc") is disc
    problem = disc.generate_task(
        disc.generate_workspace(np.random.default_rng(0)), np.random.default_rng(1)
    )
    assert Problem.from_dict(problem.to_dict()) == problem  # problem files know the robot
    for planner in ("rrt_star", "informed_rrt_star"):
        result = plan(problem, planner=planner, seed=0, max_nodes=400, stop_at_first=True)
        assert result.success and DiscChecker(problem.workspace).path_free(result.path)

    env = gymnasium.make(disc.env_id, render_mode="rgb_array")
    observation, _ = env.reset(seed=0)
    assert observation["occupancy"].shape == (8, 8)
    observation, *_ = env.step(env.action_space.sample())
    assert env.unwrapped.max_nodes == disc.max_nodes
    assert env.render().shape == (32, 32, 3)
    env.close()


def test_a_robot_is_unknown_once_forgotten(disc):
    forget_robot(disc.name)
    with pytest.raises(ValueError, match="toy_disc"):
        Workspace("toy_disc", [[0, 0], [1, 1]], np.zeros((0, 2)), np.zeros((0, 2)))
    register_robot(disc)


def test_a_robot_without_structured_families_draws_only_its_own(disc):
    rng = np.random.default_rng(0)
    assert generate_workspace(disc.name, rng, "boxes") == disc.generate_workspace(
        np.random.default_rng(0)
    )
    for family in ("maze", "mixed"):
        with pytest.raises(ValueError, match="toy_disc has not; it has only its own generator"):
            generate_workspace(disc.name, rng, family)
    with pytest.raises(ValueError, match="toy_disc has only its own generator, not 'maze'"):
        disc.generate_structured_workspace(rng, "maze")


def test_the_env_refuses_a_structured_family_for_a_robot_without_one(disc):
    with pytest.raises(ValueError, match="workspace_family: 'maze' needs structured families"):
        gymnasium.make(disc.env_id, workspace_family="maze")


def test_a_name_another_robot_has_is_refused_naming_that_robot(disc):
    import dataclasses

    twin = dataclasses.replace(disc, env_id="TEMP-Twin-v0", short_name="twin", seed_code=77)
    with pytest.raises(ValueError, match=r"^robot: name 'toy_disc' is taken by the registered "
                       r"robot 'toy_disc'; give this one another name$"):  # fmt: skip
        register_robot(twin)


@pytest.mark.parametrize("path", [None, 3, ""])
def test_a_robot_file_that_is_no_path_is_refused_in_one_line(path):
    from temp_gym import register_robot_file

    with pytest.raises(ValueError, match=r"^path: expected a robot description file \(YAML\)"):
        register_robot_file(path)
