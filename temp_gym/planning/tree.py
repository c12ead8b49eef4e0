"""The tree-extension core: one RRT* tree that every planner and the Gymnasium env drive.

`Tree.extend` is the single entry point: give it a sample, and it steers from the nearest
node, checks the steered edge (motion validity), chooses the cheapest collision-free parent
among the near nodes, inserts the node, rewires the near nodes through it (propagating the
lower costs to all their descendants) and updates the best solution. RRT* is a loop of
`extend` over uniform samples; Informed RRT* changes the sampler; TEMP's attention phase
calls `Tree.extend_with_fallback` (Algorithm 1, lines 5-10); the env calls `extend` once
per step.

The tree is stored in preallocated numpy arrays that double when full (no object per node)
and the hot loops are numba kernels (`temp_gym.planning._kernels`).

Near neighbours (Karaman & Frazzoli 2011, "Sampling-based algorithms for optimal motion
planning", Thm. 38 and its k-nearest variant), with ``n`` the number of nodes plus one:

* ``"radius"`` (default): ``r = min(gamma * (log n / n) ** (1/d), max_radius)`` with
  ``gamma = rewire_factor * 2 * (1 + 1/d) ** (1/d) * (mu_free / zeta_d) ** (1/d)``, where
  ``mu_free`` is the free configuration-space volume (exact when the checker offers
  ``free_volume()``, as the point robots' does; else estimated by Monte Carlo with the fast
  checker; once per workspace and process: `workspace_free_volume`) and ``zeta_d`` the volume
  of the unit d-ball. ``rewire_factor > 1`` keeps ``gamma`` above the asymptotic-optimality
  bound. ``max_radius`` defaults to ``2 * step_size``: for the budgets we run the cap is what
  binds, so while a cheap lower bound of ``mu_free`` (`free_volume_floor`) already puts the
  radius at the cap, the exact volume is not computed (`Tree._gamma_for`; same radii).
* ``"k_nearest"``: ``k = ceil(rewire_factor * e * (1 + 1/d) * log n)`` nearest nodes.

Examples:
    >>> tree = Tree(problem)
    >>> result = tree.extend(np.array([5.0, 5.0]))
    >>> result.node, tree.num_nodes, tree.best_cost
    (1, 2, inf)
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from temp_gym.planning import _compiled_tree, _grid
from temp_gym.planning import _kernels as kernels
from temp_gym.worlds.checkers import make_checker
from temp_gym.worlds.collision import CollisionChecker
from temp_gym.worlds.collision.compiled import compiled_context_of
from temp_gym.worlds.robots import robot_spec

if TYPE_CHECKING:
    from temp_gym.problem import Problem, Workspace

NEIGHBOURHOODS = ("radius", "k_nearest")
_FREE_VOLUME_SAMPLES = 4096
_FREE_VOLUME_CACHE: OrderedDict[Workspace, float] = OrderedDict()
_FREE_VOLUME_FLOOR_CACHE: OrderedDict[Workspace, float | None] = OrderedDict()
_FREE_VOLUME_CACHE_SIZE = 256


def default_step_size(problem: Problem) -> float:
    """The steering step ``e`` used when none is given: the robot's (`RobotSpec.step_size`).

    Point robots: 5% of the largest side of the bounds (1.0 in the usual ``[0, 20]^d``
    worlds). The 7-DOF iiwa: 0.5 rad in joint space.
    """
    return robot_spec(problem.robot).default_step_size(problem.bounds)


def unit_ball_volume(dim: int) -> float:
    """Volume ``zeta_d`` of the unit ball in ``dim`` dimensions."""
    return math.pi ** (dim / 2) / math.gamma(dim / 2 + 1)


def estimate_free_volume(problem: Problem, checker: CollisionChecker) -> float:
    """The free configuration-space volume: exact when ``checker`` has ``free_volume()``.

    Otherwise a Monte Carlo estimate with the checker's `states_free` (deterministic). Either
    way at least ``1 / _FREE_VOLUME_SAMPLES`` of the bounds, so that ``gamma`` stays positive.
    """
    low, high = problem.bounds
    total = float(np.prod(high - low))
    exact = getattr(checker, "free_volume", None)
    if exact is not None:
        fraction = float(exact()) / total
    else:
        rng = np.random.default_rng(0)
        states = rng.uniform(low, high, size=(_FREE_VOLUME_SAMPLES, problem.dim))
        fraction = float(np.mean(checker.states_free(states)))
    return _at_least_a_sliver(fraction, total)


def _at_least_a_sliver(fraction: float, total: float) -> float:
    """``fraction`` of the bounds' volume ``total``, at least ``1 / _FREE_VOLUME_SAMPLES`` of it.

    Monotone in ``fraction``, so a lower bound of the fraction gives a lower bound of the result.
    """
    return max(fraction, 1.0 / _FREE_VOLUME_SAMPLES) * total


def free_volume_floor(problem: Problem, checker: CollisionChecker) -> float:
    """A lower bound of `estimate_free_volume` that costs next to nothing.

    From the checker's ``free_volume_floor()`` when it has one (the point robots': the bounds
    less the sum of the boxes' volumes), else the sliver `estimate_free_volume` never goes
    below (``1 / _FREE_VOLUME_SAMPLES`` of the bounds: the iiwa's, whose free space only a
    Monte Carlo estimate measures), clamped as `estimate_free_volume` clamps. `Tree` uses it
    to put off the exact volume until a tree grows large enough for it to matter; in the
    iiwa's seven dimensions even the sliver puts the radius at its cap for thousands of nodes.
    """
    low, high = problem.bounds
    total = float(np.prod(high - low))
    floor = getattr(checker, "free_volume_floor", None)
    fraction = 0.0 if floor is None else float(floor()) / total
    return _at_least_a_sliver(fraction, total)


def workspace_free_volume(problem: Problem, checker: CollisionChecker) -> float:
    """`estimate_free_volume` for the default checker of ``problem``, remembered per workspace.

    The estimate depends only on the robot, the bounds and the boxes (its samples are seeded),
    not on the start and goal, so many queries in one workspace (a user's scene, an
    evaluation) pay it once per process (the iiwa's Monte Carlo estimate is worth keeping;
    the point robots' exact volume is cheap either way). The last `_FREE_VOLUME_CACHE_SIZE`
    workspaces are kept.
    ``checker`` must be ``make_checker(problem)``'s kind; `Tree` asks for no estimate of
    another checker here.
    """
    return _remembered(_FREE_VOLUME_CACHE, problem, checker, estimate_free_volume)


def workspace_free_volume_floor(problem: Problem, checker: CollisionChecker) -> float:
    """`free_volume_floor` for the default checker of ``problem``, remembered per workspace.

    Every `Tree` on a workspace whose exact volume it never needed asks for the floor again;
    remembered, a new tree in a known workspace skips the pass over the boxes.
    """
    return _remembered(_FREE_VOLUME_FLOOR_CACHE, problem, checker, free_volume_floor)


def _remembered(
    cache: OrderedDict, problem: Problem, checker: CollisionChecker, compute: Callable
) -> Any:
    """``compute(problem, checker)``, remembered in ``cache`` per workspace.

    The last `_FREE_VOLUME_CACHE_SIZE` workspaces are kept.
    """
    key = problem.workspace
    if key in cache:
        cache.move_to_end(key)
        return cache[key]
    value = compute(problem, checker)
    cache[key] = value
    if len(cache) > _FREE_VOLUME_CACHE_SIZE:
        cache.popitem(last=False)
    return value


def forget_workspace(workspace: Workspace) -> None:
    """Forget what `Tree` remembers of ``workspace`` (its free volume and the volume's floor).

    The next `Tree` on it then pays that set-up again, as the first plan on a new workspace
    does. The paper's protocol calls this before every timed run, so that each planner, not
    only the first to run on a test task's workspace, is timed as a user's first plan there
    (`temp_gym.evaluation.runner`, ``fresh_workspaces``).
    """
    _FREE_VOLUME_CACHE.pop(workspace, None)
    _FREE_VOLUME_FLOOR_CACHE.pop(workspace, None)


class Sampler(Protocol):
    """Anything that draws one configuration from an explicit generator."""

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """Return one state of shape ``(d,)``."""
        ...


@dataclass(frozen=True, slots=True)
class ExtendResult:
    """What one `Tree.extend` (or `Tree.extend_with_fallback`) call did."""

    node: int
    """Index of the node added, or -1 when none was (the steered edge collided)."""
    nearest: int
    """The nearest node the last tried sample was steered from."""
    collided: bool
    """Whether the last tried steered edge was in collision."""
    reached_goal: bool
    """Whether the added node lies in the goal region."""
    improved: bool
    """Whether the best solution cost went down during this call."""
    rewired: int
    """How many near nodes were re-parented through the new node."""
    samples: int
    """Samples used: 1 for `Tree.extend`, 1 + random retries for the fallback."""
    failures: int
    """Samples whose extension failed (collided or zero-length) during this call."""
    collision_checks: int
    """State and edge checks performed during this call."""


class Tree:
    """An RRT* tree over one `Problem`, grown one sample at a time.

    Args:
        problem: The query; the root is ``problem.start``.
        checker: Fast collision checker; defaults to ``make_checker(problem)``.
        step_size: Steering step ``e``; defaults to `default_step_size`.
        neighbourhood: ``"radius"`` or ``"k_nearest"`` (see the module docstring).
        rewire_factor: Multiplies ``gamma`` (radius) or ``k`` (k-nearest); above 1.
        max_radius: Cap of the near radius; defaults to ``2 * step_size``.
        parent_check_chunk: Parent candidates are collision-checked in cost order, this many
            per batched call, stopping at the first free one. Small for expensive checkers.
        compiled_extend: Run each `extend` as one compiled call
            (`temp_gym.planning._compiled_tree.extend_detailed`, with the checker's compiled
            motion check) instead of driving the kernels and the checker from Python: the same
            tree, result and counters, for less time per call. None (default): when
            the checker has a compiled path; False: never (the reference path); True: an
            error without one.
        capacity: Initial node capacity; doubles when full.
        checker_of: A tree on the same workspace whose checker this one uses, as if it had
            made its own (the free volume is the workspace's): a tree grown from the goal
            beside one from the start, without building a second checker. Not with
            ``checker``.

    Counters for wrappers and results: `num_nodes`, `samples`, `sampling_failures`,
    `collision_checks`; solution: `best_node`, `best_cost`, `best_path`; the newest node's
    root path (TEMP's "path so far") is `path_so_far`.
    """

    def __init__(
        self,
        problem: Problem,
        checker: CollisionChecker | None = None,
        step_size: float | None = None,
        neighbourhood: str = "radius",
        rewire_factor: float = 1.1,
        max_radius: float | None = None,
        parent_check_chunk: int = 8,
        capacity: int = 1024,
        compiled_extend: bool | None = None,
        *,
        checker_of: Tree | None = None,
    ) -> None:
        if neighbourhood not in NEIGHBOURHOODS:
            raise ValueError(
                f"neighbourhood: expected one of {NEIGHBOURHOODS}, got {neighbourhood!r}"
            )
        step_size = default_step_size(problem) if step_size is None else float(step_size)
        if not math.isfinite(step_size) or step_size <= 0:
            raise ValueError(f"step_size: must be positive and finite, got {step_size}")
        if not rewire_factor > 0:
            raise ValueError(f"rewire_factor: must be positive, got {rewire_factor}")
        if parent_check_chunk < 1:
            raise ValueError(f"parent_check_chunk: must be at least 1, got {parent_check_chunk}")
        if compiled_extend not in (None, True, False):
            raise ValueError(
                f"compiled_extend: expected None, True or False, got {compiled_extend!r}"
            )
        if checker_of is not None and (checker is not None or (
                checker_of.problem.workspace is not problem.workspace
                and checker_of.problem.workspace != problem.workspace)):  # fmt: skip
            raise ValueError("checker_of: expected a tree on this problem's workspace, and no "
                             "checker")  # fmt: skip
        self.problem = problem
        if checker_of is not None:
            self.checker = checker_of.checker
        else:
            self.checker = make_checker(problem) if checker is None else checker
        self.dim = problem.dim
        self.step_size = step_size
        self.neighbourhood = neighbourhood
        self.rewire_factor = float(rewire_factor)
        self.max_radius = 2.0 * step_size if max_radius is None else float(max_radius)
        self.parent_check_chunk = int(parent_check_chunk)
        self._compiled_extend = compiled_extend
        self._extend_context: tuple | None | bool = False  # False: not looked up yet
        self._goal = np.ascontiguousarray(problem.goal, dtype=np.float64)
        self._bounds = np.ascontiguousarray(problem.bounds, dtype=np.float64)
        self._goal_radius_sq = problem.goal_radius**2
        dim = self.dim
        self._gamma: float | None = None  # exact, computed when first needed
        self._gamma_floor: float | None = None  # a lower bound, while the cap binds anyway
        if neighbourhood == "radius":
            if checker is not None:  # a caller's own checker may see other free space
                self._gamma = self._radius_gamma(estimate_free_volume(problem, self.checker))
            elif problem.workspace not in _FREE_VOLUME_CACHE:  # else `gamma` reads the cache
                floor = workspace_free_volume_floor(problem, self.checker)
                self._gamma_floor = self._radius_gamma(floor)
        else:
            self._gamma = self.rewire_factor * math.e * (1.0 + 1.0 / dim)
        capacity = max(int(capacity), 2)
        self._gamma_in_use = self._gamma_for(capacity)
        self.positions = np.empty((capacity, dim))
        self.costs = np.empty(capacity)
        self.links = np.empty((capacity, 3), dtype=np.int64)
        self._near_idx = np.empty(capacity, dtype=np.int64)
        self._near_dist = np.empty(capacity)
        self._cand_idx = np.empty(capacity, dtype=np.int64)
        self._stack = np.empty(capacity, dtype=np.int64)
        self._goal_nodes = np.empty(capacity, dtype=np.int64)
        self._new = np.empty(dim)
        self._grid = _grid.NO_GRID
        self._grid_for(capacity)
        self.positions[0] = problem.start
        self.costs[0] = 0.0
        self.links[0] = (-1, -1, -1)
        self.num_nodes = 1
        self.num_goal_nodes = 0
        self.newest = 0
        """Index of the most recently added node (0, the root, before any)."""
        self.best_node = -1
        self.best_cost = math.inf
        self.samples = 0
        self.sampling_failures = 0
        self.collision_checks = 0
        if float(np.add.reduce((problem.start - self._goal) ** 2)) <= self._goal_radius_sq:
            self._goal_nodes[0] = 0
            self.num_goal_nodes = 1
            self.best_node, self.best_cost = 0, 0.0

    # ------------------------------------------------------------------ queries
    @property
    def capacity(self) -> int:
        """Nodes the arrays hold before the next doubling."""
        return len(self.costs)

    @property
    def parents(self) -> np.ndarray:
        """Parent index per node (-1 for the root), a view of length `num_nodes`."""
        return self.links[: self.num_nodes, kernels.PARENT]

    @property
    def goal_nodes(self) -> np.ndarray:
        """Indices of the nodes inside the goal region, in insertion order (a copy)."""
        return self._goal_nodes[: self.num_goal_nodes].copy()

    @property
    def gamma(self) -> float:
        """``gamma`` of the radius rule (module docstring), or k's factor for k-nearest."""
        if self._gamma is None:
            self._gamma = self._radius_gamma(workspace_free_volume(self.problem, self.checker))
        return self._gamma

    def _radius_gamma(self, free_volume: float) -> float:
        dim = self.dim
        return (
            self.rewire_factor
            * 2.0
            * (1.0 + 1.0 / dim) ** (1.0 / dim)
            * (free_volume / unit_ball_volume(dim)) ** (1.0 / dim)
        )

    def _gamma_for(self, capacity: int) -> float:
        """The ``gamma`` the extensions use while the tree has at most ``capacity`` nodes.

        The radius rule takes the smaller of ``gamma * (log n / n) ** (1/d)`` and the cap. While
        a lower bound of ``gamma`` already reaches the cap for every n up to ``capacity``
        (``log n / n`` is smallest at n = 2 or n = capacity), the exact ``gamma`` reaches it
        too and the radius is the cap either way: the bound stands in, and the exact free
        volume (a coordinate-compression pass over the boxes, costly in 3D; a Monte Carlo
        estimate for the iiwa) is computed only when a tree grows past that point. Same radii,
        so the same trees.
        """
        floor = self._gamma_floor
        if self._gamma is None and floor is not None:
            inverse_dim = 1.0 / self.dim
            smallest = min(math.log(2) / 2, math.log(capacity) / capacity)
            # A margin for rounding: the kernels compute the same expression per n.
            if floor * smallest**inverse_dim >= self.max_radius * (1.0 + 1e-9):
                return floor
        return self.gamma

    def near_radius(self) -> float:
        """The current near radius (radius rule) before the next insertion."""
        n = self.num_nodes + 1
        return min(self._gamma_in_use * (math.log(n) / n) ** (1.0 / self.dim), self.max_radius)

    def near_count(self) -> int:
        """The current k of the k-nearest rule before the next insertion."""
        return max(1, math.ceil(self.gamma * math.log(self.num_nodes + 1)))

    def in_goal(self, state: np.ndarray) -> bool:
        """Whether ``state`` lies in the goal region (closed ball)."""
        diff = np.asarray(state, dtype=np.float64) - self._goal
        return float(diff @ diff) <= self._goal_radius_sq

    def path_indices(self, node: int) -> np.ndarray:
        """Node indices from the root to ``node``."""
        if not 0 <= node < self.num_nodes:
            raise IndexError(f"node: {node} is not in the tree of {self.num_nodes} nodes")
        count = kernels.root_path_indices(self.links, node, self._stack)
        return self._stack[:count][::-1].copy()

    def path_to(self, node: int) -> np.ndarray:
        """States ``(K, d)`` from the root to ``node`` (a fresh array)."""
        return self.positions[self.path_indices(node)]

    def path_so_far(self) -> np.ndarray:
        """The root path of the newest node: TEMP's sigma' (Algorithm 1, line 13)."""
        return self.path_to(self.newest)

    def best_path(self) -> np.ndarray | None:
        """Root path of the cheapest goal node, or None before the first solution."""
        return None if self.best_node < 0 else self.path_to(self.best_node)

    # ------------------------------------------------------------------ compiled loops
    def compiled_state(self) -> tuple[tuple[np.ndarray, ...], np.ndarray, np.ndarray, np.ndarray]:
        """The tree as `temp_gym.planning._compiled_tree` takes it: arrays, counters, cost, params.

        ``arrays`` are the tree's own (a compiled extension writes into them); ``counters``
        (int64, `_compiled_tree.COUNTERS`) and ``best_cost`` (float64, one entry) are copies
        to hand back with `load_compiled_state`; ``params`` holds the settings
        (`_compiled_tree.PARAMETERS`). Growing the tree replaces its arrays: take the state
        again after `grow`.
        """
        arrays = (self.positions, self.costs, self.links, self._goal_nodes, self._near_idx,
                  self._near_dist, self._cand_idx, self._stack, self._new, self._grid)  # fmt: skip
        counters = np.array(
            [self.num_nodes, self.num_goal_nodes, self.newest, self.best_node, self.samples,
             self.sampling_failures, self.collision_checks],
            dtype=np.int64,
        )  # fmt: skip
        params = np.array(
            [self.step_size, self._gamma_in_use, self.max_radius, self._goal_radius_sq,
             1.0 if self.neighbourhood == "k_nearest" else 0.0]
        )  # fmt: skip
        return arrays, counters, np.array([self.best_cost]), params

    def load_compiled_state(self, counters: np.ndarray, best_cost: np.ndarray) -> None:
        """Take back the counters a compiled extension updated (see `compiled_state`)."""
        (self.num_nodes, self.num_goal_nodes, self.newest, self.best_node, self.samples,
         self.sampling_failures, self.collision_checks) = (int(c) for c in counters)  # fmt: skip
        self.best_cost = float(best_cost[0])

    def grow(self) -> None:
        """Double the node capacity now (extensions do so by themselves when full)."""
        self._grow()

    # ------------------------------------------------------------------ growth
    def _grow(self) -> None:
        capacity = 2 * self.capacity
        self._gamma_in_use = self._gamma_for(capacity)
        for name in ("positions", "costs", "links"):
            old = getattr(self, name)
            new = np.empty((capacity,) + old.shape[1:], dtype=old.dtype)
            new[: self.num_nodes] = old[: self.num_nodes]
            setattr(self, name, new)
        goal_nodes = np.empty(capacity, dtype=np.int64)
        goal_nodes[: self.num_goal_nodes] = self._goal_nodes[: self.num_goal_nodes]
        self._goal_nodes = goal_nodes
        self._near_idx = np.empty(capacity, dtype=np.int64)
        self._near_dist = np.empty(capacity)
        self._cand_idx = np.empty(capacity, dtype=np.int64)
        self._stack = np.empty(capacity, dtype=np.int64)
        self._grid_for(capacity)

    def _grid_for(self, capacity: int) -> None:
        """Room for ``capacity`` nodes in the tree's grid (`temp_gym.planning._grid`).

        The grid is made once the arrays outgrow `_grid.GRID_MIN_NODES` (point robots only).
        """
        if self._grid is not _grid.NO_GRID:
            self._grid = _grid.grown(self._grid, capacity)
        elif capacity > _grid.GRID_MIN_NODES and self.dim <= 3:
            self._grid = _grid.make_grid(self._bounds, self.max_radius, capacity)

    # ------------------------------------------------------------------ extension
    def extend(self, sample: np.ndarray, normalized: bool = False) -> ExtendResult:
        """Extend the tree towards ``sample`` (one RRT* iteration after sampling).

        Args:
            sample: A state of shape ``(d,)``; it need not be free or in bounds.
            normalized: ``sample`` is a normalized action (the env's): it is clipped to
                [-1, 1]^d and mapped into the problem's bounds (-1 and 1 to the lower and
                upper bounds) by the kernel that also finds the nearest node. A NaN or inf
                entry then raises `ValueError` and leaves the tree unchanged.

        Returns:
            An `ExtendResult`; ``node == -1`` when the steered edge collided (or the sample
            coincided with its nearest node), in which case the tree is unchanged.
        """
        if type(sample) is not np.ndarray or sample.dtype != np.float64:
            sample = self._as_point(sample, "action" if normalized else "sample")
        if sample.shape != (self.dim,):
            name = "action" if normalized else "sample"
            raise ValueError(f"{name}: expected shape ({self.dim},), got {sample.shape}")
        context = self._extend_context
        if context is False:
            context = self._extend_context = self._compiled_context()
        if context is not None:
            return self._extend_compiled(sample, normalized, context)
        new = self._new
        if normalized:
            nearest, distance = kernels.action_nearest_and_steer(
                self.positions, self.num_nodes, sample, self._bounds, self.step_size, new,
                self._grid, self._near_idx,
            )  # fmt: skip
            if nearest < 0:
                raise ValueError(f"action: must be finite, got {sample.tolist()}")
        else:
            nearest, distance = kernels.nearest_and_steer(
                self.positions,
                self.num_nodes,
                sample,
                self.step_size,
                new,
                self._grid,
                self._near_idx,
            )
        self.samples += 1
        if not distance > 0.0:
            self.sampling_failures += 1
            return ExtendResult(-1, nearest, False, False, False, 0, 1, 1, 0)
        checks = 1
        if not self.checker.edge_free(self.positions[nearest], new):
            self.sampling_failures += 1
            self.collision_checks += 1
            return ExtendResult(-1, nearest, True, False, False, 0, 1, 1, 1)
        if self.num_nodes == self.capacity:
            self._grow()
        radius, k = (
            (self.near_radius(), 0) if self.neighbourhood == "radius" else (0.0, self.near_count())
        )
        num_near, num_cand = kernels.near_and_parent_candidates(
            self.positions,
            self.costs,
            self.num_nodes,
            new,
            nearest,
            radius,
            k,
            self._near_idx,
            self._near_dist,
            self._cand_idx,
            self._grid,
        )
        parent = nearest
        chunk = self.parent_check_chunk
        for begin in range(0, num_cand, chunk):
            cands = self._cand_idx[begin : min(begin + chunk, num_cand)]
            free = self.checker.edges_free(
                self.positions[cands], np.repeat(new[None], len(cands), 0)
            )
            checks += len(cands)
            hits = np.flatnonzero(free)
            if len(hits):
                parent = int(cands[hits[0]])
                break
        node = self.num_nodes
        cost, reached_goal, num_rewire = kernels.insert_node(
            self.positions,
            self.costs,
            self.links,
            node,
            new,
            parent,
            self._goal,
            self._goal_radius_sq,
            self._near_idx,
            self._near_dist,
            num_near,
            self._cand_idx,
        )
        self.num_nodes += 1
        self.newest = node
        best_before = self.best_cost
        if reached_goal:
            self._goal_nodes[self.num_goal_nodes] = node
            self.num_goal_nodes += 1
            if cost < self.best_cost:
                self.best_node, self.best_cost = node, cost
        rewired = 0
        if num_rewire:
            targets = self._cand_idx[:num_rewire]
            free = self.checker.edges_free(
                np.repeat(new[None], num_rewire, 0), self.positions[targets]
            )
            checks += num_rewire
            rewired, best = kernels.apply_rewires(
                self.positions,
                self.costs,
                self.links,
                node,
                targets,
                np.asarray(free, dtype=np.bool_),
                num_rewire,
                self._stack,
                self._goal_nodes,
                self.num_goal_nodes,
                self.best_node,
            )
            if rewired and best >= 0:
                self.best_node, self.best_cost = best, float(self.costs[best])
        self.collision_checks += checks
        return ExtendResult(
            node, nearest, False, reached_goal, self.best_cost < best_before, rewired, 1, 0, checks
        )

    def _compiled_context(self) -> tuple | None:
        """The checker's compiled context for `_extend_compiled`, or None (`compiled_extend`)."""
        if self._compiled_extend is False:
            return None
        context = compiled_context_of(self.checker)
        if context is None and self._compiled_extend:
            raise ValueError("compiled_extend: the tree's checker has no compiled path")
        return context

    def _extend_compiled(
        self, sample: np.ndarray, normalized: bool, context: tuple
    ) -> ExtendResult:
        """`extend` as one compiled call; the `ExtendResult` the Python path gives."""
        if self.num_nodes == self.capacity:  # room for the node (the Python path grows later,
            self._grow()  # just before inserting: the radius only matters there, so the same)
        arrays, counters, best_cost, params = self.compiled_state()
        checks, goal_nodes, best_before = self.collision_checks, self.num_goal_nodes, self.best_cost
        node, nearest, rewired = _compiled_tree.extend_detailed(
            arrays, counters, best_cost, params, self._goal, self._bounds, context, sample,
            normalized, self.parent_check_chunk,
        )  # fmt: skip
        if node == _compiled_tree.BAD_ACTION:  # the tree is unchanged
            raise ValueError(f"action: must be finite, got {sample.tolist()}")
        self.load_compiled_state(counters, best_cost)
        checks = self.collision_checks - checks
        if node < 0:  # a zero-length step checks nothing; a colliding one its edge
            return ExtendResult(-1, nearest, checks > 0, False, False, 0, 1, 1, checks)
        return ExtendResult(
            node, nearest, False, self.num_goal_nodes > goal_nodes, self.best_cost < best_before,
            rewired, 1, 0, checks,
        )  # fmt: skip

    def _as_point(self, value: object, name: str) -> np.ndarray:
        """``value`` as a float64 array, refusing what is not real numbers (strings, objects).

        numpy would read ``"0.5"`` as a number and drop a complex number's imaginary part.
        """
        try:
            array = np.asarray(value)
        except (TypeError, ValueError):  # ragged nesting
            raise ValueError(f"{name}: expected {self.dim} numbers") from None
        if array.dtype.kind == "c":
            raise ValueError(f"{name}: must be real")
        if array.dtype.kind not in "fiu":
            raise ValueError(f"{name}: expected {self.dim} numbers, got values of type "
                             f"{array.dtype}")  # fmt: skip
        return array.astype(np.float64)

    def extend_with_fallback(
        self,
        sample: np.ndarray,
        sampler: Sampler,
        rng: np.random.Generator,
        max_tries: int = 1000,
        normalized: bool = False,
        local_tries: int = 0,
    ) -> ExtendResult:
        """Algorithm 1, lines 5-10: try ``sample``; while it fails, retry with random samples.

        With ``local_tries`` > 0 and a normalized ``sample`` (a policy's proposal), the first
        that many retries are drawn near the proposal instead: each random sample, mapped to
        ``[-1, 1]``, is scaled into the box of half-width `_compiled_tree.LOCAL_HALF_WIDTH`
        around it (clipped to the bounds; `_compiled_tree.near_proposal`, which the compiled
        loop calls too). A proposal that grazes an obstacle is continued past it, where a
        uniform retry lands anywhere; on walled-in arm tasks nearly every uniform retry
        collides.

        Args:
            sample: The proposed state (e.g. from the attention policy).
            sampler: Source of the random replacement samples.
            rng: Generator the replacements are drawn from.
            max_tries: Most random retries, so a walled-in tree cannot loop forever.
            normalized: ``sample`` (not the replacements) is a normalized action, as in
                `extend`.
            local_tries: Retries drawn near a normalized ``sample`` before uniform ones.

        Returns:
            The `ExtendResult` of the last attempt, with ``samples``, ``failures`` and
            ``collision_checks`` summed over all attempts.
        """
        if max_tries < 0:
            raise ValueError(f"max_tries: must be non-negative, got {max_tries}")
        if local_tries < 0:
            raise ValueError(f"local_tries: must be non-negative, got {local_tries}")
        result = self.extend(sample, normalized)
        samples, failures, checks, tries = 1, result.failures, result.collision_checks, 0
        if normalized and local_tries > 0:  # float64, as the compiled loop's proposals are
            proposal, near = np.asarray(sample, dtype=np.float64), np.empty(self.dim)
        while result.node < 0 and tries < max_tries:
            replacement = sampler.sample(rng)
            if normalized and tries < local_tries:
                _compiled_tree.near_proposal(proposal, replacement, self._bounds, near)
                result = self.extend(near, normalized=True)
            else:
                result = self.extend(replacement)
            tries += 1
            samples += 1
            failures += result.failures
            checks += result.collision_checks
        return ExtendResult(
            result.node,
            result.nearest,
            result.collided,
            result.reached_goal,
            result.improved,
            result.rewired,
            samples,
            failures,
            checks,
        )
