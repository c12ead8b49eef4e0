import math

import numpy as np
import pytest

from temp_gym import Problem, plan
from temp_gym.planning._compiled_tree import graft_branch
from temp_gym.planning.goal_tree import GoalTree
from temp_gym.planning.result import AnytimeLog
from temp_gym.planning.settings import PlanSettings
from temp_gym.planning.temp_planner import attention_solved_both_ways
from temp_gym.planning.tree import Tree
from temp_gym.worlds.checkers import certify_path


class Stuck:
    """A policy that cannot help: always the same corner, away from the goal."""

    def reset(self, problem, seed=None):
        pass

    def __call__(self, observation):
        return np.array([-1.0, -1.0], np.float32)


class KnowsTheWayOut:
    """Into the trap (`trap`) it walks straight at the goal and stalls on the U's back wall;
    out of it (planning from the goal) it knows the way: out by the opening, round the U."""

    def reset(self, problem, seed=None):
        self.problem = problem

    def __call__(self, observation):
        low, high = self.problem.bounds
        to_world = lambda normalized: low + (np.asarray(normalized) + 1) / 2 * (high - low)  # noqa: E731
        x, y = to_world(observation["path"][int(observation["path_length"][0]) - 1])
        if self.problem.start[0] < 12.5:  # into the trap: straight at the goal
            target = self.problem.goal
        elif x > 12.5 and abs(y - 10) < 2.5 and x < 19:  # inside the U: to its opening
            target = [19.5, 10.0]
        elif x >= 19 and y < 16.5:  # past the opening: along the U's open side
            target = [19.5, 17.0]
        else:
            target = self.problem.goal
        return ((np.asarray(target) - low) / (high - low) * 2 - 1).astype(np.float32)


class PythonOnly:
    """A checker seen without its compiled path: the planners drive it from Python."""

    def __init__(self, checker):
        self.checker = checker

    def __getattr__(self, name):
        if name == "compiled_context":
            raise AttributeError(name)
        return getattr(self.checker, name)


@pytest.fixture
def trap() -> Problem:
    """The goal inside a U of walls that opens away from the start: a bug trap."""
    return Problem.from_dict(
        {
            "robot": "point2d",
            "bounds": [[0, 0], [20, 20]],
            "obstacles": [
                {"center": [15, 13], "half_extents": [3, 0.5]},
                {"center": [15, 7], "half_extents": [3, 0.5]},
                {"center": [12.5, 10], "half_extents": [0.5, 3.5]},
            ],
            "start": [2, 10],
            "goal": [15, 10],
            "goal_radius": 0.5,
        }
    )


def test_in_free_space_the_goal_links_to_the_start_at_once(empty_2d):
    tree = Tree(empty_2d)
    log = AnytimeLog()
    goal_tree = GoalTree(tree)
    solved = goal_tree.grow_until_joined(
        tree, PlanSettings(), np.random.default_rng(0), log, max_nodes=100
    )
    assert solved and goal_tree.joined
    np.testing.assert_array_equal(tree.best_path(), [empty_2d.start, empty_2d.goal])
    assert tree.best_cost == pytest.approx(math.dist(empty_2d.start, empty_2d.goal))
    # The start, and the goal grafted from the goal tree (its one node): two nodes in all.
    assert log.first_nodes == 2 and log.extra_nodes == 0


def test_graft_appends_a_chain_up_to_the_first_node_in_the_goal_region(empty_2d):
    tree = Tree(empty_2d)
    branch = np.array([[5.0, 5.0], [18.8, 18.8], [19.0, 19.0]])  # the second is in the goal
    arrays, counters, best_cost, params = tree.compiled_state()
    goal = np.asarray(empty_2d.goal, dtype=np.float64)
    added = graft_branch(arrays, counters, best_cost, params, goal, 0, branch)
    tree.load_compiled_state(counters, best_cost)
    assert added == 2 and tree.num_nodes == 3
    np.testing.assert_array_equal(tree.parents, [-1, 0, 1])
    np.testing.assert_array_equal(tree.best_path(), [empty_2d.start, *branch[:2]])
    expected = math.dist([1, 1], [5, 5]) + math.dist([5, 5], [18.8, 18.8])
    assert tree.best_cost == pytest.approx(expected)
    np.testing.assert_array_equal(tree.goal_nodes, [2])


def test_temp_gets_out_of_a_stalled_attention_phase_through_the_goal_tree(trap):
    with_tree, without = [], []
    for seed in range(5):
        result = plan(trap, policy=Stuck(), seed=seed, max_nodes=5000, stop_at_first=True,
                      attention_patience=30)  # fmt: skip
        assert result.success and certify_path(trap, result.path)
        np.testing.assert_array_equal(result.path[0], trap.start)
        assert np.linalg.norm(result.path[-1] - trap.goal) <= trap.goal_radius
        assert result.attention["stop"] == "stalled" and result.attention["goal_tree_joined"]
        # The first solution counts both trees' nodes: the planner's at the stall and since,
        # and every node of the goal tree (the grafted branch once), nothing else.
        assert result.nodes == result.nodes_to_first_solution
        grown = result.attention["nodes"] + result.attention["goal_tree_nodes"]
        assert grown <= result.nodes <= grown + 2 * 32 * (result.attention["resumes"] + 1)
        with_tree.append(result.nodes_to_first_solution)
        alone = plan(trap, policy=Stuck(), seed=seed, max_nodes=5000, stop_at_first=True,
                     attention_patience=30, goal_tree=False)  # fmt: skip
        assert "goal_tree_nodes" not in alone.attention
        without.append(alone.nodes_to_first_solution)
    # Into the trap, Informed RRT* from the start needs many more nodes (seeded, so exact).
    assert sum(with_tree) < sum(without) / 2


def test_every_node_of_both_trees_counts_once(trap, monkeypatch):
    from temp_gym.planning import goal_tree as module

    grafts = []

    def recording_graft(arrays, counters, *rest):
        before = int(counters[0])
        added = graft_branch(arrays, counters, *rest)
        grafts.append((before, added))
        return added

    monkeypatch.setattr(module, "graft_branch", recording_graft)
    for seed in range(3):
        tree, log = Tree(trap), AnytimeLog()
        goal_tree = GoalTree(tree)
        settings = PlanSettings(seed=seed, max_nodes=5000)
        assert goal_tree.grow_until_joined(tree, settings, np.random.default_rng(seed), log, 5000)
        (before, added) = grafts.pop()
        assert added > 1 and tree.num_nodes == before + added
        # The planner's tree before the graft, and the whole goal tree (the grafted branch
        # copies some of its nodes: they are not counted twice).
        assert log.first_nodes == before + goal_tree.tree.num_nodes
        assert log.first_nodes == tree.num_nodes + log.extra_nodes


def test_an_unjoined_goal_tree_counts_all_its_nodes(trap):
    tree, log = Tree(trap), AnytimeLog()
    goal_tree = GoalTree(tree)
    settings = PlanSettings(seed=0, max_nodes=5000)
    assert not goal_tree.grow_until_joined(tree, settings, np.random.default_rng(0), log, 20)
    assert tree.num_nodes + goal_tree.tree.num_nodes == 20
    # what a later record of the planner (a resumed attention phase's solution) adds
    assert log.extra_nodes == goal_tree.extra_nodes == goal_tree.tree.num_nodes > 1


def test_the_goal_tree_counts_against_the_node_budget(trap):
    for budget in (60, 200):
        result = plan(trap, policy=Stuck(), seed=1, max_nodes=budget, attention_patience=30)
        assert result.nodes <= budget
    result = plan(trap, policy=Stuck(), seed=1, max_nodes=800, attention_patience=30)
    assert result.success and result.nodes == 800
    nodes = result.history["nodes"]
    assert nodes[0] == result.nodes_to_first_solution and np.all(np.diff(nodes) >= 0)
    assert np.all(np.diff(result.history["best_cost"]) < 0)


def test_goal_tree_runs_are_reproducible(trap):
    runs = [
        plan(trap, policy=Stuck(), seed=3, max_nodes=1000, attention_patience=30) for _ in range(2)
    ]
    np.testing.assert_array_equal(runs[0].path, runs[1].path)
    assert runs[0].nodes_to_first_solution == runs[1].nodes_to_first_solution


def test_no_goal_tree_when_the_attention_phase_solves(empty_2d):
    class TowardsGoal:
        def reset(self, problem, seed=None):
            pass

        def __call__(self, observation):
            return observation["goal"]

    result = plan(empty_2d, policy=TowardsGoal(), stop_at_first=True)
    assert result.attention["solved"] and "goal_tree_nodes" not in result.attention


def test_a_checker_without_a_compiled_path_joins_the_same_trees(trap):
    joined = []
    for checker in (None, "python"):
        tree = Tree(trap)
        if checker == "python":
            tree = Tree(trap, checker=PythonOnly(tree.checker))
            tree._gamma = Tree(trap).gamma  # the same radii: the free volume as computed
        log = AnytimeLog()
        goal_tree = GoalTree(tree)
        settings = PlanSettings(seed=0, max_nodes=3000)
        assert goal_tree.grow_until_joined(tree, settings, np.random.default_rng(0), log, 3000)
        joined.append((tree.best_path(), log.first_nodes, tree.collision_checks))
    np.testing.assert_array_equal(joined[0][0], joined[1][0])
    assert joined[0][1] == joined[1][1]


def test_goal_tree_setting_is_checked(trap):
    with pytest.raises(ValueError, match="goal_tree"):
        plan(trap, goal_tree="yes")


def test_the_policy_grows_the_goal_tree_out_of_a_pocket_it_stalled_entering(trap):
    by_policy, by_samples = [], []
    for seed in range(5):
        result = plan(trap, policy=KnowsTheWayOut(), seed=seed, max_nodes=5000,
                      stop_at_first=True, attention_patience=40)  # fmt: skip
        attention = result.attention
        assert attention["stop"] == "stalled" and attention["from_goal_solved"]
        assert attention["from_goal_stop"] == "joined" and attention["goal_tree_joined"]
        assert attention["resumes"] == 0
        assert result.success and certify_path(trap, result.path)
        np.testing.assert_array_equal(result.path[0], trap.start)
        # The first solution counts the planner's nodes at the stall and every node of the
        # goal tree (its grafted branch once), nothing else.
        assert result.nodes_to_first_solution == attention["nodes"] + attention["from_goal_nodes"]
        assert attention["from_goal_nodes"] == attention["goal_tree_nodes"]
        by_policy.append(result.nodes_to_first_solution)
        alone = plan(trap, policy=KnowsTheWayOut(), seed=seed, max_nodes=5000,
                     stop_at_first=True, attention_patience=40,
                     attention_from_goal=False)  # fmt: skip
        assert "from_goal_stop" not in alone.attention and alone.success
        by_samples.append(alone.nodes_to_first_solution)
    # The goal tree grown by Informed RRT*'s samples needs more nodes (seeded, so exact).
    assert sum(by_policy) < sum(by_samples)


def test_a_policy_that_stalls_from_the_goal_too_hands_over_to_the_goal_tree(trap):
    stops = []
    for seed in range(6):
        result = plan(trap, policy=Stuck(), seed=seed, max_nodes=5000, stop_at_first=True,
                      attention_patience=30, attention_rounds=0)  # fmt: skip
        attention = result.attention
        stops.append(attention["from_goal_stop"])
        assert result.success and attention["goal_tree_joined"]
        assert attention["from_goal_solved"] == (attention["from_goal_stop"] == "joined")
        if attention["from_goal_stop"] == "stalled":  # grown on by Informed RRT*'s samples
            assert attention["goal_tree_nodes"] > attention["from_goal_nodes"]
    assert "stalled" in stops


def test_attention_from_goal_setting_is_checked(trap):
    with pytest.raises(ValueError, match="attention_from_goal"):
        plan(trap, attention_from_goal="yes")
    with pytest.raises(ValueError, match="attention_from_goal"):
        plan(trap, attention_from_goal=True, goal_tree=False)


class FindsTheWayOutLater(KnowsTheWayOut):
    """As `KnowsTheWayOut`, but its first phase from the goal stalls too (it heads for the U's
    back wall, from inside), and it knows the way out from its second phase from the goal on."""

    def reset(self, problem, seed=None):
        super().reset(problem, seed)
        if problem.start[0] > 12.5:  # planning from the goal
            self.phases_from_goal = getattr(self, "phases_from_goal", 0) + 1

    def __call__(self, observation):
        if self.problem.start[0] > 12.5 and self.phases_from_goal == 1:
            low, high = self.problem.bounds
            return ((np.array([13.2, 10.0]) - low) / (high - low) * 2 - 1).astype(np.float32)
        return super().__call__(observation)


def test_a_round_of_both_phases_joins_the_trees_after_both_stalled(trap):
    joined_in_a_round = 0
    for seed in range(8):
        result = plan(trap, policy=FindsTheWayOutLater(), seed=seed, max_nodes=5000,
                      stop_at_first=True, attention_patience=20)  # fmt: skip
        attention = result.attention
        assert result.success and certify_path(trap, result.path)
        np.testing.assert_array_equal(result.path[0], trap.start)
        assert attention["stop"] == "stalled" and attention["goal_tree_joined"]
        if attention["from_goal_stop"] != "stalled":  # a fallback node of it joined the trees
            assert attention["from_goal_solved"] and attention["rounds"] == 0
            continue
        assert not attention["from_goal_solved"] and attention["rounds"] == 1
        if not attention["rounds_solved"]:
            continue
        joined_in_a_round += 1
        assert attention_solved_both_ways(attention) and attention["resumes"] == 0
        # Nothing but the policy grew the goal tree: it ended when the policy stopped.
        assert attention["from_goal_nodes"] == attention["goal_tree_nodes"]
        without = plan(trap, policy=FindsTheWayOutLater(), seed=seed, max_nodes=5000,
                       stop_at_first=True, attention_patience=20,
                       attention_rounds=0)  # fmt: skip
        assert without.attention["rounds"] == 0 and not without.attention["rounds_solved"]
        assert not attention_solved_both_ways(without.attention) and without.success
        # Informed RRT*'s samples grew the goal tree on after the policy's phase stalled.
        assert without.attention["goal_tree_nodes"] > without.attention["from_goal_nodes"]
    assert joined_in_a_round >= 4  # 6 of these 8 seeds


def test_rounds_end_when_one_stops_for_another_reason_than_a_stall(trap):
    for rounds in (1, 3):
        result = plan(trap, policy=Stuck(), seed=2, max_nodes=5000, stop_at_first=True,
                      attention_patience=30, attention_rounds=rounds)  # fmt: skip
        assert result.success and result.attention["rounds"] <= rounds
    result = plan(trap, policy=Stuck(), seed=2, max_nodes=5000, stop_at_first=True,
                  attention_patience=30, attention_rounds=0)  # fmt: skip
    assert result.attention["rounds"] == 0


def test_rounds_count_both_trees_against_the_node_budget(trap):
    for budget in (90, 150, 250):
        for rounds in (0, 1, 5):
            result = plan(trap, policy=Stuck(), seed=1, max_nodes=budget, stop_at_first=True,
                          attention_patience=30, attention_rounds=rounds)  # fmt: skip
            assert result.nodes <= budget
            if not result.success:
                assert result.nodes == budget


def test_attention_rounds_setting_is_checked(trap):
    for bad in (-1, 1.5, True, "1"):
        with pytest.raises(ValueError, match="attention_rounds"):
            plan(trap, attention_rounds=bad)
    with pytest.raises(ValueError, match="attention_rounds"):
        plan(trap, attention_rounds=1, attention_from_goal=False)
    with pytest.raises(ValueError, match="attention_rounds"):
        plan(trap, attention_rounds=2, goal_tree=False)
    # None and 0 go with either
    plan(trap, policy=Stuck(), attention_rounds=0, goal_tree=False, max_nodes=50)
    plan(trap, policy=Stuck(), attention_rounds=None, attention_from_goal=False, max_nodes=50)


def test_a_policy_may_declare_its_rounds(trap):
    class NoRounds(FindsTheWayOutLater):
        attention_rounds = 0

    for seed in range(3):
        declared = plan(trap, policy=NoRounds(), seed=seed, max_nodes=5000, stop_at_first=True,
                        attention_patience=20)  # fmt: skip
        passed = plan(trap, policy=FindsTheWayOutLater(), seed=seed, max_nodes=5000,
                      stop_at_first=True, attention_patience=20, attention_rounds=0)  # fmt: skip
        assert declared.attention["rounds"] == 0
        np.testing.assert_array_equal(declared.path, passed.path)
        # plan()'s own setting wins over the policy's
        given = plan(trap, policy=NoRounds(), seed=seed, max_nodes=5000, stop_at_first=True,
                     attention_patience=20, attention_rounds=1)  # fmt: skip
        default = plan(trap, policy=FindsTheWayOutLater(), seed=seed, max_nodes=5000,
                       stop_at_first=True, attention_patience=20)  # fmt: skip
        np.testing.assert_array_equal(given.path, default.path)

    class BadRounds(FindsTheWayOutLater):
        attention_rounds = -2

    with pytest.raises(ValueError, match="policy.attention_rounds"):
        plan(trap, policy=BadRounds(), seed=1, max_nodes=5000, attention_patience=20)


@pytest.mark.parametrize(("robot", "index"), [("point2d", 36), ("point2d", 99), ("point3d", 27)])
def test_the_compiled_phases_after_a_stall_grow_the_same_trees_as_from_python(
    robot, index, monkeypatch
):
    """The shipped policies stall on these tasks; the goal tree's phases join the trees.

    2D joins in later rounds (a phase on either tree joins), 3D in the phase from the goal.
    By default the phases after the stall run as one compiled sequence, which makes the join
    checks itself (`_compiled_attention.attention_sequence`). Driven from Python phase by
    phase instead, each compiled with the join checks made from Python between its slices,
    or grown by the Python loop, they must grow the same trees and join at the same nodes;
    the compiled loops also make the same motion checks (the Python loop's extensions count
    theirs differently).
    """
    from temp_gym.evaluation.runner import evaluation_problem
    from temp_gym.planning import goal_tree

    problem = evaluation_problem(robot, "challenging", index)
    sequence = plan(problem, seed=0, max_nodes=10_000, stop_at_first=True)
    monkeypatch.setattr(goal_tree, "SEQUENCE_COMPILED", False)
    phases = plan(problem, seed=0, max_nodes=10_000, stop_at_first=True)
    run_phase = goal_tree.run_attention_phase
    monkeypatch.setattr(
        goal_tree, "run_attention_phase",
        lambda *args, **options: run_phase(*args, **options, compiled_loop=False),
    )  # fmt: skip
    python = plan(problem, seed=0, max_nodes=10_000, stop_at_first=True)
    attention = sequence.attention
    assert attention["stop"] == "stalled" and attention["goal_tree_joined"]
    assert attention["from_goal_solved"] or (
        attention["rounds"] >= 2 and attention["rounds_solved"]
    )
    untimed = lambda attention: {k: v for k, v in attention.items() if k != "time"}  # noqa: E731
    for other in (phases, python):
        assert untimed(sequence.attention) == untimed(other.attention)
        np.testing.assert_array_equal(sequence.path, other.path)
        assert sequence.nodes_to_first_solution == other.nodes_to_first_solution
        assert sequence.nodes == other.nodes and sequence.samples == other.samples
    assert sequence.collision_checks == phases.collision_checks


@pytest.mark.parametrize("rounds", [0, 1, 3])
def test_the_compiled_sequence_stops_as_the_phases_do_within_a_budget(rounds, monkeypatch):
    """Budgets that end the sequence mid-phase (nodes), and every count of rounds.

    On 2D tasks where the shipped policy stalls, with a node budget that the rounds often
    reach, trees whose arrays must grow (capacity 16) and a time limit (short slices), the
    compiled sequence and the phases driven from Python give the same results: stops, rounds
    begun, trees. The sequence returns to Python to grow either tree and between slices.
    """
    from temp_gym.evaluation.runner import evaluation_problem
    from temp_gym.planning import _compiled_attention, goal_tree, temp_planner

    class SmallTree(Tree):
        def __init__(self, *args, **kwargs):
            kwargs.setdefault("capacity", 16)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(goal_tree, "Tree", SmallTree)
    monkeypatch.setattr(temp_planner, "Tree", SmallTree)
    statuses = set()
    run_sequence = _compiled_attention.attention_sequence

    def recorded(*args):
        status = run_sequence(*args)
        statuses.add(status)
        return status

    monkeypatch.setattr(_compiled_attention, "attention_sequence", recorded)
    compared = 0
    for index in range(40):
        problem = evaluation_problem("point2d", "challenging", index, seed=3)
        kwargs = dict(
            seed=index, max_nodes=1500, stop_at_first=True, attention_rounds=rounds,
            time_limit=2.0,
        )  # fmt: skip
        monkeypatch.setattr(goal_tree, "SEQUENCE_COMPILED", True)
        sequence = plan(problem, **kwargs)
        if "from_goal_stop" not in sequence.attention:
            continue
        monkeypatch.setattr(goal_tree, "SEQUENCE_COMPILED", False)
        phases = plan(problem, **kwargs)
        compared += 1
        untimed = lambda attention: {k: v for k, v in attention.items() if k != "time"}  # noqa: E731
        assert untimed(sequence.attention) == untimed(phases.attention), index
        assert sequence.nodes == phases.nodes and sequence.samples == phases.samples
        assert sequence.collision_checks == phases.collision_checks
        assert sequence.success == phases.success
        if sequence.success:
            np.testing.assert_array_equal(sequence.path, phases.path)
    assert compared >= 10
    assert {_compiled_attention.RUNNING, _compiled_attention.FULL_GOAL} <= statuses
    assert (_compiled_attention.FULL_PLANNER in statuses) == (rounds > 0)  # rounds grow it
