"""What a sampling policy sees of a tree: the observation shared by the env and `plan`.

`TreeObserver` builds the observation dictionary documented in
`temp_gym.envs.PlanningEnv` (occupancy, start, goal, goal radius, the path so far, best cost,
solved, progress) from a `Tree`. The env returns it from `step`; the TEMP planner hands it to
its policy; so a policy sees the same thing in both and in the demonstrations
(`temp_gym.data.format`). The hot parts are numba kernels: the env's step should cost little
more than the tree extension it wraps.
"""

from __future__ import annotations

import numba
import numpy as np

from temp_gym.planning.tree import Tree
from temp_gym.problem import Problem
from temp_gym.worlds.normalization import half_range, normalize

DEFAULT_MAX_PATH_LENGTH = 64
"""Default L, the rows of the ``path`` (path-so-far) observation."""
MAX_RATIO = 100.0
"""Upper bound of the ratio observations (``goal_radius``, ``best_cost``); larger is clipped."""


@numba.njit(cache=True, nogil=True)
def action_to_sample(action, low, high, out) -> bool:
    """Clip ``action`` to [-1, 1] and map it into the bounds; False if any entry is not finite."""
    for k in range(action.shape[0]):
        a = action[k]
        if not np.isfinite(a):
            return False
        a = min(max(a, -1.0), 1.0)
        out[k] = low[k] + 0.5 * (a + 1.0) * (high[k] - low[k])
    return True


@numba.njit(cache=True, nogil=True)
def path_observation(links, positions, node, low, high, max_length):
    """Normalized float32 root path of ``node`` (its last ``max_length`` nodes), zero-padded.

    ``links[:, 0]`` is the parent (-1 at the root), as in `Tree`. Walking up from ``node``
    meets the newest nodes first, so at most ``max_length`` steps are needed. Returns the
    fresh ``(max_length, d)`` array and the number of valid rows.
    """
    stack = np.empty(max_length, dtype=np.int64)
    length = 0
    while node >= 0 and length < max_length:
        stack[length] = node
        length += 1
        node = links[node, 0]
    dim = positions.shape[1]
    out = np.zeros((max_length, dim), dtype=np.float32)
    for row in range(length):
        index = stack[length - 1 - row]  # the stack runs newest -> oldest
        for k in range(dim):
            out[row, k] = 2.0 * (positions[index, k] - low[k]) / (high[k] - low[k]) - 1.0
    return out, length


class TreeObserver:
    """Builds observations of trees grown on one problem.

    Args:
        problem: the query the trees solve.
        occupancy: its workspace's occupancy grid (`temp_gym.worlds.encoding.occupancy_grid`).
        max_path_length: rows L of the ``path`` entry.
        max_nodes: the node budget that ``progress`` is measured against.
    """

    def __init__(
        self, problem: Problem, occupancy: np.ndarray, max_path_length: int, max_nodes: int
    ) -> None:
        self.problem = problem
        self.max_path_length = int(max_path_length)
        self.max_nodes = int(max_nodes)
        self.low, self.high = problem.bounds
        self.distance = max(float(np.linalg.norm(problem.goal - problem.start)), 1e-12)
        radius = min(problem.goal_radius / half_range(problem.bounds).mean(), MAX_RATIO)
        self._static = {
            "occupancy": np.asarray(occupancy, dtype=np.float32),
            "start": normalize(problem.start, problem.bounds).astype(np.float32),
            "goal": normalize(problem.goal, problem.bounds).astype(np.float32),
            "goal_radius": np.array([radius], np.float32),
        }

    def action_to_sample(self, action: np.ndarray) -> np.ndarray:
        """World-unit sample of a normalized action (clipped); `ValueError` if not finite."""
        action = np.asarray(action, dtype=np.float64)
        if action.shape != self.low.shape:
            raise ValueError(f"action: expected shape {self.low.shape}, got {action.shape}")
        sample = np.empty(len(self.low))
        if not action_to_sample(action, self.low, self.high, sample):
            raise ValueError(f"action: must be finite, got {action.tolist()}")
        return sample

    def observe(self, tree: Tree) -> dict[str, np.ndarray]:
        """A fresh observation of ``tree`` (every array is new)."""
        path, length = path_observation(
            tree.links, tree.positions, tree.newest, self.low, self.high, self.max_path_length
        )
        solved = tree.best_node >= 0
        static = self._static
        # One fresh array for the three scalar entries; each key gets its own row (a view).
        scalars = np.array(
            [
                [min(tree.best_cost / self.distance, MAX_RATIO) if solved else 0.0],
                [1.0 if solved else 0.0],
                [min(tree.num_nodes / self.max_nodes, 1.0)],
            ],
            np.float32,
        )
        return {
            "occupancy": static["occupancy"].copy(),
            "start": static["start"].copy(),
            "goal": static["goal"].copy(),
            "goal_radius": static["goal_radius"].copy(),
            "path": path,
            "path_length": np.array([length], np.int64),
            "best_cost": scalars[0],
            "solved": scalars[1],
            "progress": scalars[2],
        }
