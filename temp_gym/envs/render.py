"""Pictures of problems, trees and paths as ``uint8`` RGB arrays of shape ``(height, width, 3)``.

* `render_point_world` draws a ``point2d`` or ``point3d`` problem with matplotlib: boxes, the
  planner's tree, a path, the start and the goal region. It builds its own `Figure` on an Agg
  canvas (never pyplot's global state), so it is headless and safe in threads and subprocesses.
* `IiwaRenderer` draws a ``kuka_iiwa14`` problem with pybullet's software renderer in its own
  ``DIRECT`` client: the boxes and the arm at the start, at a few pale "ghost" configurations
  along the path, and at the end. The client and the arm bodies are kept between calls, so
  repeated renders cost tens of milliseconds.

Example:
    >>> image = render_point_world(problem, positions=tree.positions, parents=tree.parents,
    ...                            num_nodes=tree.num_nodes, path=tree.best_path())
    >>> image.shape, image.dtype
    ((480, 480, 3), dtype('uint8'))
    >>> with IiwaRenderer() as renderer:
    ...     frame = renderer.render(iiwa_problem, path=result.path)
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from temp_gym.quiet import import_pybullet, native_output_silenced

if TYPE_CHECKING:
    from temp_gym.problem import Problem

_DPI = 100
_BOX_COLOR = "#8c8c8c"
_EDGE_COLOR = "#4a7ab5"
_PATH_COLOR = "#e41a1c"
_START_COLOR = "#1a9e3a"
_GOAL_COLOR = "#1f4fd6"


# ---------------------------------------------------------------------- point worlds
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


def _check_path(problem: Problem, path: np.ndarray | None) -> np.ndarray | None:
    if path is None:
        return None
    path = np.asarray(path, dtype=np.float64)
    if path.ndim != 2 or path.shape[1] != problem.dim or len(path) == 0:
        raise ValueError(f"path: expected shape (K, {problem.dim}) with K >= 1, got {path.shape}")
    return path


def _tree_segments(positions: np.ndarray, parents: np.ndarray | None) -> np.ndarray:
    """Edges ``(E, 2, d)`` from each non-root node to its parent."""
    if parents is None or len(parents) < 2:
        return np.empty((0, 2, positions.shape[1]))
    children = np.flatnonzero(parents >= 0)
    return np.stack([positions[children], positions[parents[children]]], axis=1)


def _title(problem: Problem, num_nodes: int, path: np.ndarray | None) -> str:
    text = f"{problem.robot}: {num_nodes} nodes"
    if path is not None:
        cost = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
        text += f", path cost {cost:.2f}"
    return text


def _canvas_to_array(canvas: FigureCanvasAgg, width: int, height: int) -> np.ndarray:
    """The drawn canvas as RGB, cropped or white-padded to exactly ``(height, width)``."""
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    image = np.full((height, width, 3), 255, dtype=np.uint8)
    rows, cols = min(height, rgba.shape[0]), min(width, rgba.shape[1])
    image[:rows, :cols] = rgba[:rows, :cols, :3]
    return image


def _box_faces(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The six quadrilateral faces ``(6, 4, 3)`` of the box ``[lower, upper]``."""
    corners = np.array(
        [[(upper if (k >> axis) & 1 else lower)[axis] for axis in range(3)] for k in range(8)]
    )
    # Corner k has bit `axis` set when it sits on the upper side of that axis.
    quads = [(0, 2, 6, 4), (1, 3, 7, 5), (0, 1, 5, 4), (2, 3, 7, 6), (0, 1, 3, 2), (4, 5, 7, 6)]
    return corners[np.array(quads)]


def _draw_2d(figure, problem, positions, parents, path):
    axes = figure.add_subplot()
    lower, upper = problem.obstacle_lower, problem.obstacle_upper
    rectangles = [
        [(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])]
        for lo, hi in zip(lower, upper)
    ]
    axes.add_collection(
        PolyCollection(rectangles, facecolors=_BOX_COLOR, edgecolors="#555555", linewidths=0.6)
    )
    segments = _tree_segments(positions, parents)
    if len(segments):
        axes.add_collection(LineCollection(segments, colors=_EDGE_COLOR, linewidths=0.5))
    if len(positions):
        axes.plot(*positions.T, linestyle="none", marker=".", markersize=2.0, color="#23395d")
    goal = Circle(problem.goal, problem.goal_radius, facecolor=_GOAL_COLOR, alpha=0.35)
    axes.add_patch(goal)
    axes.add_patch(Circle(problem.goal, problem.goal_radius, fill=False, color=_GOAL_COLOR))
    axes.plot(*problem.goal, marker="*", markersize=9, color=_GOAL_COLOR, linestyle="none")
    if path is not None:
        axes.plot(*path.T, color=_PATH_COLOR, linewidth=2.5, solid_capstyle="round")
    axes.plot(*problem.start, marker="o", markersize=8, color=_START_COLOR, linestyle="none")
    axes.set_xlim(problem.bounds[0, 0], problem.bounds[1, 0])
    axes.set_ylim(problem.bounds[0, 1], problem.bounds[1, 1])
    axes.set_aspect("equal")
    axes.tick_params(labelsize=7)
    return axes


def _draw_3d(figure, problem, positions, parents, path):
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    axes = figure.add_subplot(projection="3d")
    if problem.num_obstacles:
        faces = np.concatenate(
            [_box_faces(lo, hi) for lo, hi in zip(problem.obstacle_lower, problem.obstacle_upper)]
        )
        boxes = Poly3DCollection(
            faces, facecolors=_BOX_COLOR, edgecolors="#444444", linewidths=0.3, alpha=0.22
        )
        axes.add_collection3d(boxes)
    segments = _tree_segments(positions, parents)
    if len(segments):
        axes.add_collection3d(Line3DCollection(segments, colors=_EDGE_COLOR, linewidths=0.4))
    if len(positions):
        axes.plot(*positions.T, linestyle="none", marker=".", markersize=1.5, color="#23395d")
    # The goal ball as a coarse wireframe sphere.
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 16), np.linspace(0, np.pi, 9))
    ball = [problem.goal[i] + problem.goal_radius * f for i, f in enumerate(_sphere(u, v))]
    axes.plot_wireframe(*ball, color=_GOAL_COLOR, linewidth=0.6, alpha=0.8)
    axes.plot(*problem.goal, marker="*", markersize=9, color=_GOAL_COLOR, linestyle="none")
    if path is not None:
        axes.plot(*path.T, color=_PATH_COLOR, linewidth=2.5)
    axes.plot(*problem.start, marker="o", markersize=7, color=_START_COLOR, linestyle="none")
    low, high = problem.bounds
    axes.set_xlim(low[0], high[0])
    axes.set_ylim(low[1], high[1])
    axes.set_zlim(low[2], high[2])
    axes.set_box_aspect(high - low, zoom=0.88)
    axes.view_init(elev=28, azim=-55)
    axes.tick_params(labelsize=6)
    return axes


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
) -> np.ndarray:
    """Draw a point-robot problem, optionally with a tree and a path.

    Boxes are grey, tree edges thin blue lines, tree nodes small dots, the path a thick red
    polyline, the start a green dot and the goal region a blue disc (2D) or wire sphere (3D).
    The axes span ``problem.bounds`` with equal aspect.

    Args:
        problem: A ``point2d`` or ``point3d`` problem.
        positions: Tree node states ``(N, d)``; rows past ``num_nodes`` are ignored.
        parents: Parent index per node (``-1`` for the root), length at least ``num_nodes``.
        path: States ``(K, d)`` drawn as the solution.
        num_nodes: Nodes to draw; defaults to all of ``positions`` (and ``parents``).
        width: Image width in pixels.
        height: Image height in pixels.

    Returns:
        A fresh ``uint8`` array of shape ``(height, width, 3)``.

    Raises:
        ValueError: For another robot or badly shaped arguments.
    """
    if problem.robot not in ("point2d", "point3d"):
        raise ValueError(
            f"problem: render_point_world draws point2d and point3d, got {problem.robot!r}; "
            "use IiwaRenderer for kuka_iiwa14"
        )
    if int(width) < 16 or int(height) < 16:
        raise ValueError(f"width, height: expected at least 16 pixels, got {width}x{height}")
    width, height = int(width), int(height)
    positions, parents = _check_tree(problem, positions, parents, num_nodes)
    path = _check_path(problem, path)
    figure = Figure(figsize=(width / _DPI, height / _DPI), dpi=_DPI)
    canvas = FigureCanvasAgg(figure)
    draw = _draw_2d if problem.dim == 2 else _draw_3d
    axes = draw(figure, problem, positions, parents, path)
    axes.set_title(_title(problem, len(positions), path), fontsize=8)
    if problem.dim == 2:
        figure.subplots_adjust(left=0.08, right=0.97, bottom=0.06, top=0.93)
    else:
        figure.subplots_adjust(left=0.0, right=1.0, bottom=0.02, top=0.95)
    return _canvas_to_array(canvas, width, height)


# ---------------------------------------------------------------------- iiwa
_START_RGBA = np.array([0.20, 0.72, 0.30, 1.0])
_END_RGBA = np.array([0.18, 0.38, 0.90, 1.0])
_GHOST_LIGHTEN = 0.55
"""Ghosts are the start-to-end colour blended this far towards white (the tiny renderer
ignores alpha, so paleness stands in for transparency)."""
_OBSTACLE_RGBA = [0.78, 0.58, 0.38, 1.0]
_FLOOR_RGBA = [0.80, 0.80, 0.80, 1.0]
_GROUND_RGBA = [0.93, 0.93, 0.93, 1.0]
_BASE_RGBA = [0.35, 0.35, 0.38, 1.0]
_PARKED = (0.0, 0.0, -100.0)
"""Where unused arm bodies wait, far outside the camera's view."""


def _path_samples(path: np.ndarray, count: int) -> np.ndarray:
    """``count`` configurations evenly spaced by joint-space arc length strictly inside path."""
    lengths = np.linalg.norm(np.diff(path, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    if count <= 0 or arc[-1] <= 0:
        return np.empty((0, path.shape[1]))
    targets = arc[-1] * np.arange(1, count + 1) / (count + 1)
    return np.stack([np.interp(targets, arc, path[:, j]) for j in range(path.shape[1])], axis=1)


class IiwaRenderer:
    """Draws ``kuka_iiwa14`` problems with pybullet's tiny (CPU) renderer.

    The renderer owns its own ``DIRECT`` pybullet client, created at the first `render`, and
    keeps the arm bodies loaded; the boxes are rebuilt only when a different problem object
    is rendered. Call `close` (or use it as a context manager) to free the client; closing
    twice is harmless, and a closed renderer reconnects on the next `render`.

    Args:
        ghosts: Most intermediate configurations drawn along a path.
        yaw: Camera yaw around the vertical axis, degrees.
        pitch: Camera pitch, degrees (negative looks down).
        distance: Camera distance from ``target``, metres.
        target: Point the camera looks at, metres.
        fov: Vertical field of view, degrees.
        shadow: Whether the renderer casts shadows (about 3x slower).

    Example:
        >>> renderer = IiwaRenderer()
        >>> image = renderer.render(problem, path=result.path)  # (480, 480, 3) uint8
        >>> renderer.close()
    """

    def __init__(
        self,
        ghosts: int = 5,
        yaw: float = 50.0,
        pitch: float = -28.0,
        distance: float = 3.3,
        target: tuple[float, float, float] = (0.0, 0.0, 0.4),
        fov: float = 45.0,
        shadow: bool = False,
    ) -> None:
        if ghosts < 0:
            raise ValueError(f"ghosts: expected a non-negative count, got {ghosts}")
        self.ghosts = int(ghosts)
        self.yaw, self.pitch, self.distance = float(yaw), float(pitch), float(distance)
        self.target = tuple(float(x) for x in target)
        self.fov = float(fov)
        self.shadow = bool(shadow)
        self._client = None
        self._arms: list[int] = []
        self._joints: list[int] = []
        self._links: list[int] = []
        self._boxes: list[int] = []
        self._problem: Problem | None = None
        self._pid = os.getpid()

    # ------------------------------------------------------------------ lifecycle
    def __enter__(self) -> IiwaRenderer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        """Disconnect the pybullet client (idempotent)."""
        client, self._client = self._client, None
        self._arms, self._boxes, self._problem = [], [], None
        # A forked child must not disconnect the parent's client.
        if client is not None and self._pid == os.getpid():
            try:
                client.disconnect()
            except Exception:  # already gone (e.g. at interpreter exit)
                pass

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # never raise from a finalizer
            pass

    def _connect(self):
        """The client, connected and holding ``ghosts + 2`` parked arms."""
        if self._client is not None:
            return self._client
        import pybullet_data

        pybullet = import_pybullet()
        from pybullet_utils.bullet_client import BulletClient

        with native_output_silenced():  # no "argv[0]=" on the user's stdout
            client = BulletClient(connection_mode=pybullet.DIRECT)
        self._client, self._pid = client, os.getpid()
        urdf = f"{pybullet_data.getDataPath()}/kuka_iiwa/model.urdf"
        for _ in range(self.ghosts + 2):
            self._arms.append(client.loadURDF(urdf, basePosition=_PARKED, useFixedBase=True))
        arm = self._arms[0]
        count = client.getNumJoints(arm)
        self._joints = [
            j for j in range(count) if client.getJointInfo(arm, j)[2] == pybullet.JOINT_REVOLUTE
        ]
        self._links = [-1, *range(count)]
        return client

    def _load_problem(self, client, problem: Problem) -> None:
        """Replace the boxes when ``problem`` is a different object than last time."""
        if problem is self._problem:
            return
        pybullet = import_pybullet()

        for body in self._boxes:
            client.removeBody(body)
        self._boxes = []
        lower, upper = problem.obstacle_lower, problem.obstacle_upper
        ground_z = min(0.0, float(lower[:, 2].min())) if len(lower) else 0.0
        boxes = list(zip(problem.obstacle_centers, problem.obstacle_half_extents))
        # A pale visual-only ground under everything, so the scene does not float.
        ground = (np.array([0.0, 0.0, ground_z - 0.006]), np.array([1.6, 1.6, 0.005]))
        for index, (center, half) in enumerate([ground, *boxes]):
            if index == 0:
                rgba, collision = _GROUND_RGBA, -1
            else:
                # Thin slabs below the base (the generators' floor) get a neutral colour.
                is_floor = upper[index - 1, 2] <= 0.0 and half[2] < 0.1
                rgba = _FLOOR_RGBA if is_floor else _OBSTACLE_RGBA
                collision = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
            visual = client.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=rgba)
            body = client.createMultiBody(
                baseMass=0.0,
                baseCollisionShapeIndex=collision,
                baseVisualShapeIndex=visual,
                basePosition=center.tolist(),
            )
            self._boxes.append(body)
        self._problem = problem

    def _pose_arm(self, client, arm: int, config: np.ndarray | None, rgba: np.ndarray) -> None:
        """Show ``arm`` at ``config`` in colour ``rgba``, or park it when ``config`` is None."""
        if config is None:
            client.resetBasePositionAndOrientation(arm, _PARKED, (0, 0, 0, 1))
            return
        client.resetBasePositionAndOrientation(arm, (0, 0, 0), (0, 0, 0, 1))
        for joint, angle in zip(self._joints, config):
            client.resetJointState(arm, joint, float(angle))
        for link in self._links:
            # The fixed base is the same for every arm: one neutral colour avoids z-fighting.
            colour = _BASE_RGBA if link == -1 else rgba.tolist()
            client.changeVisualShape(arm, link, rgbaColor=colour)

    # ------------------------------------------------------------------ drawing
    def render(
        self,
        problem: Problem,
        path: np.ndarray | None = None,
        width: int = 480,
        height: int = 480,
    ) -> np.ndarray:
        """Draw ``problem`` with the arm along ``path`` (or at its start and goal).

        With a path: the arm at ``path[0]`` (green), at up to ``ghosts`` pale configurations
        evenly spaced along the path by joint-space length (shading from green to blue), and
        at ``path[-1]`` (blue). Without one: at ``problem.start`` (green) and ``problem.goal``
        (blue).

        Args:
            problem: A ``kuka_iiwa14`` problem.
            path: Joint configurations ``(K, 7)``, or None.
            width: Image width in pixels.
            height: Image height in pixels.

        Returns:
            A fresh ``uint8`` array of shape ``(height, width, 3)``.

        Raises:
            ValueError: For another robot or a badly shaped path.
        """
        if problem.robot != "kuka_iiwa14":
            raise ValueError(
                f"problem: IiwaRenderer draws kuka_iiwa14, got {problem.robot!r}; "
                "use render_point_world for point robots"
            )
        if int(width) < 16 or int(height) < 16:
            raise ValueError(f"width, height: expected at least 16 pixels, got {width}x{height}")
        width, height = int(width), int(height)
        path = _check_path(problem, path)
        pybullet = import_pybullet()

        client = self._connect()
        self._load_problem(client, problem)
        if path is None:
            first, last, middle = problem.start, problem.goal, np.empty((0, 7))
        else:
            first, last, middle = path[0], path[-1], _path_samples(path, self.ghosts)
        white = np.ones(4)
        poses = [(first, _START_RGBA), (last, _END_RGBA)]
        for k, config in enumerate(middle):
            fraction = (k + 1) / (len(middle) + 1)
            tint = (1 - fraction) * _START_RGBA + fraction * _END_RGBA
            poses.append((config, (1 - _GHOST_LIGHTEN) * tint + _GHOST_LIGHTEN * white))
        for index, arm in enumerate(self._arms):
            config, rgba = poses[index] if index < len(poses) else (None, None)
            self._pose_arm(client, arm, config, rgba)
        view = client.computeViewMatrixFromYawPitchRoll(
            cameraTargetPosition=self.target,
            distance=self.distance,
            yaw=self.yaw,
            pitch=self.pitch,
            roll=0.0,
            upAxisIndex=2,
        )
        projection = client.computeProjectionMatrixFOV(
            fov=self.fov, aspect=width / height, nearVal=0.05, farVal=20.0
        )
        _, _, rgba, _, _ = client.getCameraImage(
            width,
            height,
            view,
            projection,
            shadow=int(self.shadow),
            lightDirection=[1.0, 0.6, 2.0],
            renderer=pybullet.ER_TINY_RENDERER,
            flags=pybullet.ER_NO_SEGMENTATION_MASK,
        )
        return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()


__all__ = ["IiwaRenderer", "render_point_world"]
