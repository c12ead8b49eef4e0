import numpy as np
import pytest

from temp_gym import Problem, plan
from temp_gym.policies import UniformPolicy
from temp_gym.worlds.checkers import certify_path


class TowardsGoal:
    """Proposes the goal itself: a perfect policy in an open world."""

    def reset(self, problem, seed=None):
        self.goal = problem.goal
        self.bounds = problem.bounds

    def __call__(self, observation):
        return observation["goal"]


class Stuck:
    """A policy that cannot help: always the same corner, away from the goal."""

    def reset(self, problem, seed=None):
        pass

    def __call__(self, observation):
        return np.array([-1.0, -1.0], np.float32)


class ObservationOnly:
    """A learned policy seen through ``__call__`` alone: the planner's generic policy path."""

    def __init__(self, policy):
        self.policy = policy

    def reset(self, problem, seed=None):
        self.policy.reset(problem, seed=seed)

    def __call__(self, observation):
        return self.policy(observation)


def test_policy_fast_path_plans_exactly_like_full_observations():
    # The planner hands a TEMPPolicy only the path so far (`propose`); any other policy gets
    # whole observations. Same policy, same seeds: the same trees, node for node. An
    # observation asks for one sample, so the fast path is compared at one proposal per call
    # (the shipped 2D model predicts a chunk of 4; chunks are tested in test_attention.py).
    from temp_gym.models.registry import load_policy
    from temp_gym.worlds.generators import generate_problem

    # The wrapper hides the settings the shipped policy declares: both runs get them from plan().
    shipped = load_policy("point2d")
    declared = {"attention_patience": shipped.attention_patience,
                "attention_rounds": shipped.attention_rounds,
                "attention_local_fallback": shipped.attention_local_fallback}  # fmt: skip
    rng = np.random.default_rng(7)
    for index in range(4):
        problem = generate_problem("point2d", rng)
        runs = [
            plan(
                problem,
                planner="temp",
                policy=policy,
                seed=index,
                max_nodes=1500,
                stop_at_first=True,
                **declared,
            )  # fmt: skip
            for policy in (
                load_policy("point2d").fresh(horizon=1),
                ObservationOnly(load_policy("point2d").fresh(horizon=1)),
            )
        ]
        assert runs[0].attention["policy_samples"] > 0
        # The TEMPPolicy runs compiled, the wrapped one from Python: the same phase.
        assert runs[0].attention["compiled"] and not runs[1].attention["compiled"]
        same_keys = {"time": runs[0].attention["time"], "compiled": True}
        assert runs[0].attention == {**runs[1].attention, **same_keys}
        np.testing.assert_array_equal(runs[0].path, runs[1].path)


def test_attention_phase_follows_the_policy_and_stops_in_the_goal_region(wall):
    problem = Problem.from_dict({**wall, "obstacles": []})
    result = plan(problem, planner="temp", policy=TowardsGoal(), stop_at_first=True)
    assert result.success and result.attention["solved"]
    # Straight at the goal with step 1.0: 16 - 0.5 = 15.5 -> 16 steps, 17 nodes.
    assert result.attention["nodes"] == 17 == result.nodes
    assert result.attention["sampling_failures"] == 0
    assert result.cost == pytest.approx(np.linalg.norm(result.path[-1] - problem.start))
    assert np.linalg.norm(result.path[-1] - problem.goal) <= problem.goal_radius


def test_random_fallback_on_collision_counts_failures(wall):
    problem = Problem.from_dict(wall)
    result = plan(problem, planner="temp", policy=TowardsGoal(), stop_at_first=True, seed=1)
    assert result.success and result.attention["solved"]
    assert result.attention["sampling_failures"] > 0  # the wall blocks the goal direction
    assert certify_path(problem, result.path)


def test_probabilistic_completeness_with_a_policy_that_cannot_help(wall):
    problem = Problem.from_dict(wall)
    result = plan(
        problem,
        planner="temp",
        policy=Stuck(),
        seed=0,
        max_nodes=3000,
        attention_nodes=200,
        stop_at_first=True,
        goal_bias=0.0,  # Algorithm 1 as written: only the random fallback can help
    )
    assert not result.attention["solved"] and result.attention["nodes"] == 200
    assert result.attention["policy_samples"] == 199
    assert result.success  # classical planning took over and found the way around
    assert certify_path(problem, result.path)
    assert result.path[0].tolist() == problem.start.tolist()


def test_goal_bias_samples_the_goal_instead_of_calling_the_policy(wall):
    # Open world, a policy stuck in a corner: with no goal bias AP never gets there; with the
    # baselines' goal bias, the goal samples walk the tree straight in.
    problem = Problem.from_dict({**wall, "obstacles": []})
    kwargs = dict(planner="temp", policy=Stuck(), seed=0, max_nodes=400, stop_at_first=True)
    assert not plan(problem, attention_nodes=300, goal_bias=0.0, **kwargs).attention["solved"]
    result = plan(problem, attention_nodes=300, goal_bias=0.3, **kwargs)
    assert result.attention["solved"]
    goal_samples = result.attention["samples"] - result.attention["policy_samples"]
    assert goal_samples >= 16  # 16 steps of 1.0 from the start to the goal region


def test_classical_phase_refines_after_attention_phase(wall):
    problem = Problem.from_dict(wall)
    result = plan(problem, planner="temp", policy=UniformPolicy(seed=0), seed=0, max_nodes=2500)
    assert result.attention["solved"]
    assert result.nodes == 2500
    assert result.cost < result.attention["cost"]
    assert np.all(np.diff(result.history["best_cost"]) < 0)


def test_same_seed_same_result_and_policy_validation(wall):
    problem = Problem.from_dict(wall)
    a = plan(problem, planner="temp", policy=UniformPolicy(seed=3), seed=3, max_nodes=800)
    b = plan(problem, planner="temp", policy=UniformPolicy(seed=3), seed=3, max_nodes=800)
    np.testing.assert_array_equal(a.path, b.path)
    assert a.attention["nodes"] == b.attention["nodes"]
    with pytest.raises(ValueError, match="only the temp planner"):
        plan(problem, planner="rrt_star", policy=UniformPolicy())
    with pytest.raises(ValueError, match="SamplingPolicy"):
        plan(problem, planner="temp", policy=object())
    with pytest.raises(ValueError, match="attention_nodes"):
        plan(problem, planner="temp", policy=UniformPolicy(), attention_nodes=0)


def test_without_a_policy_the_planner_asks_the_default_hook(wall, monkeypatch):
    from temp_gym import hooks
    from temp_gym.planning import temp_planner

    asked = []

    def loader(robot):
        asked.append(robot)
        return TowardsGoal()

    problem = Problem.from_dict(wall)
    monkeypatch.setattr(hooks, "default_policy_loader", loader)
    result = plan(problem, planner="temp", seed=0, max_nodes=300, stop_at_first=True)
    assert asked and set(asked) == {problem.robot}
    assert result.success
    monkeypatch.setattr(hooks, "default_policy_loader", None)
    with pytest.raises(ValueError, match="no default policy"):
        temp_planner.temp(problem, temp_planner.TEMPSettings(max_nodes=10))


def test_replacements_near_the_proposal_are_a_setting_of_plan_or_of_the_policy():
    from temp_gym.models.registry import load_policy
    from temp_gym.worlds.generators import generate_problem

    problem = generate_problem("kuka_iiwa14", np.random.default_rng(2), "challenging")
    policy = load_policy("kuka_iiwa14").fresh(attention_local_fallback=0)  # Algorithm 1
    uniform = plan(problem, policy=policy, seed=0, max_nodes=2000, stop_at_first=True)
    near = plan(problem, policy=policy, seed=0, max_nodes=2000, stop_at_first=True,
                attention_local_fallback=20)  # fmt: skip
    declared = plan(problem, policy=policy.fresh(attention_local_fallback=20), seed=0,
                    max_nodes=2000, stop_at_first=True)  # fmt: skip
    explicit_zero = plan(problem, policy=policy.fresh(attention_local_fallback=20), seed=0,
                         max_nodes=2000, stop_at_first=True,
                         attention_local_fallback=0)  # fmt: skip
    assert uniform.attention["sampling_failures"] > 0  # a proposal collided: the setting acts
    assert near.nodes == declared.nodes and np.array_equal(near.path, declared.path)
    assert explicit_zero.nodes == uniform.nodes and np.array_equal(explicit_zero.path, uniform.path)
    assert near.nodes != uniform.nodes or not np.array_equal(near.path, uniform.path)
    for result in (uniform, near):
        assert result.success and certify_path(problem, result.path)
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="attention_local_fallback"):
            plan(problem, policy=policy, attention_local_fallback=bad)
