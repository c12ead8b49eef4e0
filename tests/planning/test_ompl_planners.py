import numpy as np
import pytest

from temp_gym.planning import plan
from temp_gym.problem import Problem
from temp_gym.worlds.checkers import certify_path

pytest.importorskip("ompl")

from temp_gym.planning.ompl_planners import RANGE_FACTOR  # noqa: E402


@pytest.mark.parametrize("planner", ["ompl_rrt_star", "ompl_informed_rrt_star"])
def test_ompl_planners_solve_a_2d_problem(problem_2d, planner):
    result = plan(problem_2d, planner=planner, seed=0, max_nodes=1000)
    assert result.success and result.planner == planner
    assert result.nodes == 1000
    np.testing.assert_array_equal(result.path[0], problem_2d.start)
    assert np.linalg.norm(result.path[-1] - problem_2d.goal) <= problem_2d.goal_radius + 1e-9
    assert certify_path(problem_2d, result.path)
    assert result.history["best_cost"][-1] == pytest.approx(result.cost)
    assert result.time_to_first_solution is not None


def test_ompl_stop_at_first(problem_2d):
    result = plan(problem_2d, planner="ompl_rrt_star", seed=0, stop_at_first=True, max_nodes=5000)
    assert result.success and result.nodes < 5000


@pytest.mark.parametrize("planner", ["ompl_rrt_star", "ompl_informed_rrt_star"])
def test_ompl_cost_approaches_the_optimum_in_an_empty_world(planner):
    # OMPL caps every RRTstar edge (choose-parent and rewiring included) at its range; with
    # range = one step, 2D costs stayed up to 7% above the optimum at 2000 nodes (3D: 30%).
    problem = Problem.from_dict(
        {
            "robot": "point2d",
            "bounds": [[0, 0], [20, 20]],
            "obstacles": [],
            "start": [2, 2],
            "goal": [18, 18],
            "goal_radius": 0.5,
        }
    )
    optimum = float(np.linalg.norm(problem.goal - problem.start)) - problem.goal_radius
    for seed in range(3):
        result = plan(problem, planner=planner, seed=seed, max_nodes=2000)
        assert result.success and result.nodes == 2000
        assert result.cost <= 1.05 * optimum


def test_ompl_range_is_the_near_radius_cap_of_our_planners(problem_2d):
    # OMPL's range bounds every edge it makes: it is set to our near-radius cap, 2 steps.
    result = plan(problem_2d, planner="ompl_rrt_star", seed=0, max_nodes=1000, step_size=0.5)
    edges = np.linalg.norm(np.diff(result.path, axis=0), axis=1)
    assert edges.max() <= RANGE_FACTOR * 0.5 + 1e-9
    assert edges.max() > 0.5 + 1e-6


def test_ompl_range_is_a_setting_of_the_ompl_planners(problem_2d):
    from temp_gym.planning import OMPLRRTStarSettings

    settings = OMPLRRTStarSettings(seed=0, max_nodes=1000, step_size=0.5, range=0.4)
    result = plan(problem_2d, settings=settings)  # the planner its settings class names
    assert result.planner == "ompl_rrt_star"
    edges = np.linalg.norm(np.diff(result.path, axis=0), axis=1)
    assert edges.max() <= 0.4 + 1e-9


@pytest.mark.parametrize("planner", ["ompl_rrt_star", "ompl_informed_rrt_star"])
def test_ompl_target_cost_is_in_the_history(problem_2d, planner):
    # OMPL returns as soon as a solution meets the cost threshold; the tolerance protocol reads
    # the time and nodes of that solution from the anytime history, so it must be logged.
    first = plan(problem_2d, planner=planner, seed=0, stop_at_first=True, max_nodes=5000)
    target = first.cost * 0.97
    result = plan(problem_2d, planner=planner, seed=0, target_cost=target, max_nodes=20000)
    assert result.success and result.cost <= target + 1e-9
    assert result.history["best_cost"][-1] <= target + 1e-9
    assert result.history["nodes"][-1] <= result.nodes


def first_ompl_run(seed: int) -> dict:
    """The first OMPL run of a fresh process (the one OMPL's process-wide seed applies to)."""
    import json
    import subprocess
    import sys

    script = (
        "import json, sys; from temp_gym import Problem, plan; "
        "sys.path.insert(0, sys.argv[2]); from conftest import make_problem_2d; "
        "r = plan(make_problem_2d(), 'ompl_rrt_star', seed=int(sys.argv[1]), max_nodes=300); "
        "print(json.dumps([r.cost, r.path.tolist()]))"
    )
    from pathlib import Path

    done = subprocess.run(
        [sys.executable, "-c", script, str(seed), str(Path(__file__).parent)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_ompl_seeds_0_and_1_are_different_runs_and_a_seed_repeats():
    # OMPL maps its seed 0 to 1; ours are passed as seed + 1, so 0 and 1 stay distinct.
    zero, one, zero_again = first_ompl_run(0), first_ompl_run(1), first_ompl_run(0)
    assert zero != one
    assert zero == zero_again


def test_ompl_seed_mapping_is_one_to_one_and_bounded():
    from temp_gym.planning.ompl_planners import MAX_SEED, ompl_seed

    assert [ompl_seed(seed) for seed in (0, 1, 2)] == [1, 2, 3]
    assert ompl_seed(MAX_SEED) == 2**64 - 1
    with pytest.raises(ValueError, match="seed"):
        ompl_seed(MAX_SEED + 1)


@pytest.mark.parametrize("planner", ["ompl_rrt_star", "ompl_informed_rrt_star"])
def test_a_start_in_the_goal_region_is_a_solution_of_cost_zero_as_for_our_planners(planner):
    problem = Problem.from_dict({
        "robot": "point2d", "bounds": [[0, 0], [20, 20]], "start": [2, 2], "goal": [2, 2],
        "goal_radius": 0.5, "obstacles": [],
    })  # fmt: skip
    ours = plan(problem, planner="rrt_star", seed=0, max_nodes=50)
    result = plan(problem, planner=planner, seed=0, max_nodes=50)
    assert result.success and result.cost == 0.0 == ours.cost
    np.testing.assert_array_equal(result.path, ours.path)
    assert result.nodes_to_first_solution == 1 == ours.nodes_to_first_solution
    assert result.history["best_cost"].tolist() == [0.0]


@pytest.mark.parametrize("planner", ["ompl_rrt_star", "ompl_informed_rrt_star"])
def test_bounds_too_small_for_ompl_are_a_clear_error(planner):
    problem = Problem.from_dict({
        "robot": "point2d", "bounds": [[0, 0], [1e-29, 1e-29]], "start": [0, 0],
        "goal": [1e-29, 1e-29], "goal_radius": 1e-30, "obstacles": [],
    })  # fmt: skip
    plan(problem, planner="rrt_star", seed=0, max_nodes=50)  # ours take them
    with pytest.raises(ValueError, match="bounds: OMPL's planners need bounds"):
        plan(problem, planner=planner, seed=0, max_nodes=50)


@pytest.mark.parametrize("planner", ["ompl_rrt_connect", "ompl_bit_star"])
@pytest.mark.parametrize("fixture", ["problem_2d", "problem_3d"])
def test_ompl_rrt_connect_and_bit_star_solve_within_the_budget(request, fixture, planner):
    problem = request.getfixturevalue(fixture)
    result = plan(problem, planner=planner, seed=0, max_nodes=1500)
    assert result.success and result.planner == planner
    np.testing.assert_array_equal(result.path[0], problem.start)
    assert np.linalg.norm(result.path[-1] - problem.goal) <= problem.goal_radius + 1e-9
    assert certify_path(problem, result.path)
    assert result.history["best_cost"][-1] == pytest.approx(result.cost)
    assert result.nodes_to_first_solution <= result.nodes <= 1500


def test_ompl_rrt_connect_stops_at_its_first_solution_with_edges_within_its_range(problem_2d):
    from temp_gym.planning import OMPLRRTConnectSettings

    result = plan(problem_2d, settings=OMPLRRTConnectSettings(seed=0, max_nodes=5000, range=0.5))
    assert result.success and result.planner == "ompl_rrt_connect"
    assert result.history["nodes"].tolist() == [result.nodes] and result.nodes < 5000
    assert np.linalg.norm(np.diff(result.path, axis=0), axis=1).max() <= 0.5 + 1e-9


@pytest.mark.parametrize("max_nodes", [10, 25])
def test_ompl_rrt_connect_never_overshoots_the_node_budget(problem_2d, max_nodes):
    # A CONNECT adds nodes without looking at the termination condition: the validator stops it.
    result = plan(problem_2d, planner="ompl_rrt_connect", seed=0, max_nodes=max_nodes)
    assert not result.success and result.nodes == max_nodes


def test_ompl_bit_star_stop_at_first_and_its_own_settings(problem_2d):
    first = plan(problem_2d, planner="ompl_bit_star", seed=0, stop_at_first=True, max_nodes=5000)
    assert first.success and first.nodes < 5000 and len(first.history["nodes"]) == 1
    result = plan(problem_2d, planner="ompl_bit_star", seed=0, max_nodes=400, k_nearest=True,
                  samples_per_batch=50)  # fmt: skip
    assert result.success and result.nodes <= 400
    for batch, words in ((0, r"an integer in \[1, 2\*\*53\], got 0"), (2**31, r"at most 2\*\*31")):
        with pytest.raises(ValueError, match=rf"^samples_per_batch: expected {words}"):
            plan(problem_2d, planner="ompl_bit_star", samples_per_batch=batch)
    with pytest.raises(ValueError, match=r"^range: only the .* planners take it, not ompl_bit"):
        plan(problem_2d, planner="ompl_bit_star", range=1.0)


@pytest.mark.parametrize("planner", ["ompl_rrt_connect", "ompl_bit_star"])
def test_ompl_rrt_connect_and_bit_star_find_no_path_to_an_enclosed_goal(enclosed_goal_2d, planner):
    result = plan(enclosed_goal_2d, planner=planner, seed=0, max_nodes=400)
    assert not result.success and result.path is None and result.nodes <= 400


NEAR_SPHERE = {
    "robot": "kuka_iiwa14",
    "obstacles": [
        {"center": [0.0, 0.0, -0.06], "half_extents": [1.5, 1.5, 0.05]},
        {"center": [0.62, 0.0, 0.3], "half_extents": [0.12, 0.12, 0.3]},
        {"center": [-0.1, 0.75, 0.2], "half_extents": [0.3, 0.15, 0.2]},
        {"type": "sphere", "radius": 0.1,
         "center": [0.41915965854760545, 0.47283631096260204, 0.4696771644313962]},
    ],
    "start": [-1.0, 0.8, 0.0, -0.9, 0.0, 0.6, 0.0],
    "goal": [1.0, 0.8, 0.0, -0.9, 0.0, 0.6, 0.0],
    "goal_radius": 0.1,
}  # fmt: skip
"""A goal the exact checker calls free, a sphere nearer it than the fast checker can clear."""


@pytest.mark.parametrize("planner", ["ompl_rrt_connect", "ompl_bit_star"])
def test_a_goal_the_fast_checker_refuses_ends_a_goal_sampling_planner_at_once(planner):
    """OMPL waits for a valid goal state, polling the stop condition every few milliseconds:
    without the check, a run took 5 ms x 100 x max_nodes and reported those polls."""
    from temp_gym.worlds.checkers import make_checker

    problem = Problem.from_dict(NEAR_SPHERE)
    assert not make_checker(problem.workspace).states_free(problem.goal[None])[0]
    result = plan(problem, planner=planner, seed=0, max_nodes=5)
    assert not result.success and result.samples == 0 and result.collision_checks == 2
