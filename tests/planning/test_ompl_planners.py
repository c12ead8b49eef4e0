import numpy as np
import pytest

from temp_gym.planning import plan
from temp_gym.worlds.collision import certify_path

pytest.importorskip("ompl")


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
