"""On-policy correction (DAgger): label the states a learned policy reaches with the expert.

Behaviour cloning trains the MPT on the expert's own paths, but in attention-based planning the
policy reads the paths of *its* tree: after a fallback, a rewire or a wrong turn it stands in
states the expert never visited, and its errors compound (Ross et al. 2011, "A reduction of
imitation learning and structured prediction to no-regret online learning"). DAgger closes the
gap: plan with the current policy, record the path so far of every policy call, ask the expert
where it would go from the end of that path, add these samples to the data and train again.

The expert of point worlds is `temp_gym.worlds.reference.GoalField`: shortest lattice paths to
the goal from any state, shortcut, resampled at the steering step like the demonstrations
(`temp_gym.data.demonstrations.resample_path`). A sample holds the policy's own input (its
path so far, normalized, exactly as the planner handed it over) and, as targets, the expert's
next ``chunk`` nodes from the path's last node, with a mask where the expert's path ends
sooner.
"""

from __future__ import annotations

import numpy as np

from temp_gym.data.demonstrations import normalized_goal_radius, resample_path
from temp_gym.planning.attention import AttentionLimits, run_attention_phase
from temp_gym.planning.tree import Tree, default_step_size
from temp_gym.problem import Problem
from temp_gym.worlds.normalization import denormalize, normalize
from temp_gym.worlds.reference import GoalField


def expert_next_nodes(
    field: GoalField, state: np.ndarray, step: float, count: int
) -> tuple[np.ndarray, np.ndarray] | None:
    """The expert's next ``count`` nodes from ``state``: ``(nodes (count, d), mask (count,))``.

    Nodes past the end of the expert's path repeat its last node and are masked out; None when
    the expert finds no path from ``state``.
    """
    path = field.path(state, length=(count + 1) * step)
    if path is None:
        return None
    nodes = resample_path(path, step)[1 : count + 1]
    if len(nodes) == 0:  # the state is the goal itself
        return None
    mask = np.zeros(count, dtype=bool)
    mask[: len(nodes)] = True
    padded = np.concatenate([nodes, np.repeat(nodes[-1:], count - len(nodes), axis=0)])
    return padded, mask


class _Recorder:
    """A policy seen through ``propose_chunk``, keeping each call's input (the Python loop)."""

    def __init__(self, policy) -> None:
        self.policy = policy
        self.encoding_resolution = policy.encoding_resolution
        self.max_path_length = policy.max_path_length
        self.inputs: list[tuple[np.ndarray, int]] = []

    def reset(self, problem: Problem, seed: int | None = None) -> None:
        self.policy.reset(problem, seed=seed)

    def propose_chunk(self, path: np.ndarray, length: int) -> np.ndarray:
        self.inputs.append((np.array(path, dtype=np.float32), int(length)))
        return self.policy.propose_chunk(path, length)

    def __call__(self, observation):
        return self.policy(observation)


def correction_samples(
    policy,
    problem: Problem,
    field: GoalField,
    seed: int,
    max_nodes: int,
    max_samples: int,
    chunk: int,
    goal_bias: float = 0.05,
) -> dict[str, np.ndarray]:
    """Plan ``problem`` with ``policy`` (attention phase only) and label its inputs.

    Every policy call's path so far becomes a sample (at most ``max_samples``, evenly spread
    over the calls) whose targets are the expert's next ``chunk`` nodes from the path's last
    node. Keys: ``path`` (m, L, d), ``path_length`` (m, 1), ``start``, ``goal`` (m, d),
    ``goal_radius`` (m, 1), ``targets`` (m, chunk, d), ``target_mask`` (m, chunk), ``target``
    (m, d, the first target) and ``step`` (m,, the call's index), float32 and normalized like
    the demonstrations (`temp_gym.data.format`).
    """
    recorder = _Recorder(policy)
    recorder.reset(problem, seed=seed)
    tree = Tree(problem)
    limits = AttentionLimits(max_nodes, max_nodes, 100 * max_nodes, patience=0)
    run_attention_phase(tree, recorder, np.random.default_rng(seed), goal_bias, limits, False)
    calls = recorder.inputs
    if len(calls) > max_samples:
        keep = np.unique(np.linspace(0, len(calls) - 1, max_samples).round().astype(int))
        calls = [calls[i] for i in keep]
        indices = keep
    else:
        indices = np.arange(len(calls))
    step = default_step_size(problem)
    rows: dict[str, list] = {key: [] for key in ("path", "path_length", "targets", "target_mask",
                                                  "step")}  # fmt: skip
    for index, (path, length) in zip(indices, calls):
        state = denormalize(path[length - 1], problem.bounds)
        labelled = expert_next_nodes(field, state, step, chunk)
        if labelled is None:
            continue
        nodes, mask = labelled
        rows["path"].append(path)
        rows["path_length"].append([length])
        rows["targets"].append(normalize(nodes, problem.bounds).astype(np.float32))
        rows["target_mask"].append(mask)
        rows["step"].append(int(index))
    count, dim = len(rows["path"]), problem.dim
    out = {
        "path": np.array(rows["path"], dtype=np.float32).reshape(count, -1, dim),
        "path_length": np.array(rows["path_length"], dtype=np.int64).reshape(count, 1),
        "targets": np.array(rows["targets"], dtype=np.float32).reshape(count, chunk, dim),
        "target_mask": np.array(rows["target_mask"], dtype=bool).reshape(count, chunk),
        "step": np.array(rows["step"], dtype=np.int64),
    }
    out["target"] = out["targets"][:, 0].copy()
    for key, value in (("start", problem.start), ("goal", problem.goal)):
        out[key] = np.repeat(normalize(value, problem.bounds)[None].astype(np.float32), count, 0)
    radius = normalized_goal_radius(problem.goal_radius, problem.bounds)
    out["goal_radius"] = np.full((count, 1), radius, dtype=np.float32)
    return out
