"""The attention phase: compiled and Python loops grow the same trees; chunks; the stall rule."""

from unittest.mock import ANY

import numpy as np
import pytest
import torch

from temp_gym import Problem, plan
from temp_gym.models.policy import TEMPPolicy
from temp_gym.models.registry import load_policy
from temp_gym.models.temp import TEMPModel
from temp_gym.planning.attention import (
    NEAR_GOAL_SHARE,
    AttentionLimits,
    closest_approach_sq,
    default_patience,
    near_goal_limits,
    resume_nodes,
    run_attention_phase,
)
from temp_gym.planning.temp_planner import resume_turns
from temp_gym.planning.tree import Tree
from temp_gym.worlds.generators import generate_problem

SMALL = {"token_dim": 16, "num_heads": 2, "num_layers": 2, "ffn_dim": 32, "num_sei_tokens": 4}


def _chunked_policy(
    robot: str, chunk: int, noise_std: float, horizon=None, path_window=None
) -> TEMPPolicy:
    """An untrained (random) chunked model: its proposals exercise every branch of the loop."""
    torch.manual_seed(chunk)
    model = TEMPModel(robot, 8, 16, eise_hidden=16, chunk=chunk, **SMALL)
    return TEMPPolicy(model, noise_std=noise_std, horizon=horizon, path_window=path_window)


def _grow(
    problem,
    policy,
    seed,
    compiled_loop,
    patience=0,
    goal_bias=0.05,
    uniform=0.0,
    near=(-1.0, 0),
    follow=1.0,
    keep_chunk=False,
    local_tries=0,
):
    policy.reset(problem, seed=seed)
    tree = Tree(problem, capacity=16)  # small: the compiled loop must grow it on the way
    rng = np.random.default_rng(seed)
    limits = AttentionLimits(
        1500, 1500, 150_000, patience, near_sq=near[0], near_patience=near[1],
        local_tries=local_tries,
    )  # fmt: skip
    outcome = run_attention_phase(
        tree, policy, rng, goal_bias, limits, compiled_loop, uniform, follow_fallback=follow,
        keep_chunk=keep_chunk,
    )  # fmt: skip
    return tree, outcome, rng.random(), policy.rng.random()


def _assert_same_tree(a, b):
    n = a.num_nodes
    assert n == b.num_nodes
    np.testing.assert_array_equal(a.positions[:n], b.positions[:n])
    np.testing.assert_array_equal(a.costs[:n], b.costs[:n])
    np.testing.assert_array_equal(a.links[:n], b.links[:n])
    assert (a.samples, a.sampling_failures, a.best_node, a.best_cost, a.newest) == (
        b.samples, b.sampling_failures, b.best_node, b.best_cost, b.newest,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("robot", "policy_kind", "patience"),
    [("point2d", "shipped", 0), ("point2d", "chunk3", 0), ("point3d", "shipped", 60),
     ("point3d", "chunk2", 0), ("point2d", "chunk4-horizon2", 0),
     ("kuka_iiwa14", "shipped", 0), ("point2d", "shipped-uniform", 0),
     ("point2d", "shipped-follow0.25", 0), ("point3d", "chunk2-follow0", 40),
     ("point2d", "shipped-keep", 0), ("point3d", "chunk3-keep", 60),
     ("point2d", "chunk4-horizon2-keep", 0), ("point2d", "chunk2-window3", 0),
     ("point3d", "shipped-window5", 60)],
)  # fmt: skip
def test_compiled_loop_grows_the_python_loops_tree(robot, policy_kind, patience):
    rng = np.random.default_rng(11)
    for index in range(3):
        problem = generate_problem(robot, rng, "challenging" if index % 2 else "easy")
        runs = []
        keep_chunk = policy_kind.endswith("-keep")
        for compiled_loop in (True, False):
            kind, _, follow = policy_kind.removesuffix("-keep").partition("-follow")
            kind, _, window = kind.partition("-window")
            window = int(window) if window else None
            if kind.startswith("shipped"):
                policy = load_policy(robot, noise_std=0.05).fresh(path_window=window)
            elif "horizon" in kind:
                policy = _chunked_policy(robot, 4, noise_std=0.05, horizon=2)
            else:
                policy = _chunked_policy(robot, int(kind[-1]), noise_std=0.05, path_window=window)
            uniform = 0.2 if kind.endswith("uniform") else 0.0
            follow = float(follow or 1.0)
            runs.append(
                _grow(
                    problem,
                    policy,
                    index,
                    compiled_loop,
                    patience,
                    uniform=uniform,
                    follow=follow,
                    keep_chunk=keep_chunk,
                )  # fmt: skip
            )
        (tree_c, out_c, rng_c, noise_c), (tree_p, out_p, rng_p, noise_p) = runs
        assert out_c.compiled and not out_p.compiled
        _assert_same_tree(tree_c, tree_p)
        assert (out_c.stop, out_c.policy_calls, out_c.policy_samples) == (
            out_p.stop, out_p.policy_calls, out_p.policy_samples,
        )  # fmt: skip
        assert (rng_c, noise_c) == (rng_p, noise_p)  # both generators drew the same numbers
        assert tree_c.num_nodes > 16  # the arrays were grown


@pytest.mark.parametrize("robot", ["point2d", "point3d", "kuka_iiwa14"])
def test_both_loops_draw_replacements_near_the_proposal_alike(robot):
    rng = np.random.default_rng(7)
    nearer = 0
    for index in range(3):
        problem = generate_problem(robot, rng, "challenging")
        runs = [
            _grow(
                problem, load_policy(robot, noise_std=0.05), index, compiled_loop, 0, local_tries=20
            )  # fmt: skip
            for compiled_loop in (True, False)
        ]
        (tree_c, out_c, rng_c, noise_c), (tree_p, out_p, rng_p, noise_p) = runs
        assert out_c.compiled and not out_p.compiled
        _assert_same_tree(tree_c, tree_p)
        assert (rng_c, noise_c) == (rng_p, noise_p)
        # The setting changes the tree whenever a proposal collided (Algorithm 1 otherwise).
        uniform_tree = _grow(problem, load_policy(robot, noise_std=0.05), index, True, 0)[0]
        if tree_c.sampling_failures > 0:
            nearer += uniform_tree.num_nodes != tree_c.num_nodes or not np.array_equal(
                uniform_tree.positions[: tree_c.num_nodes], tree_c.positions[: tree_c.num_nodes]
            )
    assert nearer > 0


def test_replacements_near_a_proposal_stay_in_its_box_and_the_bounds(wall):
    problem = Problem.from_dict(wall)
    tree = Tree(problem)
    low, high = problem.bounds

    class Uniform:
        def sample(self, rng):
            return rng.uniform(low, high)

    sampler = Uniform()
    original = tree.extend
    calls = []
    tree.extend = lambda sample, normalized=False: (
        calls.append((np.array(sample, dtype=float), normalized)) or original(sample, normalized)
    )
    proposal = np.array([0.95, -0.2])  # towards the wall from the start: every try collides
    tree.extend_with_fallback(proposal, sampler, np.random.default_rng(0), max_tries=30,
                              normalized=True, local_tries=10)  # fmt: skip
    near = [sample for sample, normalized in calls[1:] if normalized]
    assert calls[0][1] and len(near) == min(10, len(calls) - 1)
    for sample in near:
        assert np.all(np.abs(sample - np.clip(sample, -1, 1)) == 0)
        assert np.all(np.abs(sample - proposal) <= 0.15 + 1e-12)
    assert all(not normalized for _, normalized in calls[11:])  # then uniform, world units
    with pytest.raises(ValueError, match="local_tries"):
        tree.extend_with_fallback(proposal, sampler, np.random.default_rng(0), local_tries=-1)


@pytest.mark.parametrize("robot", ["point2d", "point3d"])
def test_both_loops_apply_the_near_goal_patience_alike(robot):
    rng = np.random.default_rng(5)
    stops = set()
    for index in range(4):
        problem = generate_problem(robot, rng, "challenging")
        distance_sq = float(np.sum((problem.goal - problem.start) ** 2))
        near = (0.25 * distance_sq, 45)  # within half the distance: 45 nodes, else 15
        runs = [
            _grow(
                problem,
                _chunked_policy(robot, 2, noise_std=0.05),
                index,
                compiled_loop,
                15,
                near=near,
            )  # fmt: skip
            for compiled_loop in (True, False)
        ]
        (tree_c, out_c, rng_c, noise_c), (tree_p, out_p, rng_p, noise_p) = runs
        _assert_same_tree(tree_c, tree_p)
        assert (out_c.stop, out_c.policy_calls, rng_c, noise_c) == (
            out_p.stop, out_p.policy_calls, rng_p, noise_p,
        )  # fmt: skip
        stops.add(out_c.stop)
    assert "stalled" in stops


class Drifting:
    """A policy that proposes points around where it stands: the tree wanders, never solving."""

    def reset(self, problem, seed=None):
        self.rng = np.random.default_rng(seed)

    def __call__(self, observation):
        last = observation["path"][int(observation["path_length"][0]) - 1]
        return np.clip(last + self.rng.normal(0.0, 0.02, 2), -1, 1).astype(np.float32)


@pytest.mark.parametrize(
    ("near_sq", "near_patience", "stop"),
    [(-1.0, 0, "stalled"), (1e9, 400, "stalled"), (1e9, 5000, "attention_budget")],
)
def test_near_the_goal_the_phase_waits_near_patience_nodes(wall, near_sq, near_patience, stop):
    problem = Problem.from_dict({**wall, "obstacles": []})
    policy = Drifting()
    policy.reset(problem, seed=0)
    limits = AttentionLimits(1200, 1200, 100_000, 40, near_sq=near_sq, near_patience=near_patience)
    tree = Tree(problem)
    outcome = run_attention_phase(tree, policy, np.random.default_rng(0), 0.0, limits)
    assert outcome.stop == stop
    if stop == "stalled":  # the rule's 40 nodes far from the goal, near_patience near it
        assert tree.num_nodes < (100 if near_sq < 0 else 1200)
        assert near_sq < 0 or tree.num_nodes > 400


def test_near_goal_limits_scale_the_patience(wall):
    problem = Problem.from_dict(wall)
    near_sq, near_patience = near_goal_limits(problem, 200, 2.5)
    distance = float(np.linalg.norm(problem.goal - problem.start))
    assert near_sq == pytest.approx((NEAR_GOAL_SHARE * distance) ** 2)
    assert near_patience == 500


class DeclaringStuck:
    """`Stuck` with a declared near-goal factor, as a shipped policy carries one."""

    def __init__(self, factor):
        self.attention_near_goal_factor = factor

    def reset(self, problem, seed=None):
        pass

    def __call__(self, observation):
        return np.array([-1.0, -1.0], np.float32)


def test_the_near_goal_factor_comes_from_plan_else_the_policy_else_none(wall, monkeypatch):
    from temp_gym.planning import temp_planner

    seen = []

    def recording(tree, policy, rng, goal_bias, limits, **kwargs):
        if not kwargs.get("resumed"):  # the first phase of each plan; resumed ones share it
            seen.append(limits)
        return run_attention_phase(tree, policy, rng, goal_bias, limits, **kwargs)

    monkeypatch.setattr(temp_planner, "run_attention_phase", recording)
    problem = Problem.from_dict(wall)
    kwargs = dict(planner="temp", seed=0, max_nodes=300, stop_at_first=True)
    plan(problem, policy=Stuck(), **kwargs)  # no factor anywhere: one patience everywhere
    plan(problem, policy=DeclaringStuck(3), **kwargs)  # the policy's own
    plan(problem, policy=DeclaringStuck(3), attention_near_goal_factor=2, **kwargs)  # plan's wins
    plan(problem, policy=Stuck(), attention_patience=50, attention_near_goal_factor=2, **kwargs)
    patience = default_patience(problem, Tree(problem).step_size)
    expected = [
        (patience, -1.0, 0),
        (patience, *near_goal_limits(problem, patience, 3.0)),
        (patience, *near_goal_limits(problem, patience, 2.0)),
        (50, *near_goal_limits(problem, 50, 2.0)),
    ]
    assert [(s.patience, s.near_sq, s.near_patience) for s in seen] == expected
    with pytest.raises(ValueError, match="policy.attention_near_goal_factor"):
        plan(problem, policy=DeclaringStuck(0.5), **kwargs)
    with pytest.raises(ValueError, match="attention_near_goal_factor"):
        plan(problem, policy=Stuck(), attention_near_goal_factor=float("inf"), **kwargs)


def test_slices_of_one_iteration_give_the_python_loops_tree(monkeypatch):
    """The compiled loop resumed after every iteration (its state, the chunk and both
    generators carried across calls) grows the same tree and draws the same numbers."""
    from temp_gym.planning import attention

    monkeypatch.setattr(attention, "slice_length", lambda *args: 1)
    problem = generate_problem("point2d", np.random.default_rng(3), "challenging")
    runs = [
        _grow(problem, _chunked_policy("point2d", 2, noise_std=0.05), 4, compiled_loop)
        for compiled_loop in (True, False)
    ]
    (tree_c, out_c, rng_c, noise_c), (tree_p, out_p, rng_p, noise_p) = runs
    _assert_same_tree(tree_c, tree_p)
    assert out_c.policy_calls == out_p.policy_calls > 8
    assert (rng_c, noise_c) == (rng_p, noise_p)


class IntoTheWall:
    """A policy whose every proposal collides (the wall's centre), recording where it stood."""

    def __init__(self):
        self.stood = []

    def reset(self, problem, seed=None):
        self.bounds = problem.bounds

    def __call__(self, observation):
        last = observation["path"][int(observation["path_length"][0]) - 1]
        low, high = self.bounds
        self.stood.append(low + (last + 1.0) / 2.0 * (high - low))  # back to world units
        return np.array([0.0, 0.0], np.float32)  # normalized: (10, 10), inside the wall


def test_the_policy_goes_on_from_a_fallback_node_only_with_its_probability(wall):
    problem = Problem.from_dict(wall)

    def stood(follow):
        policy = IntoTheWall()
        policy.reset(problem)
        limits = AttentionLimits(300, 300, 30_000, 0)
        rng = np.random.default_rng(0)
        run_attention_phase(Tree(problem), policy, rng, 0.0, limits, follow_fallback=follow)
        return [float(np.linalg.norm(x - problem.goal)) for x in policy.stood]

    # Every node is a fallback node: with 0 the policy stands on a new one only when it got
    # closer to the goal, so its distance to the goal only falls; with 1 (Algorithm 1) it
    # stands wherever the fallback landed.
    never = stood(0.0)
    assert len(never) > 50 and never == sorted(never, reverse=True)
    always = stood(1.0)
    assert always != sorted(always, reverse=True)
    sometimes = stood(0.5)
    assert sometimes not in (never, always)


def test_follow_fallback_one_is_algorithm_1_and_a_share_draws_from_the_planner():
    problem = generate_problem("point2d", np.random.default_rng(8), "challenging")
    policy = load_policy("point2d", noise_std=0.05)
    default = _grow(problem, policy, 1, compiled_loop=True)
    one = _grow(problem, policy, 1, compiled_loop=True, follow=1.0)
    _assert_same_tree(default[0], one[0])
    assert default[2:] == one[2:]  # no draw for the probability 1
    half = _grow(problem, policy, 1, compiled_loop=True, follow=0.5)
    assert half[0].num_nodes != one[0].num_nodes or half[2] != one[2]


def test_follow_fallback_comes_from_plan_else_the_policy_and_is_checked(wall):
    problem = Problem.from_dict(wall)
    kwargs = dict(planner="temp", seed=0, max_nodes=300, stop_at_first=True)

    class Declaring(Stuck):
        attention_follow_fallback = 0.0

    declared = plan(problem, policy=Declaring(), **kwargs)
    assert (
        declared.nodes == plan(problem, policy=Stuck(), attention_follow_fallback=0, **kwargs).nodes
    )
    Declaring.attention_follow_fallback = 1.5
    with pytest.raises(ValueError, match="policy.attention_follow_fallback"):
        plan(problem, policy=Declaring(), **kwargs)
    for bad in (-0.1, 1.5, float("nan"), True, "half"):
        with pytest.raises(ValueError, match="attention_follow_fallback"):
            plan(problem, policy=Stuck(), attention_follow_fallback=bad, **kwargs)


def test_a_chunk_is_used_in_turn_and_dropped_after_a_fallback(wall):
    policy = _chunked_policy("point2d", 4, noise_std=0.0)
    open_world = Problem.from_dict({**wall, "obstacles": []})
    tree, outcome, _, _ = _grow(open_world, policy, 0, compiled_loop=True, goal_bias=0.0)
    # Four proposals per call while they extend the tree; each failure (an untrained model
    # also proposes the node it stands on, or a clipped corner) ends its chunk early.
    calls, proposals = outcome.policy_calls, outcome.policy_samples
    fallbacks = tree.samples - proposals  # no goal bias: the rest are random replacements
    assert proposals > 100 and calls < proposals / 2  # most proposals come in full chunks
    assert -(-proposals // 4) <= calls <= -(-proposals // 4) + fallbacks


class Stuck:
    """A policy that cannot help: always the same corner, away from the goal."""

    def reset(self, problem, seed=None):
        pass

    def __call__(self, observation):
        return np.array([-1.0, -1.0], np.float32)


def test_a_stalled_attention_phase_hands_over_to_classical_planning(wall):
    problem = Problem.from_dict(wall)
    kwargs = dict(planner="temp", policy=Stuck(), seed=0, max_nodes=3000, stop_at_first=True)
    stalled = plan(problem, attention_patience=50, **kwargs)
    assert stalled.attention["stop"] == "stalled" and not stalled.attention["solved"]
    assert stalled.attention["nodes"] < 200
    assert stalled.success  # Informed RRT* took over with the budget left
    kwargs["goal_bias"] = 0.0  # Algorithm 1 as written: only the random fallback helps
    algorithm_1 = plan(problem, attention_patience=0, attention_nodes=200, **kwargs)
    assert algorithm_1.attention["stop"] == "attention_budget"
    assert algorithm_1.attention["nodes"] == 200


def _classical_tree(problem, seed, nodes, low=None, high=None):
    """A tree that RRT* grew to ``nodes`` nodes from uniform samples in ``[low, high]``."""
    tree = Tree(problem, capacity=16)
    rng = np.random.default_rng(seed)
    low = problem.bounds[0] if low is None else np.asarray(low, float)
    high = problem.bounds[1] if high is None else np.asarray(high, float)
    while tree.num_nodes < nodes:
        tree.extend(rng.uniform(low, high))
    assert tree.best_node < 0
    return tree


@pytest.mark.parametrize("robot", ["point2d", "point3d"])
def test_a_resumed_phase_grows_the_same_tree_in_both_loops(robot):
    rng = np.random.default_rng(5)
    problem = generate_problem(robot, rng, "challenging")
    runs = []
    for compiled_loop in (True, False):
        tree = _classical_tree(problem, 3, 40)
        closest = closest_approach_sq(tree)
        policy = load_policy(robot, noise_std=0.05)
        policy.reset(problem, seed=1)
        planner_rng = np.random.default_rng(1)
        limits = AttentionLimits(1500, 1500, 150_000, 30)
        outcome = run_attention_phase(
            tree, policy, planner_rng, 0.05, limits, compiled_loop, resumed=True
        )
        runs.append((tree, outcome, planner_rng.random(), policy.rng.random()))
        assert closest_approach_sq(tree) <= closest
    (tree_c, out_c, *draws_c), (tree_p, out_p, *draws_p) = runs
    _assert_same_tree(tree_c, tree_p)
    assert (out_c.stop, out_c.policy_calls) == (out_p.stop, out_p.policy_calls)
    assert draws_c == draws_p


def test_a_resumed_phase_counts_progress_from_the_trees_closest_approach(wall):
    problem = Problem.from_dict(wall)
    region = ([6.0, 6.0], [9.0, 14.0])  # left of the wall, within 13 of the goal
    grown = _classical_tree(problem, 0, 300, *region)
    offsets = grown.positions[: grown.num_nodes] - problem.goal
    assert closest_approach_sq(grown) == pytest.approx(np.min(np.sum(offsets**2, axis=1)))
    ends = {}
    for resumed in (False, True):
        tree = _classical_tree(problem, 0, 300, *region)
        limits = AttentionLimits(3000, 3000, 300_000, 25)
        outcome = run_attention_phase(
            tree, Stuck(), np.random.default_rng(0), 0.0, limits, resumed=resumed
        )
        assert outcome.stop == "stalled"
        ends[resumed] = tree.num_nodes - 300
    # The stuck policy heads for the far corner from the newest node. From the start's
    # distance (16), its first node counts as progress; from the tree's closest approach
    # (near the wall) none does, so the resumed phase stalls after exactly `patience` nodes.
    assert ends[True] == 25 and ends[False] > ends[True]


def test_a_stalled_phase_resumes_after_classical_planning_until_the_first_solution(wall):
    problem = Problem.from_dict(wall)
    kwargs = dict(planner="temp", seed=0, max_nodes=3000, stop_at_first=True, goal_bias=0.0,
                  attention_patience=30, goal_tree=False)  # fmt: skip
    resumed = plan(problem, policy=Stuck(), attention_resume=0.5, **kwargs)
    assert resumed.success and resumed.attention["stop"] == "stalled"
    assert resumed.attention["resumes"] >= 1
    patient = plan(problem, policy=Stuck(), attention_resume=100, **kwargs)
    assert patient.success and patient.attention["resumes"] == 0  # classical planning solved it
    never = plan(problem, policy=Stuck(), attention_resume=0, **kwargs)
    assert never.success and never.attention["resumes"] == 0
    # the first phase is the same
    assert resumed.attention == {**never.attention, "resumes": ANY, "time": ANY}
    assert resume_nodes(30, 0.5) == 15 and resume_nodes(30, 1e-9) == 1
    assert resume_nodes(200, 1e300) == resume_nodes(200, 1e301)  # held to the largest budget


def test_attention_resume_comes_from_plan_else_the_policy_and_is_checked(wall):
    problem = Problem.from_dict(wall)
    kwargs = dict(planner="temp", seed=0, max_nodes=3000, stop_at_first=True,
                  attention_patience=30)  # fmt: skip

    class Declaring(Stuck):
        attention_resume = 0.0

    declared = plan(problem, policy=Declaring(), **kwargs)
    assert declared.attention["resumes"] == 0
    assert declared.nodes == plan(problem, policy=Stuck(), attention_resume=0, **kwargs).nodes
    Declaring.attention_resume = -1.0
    with pytest.raises(ValueError, match="policy.attention_resume"):
        plan(problem, policy=Declaring(), **kwargs)
    for bad in (-0.5, float("nan"), float("inf"), True, "once"):
        with pytest.raises(ValueError, match="attention_resume"):
            plan(problem, policy=Stuck(), attention_resume=bad, **kwargs)
    with pytest.raises(ValueError, match="attention_resume"):
        TEMPPolicy(load_policy("point2d").core, attention_resume=-1)


def test_resume_turns_grow_by_the_factor_and_stay_within_the_budget():
    turns = resume_turns(30, 4.0, 10_000)
    assert [next(turns) for _ in range(8)] == [30, 120, 480, 1920, 7680, 10_000, 10_000, 10_000]
    equal = resume_turns(30, 1.0, 10_000)
    assert [next(equal) for _ in range(5)] == [30] * 5
    slow = resume_turns(1, 1.5, 100)
    assert [next(slow) for _ in range(6)] == [1, 2, 2, 3, 5, 8]  # rounded, at least 1


def test_growing_turns_resume_the_stuck_policy_less_often(wall):
    problem = Problem.from_dict(wall)
    kwargs = dict(planner="temp", seed=1, max_nodes=3000, stop_at_first=True, goal_bias=0.0,
                  attention_patience=30, attention_resume=0.5, goal_tree=False)  # fmt: skip
    default = plan(problem, policy=Stuck(), **kwargs)
    equal = plan(problem, policy=Stuck(), attention_resume_growth=1, **kwargs)
    growing = plan(problem, policy=Stuck(), attention_resume_growth=4, **kwargs)
    assert default.success and equal.success and growing.success
    # 1 is the default: the same turns, the same tree
    assert (
        equal.nodes == default.nodes and equal.attention["resumes"] == default.attention["resumes"]
    )
    np.testing.assert_array_equal(equal.path, default.path)
    # turns of 15, 60, 240, ... nodes: the stuck policy gets fewer turns
    assert default.attention["resumes"] > 5
    assert 1 <= growing.attention["resumes"] < default.attention["resumes"]
    # the first phase is the same
    assert growing.attention == {**default.attention, "resumes": ANY, "time": ANY}


def test_attention_resume_growth_comes_from_plan_else_the_policy_and_is_checked(wall):
    problem = Problem.from_dict(wall)
    kwargs = dict(planner="temp", seed=1, max_nodes=3000, stop_at_first=True, goal_bias=0.0,
                  attention_patience=30, attention_resume=0.5, goal_tree=False)  # fmt: skip

    class Declaring(Stuck):
        attention_resume_growth = 4.0

    declared = plan(problem, policy=Declaring(), **kwargs)
    given = plan(problem, policy=Stuck(), attention_resume_growth=4, **kwargs)
    assert (declared.nodes, declared.attention["resumes"]) == (
        given.nodes, given.attention["resumes"],
    )  # fmt: skip
    overridden = plan(problem, policy=Declaring(), attention_resume_growth=1, **kwargs)
    assert overridden.nodes == plan(problem, policy=Stuck(), **kwargs).nodes
    Declaring.attention_resume_growth = 0.5
    with pytest.raises(ValueError, match="policy.attention_resume_growth"):
        plan(problem, policy=Declaring(), **kwargs)
    for bad in (0.5, 0, -2.0, float("nan"), float("inf"), True, "twice"):
        with pytest.raises(ValueError, match="attention_resume_growth"):
            plan(problem, policy=Stuck(), attention_resume_growth=bad, **kwargs)
    with pytest.raises(ValueError, match="attention_resume_growth"):
        TEMPPolicy(load_policy("point2d").core, attention_resume_growth=0.9)
    kept = TEMPPolicy(None, core=load_policy("point2d").core, attention_resume_growth=2)
    assert kept.attention_resume_growth == kept.fresh().attention_resume_growth == 2.0


def test_default_patience_grows_with_the_distance_in_steps(wall):
    near = Problem.from_dict({**wall, "start": [2, 2], "goal": [4, 2]})
    far = Problem.from_dict(wall)
    assert default_patience(near, 1.0) == 200  # the floor
    assert default_patience(far, 0.1) > default_patience(far, 1.0) >= 200


def test_compiled_loop_cannot_be_forced_on_a_python_policy(wall):
    problem = Problem.from_dict(wall)
    with pytest.raises(ValueError, match="compiled"):
        run_attention_phase(
            Tree(problem), Stuck(), np.random.default_rng(0), 0.05,
            AttentionLimits(10, 10, 100, 0), compiled_loop=True,
        )  # fmt: skip


def _reset_pair(chunk: int, **setting) -> tuple[TEMPPolicy, TEMPPolicy]:
    """The same untrained model without and with ``setting``, both reset to one problem."""
    pair = (
        _chunked_policy("point2d", chunk, 0.0),
        _chunked_policy("point2d", chunk, 0.0, **setting),
    )
    problem = generate_problem("point2d", np.random.default_rng(0))
    for policy in pair:
        policy.reset(problem)
    return pair


def test_a_horizon_uses_the_first_proposals_of_each_chunk():
    full, short = _reset_pair(4, horizon=2)
    path = np.zeros((16, 2), np.float32)
    path[0] = [-0.5, 0.2]
    assert short.propose_chunk(path, 1).shape == (2, 2)
    np.testing.assert_array_equal(short.propose_chunk(path, 1), full.propose_chunk(path, 1)[:2])
    for bad in (0, 5, 1.5):
        with pytest.raises(ValueError, match="horizon"):
            _chunked_policy("point2d", 4, noise_std=0.0, horizon=bad)


def test_a_path_window_reads_the_newest_nodes_of_the_path():
    """The window's proposals are the whole model's on the path's newest rows alone."""
    full, windowed = _reset_pair(2, path_window=4)
    path = np.random.default_rng(1).uniform(-1, 1, (16, 2)).astype(np.float32)
    newest = path[6:10].copy()
    np.testing.assert_array_equal(windowed.propose_chunk(path, 10), full.propose_chunk(newest, 4))
    assert not np.array_equal(windowed.propose_chunk(path, 10), full.propose_chunk(path, 10))
    np.testing.assert_array_equal(windowed.propose_chunk(path, 3), full.propose_chunk(path, 3))
    assert (windowed.window, windowed.max_path_length, full.window) == (4, 16, 16)
    assert windowed.compiled_proposer()[-1] == 4  # the compiled loop reads 4 rows too
    assert windowed.fresh().path_window == 4
    for bad in (0, 17, 2.0, True):
        with pytest.raises(ValueError, match="path_window"):
            _chunked_policy("point2d", 2, noise_std=0.0, path_window=bad)


def test_keep_chunk_goes_on_with_the_chunk_past_a_fallback_and_one_sample_is_the_same():
    """With ``keep_chunk`` the MPT is called only for used-up chunks (or a node not added)."""
    rng = np.random.default_rng(3)
    totals = {False: [0, 0], True: [0, 0]}  # MPT calls, proposals used
    for index in range(4):
        problem = generate_problem("point2d", rng, "challenging")
        for keep in (False, True):
            policy = load_policy("point2d", noise_std=0.0)
            _, outcome, *_ = _grow(problem, policy, index, True, keep_chunk=keep)
            totals[keep][0] += outcome.policy_calls
            totals[keep][1] += outcome.policy_samples
    (calls_off, used_off), (calls_on, used_on) = totals[False], totals[True]
    assert used_off / calls_off < used_on / calls_on <= 4  # more of each chunk of 4 is used
    # A one-sample policy has no rest of a chunk to keep: the same tree either way.
    problem = generate_problem("point2d", np.random.default_rng(9), "challenging")
    policy = _chunked_policy("point2d", 1, noise_std=0.05)
    off = _grow(problem, policy, 2, True, keep_chunk=False)
    on = _grow(problem, policy, 2, True, keep_chunk=True)
    _assert_same_tree(off[0], on[0])


def test_keep_chunk_is_a_checked_plan_setting(wall):
    problem = Problem.from_dict(wall)
    kwargs = dict(planner="temp", seed=0, max_nodes=300, stop_at_first=True)
    assert (
        plan(problem, attention_keep_chunk=None, **kwargs).nodes
        == plan(problem, attention_keep_chunk=False, **kwargs).nodes
    )  # None is the rule shipped policies use
    for bad in (1, "yes", 0.5):
        with pytest.raises(ValueError, match="attention_keep_chunk"):
            plan(problem, attention_keep_chunk=bad, **kwargs)


@pytest.mark.parametrize("join_at", [3, None])
def test_joined_checks_come_at_the_same_nodes_in_both_loops(join_at):
    """The check a goal tree grown by attention makes (`run_attention_phase`'s ``joined``)."""
    problem = generate_problem("point2d", np.random.default_rng(5), "challenging")
    runs = []
    for compiled_loop in (True, False, None):
        calls = []
        policy = load_policy("point2d", noise_std=0.05)
        policy.reset(problem, seed=2)
        tree = Tree(problem, capacity=16)

        def joined(tree_sizes=calls, tree=tree):
            tree_sizes.append(tree.num_nodes)
            return len(tree_sizes) == join_at

        rng = np.random.default_rng(2)
        limits = AttentionLimits(1500, 1500, 150_000, 0)
        hook = None if compiled_loop is None else joined
        outcome = run_attention_phase(tree, policy, rng, 0.05, limits, bool(compiled_loop),
                                      joined=hook, check_every=7)  # fmt: skip
        runs.append((tree, outcome, calls))
    (tree_c, out_c, calls_c), (tree_p, out_p, calls_p), (tree_none, out_none, _) = runs
    _assert_same_tree(tree_c, tree_p)
    assert calls_c == calls_p
    if join_at is None:  # checks that never join leave the tree as it grows without them
        _assert_same_tree(tree_c, tree_none)
        assert out_c.stop == out_p.stop == out_none.stop == "solved"
        assert calls_c[:-1] == list(range(8, 8 + 7 * (len(calls_c) - 1), 7))
        assert calls_c[-1] == tree_c.num_nodes  # the last check, as the phase stopped
    else:
        assert out_c.stop == out_p.stop == "joined"
        assert calls_c == [8, 15, 22] and tree_c.num_nodes == 22


def test_check_every_must_be_positive(wall):
    with pytest.raises(ValueError, match="check_every"):
        run_attention_phase(Tree(Problem.from_dict(wall)), load_policy("point2d"),
                            np.random.default_rng(0), 0.05,
                            AttentionLimits(10, 10, 100, 0), joined=lambda: False,
                            check_every=0)  # fmt: skip
