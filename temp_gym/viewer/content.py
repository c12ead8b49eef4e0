"""`plan_content`: what the viewer draws, in world coordinates, computed without a browser.

A plan is shown in the robot's workspace (3D; a 2D world lies in the plane z = 0):

* the region (a point robot's bounds; an arm's encoded workspace region) and the obstacles,
  each of its kind with its parameters (`temp_gym.worlds.rendering.solids.Solids`: boxes,
  turned or not, cylinders and spheres; a 2D world's rectangles and discs stand in the plane
  as low boxes and cylinders);
* the start and the goal: a point robot's positions and goal ball; an arm's hand positions
  (the last link's origin) and its arm at start and goal (`ArmContent`);
* the tree's edges: between positions for a point robot, between hand positions for an arm;
* the path: as a polyline, and as the frames the playback control steps through (states
  evenly spaced by path length), with the hand's trace for an arm.

Only `temp_gym.viewer.arm_geometry` knows how an arm looks; everything here reads the
robot's spec.

Example:
    >>> content = plan_content(problem, path=result.path, tree=result.tree)
    >>> content.tree_segments.shape  # (edges, 2, 3)
    (1499, 2, 3)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from temp_gym.problem.obstacles import CYLINDER, SPHERE
from temp_gym.viewer.arm_geometry import (
    LinkMesh,
    arm_link_meshes,
    arm_link_poses,
    has_arm_geometry,
    is_point_robot,
)
from temp_gym.worlds.rendering.common import floor_slabs
from temp_gym.worlds.rendering.solids import Solids

if TYPE_CHECKING:
    from temp_gym.planning.result import PlanTree
    from temp_gym.problem import Problem

PLAYBACK_FRAMES = 120
"""States the playback steps through along a path (evenly spaced by path length)."""
FLAT_HEIGHT_SHARE = 0.02
"""A 2D world's obstacles are drawn this share of the region's largest side high."""


@dataclass(frozen=True)
class ArmContent:
    """An arm's links: meshes in link frames and world poses at start, goal and each frame."""

    meshes: tuple[LinkMesh, ...]
    """Per link, ``(vertices, faces)`` in its frame (`arm_link_meshes`)."""
    start_poses: np.ndarray
    """``(links, 4, 4)`` world poses at the start."""
    goal_poses: np.ndarray
    """``(links, 4, 4)`` world poses at the goal."""
    frame_poses: np.ndarray
    """``(frames, links, 4, 4)`` world poses at each playback frame."""


@dataclass(frozen=True)
class PlanContent:
    """Everything the viewer draws, in 3D world coordinates (see the module docstring)."""

    robot: str
    """The robot's name."""
    flat: bool
    """Whether the world is 2D (drawn in the plane z = 0, seen from above)."""
    region: np.ndarray
    """``(2, 3)`` lower and upper corners of the region shown."""
    obstacles: Solids
    """The obstacles in 3D: kind, center, half extents, rotation and bounding box of each."""
    box_is_floor: np.ndarray
    """``(B,)`` which obstacles are an arm's floor slab (drawn grey)."""
    start: np.ndarray
    """``(3,)`` the start position (an arm: its hand)."""
    goal: np.ndarray
    """``(3,)`` the goal position (an arm: its hand)."""
    goal_radius: float | None
    """The goal ball's radius in the world (None for an arm: its goal region is in joint
    space)."""
    tree_segments: np.ndarray
    """``(E, 2, 3)`` the tree's edges, child to parent."""
    path_trace: np.ndarray | None
    """``(K, 3)`` the path drawn as a polyline (an arm: its hand's trace), or None."""
    frame_positions: np.ndarray
    """``(frames, 3)`` the robot's position (an arm: its hand) at each playback frame; one
    frame, the start, without a path."""
    arm: ArmContent | None = None
    """The arm's links, or None for a point robot."""

    @property
    def box_lower(self) -> np.ndarray:
        """``(B, 3)`` lower corners of the obstacles' bounding boxes (an axis-aligned box's own)."""
        return self.obstacles.lower

    @property
    def box_upper(self) -> np.ndarray:
        """``(B, 3)`` upper corners of the obstacles' bounding boxes (an axis-aligned box's own)."""
        return self.obstacles.upper

    @property
    def size(self) -> float:
        """The region's largest side: the scale of markers and lines."""
        return float(np.max(self.region[1] - self.region[0]))

    @property
    def frames(self) -> int:
        """Playback frames."""
        return len(self.frame_positions)


def resample_path(path: np.ndarray, count: int) -> np.ndarray:
    """``count`` states ``(count, d)`` evenly spaced by length along ``path``, ends included."""
    path = np.asarray(path, dtype=np.float64)
    lengths = np.linalg.norm(np.diff(path, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    if arc[-1] <= 0.0 or count < 2:
        return path[[0, -1]] if count >= 2 else path[:1]
    targets = np.linspace(0.0, arc[-1], count)
    return np.stack([np.interp(targets, arc, path[:, j]) for j in range(path.shape[1])], axis=1)


def _in_3d(points: np.ndarray) -> np.ndarray:
    """Points ``(N, 2)`` or ``(N, 3)`` as ``(N, 3)``: a 2D world lies in z = 0."""
    points = np.atleast_2d(np.asarray(points, dtype=np.float64))
    if points.shape[1] == 3:
        return points.copy()
    return np.concatenate([points, np.zeros((len(points), 1))], axis=1)


def _tree_edges(tree: PlanTree | None, dim: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tree's states ``(N, dim)`` and its edges as child and parent indices (``(E,)`` each).

    No tree: no states and no edges.
    """
    if tree is None:
        return np.empty((0, dim)), np.empty(0, np.int64), np.empty(0, np.int64)
    positions = np.asarray(tree.positions, dtype=np.float64)
    parents = np.asarray(tree.parents, dtype=np.int64)
    if positions.ndim != 2 or positions.shape[1] != dim or parents.shape != (len(positions),):
        raise ValueError(
            f"tree: expected positions (N, {dim}) and N parents, got {positions.shape} "
            f"and {parents.shape}"
        )
    children = np.flatnonzero(parents >= 0)
    if np.any(parents[children] >= len(positions)):
        raise ValueError("tree: a parent index points past the nodes")
    return positions, children, parents[children]


def _segments(points: np.ndarray, children: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """Edges ``(E, 2, 3)`` from each child's world point to its parent's."""
    if len(children) == 0:
        return np.empty((0, 2, 3))
    return np.stack([points[children], points[parents]], axis=1)


def _check_path(problem: Problem, path: np.ndarray | None) -> np.ndarray | None:
    if path is None:
        return None
    path = np.asarray(path, dtype=np.float64)
    if path.ndim != 2 or path.shape[1] != problem.dim or len(path) == 0:
        raise ValueError(f"path: expected shape (K, {problem.dim}) with K >= 1, got {path.shape}")
    if not np.all(np.isfinite(path)):
        raise ValueError("path: expected finite numbers")
    return path


def plan_content(
    problem: Problem,
    path: np.ndarray | None = None,
    tree: PlanTree | None = None,
    frames: int = PLAYBACK_FRAMES,
) -> PlanContent:
    """What the viewer draws for ``problem``, a ``path`` ``(K, dim)`` and a planner's ``tree``.

    Raises:
        ValueError: a misshaped path or tree, or a robot that is neither a point robot nor
            an arm with a known model (`temp_gym.viewer.arm_geometry`).
    """
    from temp_gym.worlds.robots import robot_spec

    spec = robot_spec(problem.robot)
    path = _check_path(problem, path)
    nodes, children, parents = _tree_edges(tree, problem.dim)
    played = resample_path(path, frames) if path is not None else problem.start[None]
    if is_point_robot(spec):
        return _point_content(problem, spec, path, nodes, children, parents, played)
    if not has_arm_geometry(spec):
        raise ValueError(
            f"robot: the viewer draws point robots and arms with a known model, "
            f"not {problem.robot!r}"
        )
    return _arm_content(problem, spec, path, nodes, children, parents, played)


def _flat_solids(workspace, height: float) -> Solids:
    """A 2D workspace's obstacles standing ``height`` high on the plane z = 0.

    A rectangle becomes a low box turned about z, a disc a low cylinder.
    """
    lower, upper = _in_3d(workspace.obstacle_lower), _in_3d(workspace.obstacle_upper)
    upper[:, 2] = height
    count = workspace.num_obstacles
    centers = _in_3d(workspace.obstacle_centers)
    centers[:, 2] = height / 2
    halves = np.concatenate([workspace.obstacle_half_extents, np.full((count, 1), height / 2)], 1)
    rotations = np.broadcast_to(np.eye(3), (count, 3, 3)).copy()
    rotations[:, :2, :2] = workspace.obstacle_rotations
    kinds = np.where(workspace.obstacle_kinds == SPHERE, CYLINDER, workspace.obstacle_kinds)
    return Solids(lower, upper, kinds.astype(np.int8), centers, halves, rotations)


def _point_content(problem, spec, path, nodes, children, parents, played) -> PlanContent:
    flat = spec.workspace_dim == 2
    region = _in_3d(spec.region(problem.bounds))
    height = FLAT_HEIGHT_SHARE * float(np.max(region[1] - region[0]))
    if flat:
        obstacles = _flat_solids(problem.workspace, height)
    else:
        obstacles = Solids.of_workspace(problem.workspace)
    return PlanContent(
        robot=problem.robot,
        flat=flat,
        region=region,
        obstacles=obstacles,
        box_is_floor=np.zeros(len(obstacles), dtype=bool),
        start=_in_3d(problem.start)[0],
        goal=_in_3d(problem.goal)[0],
        goal_radius=problem.goal_radius,
        tree_segments=_segments(_in_3d(nodes), children, parents),
        path_trace=None if path is None else _in_3d(path),
        frame_positions=_in_3d(played),
    )


def _arm_content(problem, spec, path, nodes, children, parents, played) -> PlanContent:
    lower, upper = problem.workspace.obstacle_lower, problem.workspace.obstacle_upper
    ends = arm_link_poses(spec, np.stack([problem.start, problem.goal]))
    frame_poses = arm_link_poses(spec, played)
    hands = arm_link_poses(spec, nodes)[:, -1, :3, 3] if len(nodes) else np.empty((0, 3))
    return PlanContent(
        robot=problem.robot,
        flat=False,
        region=spec.region(problem.bounds),
        obstacles=Solids.of_workspace(problem.workspace),
        box_is_floor=floor_slabs(lower, upper),
        start=ends[0, -1, :3, 3].copy(),
        goal=ends[1, -1, :3, 3].copy(),
        goal_radius=None,
        tree_segments=_segments(hands, children, parents),
        path_trace=None if path is None else frame_poses[:, -1, :3, 3].copy(),
        frame_positions=frame_poses[:, -1, :3, 3].copy(),
        arm=ArmContent(arm_link_meshes(spec), ends[0], ends[1], frame_poses),
    )
