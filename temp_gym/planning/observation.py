"""What a sampling policy sees of a tree: the observation shared by the env and `plan`.

`TreeObserver` builds the observation dictionary documented in
`temp_gym.envs.PlanningEnv` (occupancy, start, goal, goal radius, the path so far, best cost,
solved, progress) from a `Tree`. The env returns it from `step`; the TEMP planner hands it to
its policy; so a policy sees the same thing in both and in the demonstrations
(`temp_gym.data.format`).

The env's step should cost little more than the tree extension it wraps, so the observer
keeps the observation's float32 entries in one state block, brought up to date by one numba
kernel when the tree has grown, and every observation is a fresh copy of that block whose
entries are disjoint views of it; ``occupancy`` and ``path_length`` are copies of their own.
No two observations share memory.
"""

from __future__ import annotations

import numbers

import numba
import numpy as np

from temp_gym.limits import MAX_PATH_LENGTH
from temp_gym.planning.tree import Tree
from temp_gym.problem import Problem
from temp_gym.worlds.normalization import MAX_RATIO, goal_radius_ratio, normalize

DEFAULT_MAX_PATH_LENGTH = 64
"""Default L, the rows of the ``path`` (path-so-far) observation."""


def check_path_length(value: object, name: str = "max_path_length") -> int:
    """``value`` as L, the rows of the path observation, checked.

    An integer from 2 (the start and one node) to `temp_gym.limits.MAX_PATH_LENGTH`.

    Raises:
        ValueError: anything else, in one line naming ``name``.
    """
    integral = isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if not integral or not 2 <= value <= MAX_PATH_LENGTH:
        raise ValueError(f"{name}: expected an integer from 2 to {MAX_PATH_LENGTH}, got {value!r}")
    return int(value)


# Not nogil: releasing and taking back the GIL costs more than this microsecond kernel.
@numba.njit(cache=True)
def update_observation(
    state, path_length, links, positions, params, node, best_node, best_cost, count
):
    """Bring the per-step entries of an observer's state block up to date with a tree.

    ``state`` holds the static entries, then ``best_cost``, ``solved``, ``progress`` and
    ``path`` (its last L * d floats). ``params`` is ``(start-goal distance, max_nodes, L,
    lower bounds (d), upper bounds (d))``, one array because every argument costs dispatch
    time. ``path`` gets the normalized root path of ``node`` (its last L nodes), zero-padded;
    ``links[:, 0]`` is the parent (-1 at the root), as in `Tree`. Walking up from ``node``
    meets the newest nodes first, so the rows are written from the last one backwards; of
    the padding only the rows the previous path used (``path_length[0]`` rows) are cleared.
    ``path_length[0]`` gets the new number of rows.
    """
    dim = positions.shape[1]
    max_length = np.int64(params[2])
    offset = state.shape[0] - max_length * dim
    solved = best_node >= 0
    state[offset - 3] = min(best_cost / params[0], MAX_RATIO) if solved else 0.0
    state[offset - 2] = 1.0 if solved else 0.0
    state[offset - 1] = min(count / params[1], 1.0)
    length = 0
    probe = node
    while probe >= 0 and length < max_length:
        length += 1
        probe = links[probe, 0]
    for index in range(offset + length * dim, offset + path_length[0] * dim):
        state[index] = 0.0
    for row in range(length - 1, -1, -1):
        base = offset + row * dim
        for k in range(dim):
            low = params[3 + k]
            state[base + k] = 2.0 * (positions[node, k] - low) / (params[3 + dim + k] - low) - 1.0
        node = links[node, 0]
    path_length[0] = length


def task_entries(problem: Problem) -> dict[str, np.ndarray]:
    """The observation's task entries: ``start``, ``goal`` and ``goal_radius``, float32.

    What every observation of a tree grown on ``problem`` carries, so a policy can tell from an
    observation which task it belongs to (`temp_gym.policies.task_signature`).
    """
    radius = goal_radius_ratio(problem.goal_radius, problem.bounds)
    return {
        "start": normalize(problem.start, problem.bounds).astype(np.float32),
        "goal": normalize(problem.goal, problem.bounds).astype(np.float32),
        "goal_radius": np.array([radius], np.float32),
    }


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
        # A floor relative to the bounds (a start inside the goal region may sit on it), not
        # an absolute one: worlds may be 1e-30 across.
        floor = 1e-12 * float(np.linalg.norm(problem.bounds[1] - problem.bounds[0]))
        self.distance = max(float(np.linalg.norm(problem.goal - problem.start)), floor)
        self._params = np.concatenate(
            [[self.distance, self.max_nodes, self.max_path_length], np.ravel(problem.bounds)]
        )
        self._occupancy = np.array(occupancy, dtype=np.float32)
        # The block: start | goal | goal_radius | best_cost | solved | progress | path.
        dim = problem.dim
        sizes = [dim, dim, 1, 1, 1, 1, self.max_path_length * dim]
        ends = np.cumsum(sizes).tolist()
        self._slices = tuple(slice(b, e) for b, e in zip([0] + ends[:-1], ends))
        self._path_shape = (self.max_path_length, dim)
        self._state = np.zeros(ends[-1], np.float32)
        self._state[: ends[2]] = np.concatenate(list(task_entries(problem).values()))
        # What `observe` reads, in one attribute. The state block and path length are
        # updated in place and copied into every observation.
        self._tree: Tree | None = None
        self._nodes = -1
        self._node = -1
        self._parts = (
            self._state,
            np.zeros(1, np.int64),
            self._params,
            self._occupancy,
            self._path_shape,
            self._slices,
        )

    def _sync(self, tree: Tree, node: int | None) -> None:
        """Bring the state block up to date with ``tree`` and the root path of ``node``.

        ``node`` None is the newest node. Only when the tree is another one, has grown, or the
        node is another one.
        """
        state, length, params = self._parts[:3]
        node = tree.newest if node is None else int(node)
        if tree is not self._tree or tree.num_nodes != self._nodes or node != self._node:
            if not 0 <= node < tree.num_nodes:
                raise ValueError(f"node: expected a node of the tree (0..{tree.num_nodes - 1}), "
                                 f"got {node}")  # fmt: skip
            update_observation(
                state,
                length,
                tree.links,
                tree.positions,
                params,
                node,
                tree.best_node,
                tree.best_cost,
                tree.num_nodes,
            )
            self._tree = tree
            self._nodes = tree.num_nodes
            self._node = node

    def path_so_far(self, tree: Tree, node: int | None = None) -> tuple[np.ndarray, int]:
        """The ``path`` and ``path_length`` entries of `observe`, without building the rest.

        Returns the observer's own ``(L, d)`` float32 rows (a view, valid until the next call:
        read it, do not keep or change it) and the number of valid rows. The TEMP planner's
        policy reads only these, once per step. ``node``: whose root path (None: the newest
        node's, Algorithm 1's sigma').
        """
        self._sync(tree, node)
        state, length, _, _, path_shape, slices = self._parts
        return state[slices[-1]].reshape(path_shape), int(length[0])

    def observe(self, tree: Tree, node: int | None = None) -> dict[str, np.ndarray]:
        """A fresh observation of ``tree``: no array is shared with another observation.

        The float32 entries but ``occupancy`` are disjoint views of one new block, a copy of
        the observer's state. The state is updated only when ``tree`` is another tree or has
        grown since the last call (a tree changes only by gaining a node: `Tree.extend`
        leaves it unchanged otherwise, so a failed extension costs no update), or when
        ``node``, whose root path the observation carries (None: the newest node's), changed.
        """
        self._sync(tree, node)
        state, length, _, occupancy, path_shape, slices = self._parts
        block = state.copy()
        start, goal, radius, best_cost, solved, progress, path = slices
        return {
            "occupancy": occupancy.copy(),
            "start": block[start],
            "goal": block[goal],
            "goal_radius": block[radius],
            "path": block[path].reshape(path_shape),
            "path_length": length.copy(),
            "best_cost": block[best_cost],
            "solved": block[solved],
            "progress": block[progress],
        }
