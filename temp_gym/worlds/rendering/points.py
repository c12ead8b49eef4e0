"""`render_point_world`: a point robot's problem, tree and path (2D or 3D), with matplotlib.

It builds its own `Figure` on an Agg canvas (never pyplot's global state), so it is headless
and safe in threads and subprocesses.

Obstacles of every kind are drawn by their shape: rectangles (turned or not) and discs in 2D,
boxes, cylinders and spheres in 3D (`temp_gym.worlds.rendering.solids`).

3D pictures are kept readable: the obstacles are pale and drawn first, at most
`MAX_3D_EDGES` tree edges are drawn (the oldest ones: the tree's early skeleton, which shows
how it spread), and the path, start and goal are drawn last, on top of everything, with the
start and goal labelled.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from temp_gym.problem.obstacles import BOX
from temp_gym.worlds.rendering.common import (
    DPI,
    GOAL_COLOR,
    PATH_SO_FAR_COLOR,
    SOLUTION_COLOR,
    START_COLOR,
    TREE_COLOR,
    LegendEntry,
    canvas_to_array,
    check_paths,
    check_size,
    legend_handles,
    plan_title,
)
from temp_gym.worlds.rendering.solids import Solids, box_faces, outline, surface

if TYPE_CHECKING:
    from temp_gym.problem import Problem

MAX_3D_EDGES = 400
"""Most tree edges drawn in 3D, where more turn the picture into a thicket."""
_BOX_COLOR = "#8c8c8c"
_NODE_COLOR = "#23395d"


def _check_tree(
    problem: Problem,
    positions: np.ndarray | None,
    parents: np.ndarray | None,
    num_nodes: int | None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Validate the tree arguments; return ``(positions[:n], parents[:n] or None)``."""
    if positions is None:
        if parents is not None:
            raise ValueError("parents: given without positions")
        return np.empty((0, problem.dim)), None
    positions = np.asarray(positions, dtype=np.float64)
    if positions.ndim != 2 or positions.shape[1] != problem.dim:
        raise ValueError(f"positions: expected shape (N, {problem.dim}), got {positions.shape}")
    count = len(positions) if parents is None else min(len(positions), len(parents))
    if num_nodes is not None:
        if not 0 <= num_nodes <= count:
            raise ValueError(f"num_nodes: expected 0..{count}, got {num_nodes}")
        count = int(num_nodes)
    if parents is None:
        return positions[:count], None
    parents = np.asarray(parents, dtype=np.int64)[:count]
    if np.any(parents >= count):
        raise ValueError("parents: an index points past num_nodes")
    return positions[:count], parents


def _tree_segments(
    positions: np.ndarray, parents: np.ndarray | None, limit: int | None = None
) -> np.ndarray:
    """Edges ``(E, 2, d)`` from each non-root node to its parent; the oldest ``limit`` only."""
    if parents is None or len(parents) < 2:
        return np.empty((0, 2, positions.shape[1]))
    children = np.flatnonzero(parents >= 0)[:limit]
    return np.stack([positions[children], positions[parents[children]]], axis=1)


def _path_style(solution: bool) -> dict:
    if solution:
        return {"color": SOLUTION_COLOR, "linewidth": 2.5, "solid_capstyle": "round"}
    return {"color": PATH_SO_FAR_COLOR, "linewidth": 1.6, "linestyle": (0, (4, 2))}


def _outlines(workspace) -> list:
    """Every 2D obstacle's boundary: a rectangle (turned or not) or a disc (`outline`).

    An axis-aligned box is the rectangle of its corners, as it always was.
    """
    lower, upper = workspace.obstacle_lower, workspace.obstacle_upper
    aligned = workspace.unrotated & (workspace.obstacle_kinds == BOX)
    return [
        [(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])]
        if aligned[index]
        else outline(kind, center, half, rotation)
        for index, (lo, hi, kind, center, half, rotation) in enumerate(
            zip(
                lower,
                upper,
                workspace.obstacle_kinds,
                workspace.obstacle_centers,
                workspace.obstacle_half_extents,
                workspace.obstacle_rotations,
            )
        )
    ]


def _surfaces(workspace) -> np.ndarray | list:
    """Every 3D obstacle's faces, as polygons (`surface`).

    When every obstacle is an axis-aligned box, the array ``(6M, 4, 3)`` of their faces, as it
    always was.
    """
    if workspace.axis_aligned:
        return np.concatenate(
            [
                box_faces(lo, hi)
                for lo, hi in zip(workspace.obstacle_lower, workspace.obstacle_upper)
            ]
        )
    solids = Solids.of_workspace(workspace)
    aligned = solids.aligned_boxes
    faces: list = []
    for index in range(len(solids)):
        if aligned[index]:
            faces.extend(box_faces(solids.lower[index], solids.upper[index]))
        else:
            faces.extend(
                surface(
                    solids.kinds[index],
                    solids.centers[index],
                    solids.half_extents[index],
                    solids.rotations[index],
                )
            )
    return faces


def _draw_2d(figure, problem, positions, parents, path, solution):
    axes = figure.add_subplot()
    axes.add_collection(
        PolyCollection(
            _outlines(problem.workspace),
            facecolors=_BOX_COLOR,
            edgecolors="#555555",
            linewidths=0.6,
        )
    )
    segments = _tree_segments(positions, parents)
    if len(segments):
        axes.add_collection(LineCollection(segments, colors=TREE_COLOR, linewidths=0.5))
    if len(positions):
        axes.plot(*positions.T, linestyle="none", marker=".", markersize=2.0, color=_NODE_COLOR)
    goal = Circle(problem.goal, problem.goal_radius, facecolor=GOAL_COLOR, alpha=0.35)
    axes.add_patch(goal)
    axes.add_patch(Circle(problem.goal, problem.goal_radius, fill=False, color=GOAL_COLOR))
    axes.plot(*problem.goal, marker="*", markersize=9, color=GOAL_COLOR, linestyle="none")
    if path is not None and len(path) > 1:
        axes.plot(*path.T, **_path_style(solution))
    axes.plot(*problem.start, marker="o", markersize=8, color=START_COLOR, linestyle="none")
    axes.set_xlim(problem.bounds[0, 0], problem.bounds[1, 0])
    axes.set_ylim(problem.bounds[0, 1], problem.bounds[1, 1])
    axes.set_aspect("equal")
    axes.tick_params(labelsize=7)
    return axes


def _draw_3d(figure, problem, positions, parents, path, solution):
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    # Drawn in zorder, not by depth: the path, start and goal stay in front of the boxes.
    axes = figure.add_subplot(projection="3d", computed_zorder=False)
    if problem.workspace.num_obstacles:
        faces = _surfaces(problem.workspace)
        boxes = Poly3DCollection(
            faces, facecolors=_BOX_COLOR, edgecolors="#9a9a9a", linewidths=0.25, alpha=0.1
        )
        boxes.set_zorder(1)
        axes.add_collection3d(boxes)
    segments = _tree_segments(positions, parents, MAX_3D_EDGES)
    if len(segments):
        edges = Line3DCollection(segments, colors=TREE_COLOR, linewidths=0.5, alpha=0.6)
        edges.set_zorder(2)
        axes.add_collection3d(edges)
    # The goal ball as a coarse wireframe sphere.
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 16), np.linspace(0, np.pi, 9))
    ball = [problem.goal[i] + problem.goal_radius * f for i, f in enumerate(_sphere(u, v))]
    axes.plot_wireframe(*ball, color=GOAL_COLOR, linewidth=0.6, alpha=0.8, zorder=3)
    if path is not None and len(path) > 1:
        axes.plot(*path.T, zorder=4, **_path_style(solution))
    for point, color, marker, label in (
        (problem.start, START_COLOR, "o", "start"),
        (problem.goal, GOAL_COLOR, "*", "goal"),
    ):
        axes.plot(*point, marker=marker, markersize=9, color=color, linestyle="none", zorder=5)
        axes.text(*point, f"  {label}", color=color, fontsize=8, fontweight="bold", zorder=5)
    low, high = problem.bounds
    axes.set_xlim(low[0], high[0])
    axes.set_ylim(low[1], high[1])
    axes.set_zlim(low[2], high[2])
    axes.set_box_aspect(high - low, zoom=0.88)
    axes.view_init(elev=28, azim=-55)
    axes.tick_params(labelsize=6)
    return axes


def legend_entries(
    problem: Problem, tree_drawn: bool, path: np.ndarray | None, solution: bool
) -> list[LegendEntry]:
    """What the picture shows, for its legend: start, goal, and what else is drawn."""
    entries: list[LegendEntry] = [
        ("start", START_COLOR, "dot"),
        ("goal region", GOAL_COLOR, "star"),
    ]
    if tree_drawn:
        entries.append(("tree", TREE_COLOR, "line"))
    if path is not None and len(path) > 1:
        if solution:
            entries.append(("solution", SOLUTION_COLOR, "line"))
        else:
            entries.append(("path so far", PATH_SO_FAR_COLOR, "dashed"))
    if problem.workspace.num_obstacles:
        entries.append(("obstacles", _BOX_COLOR, "box"))
    return entries


def _sphere(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)


def render_point_world(
    problem: Problem,
    positions: np.ndarray | None = None,
    parents: np.ndarray | None = None,
    path: np.ndarray | None = None,
    num_nodes: int | None = None,
    width: int = 480,
    height: int = 480,
    path_so_far: np.ndarray | None = None,
    legend: bool = True,
) -> np.ndarray:
    """Draw a point-robot problem, optionally with a tree and a path.

    Obstacles are grey, tree edges thin blue lines (in 3D at most `MAX_3D_EDGES`, the oldest),
    tree nodes small dots (2D), the start a green dot and the goal region a blue disc (2D) or
    wire sphere (3D). A solution ``path`` is a thick red polyline, titled with its cost; a
    ``path_so_far`` (before any solution: the root path of the newest node) a dashed orange
    one, titled "no solution yet". The axes span ``problem.bounds`` with equal aspect; a
    legend across the bottom names what is drawn.

    Args:
        problem: A point robot's problem (2D or 3D).
        positions: Tree node states ``(N, d)``; rows past ``num_nodes`` are ignored.
        parents: Parent index per node (``-1`` for the root), length at least ``num_nodes``.
        path: States ``(K, d)`` of a solution.
        num_nodes: Nodes to draw; defaults to all of ``positions`` (and ``parents``).
        width: Image width in pixels.
        height: Image height in pixels.
        path_so_far: States ``(K, d)`` of a path that does not reach the goal yet.
        legend: Whether to draw the legend.

    Returns:
        A fresh ``uint8`` array of shape ``(height, width, 3)``.

    Raises:
        ValueError: For another robot, badly shaped arguments, or both kinds of path.
    """
    if problem.dim not in (2, 3) or problem.dim != problem.workspace.workspace_dim:
        raise ValueError(
            f"problem: render_point_world draws point robots in 2D or 3D, got {problem.robot!r}; "
            "an arm's renderer is ArmRenderer"
        )
    width, height = check_size(width, height)
    positions, parents = _check_tree(problem, positions, parents, num_nodes)
    path, path_so_far = check_paths(problem, path, path_so_far)
    figure = Figure(figsize=(width / DPI, height / DPI), dpi=DPI)
    canvas = FigureCanvasAgg(figure)
    draw = _draw_2d if problem.dim == 2 else _draw_3d
    solution = path is not None
    axes = draw(figure, problem, positions, parents, path if solution else path_so_far, solution)
    shown = (
        "orange dashed" if not solution and path_so_far is not None and len(path_so_far) > 1 else ""
    )
    axes.set_title(plan_title(problem, len(positions), path, shown), fontsize=8)
    bottom = 0.0
    if legend:
        drawn = path if solution else path_so_far
        tree_drawn = parents is not None and len(positions) > 1
        entries = legend_entries(problem, tree_drawn, drawn, solution)
        figure.legend(
            handles=legend_handles(entries),
            loc="lower center",
            ncol=len(entries),
            fontsize=7,
            frameon=False,
            handlelength=1.4,
            columnspacing=1.0,
            borderaxespad=0.2,
        )
        bottom = min(0.07, 24 / height)
    if problem.dim == 2:
        figure.subplots_adjust(left=0.08, right=0.97, bottom=0.06 + bottom, top=0.93)
    else:
        figure.subplots_adjust(left=0.0, right=1.0, bottom=0.02 + bottom, top=0.95)
    return canvas_to_array(canvas, width, height)


class PointWorldRenderer:
    """The point robots' `temp_gym.worlds.rendering.common.TreeRenderer`: `render_point_world`."""

    def draw_tree(
        self,
        problem: Problem,
        positions: np.ndarray | None,
        parents: np.ndarray | None,
        num_nodes: int,
        path: np.ndarray | None = None,
        path_so_far: np.ndarray | None = None,
    ) -> np.ndarray:
        """The problem, the first ``num_nodes`` nodes of a tree, and a solution or path so far."""
        return render_point_world(
            problem, positions, parents, path, num_nodes, path_so_far=path_so_far
        )

    def close(self) -> None:
        """Nothing to release: every picture has its own figure."""
