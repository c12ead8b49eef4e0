"""Reference paths for point worlds: the yardstick behind "easy" and "challenging".

A `ReferencePlanner` discretizes a point workspace into a lattice, keeps the free lattice
points, joins every pair of neighbours (up to two cells apart in 2D, one in 3D) whose segment
is free under the exact analytic checker (`point_checker`: every obstacle kind by its own
geometry, nothing rasterized), and answers start-goal queries with Dijkstra on that graph
followed by greedy shortcutting. The result is a collision-free path whose cost is an
upper bound on the optimal cost and, at the default resolution, typically within a few percent
of it. The graph is built once per workspace, so many tasks in one workspace are cheap.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from temp_gym.problem import Workspace
from temp_gym.worlds.collision.point_shapes import point_checker

DEFAULT_SPACING = {2: 0.25, 3: 0.5}
"""Lattice spacing per dimension for the default [0, 20]^d worlds."""


def has_lattice(workspace_dim: int, dim: int) -> bool:
    """Whether a robot of these dimensions has a reference lattice: a 2D or 3D point robot."""
    return dim == workspace_dim and dim in DEFAULT_SPACING


@dataclass(frozen=True)
class ReferencePath:
    """A reference solution: ``path`` (K x d) and its ``cost``; ``path`` is None if unreachable."""

    path: np.ndarray | None
    cost: float


def _neighbour_offsets(dim: int) -> np.ndarray:
    """Half of the symmetric neighbourhood (each undirected edge once), primitive directions."""
    reach = 2 if dim == 2 else 1
    offsets = []
    for offset in itertools.product(range(-reach, reach + 1), repeat=dim):
        offset = np.array(offset)
        if not offset.any() or np.gcd.reduce(np.abs(offset)) != 1:
            continue
        first_nonzero = offset[np.flatnonzero(offset)[0]]
        if first_nonzero > 0:
            offsets.append(offset)
    return np.array(offsets)


class ReferencePlanner:
    """Shortest paths on a free-space lattice of a point workspace, then shortcut.

    Args:
        workspace: a point robot's workspace (its configuration is its position, 2D or 3D).
        spacing: lattice spacing; defaults to `DEFAULT_SPACING` for the dimension.
    """

    def __init__(self, workspace: Workspace, spacing: float | None = None) -> None:
        dim = workspace.dim
        if not has_lattice(workspace.workspace_dim, dim):
            raise ValueError(
                f"robot: reference paths exist for point robots, not {workspace.robot}"
            )
        self.spacing = float(spacing or DEFAULT_SPACING[dim])
        self.checker = point_checker(workspace)
        lower, upper = workspace.bounds
        shape = np.floor((upper - lower) / self.spacing + 1e-9).astype(int) + 1
        self._shape = shape
        self._lower = lower
        axes = [lower[k] + self.spacing * np.arange(shape[k]) for k in range(dim)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)
        self._points = grid
        self._free = self.checker.states_free(grid)
        index = np.arange(len(grid)).reshape(shape)
        rows, cols, weights = [], [], []
        for offset in _neighbour_offsets(dim):
            src = index[
                tuple(slice(max(0, -o), shape[k] - max(0, o)) for k, o in enumerate(offset))
            ]
            dst = index[
                tuple(slice(max(0, o), shape[k] - max(0, -o)) for k, o in enumerate(offset))
            ]
            src, dst = src.ravel(), dst.ravel()
            both_free = self._free[src] & self._free[dst]
            src, dst = src[both_free], dst[both_free]
            ok = self.checker.edges_free(grid[src], grid[dst])
            rows.append(src[ok])
            cols.append(dst[ok])
            weights.append(np.full(ok.sum(), self.spacing * np.linalg.norm(offset)))
        rows_all = np.concatenate(rows)
        cols_all = np.concatenate(cols)
        weights_all = np.concatenate(weights)
        n = len(grid)
        self._graph = csr_matrix(
            (
                np.concatenate([weights_all, weights_all]),
                (np.concatenate([rows_all, cols_all]), np.concatenate([cols_all, rows_all])),
            ),
            shape=(n, n),
        )

    def _attach(self, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Free lattice points near ``point`` that it sees, with the distances to them."""
        radius = 2.0 * self.spacing
        cell = np.round((point - self._lower) / self.spacing).astype(int)
        ranges = [range(max(0, c - 2), min(self._shape[k], c + 3)) for k, c in enumerate(cell)]
        candidates = np.array(
            [np.ravel_multi_index(idx, self._shape) for idx in itertools.product(*ranges)]
        )
        candidates = candidates[self._free[candidates]]
        points = self._points[candidates]
        dist = np.linalg.norm(points - point, axis=1)
        near = dist <= radius
        candidates, points, dist = candidates[near], points[near], dist[near]
        if len(candidates) == 0:
            return candidates, dist
        visible = self.checker.edges_free(np.broadcast_to(point, points.shape), points)
        return candidates[visible], dist[visible]

    def shortcut(self, path: np.ndarray, length: float = np.inf) -> np.ndarray:
        """Greedy shortcutting: from each kept vertex jump to the farthest one it sees.

        With ``length``, shortcutting stops once the kept part is that long and the rest of
        ``path`` follows unchanged: the same start as the full shortcut, for less work.
        """
        kept = [0]
        i = 0
        covered = 0.0
        while i < len(path) - 1 and covered < length:
            ends = path[i + 1 :]
            visible = self.checker.edges_free(np.broadcast_to(path[i], ends.shape), ends)
            j = i + 1 + int(np.flatnonzero(visible)[-1])
            covered += float(np.linalg.norm(path[j] - path[i]))
            kept.append(j)
            i = j
        return np.concatenate([path[kept], path[i + 1 :]])

    def solve(self, start: np.ndarray, goal: np.ndarray) -> ReferencePath:
        """A collision-free path from ``start`` to ``goal`` and its cost (inf if none found)."""
        start = np.asarray(start, dtype=np.float64)
        goal = np.asarray(goal, dtype=np.float64)
        if self.checker.edge_free(start, goal):
            return ReferencePath(np.stack([start, goal]), float(np.linalg.norm(goal - start)))
        start_nodes, start_dist = self._attach(start)
        goal_nodes, goal_dist = self._attach(goal)
        if len(start_nodes) == 0 or len(goal_nodes) == 0:
            return ReferencePath(None, float("inf"))
        # One multi-source Dijkstra; the source offsets differ by at most two lattice steps and
        # the shortcut pass below removes the detours they could cause.
        dist, predecessors, sources = dijkstra(
            self._graph, indices=start_nodes, return_predecessors=True, min_only=True
        )
        totals = dist[goal_nodes] + goal_dist
        best = int(np.argmin(totals))
        if not np.isfinite(totals[best]):
            return ReferencePath(None, float("inf"))
        node = goal_nodes[best]
        source = sources[node]
        chain = [node]
        while node != source:
            node = predecessors[node]
            chain.append(node)
        lattice_path = self._points[chain[::-1]]
        path = self.shortcut(np.vstack([start, lattice_path, goal]))
        cost = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
        return ReferencePath(path, cost)


class GoalField:
    """Shortest paths to one goal from anywhere in a workspace: the expert of on-policy labels.

    One Dijkstra from the goal over the lattice of a `ReferencePlanner` gives every lattice
    point its cost to the goal; a query state joins the lattice through the points it sees,
    follows the predecessors to the goal and is shortcut, as `ReferencePlanner.solve` does.
    Many queries in one task cost one Dijkstra. On-policy correction
    (`temp_gym.data.correction`) asks it where the expert would go from the states a learned
    policy actually reaches.

    Args:
        reference: the workspace's lattice.
        goal: the goal state.
    """

    def __init__(self, reference: ReferencePlanner, goal: np.ndarray) -> None:
        self.reference = reference
        self.goal = np.asarray(goal, dtype=np.float64)
        goal_nodes, goal_dist = reference._attach(self.goal)
        self._reachable = len(goal_nodes) > 0
        if self._reachable:
            dist, predecessors, sources = dijkstra(
                reference._graph, indices=goal_nodes, return_predecessors=True, min_only=True
            )
            # Each lattice point's cost to the goal through the goal node its tree hangs from.
            offsets = np.full(len(dist), np.inf)
            reached = np.isfinite(dist)
            offset_of = dict(zip(goal_nodes.tolist(), goal_dist.tolist()))
            offsets[reached] = [offset_of[int(s)] for s in sources[reached]]
            self._cost = dist + offsets
            self._predecessors = predecessors

    def path(self, state: np.ndarray, length: float = np.inf) -> np.ndarray | None:
        """A collision-free path ``(K, d)`` from ``state`` to the goal, or None if there is none.

        ``length``: only the path's first ``length`` need be shortcut (`ReferencePlanner.shortcut`).
        """
        state = np.asarray(state, dtype=np.float64)
        checker = self.reference.checker
        if checker.edge_free(state, self.goal):
            return np.stack([state, self.goal])
        if not self._reachable:
            return None
        nodes, dist = self.reference._attach(state)
        if len(nodes) == 0:
            return None
        totals = dist + self._cost[nodes]
        best = int(np.argmin(totals))
        if not np.isfinite(totals[best]):
            return None
        chain = [int(nodes[best])]
        while self._predecessors[chain[-1]] >= 0:
            chain.append(int(self._predecessors[chain[-1]]))
        points = self.reference._points[chain]
        return self.reference.shortcut(np.vstack([state, points, self.goal]), length)
