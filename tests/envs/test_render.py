import numpy as np
import pytest

from temp_gym.envs.render import IiwaRenderer, render_point_world
from temp_gym.problem import Problem

POINT2D = {
    "robot": "point2d",
    "bounds": [[0, 0], [20, 20]],
    "obstacles": [
        {"center": [10, 10], "half_extents": [1, 6]},
        {"center": [4, 15], "half_extents": [2, 1]},
    ],
    "start": [2, 2],
    "goal": [18, 18],
    "goal_radius": 0.8,
}
POINT3D = {
    "robot": "point3d",
    "bounds": [[0, 0, 0], [20, 20, 20]],
    "obstacles": [{"center": [10, 10, 10], "half_extents": [2, 6, 4]}],
    "start": [2, 2, 2],
    "goal": [18, 18, 18],
    "goal_radius": 0.8,
}
IIWA = {
    "robot": "kuka_iiwa14",
    "obstacles": [{"center": [0.6, 0, 0.3], "half_extents": [0.1, 0.3, 0.3]}],
    "start": [0, 0, 0, 0, 0, 0, 0],
    "goal": [1, 0.5, 0, -1, 0, 0.5, 0],
    "goal_radius": 0.1,
}
IIWA_OTHER = {
    **IIWA,
    "obstacles": [
        {"center": [-0.5, -0.5, 0.2], "half_extents": [0.2, 0.2, 0.2]},
        {"center": [0.0, 0.8, 0.6], "half_extents": [0.6, 0.05, 0.6]},
    ],
}


def random_tree(problem: Problem, count: int, seed: int = 0):
    """Positions and parents of a random tree (each node's parent is an earlier node)."""
    rng = np.random.default_rng(seed)
    positions = rng.uniform(*problem.bounds, size=(count, problem.dim))
    positions[0] = problem.start
    parents = np.array([-1] + [int(rng.integers(i)) for i in range(1, count)])
    return positions, parents


def distinct_colours(image: np.ndarray) -> int:
    return len(np.unique(image.reshape(-1, 3), axis=0))


def red_pixels(image: np.ndarray) -> int:
    r, g, b = (image[..., k].astype(int) for k in range(3))
    return int(np.sum((r > 180) & (g < 80) & (b < 80)))


def check_image(image: np.ndarray, height: int, width: int) -> None:
    assert isinstance(image, np.ndarray)
    assert image.shape == (height, width, 3)
    assert image.dtype == np.uint8
    assert image.flags.writeable and image.flags.c_contiguous
    assert distinct_colours(image) >= 5


# ---------------------------------------------------------------------- point worlds
def test_2d_with_tree_and_path():
    problem = Problem.from_dict(POINT2D)
    positions, parents = random_tree(problem, 300)
    path = np.array([problem.start, [8, 18], problem.goal])
    image = render_point_world(problem, positions, parents, path=path, num_nodes=200)
    check_image(image, 480, 480)
    assert red_pixels(image) > 200
    without_path = render_point_world(problem, positions, parents, num_nodes=200)
    assert red_pixels(without_path) < red_pixels(image) // 10


def test_2d_bare_problem_and_odd_size():
    problem = Problem.from_dict(POINT2D)
    image = render_point_world(problem, width=333, height=217)
    check_image(image, 217, 333)


def test_2d_accepts_tree_arrays_longer_than_num_nodes():
    problem = Problem.from_dict(POINT2D)
    positions, parents = random_tree(problem, 50)
    image = render_point_world(problem, positions, parents[:20], num_nodes=10)
    check_image(image, 480, 480)


def test_3d_with_tree_and_path():
    problem = Problem.from_dict(POINT3D)
    positions, parents = random_tree(problem, 200)
    path = np.array([problem.start, [2, 18, 10], problem.goal])
    image = render_point_world(problem, positions, parents, path=path, width=320, height=240)
    check_image(image, 240, 320)
    assert red_pixels(image) > 50


def test_point_renderer_rejects_bad_arguments():
    problem = Problem.from_dict(POINT2D)
    with pytest.raises(ValueError, match="positions"):
        render_point_world(problem, positions=np.zeros((5, 3)), parents=np.zeros(5, int))
    with pytest.raises(ValueError, match="path"):
        render_point_world(problem, path=np.zeros((4, 3)))
    with pytest.raises(ValueError, match="num_nodes"):
        render_point_world(problem, positions=np.zeros((5, 2)), num_nodes=6)


# ---------------------------------------------------------------------- iiwa
@pytest.fixture(scope="module")
def iiwa_problems():
    pytest.importorskip("temp_gym.worlds.collision.iiwa_fast")
    return Problem.from_dict(IIWA), Problem.from_dict(IIWA_OTHER)


@pytest.fixture(scope="module")
def renderer():
    renderer = IiwaRenderer()
    yield renderer
    renderer.close()


def test_iiwa_start_and_goal(iiwa_problems, renderer):
    image = renderer.render(iiwa_problems[0], width=320, height=240)
    check_image(image, 240, 320)
    r, g, b = (image[..., k].astype(int) for k in range(3))
    assert np.sum((g > r + 40) & (g > b + 20)) > 100  # the green start arm
    assert np.sum((b > r + 60) & (b > g + 40)) > 100  # the blue goal arm


def test_iiwa_path_is_repeatable(iiwa_problems, renderer):
    problem = iiwa_problems[0]
    path = np.linspace(problem.start, problem.goal, 4)
    first = renderer.render(problem, path=path)
    check_image(first, 480, 480)
    assert not np.array_equal(first, renderer.render(problem))
    np.testing.assert_array_equal(first, renderer.render(problem, path=path))


def test_iiwa_two_problems(iiwa_problems, renderer):
    one = renderer.render(iiwa_problems[0], width=200, height=200)
    two = renderer.render(iiwa_problems[1], width=200, height=200)
    assert not np.array_equal(one, two)
    np.testing.assert_array_equal(one, renderer.render(iiwa_problems[0], width=200, height=200))


def test_iiwa_close_twice_and_reconnect(iiwa_problems):
    renderer = IiwaRenderer(ghosts=2)
    image = renderer.render(iiwa_problems[0], width=120, height=100)
    renderer.close()
    renderer.close()
    np.testing.assert_array_equal(image, renderer.render(iiwa_problems[0], width=120, height=100))
    renderer.close()
    with IiwaRenderer() as unused:
        unused.close()


def test_renderers_reject_the_wrong_robot(iiwa_problems):
    with pytest.raises(ValueError, match="IiwaRenderer"):
        render_point_world(iiwa_problems[0])
    with pytest.raises(ValueError, match="render_point_world"):
        IiwaRenderer().render(Problem.from_dict(POINT2D))
    with pytest.raises(ValueError, match="path"):
        IiwaRenderer().render(iiwa_problems[0], path=np.zeros((3, 6)))
