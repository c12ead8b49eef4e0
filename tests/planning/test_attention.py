"""The attention phase: compiled and Python loops grow the same trees; chunks; the stall rule."""

import numpy as np
import pytest
import torch

from temp_gym import Problem, plan
from temp_gym.models.policy import TEMPPolicy
from temp_gym.models.registry import load_policy
from temp_gym.models.temp import TEMPModel
from temp_gym.planning.attention import AttentionLimits, default_patience, run_attention_phase
from temp_gym.planning.tree import Tree
from temp_gym.worlds.generators import generate_problem

SMALL = {"token_dim": 16, "num_heads": 2, "num_layers": 2, "ffn_dim": 32, "num_sei_tokens": 4}


def _chunked_policy(robot: str, chunk: int, noise_std: float, horizon=None) -> TEMPPolicy:
    """An untrained (random) chunked model: its proposals exercise every branch of the loop."""
    torch.manual_seed(chunk)
    model = TEMPModel(robot, 8, 16, eise_hidden=16, chunk=chunk, **SMALL)
    return TEMPPolicy(model, noise_std=noise_std, horizon=horizon)


def _grow(problem, policy, seed, compiled_loop, patience=0, goal_bias=0.05, uniform=0.0):
    policy.reset(problem, seed=seed)
    tree = Tree(problem, capacity=16)  # small: the compiled loop must grow it on the way
    rng = np.random.default_rng(seed)
    limits = AttentionLimits(1500, 1500, 150_000, patience)
    outcome = run_attention_phase(tree, policy, rng, goal_bias, limits, compiled_loop, uniform)
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
     ("kuka_iiwa14", "shipped", 0), ("point2d", "shipped-uniform", 0)],
)  # fmt: skip
def test_compiled_loop_grows_the_python_loops_tree(robot, policy_kind, patience):
    rng = np.random.default_rng(11)
    for index in range(3):
        problem = generate_problem(robot, rng, "challenging" if index % 2 else "easy")
        runs = []
        for compiled_loop in (True, False):
            if policy_kind.startswith("shipped"):
                policy = load_policy(robot, noise_std=0.05)
            elif "horizon" in policy_kind:
                policy = _chunked_policy(robot, 4, noise_std=0.05, horizon=2)
            else:
                policy = _chunked_policy(robot, int(policy_kind[-1]), noise_std=0.05)
            uniform = 0.2 if policy_kind.endswith("uniform") else 0.0
            runs.append(_grow(problem, policy, index, compiled_loop, patience, uniform=uniform))
        (tree_c, out_c, rng_c, noise_c), (tree_p, out_p, rng_p, noise_p) = runs
        assert out_c.compiled and not out_p.compiled
        _assert_same_tree(tree_c, tree_p)
        assert (out_c.stop, out_c.policy_calls, out_c.policy_samples) == (
            out_p.stop, out_p.policy_calls, out_p.policy_samples,
        )  # fmt: skip
        assert (rng_c, noise_c) == (rng_p, noise_p)  # both generators drew the same numbers
        assert tree_c.num_nodes > 16  # the arrays were grown


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


def test_a_horizon_uses_the_first_proposals_of_each_chunk():
    full = _chunked_policy("point2d", 4, noise_std=0.0)
    short = _chunked_policy("point2d", 4, noise_std=0.0, horizon=2)
    problem = generate_problem("point2d", np.random.default_rng(0))
    full.reset(problem)
    short.reset(problem)
    path = np.zeros((16, 2), np.float32)
    path[0] = [-0.5, 0.2]
    assert short.propose_chunk(path, 1).shape == (2, 2)
    np.testing.assert_array_equal(short.propose_chunk(path, 1), full.propose_chunk(path, 1)[:2])
    for bad in (0, 5, 1.5):
        with pytest.raises(ValueError, match="horizon"):
            _chunked_policy("point2d", 4, noise_std=0.0, horizon=bad)
