import numpy as np
import pytest

from temp_gym.problem import Problem
from temp_gym.worlds.rendering import (
    MAX_3D_EDGES,
    ArmRenderer,
    arm_poses,
    plan_title,
    render_point_world,
)

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
PANDA = {
    "robot": "franka_panda",
    "obstacles": [{"center": [0.6, 0, 0.3], "half_extents": [0.1, 0.3, 0.3]}],
    "start": [0, -0.785, 0, -2.356, 0, 1.571, 0.785],  # the Panda's "ready" pose
    "goal": [1, 0.3, 0, -1.5, 0, 1.8, 0.5],
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


def orange_pixels(image: np.ndarray) -> int:
    r, g, b = (image[..., k].astype(int) for k in range(3))
    return int(np.sum((r > 200) & (g > 110) & (g < 170) & (b < 90)))


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
    return Problem.from_dict(IIWA), Problem.from_dict(IIWA_OTHER)


@pytest.fixture(scope="module")
def renderer():
    renderer = ArmRenderer()
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
    renderer = ArmRenderer(ghosts=2)
    image = renderer.render(iiwa_problems[0], width=120, height=100)
    renderer.close()
    renderer.close()
    np.testing.assert_array_equal(image, renderer.render(iiwa_problems[0], width=120, height=100))
    renderer.close()
    with ArmRenderer() as unused:
        unused.close()


def test_renderers_reject_the_wrong_robot(iiwa_problems):
    with pytest.raises(ValueError, match="ArmRenderer"):
        render_point_world(iiwa_problems[0])
    with pytest.raises(ValueError, match="render_point_world"):
        ArmRenderer().render(Problem.from_dict(POINT2D))
    with pytest.raises(ValueError, match="path"):
        ArmRenderer().render(iiwa_problems[0], path=np.zeros((3, 6)))


def test_any_arm_is_drawn_by_its_own_renderer(iiwa_problems):
    from temp_gym.worlds.arm_world import arm_of

    panda = Problem.from_dict(PANDA)
    with ArmRenderer(arm_of("franka_panda")) as renderer:
        image = renderer.render(panda, width=320, height=240)
        check_image(image, 240, 320)
        r, g, b = (image[..., k].astype(int) for k in range(3))
        assert np.sum((g > r + 40) & (g > b + 20)) > 100  # the green start arm
        assert np.sum((b > r + 60) & (b > g + 40)) > 100  # the blue goal arm
        with pytest.raises(ValueError, match="draws franka_panda, got 'kuka_iiwa14'"):
            renderer.render(iiwa_problems[0])


# ---------------------------------------------------------------------- solution vs path so far
def test_titles_tell_a_solution_from_none_yet():
    problem = Problem.from_dict(POINT2D)
    assert plan_title(problem, 1, None) == "point2d: 1 node, no solution yet"
    shown = plan_title(problem, 21, None, "orange dashed")
    assert shown == "point2d: 21 nodes, no solution yet (orange dashed: path to the newest node)"
    path = np.array([problem.start, [2, 18], problem.goal])
    assert plan_title(problem, 812, path) == "point2d: 812 nodes, solution cost 32.00"


def test_path_so_far_is_drawn_unlike_a_solution():
    problem = Problem.from_dict(POINT2D)
    path = np.array([problem.start, [8, 18], [12, 18]])
    so_far = render_point_world(problem, path_so_far=path)
    solution = render_point_world(problem, path=path)
    assert red_pixels(so_far) == 0 and orange_pixels(so_far) > 100
    assert red_pixels(solution) > 200 and orange_pixels(solution) == 0
    with pytest.raises(ValueError, match="not both"):
        render_point_world(problem, path=path, path_so_far=path)
    with pytest.raises(ValueError, match="path_so_far"):
        render_point_world(problem, path_so_far=np.zeros((2, 3)))


@pytest.mark.parametrize("env_id", ["TEMP-2D-v0", "TEMP-3D-v0"])
def test_env_draws_no_solution_before_one_exists(env_id):
    import gymnasium as gym

    env = gym.make(env_id, render_mode="rgb_array", fallback="none")
    empty = Problem.from_dict({**(POINT2D if "2D" in env_id else POINT3D), "obstacles": []})
    observation, _ = env.reset(seed=0, options={"problem": empty})
    assert red_pixels(env.render()) == 0  # at reset: the start alone, nothing bold red
    goal = observation["goal"]
    away = -goal
    away[0] = goal[0]  # a corner of the box that is neither start nor goal
    for _ in range(3):  # a few steps there: a path so far, no solution
        env.step(away)
    assert not env.unwrapped.tree.best_node >= 0
    assert red_pixels(env.render()) == 0 and orange_pixels(env.render()) > 0
    for _ in range(200):
        _, _, terminated, _, _ = env.step(goal)
        if terminated:
            break
    assert terminated and red_pixels(env.render()) > 50
    env.close()


def test_3d_draws_few_edges_and_keeps_the_path_on_top_of_boxes():
    problem = Problem.from_dict(POINT3D)
    path = np.array([problem.start, [2, 18, 10], problem.goal])
    clear = render_point_world(Problem.from_dict({**POINT3D, "obstacles": []}), path=path)
    # Boxes all around the path's middle leg, between it and the camera.
    boxed = Problem.from_dict(
        {**POINT3D, "obstacles": [{"center": [4, 12, 10], "half_extents": [2.5, 6, 9]}]}
    )
    hidden = render_point_world(boxed, path=path)
    assert red_pixels(hidden) >= 0.9 * red_pixels(clear)
    positions, parents = random_tree(problem, 3 * MAX_3D_EDGES)
    from temp_gym.worlds.rendering.points import _tree_segments

    assert len(_tree_segments(positions, parents, MAX_3D_EDGES)) == MAX_3D_EDGES
    check_image(render_point_world(problem, positions, parents, path=path), 480, 480)


def test_arm_poses_draw_each_configuration_once(iiwa_problems):
    problem = iiwa_problems[0]
    reset = arm_poses(problem, path_so_far=problem.start[None])  # the env's reset frame
    assert [list(config) for config, _ in reset] == [list(problem.start), list(problem.goal)]
    so_far = np.linspace(problem.start, problem.start + 0.5, 4)
    poses = arm_poses(problem, path_so_far=so_far, ghosts=2)
    assert len(poses) == 3 + 2  # start, goal, newest node, two ghosts
    np.testing.assert_array_equal(poses[2][0], so_far[-1])
    looped = arm_poses(problem, path=np.stack([problem.start, problem.goal, problem.start]))
    configs = [config.tobytes() for config, _ in looped]
    assert len(configs) == len(set(configs))


def test_camera_is_chosen_to_show_the_arm(iiwa_problems):
    # A tall block between the arm and the old fixed camera (yaw 50, pitch -28) hides the arm.
    walled = Problem.from_dict(
        {**IIWA, "obstacles": [{"center": [1.1, -0.9, 1.0], "half_extents": [0.45, 0.45, 1.0]}]}
    )
    with ArmRenderer() as renderer:
        assert renderer.visible_arm_pixels(walled, (50.0, -28.0)) < 10
        renderer.render(walled, width=64, height=64)
        assert renderer.visible_arm_pixels(walled, renderer.view) > 200
        first_view = renderer.view
        renderer.render(walled, path_so_far=np.stack([walled.start, walled.goal]))
        assert renderer.view == first_view  # one view per problem: frames do not jump
    with ArmRenderer(yaw=50.0, pitch=-28.0) as fixed:
        fixed.render(walled, width=64, height=64)
        assert fixed.view == (50.0, -28.0)


def test_iiwa_title_band(iiwa_problems, renderer):
    plain = renderer.render(iiwa_problems[0], width=200, height=160)
    titled = renderer.render(iiwa_problems[0], width=200, height=160, title="kuka: 1 node")
    assert titled.shape == plain.shape
    assert not np.array_equal(titled[:20], plain[:20])
    np.testing.assert_array_equal(titled[60:], plain[60:])


def test_a_copied_or_pickled_7d_env_renders_and_leaves_the_original_rendering(iiwa_problems):
    import copy
    import pickle

    import gymnasium as gym

    env = gym.make("TEMP-7D-v0", render_mode="rgb_array").unwrapped
    env.reset(seed=0, options={"problem": iiwa_problems[0]})
    image = env.render()
    twin = copy.deepcopy(env)
    twin.close()  # closes only its own connection (it had none yet)
    np.testing.assert_array_equal(env.render(), image)
    for other in (copy.deepcopy(env), pickle.loads(pickle.dumps(env))):
        np.testing.assert_array_equal(other.render(), image)  # its own renderer
        other.close()
    np.testing.assert_array_equal(env.render(), image)
    env.close()


# ---------------------------------------------------------------------- legends and the camera
def test_point_legend_names_what_is_drawn():
    from temp_gym.worlds.rendering.points import legend_entries

    problem = Problem.from_dict(POINT2D)
    path = np.array([problem.start, problem.goal])
    labels = [label for label, _, _ in legend_entries(problem, True, path, True)]
    assert labels == ["start", "goal region", "tree", "solution", "obstacles"]
    labels = [label for label, _, _ in legend_entries(problem, False, path, False)]
    assert labels == ["start", "goal region", "path so far", "obstacles"]
    bare = Problem.from_dict({**POINT2D, "obstacles": []})
    assert [label for label, _, _ in legend_entries(bare, False, None, False)] == [
        "start",
        "goal region",
    ]


def test_point_pictures_have_a_legend_across_the_bottom():
    problem = Problem.from_dict(POINT2D)
    positions, parents = random_tree(problem, 50)
    path = np.array([problem.start, [8, 18], problem.goal])
    shown = render_point_world(problem, positions, parents, path=path)
    bare = render_point_world(problem, positions, parents, path=path, legend=False)
    legend_rows = shown[-24:]
    assert distinct_colours(legend_rows) > distinct_colours(bare[-24:]) + 5
    assert red_pixels(legend_rows) > 10  # the solution's swatch


def test_iiwa_legend_says_which_arm_is_which(iiwa_problems):
    from temp_gym.worlds.rendering.arm import arm_legend

    def labels(*args):
        return [label for label, _, _ in arm_legend(*args)]

    path = np.linspace(iiwa_problems[0].start, iiwa_problems[0].goal, 4)
    assert labels(path, None, True) == ["start", "path's end (goal)", "along the path", "obstacles"]
    assert labels(None, path, True) == [
        "start",
        "goal",
        "newest node",
        "along the path",
        "obstacles",
    ]
    assert labels(None, None, False) == ["start", "goal", "obstacles"]
    with ArmRenderer(legend=False) as bare:
        plain = bare.render(iiwa_problems[0], path=path, width=320, height=240)
    with ArmRenderer() as renderer:
        legend = renderer.render(iiwa_problems[0], path=path, width=320, height=240)
    assert not np.array_equal(legend[-20:], plain[-20:])
    np.testing.assert_array_equal(legend[:-50], plain[:-50])  # the band alone differs


def test_iiwa_draws_start_end_and_two_ghosts_along_a_path(iiwa_problems):
    problem = iiwa_problems[0]
    path = np.linspace(problem.start, problem.goal, 12)
    poses = arm_poses(problem, path=path)
    assert len(poses) == 4  # start, end, two pale arms between
    np.testing.assert_array_equal(poses[0][0], path[0])
    np.testing.assert_array_equal(poses[1][0], path[-1])


def test_camera_sees_the_goal_hand_before_the_most_of_the_arm(iiwa_problems, monkeypatch):
    from temp_gym.worlds.rendering.arm import CANDIDATE_PITCHES, CANDIDATE_YAWS
    from temp_gym.worlds.rendering.camera import orbit_position, visible_points
    from temp_gym.worlds.rendering.solids import Solids

    # A tall shelf back right behind the goal hand, between it and the +y half of the ring.
    shelved = Problem.from_dict(
        {
            **IIWA,
            "obstacles": [
                {"center": [0.2, 0.85, 0.7], "half_extents": [0.7, 0.05, 0.7]},
                {"center": [0.2, 0.55, 1.35], "half_extents": [0.7, 0.3, 0.05]},
            ],
        }
    )
    solids = Solids.of_workspace(shelved.workspace)
    views = [(float(yaw), pitch) for pitch in CANDIDATE_PITCHES for yaw in CANDIDATE_YAWS]
    with ArmRenderer() as renderer:
        renderer.render(shelved, width=64, height=64)
        hand, target = renderer._goal_hand, renderer.view_target
        sees = {
            view: visible_points(
                orbit_position(target, *view, renderer.distance), hand, solids
            ).all()
            for view in views
        }
        assert not all(sees.values())  # some views look at the hand through the shelf
        assert sees[renderer.view]  # the chosen one sees it
        assert renderer.visible_arm_pixels(shelved, renderer.view) > 100
        # Even where a hidden hand's view would show more of the arm, the hand comes first.
        hidden = [view for view in views if not sees[view]]
        monkeypatch.setattr(
            renderer, "_count_arm_pixels", lambda client, view, arms: 1000 * (view in hidden)
        )
        renderer.view = None
        renderer.render(shelved, width=32, height=32)
        assert sees[renderer.view]


def test_human_mode_draws_at_reset_and_after_every_step(monkeypatch):
    import gymnasium as gym

    from temp_gym.envs.planning_env import PlanningEnv

    shown = []
    monkeypatch.setattr(PlanningEnv, "_show", lambda self, image: shown.append(image.shape))
    env = gym.make("TEMP-2D-v0", render_mode="human")
    env.reset(seed=0)
    assert len(shown) == 1  # Gymnasium's convention: reset draws too
    env.step(env.action_space.sample())
    assert len(shown) == 2 and len(shown[0]) == 3
    env.close()
