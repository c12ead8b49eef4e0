"""`ArmRenderer`: an arm's problem drawn with pybullet's software renderer.

The arm is drawn at a few configurations in its own ``DIRECT`` client, with the obstacles
(boxes, turned or not, cylinders and spheres, each as pybullet's shape of its kind):

* a solution: the start (green), two pale ghosts along the path, the end (blue);
* before a solution: the start (green), the goal (blue) and the newest node of the path so
  far (orange), with pale ghosts between start and newest node;
* neither: the start and the goal.

A legend across the bottom names each arm. A configuration is drawn once: two arms at the
same pose would fight over every pixel (a speckled picture), so repeated poses are dropped.

The camera is chosen per scene (unless fixed by the arguments). It looks at the middle of
the start and goal arms, from a ring of views around them: first those from which the goal
hand (wrist to flange) is not hidden behind an obstacle (straight rays to it miss every
obstacle, `temp_gym.worlds.rendering.camera`), then, among them, the one that shows the most of the
start and goal arms, measured on small segmentation renders. The choice is made once per
problem, so the frames of an episode share one view.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from temp_gym.problem.obstacles import BOX, CYLINDER
from temp_gym.quiet import import_pybullet, native_output_silenced
from temp_gym.worlds.arm.bullet import set_configuration
from temp_gym.worlds.rendering.camera import clearest_views
from temp_gym.worlds.rendering.common import (
    LegendEntry,
    caption,
    check_paths,
    check_size,
    floor_slabs,
    legend_band,
    plan_title,
)
from temp_gym.worlds.rendering.solids import Solids

if TYPE_CHECKING:
    from temp_gym.problem import Problem

START_RGBA = np.array([0.20, 0.72, 0.30, 1.0])
GOAL_RGBA = np.array([0.18, 0.38, 0.90, 1.0])
NEWEST_RGBA = np.array([0.95, 0.55, 0.10, 1.0])
_GHOST_LIGHTEN = 0.55
"""Ghosts are their tint blended this far towards white (the tiny renderer ignores alpha, so
paleness stands in for transparency)."""
GHOSTS = 2
"""Pale arms drawn along a path between its first and last arm: few enough to tell apart."""
_OBSTACLE_RGBA = [0.78, 0.58, 0.38, 1.0]
_FLOOR_RGBA = [0.80, 0.80, 0.80, 1.0]
_GROUND_RGBA = [0.93, 0.93, 0.93, 1.0]
_BASE_RGBA = [0.35, 0.35, 0.38, 1.0]
_PARKED = (0.0, 0.0, -100.0)
"""Where unused arm bodies wait, far outside the camera's view."""
CANDIDATE_YAWS = tuple(range(0, 360, 45))
"""Camera yaws (degrees) tried per scene."""
CANDIDATE_PITCHES = (-28.0, -50.0)
"""Camera pitches (degrees) tried per scene: the usual view and a steeper one over furniture."""
_PROBE_SIZE = 96
"""Side in pixels of the segmentation renders that score a view."""
_HAND_LINKS = 3
"""The goal hand the camera must see: the origins of the arm's last links (wrist to flange)."""


def _path_samples(path: np.ndarray, count: int) -> np.ndarray:
    """``count`` configurations evenly spaced by joint-space arc length strictly inside path."""
    lengths = np.linalg.norm(np.diff(path, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    if count <= 0 or arc[-1] <= 0:
        return np.empty((0, path.shape[1]))
    targets = arc[-1] * np.arange(1, count + 1) / (count + 1)
    return np.stack([np.interp(targets, arc, path[:, j]) for j in range(path.shape[1])], axis=1)


def _pale(rgba: np.ndarray) -> np.ndarray:
    return (1 - _GHOST_LIGHTEN) * rgba + _GHOST_LIGHTEN * np.ones(4)


def arm_poses(
    problem: Problem,
    path: np.ndarray | None = None,
    path_so_far: np.ndarray | None = None,
    ghosts: int = GHOSTS,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The ``(configuration, rgba)`` pairs a render draws, solid arms first, no pose twice.

    See the module docstring for what each case shows. Ghosts are tinted along the way from
    the first arm's colour to the last's, and paled.
    """
    if path is not None:
        first, last, last_rgba, along = path[0], path[-1], GOAL_RGBA, path
        solid = [(first, START_RGBA), (last, last_rgba)]
    elif path_so_far is not None and len(path_so_far) > 1:
        first, last, last_rgba, along = path_so_far[0], path_so_far[-1], NEWEST_RGBA, path_so_far
        solid = [(first, START_RGBA), (problem.goal, GOAL_RGBA), (last, last_rgba)]
    else:
        first, along = problem.start, None
        solid = [(problem.start, START_RGBA), (problem.goal, GOAL_RGBA)]
    poses: list[tuple[np.ndarray, np.ndarray]] = []
    for config, rgba in solid:
        if not any(np.array_equal(config, seen) for seen, _ in poses):
            poses.append((np.asarray(config, dtype=np.float64), rgba))
    if along is not None:
        middle = _path_samples(along, ghosts)
        for k, config in enumerate(middle):
            fraction = (k + 1) / (len(middle) + 1)
            tint = (1 - fraction) * START_RGBA + fraction * last_rgba
            if not any(np.array_equal(config, seen) for seen, _ in poses):
                poses.append((config, _pale(tint)))
    return poses


def _bullet_shape(pybullet, kind: int, half: np.ndarray) -> dict:
    """The keywords of ``createCollisionShape`` for one obstacle of ``kind`` (its own frame)."""
    if kind == BOX:
        return {"shapeType": pybullet.GEOM_BOX, "halfExtents": half}
    if kind == CYLINDER:  # pybullet's cylinders, like ours, stand along their local z
        return {"shapeType": pybullet.GEOM_CYLINDER, "radius": half[0], "height": 2.0 * half[2]}
    return {"shapeType": pybullet.GEOM_SPHERE, "radius": half[0]}


def _visual(shape: dict) -> dict:
    """``createVisualShape``'s keywords for a collision ``shape``: a cylinder's ``length``."""
    if "height" in shape:
        shape = {**shape, "length": shape["height"]}
        del shape["height"]
    return shape


def _hex(rgba: np.ndarray) -> str:
    return "#" + "".join(f"{round(255 * float(c)):02x}" for c in rgba[:3])


def arm_legend(
    path: np.ndarray | None, path_so_far: np.ndarray | None, ghosts: bool
) -> list[LegendEntry]:
    """The legend of a picture drawn with `arm_poses`: which arm is which."""
    entries: list[LegendEntry] = [("start", _hex(START_RGBA), "box")]
    if path is not None:
        entries.append(("path's end (goal)", _hex(GOAL_RGBA), "box"))
        last = GOAL_RGBA
    else:
        entries.append(("goal", _hex(GOAL_RGBA), "box"))
        last = None
        if path_so_far is not None and len(path_so_far) > 1:
            entries.append(("newest node", _hex(NEWEST_RGBA), "box"))
            last = NEWEST_RGBA
    if ghosts and last is not None:
        entries.append(("along the path", _hex(_pale((START_RGBA + last) / 2)), "box"))
    entries.append(("obstacles", _hex(np.array(_OBSTACLE_RGBA)), "box"))
    return entries


class ArmRenderer:
    """Draws an arm's problems with pybullet's tiny (CPU) renderer.

    The renderer owns its own ``DIRECT`` pybullet client, created at the first `render`, and
    keeps the arm bodies loaded; the boxes (and the camera, when chosen per scene) change only
    when a different problem object is rendered. Call `close` (or use it as a context
    manager) to free the client; closing twice is harmless, and a closed renderer reconnects
    on the next `render`.

    Args:
        arm: the arm (`temp_gym.worlds.arm.load_arm`); None: the iiwa.
        ghosts: Most intermediate configurations drawn along a path.
        yaw: Camera yaw around the vertical axis, degrees; None: chosen per scene (with
            ``pitch``) to see the goal hand and the most of the arm.
        pitch: Camera pitch, degrees (negative looks down); None: chosen per scene.
        distance: Camera distance from ``target``, metres.
        target: Point the camera looks at, metres; None: the middle of the start and goal
            arms.
        fov: Vertical field of view, degrees.
        shadow: Whether the renderer casts shadows (about 3x slower).
        legend: Whether pictures have a legend across the bottom.

    Examples:
        >>> renderer = ArmRenderer(arm)
        >>> image = renderer.render(problem, path=result.path)  # (480, 480, 3) uint8
        >>> renderer.close()
    """

    def __init__(
        self,
        arm=None,
        ghosts: int = GHOSTS,
        yaw: float | None = None,
        pitch: float | None = None,
        distance: float = 3.3,
        target: tuple[float, float, float] | None = None,
        fov: float = 45.0,
        shadow: bool = False,
        legend: bool = True,
    ) -> None:
        if arm is None:
            from temp_gym.worlds.arm.model import load_arm
            from temp_gym.worlds.robots.kuka_iiwa14 import DESCRIPTION

            arm = load_arm(DESCRIPTION)
        self.arm = arm
        if ghosts < 0:
            raise ValueError(f"ghosts: expected a non-negative count, got {ghosts}")
        self.ghosts = int(ghosts)
        self.yaw = None if yaw is None else float(yaw)
        self.pitch = None if pitch is None else float(pitch)
        self.distance = float(distance)
        self.target = None if target is None else tuple(float(x) for x in target)
        self.fov = float(fov)
        self.shadow = bool(shadow)
        self.legend = bool(legend)
        self.view: tuple[float, float] | None = None
        """The (yaw, pitch) of the last render."""
        self.view_target: tuple[float, float, float] | None = None
        """The point the last render looked at."""
        self._goal_hand = np.empty((0, 3))
        self._client = None
        self._arms: list = []
        self._links: list[int] = []
        self._boxes: list[int] = []
        self._problem: Problem | None = None
        self._pid = os.getpid()

    # ------------------------------------------------------------------ lifecycle
    def __enter__(self) -> ArmRenderer:
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
        """The client, connected and holding ``ghosts + 3`` parked arms."""
        if self._client is not None:
            return self._client
        pybullet = import_pybullet()
        from pybullet_utils.bullet_client import BulletClient

        from temp_gym.worlds.arm.bullet import load_bullet_arm

        with native_output_silenced():  # no "argv[0]=" on the user's stdout
            client = BulletClient(connection_mode=pybullet.DIRECT)
        self._client, self._pid = client, os.getpid()
        for _ in range(self.ghosts + 3):
            loaded = load_bullet_arm(client, self.arm)
            client.resetBasePositionAndOrientation(loaded.body, _PARKED, (0, 0, 0, 1))
            self._arms.append(loaded)
        # The chain's links, base first: the camera aims at them and the legend colours them.
        self._links = [self._arms[0].links.get(name, -1) for name in self.arm.body_names]
        self._all_links = sorted(set(self._arms[0].links.values()))
        return client

    def _load_problem(self, client, problem: Problem) -> bool:
        """Replace the boxes when ``problem`` is a different object; True when it was."""
        if problem is self._problem:
            return False
        pybullet = import_pybullet()
        for body in self._boxes:
            client.removeBody(body)
        self._boxes = []
        workspace = problem.workspace
        lower, upper = workspace.obstacle_lower, workspace.obstacle_upper
        floors = floor_slabs(lower, upper)
        ground_z = min(0.0, float(lower[:, 2].min())) if len(lower) else 0.0
        # A pale visual-only ground under everything, so the scene does not float.
        ground_half = np.array([1.6, 1.6, 0.005])
        visual = client.createVisualShape(
            pybullet.GEOM_BOX, halfExtents=ground_half, rgbaColor=_GROUND_RGBA
        )
        self._boxes.append(
            client.createMultiBody(
                baseMass=0.0,
                baseCollisionShapeIndex=-1,
                baseVisualShapeIndex=visual,
                basePosition=[0.0, 0.0, ground_z - 0.006],
            )
        )
        unrotated = workspace.unrotated
        for index, (center, half) in enumerate(
            zip(workspace.obstacle_centers, workspace.obstacle_half_extents)
        ):
            # Thin slabs below the base (the generators' floor) get a neutral colour.
            rgba = _FLOOR_RGBA if floors[index] else _OBSTACLE_RGBA
            kind = workspace.obstacle_kinds[index]
            shape = _bullet_shape(pybullet, kind, half)
            collision = client.createCollisionShape(**shape)
            visual = client.createVisualShape(**_visual(shape), rgbaColor=rgba)
            placed = {"basePosition": center.tolist()}
            if kind != BOX or not unrotated[index]:
                quaternion = workspace.obstacle_orientations[index]
                placed["baseOrientation"] = (quaternion / np.linalg.norm(quaternion)).tolist()
            body = client.createMultiBody(
                baseMass=0.0,
                baseCollisionShapeIndex=collision,
                baseVisualShapeIndex=visual,
                **placed,
            )
            self._boxes.append(body)
        self._problem = problem
        self._pose_arms(client, [(problem.start, START_RGBA), (problem.goal, GOAL_RGBA)])
        joints = np.concatenate([self._link_origins(client, arm) for arm in self._arms[:2]])
        self._goal_hand = self._link_origins(client, self._arms[1])[-_HAND_LINKS:]
        middle = (joints.min(axis=0) + joints.max(axis=0)) / 2
        self.view_target = self.target or tuple(float(x) for x in middle)
        return True

    def _link_origins(self, client, arm: int) -> np.ndarray:
        """World positions ``(links, 3)`` of ``arm``'s base and link frames, base first."""
        points = [
            client.getBasePositionAndOrientation(arm.body)[0] if link == -1
            else client.getLinkState(arm.body, link)[4]
            for link in self._links
        ]  # fmt: skip
        return np.array(points, dtype=np.float64)

    def _pose_arms(self, client, poses: list[tuple[np.ndarray, np.ndarray]]) -> None:
        """Show the first arms at ``poses``; park the rest."""
        for index, arm in enumerate(self._arms):
            if index >= len(poses):
                client.resetBasePositionAndOrientation(arm.body, _PARKED, (0, 0, 0, 1))
                continue
            config, rgba = poses[index]
            client.resetBasePositionAndOrientation(arm.body, arm.base_position,
                                                   arm.base_orientation)  # fmt: skip
            set_configuration(client, arm, config)
            for link in self._all_links:
                # The fixed base is the same for every arm: one neutral colour avoids z-fighting.
                colour = _BASE_RGBA if link == self._links[0] else rgba.tolist()
                client.changeVisualShape(arm.body, link, rgbaColor=colour)

    def _camera_image(self, client, view: tuple[float, float], width: int, height: int, seg: bool):
        pybullet = import_pybullet()
        matrix = client.computeViewMatrixFromYawPitchRoll(
            cameraTargetPosition=self.view_target,
            distance=self.distance,
            yaw=view[0],
            pitch=view[1],
            roll=0.0,
            upAxisIndex=2,
        )
        projection = client.computeProjectionMatrixFOV(
            fov=self.fov, aspect=width / height, nearVal=0.05, farVal=20.0
        )
        return client.getCameraImage(
            width,
            height,
            matrix,
            projection,
            shadow=int(self.shadow and not seg),
            lightDirection=[1.0, 0.6, 2.0],
            renderer=pybullet.ER_TINY_RENDERER,
            flags=0 if seg else pybullet.ER_NO_SEGMENTATION_MASK,
        )

    def visible_arm_pixels(self, problem: Problem, view: tuple[float, float]) -> int:
        """Pixels of the start and goal arms seen from ``view`` = (yaw, pitch), small render."""
        client = self._connect()
        if self._load_problem(client, problem):
            self.view = None  # chosen again for this problem at the next render
        self._pose_arms(client, arm_poses(problem, ghosts=0))
        return self._count_arm_pixels(client, view, 2)

    def _count_arm_pixels(self, client, view: tuple[float, float], arms: int) -> int:
        mask = np.asarray(self._camera_image(client, view, _PROBE_SIZE, _PROBE_SIZE, True)[4])
        return int(np.isin(mask, [arm.body for arm in self._arms[:arms]]).sum())

    def _choose_view(self, client, problem: Problem) -> tuple[float, float]:
        """The fixed view, or the best candidate (module docstring): goal hand in sight first."""
        yaws = CANDIDATE_YAWS if self.yaw is None else (self.yaw,)
        pitches = CANDIDATE_PITCHES if self.pitch is None else (self.pitch,)
        views = [(float(yaw), float(pitch)) for pitch in pitches for yaw in yaws]
        if len(views) == 1:
            return views[0]
        solids = Solids.of_workspace(problem.workspace)
        views = clearest_views(self._goal_hand, solids, views, self.view_target, self.distance)
        self._pose_arms(client, arm_poses(problem, ghosts=0))
        scores = {view: self._count_arm_pixels(client, view, 2) for view in views}
        return max(scores, key=scores.get)  # first of the best: the order above breaks ties

    # ------------------------------------------------------------------ drawing
    def draw_tree(
        self,
        problem: Problem,
        positions: np.ndarray | None,
        parents: np.ndarray | None,
        num_nodes: int,
        path: np.ndarray | None = None,
        path_so_far: np.ndarray | None = None,
    ) -> np.ndarray:
        """`render` titled like a tree picture (`TreeRenderer`); the tree itself is not drawn.

        A 7D tree drawn as arms would hide the path, so the picture shows the arm along the
        solution, or at the newest node of the path so far (an orange arm).
        """
        del positions, parents  # a tree of arm poses is no picture
        shown = "orange arm" if path is None and num_nodes > 1 else ""
        title = plan_title(problem, num_nodes, path, shown)
        return self.render(problem, title=title, path=path, path_so_far=path_so_far)

    def render(
        self,
        problem: Problem,
        path: np.ndarray | None = None,
        width: int = 480,
        height: int = 480,
        path_so_far: np.ndarray | None = None,
        title: str | None = None,
    ) -> np.ndarray:
        """Draw ``problem`` with the arm along a solution, a path so far, or at start and goal.

        Args:
            problem: A problem of this renderer's arm.
            path: Joint configurations ``(K, dim)`` of a solution, or None.
            width: Image width in pixels.
            height: Image height in pixels.
            path_so_far: Joint configurations ``(K, dim)`` of a path that does not reach the
                goal yet (the root path of the newest node), or None.
            title: Text on a white band across the top, or None for none.

        Returns:
            A fresh ``uint8`` array of shape ``(height, width, 3)``.

        Raises:
            ValueError: For another robot, a badly shaped path, or both kinds of path.
        """
        if problem.robot != self.arm.name:
            raise ValueError(
                f"problem: this ArmRenderer draws {self.arm.name}, got {problem.robot!r}; "
                "use render_point_world for point robots"
            )
        width, height = check_size(width, height)
        path, path_so_far = check_paths(problem, path, path_so_far)
        client = self._connect()
        if self._load_problem(client, problem) or self.view is None:
            self.view = self._choose_view(client, problem)
        poses = arm_poses(problem, path, path_so_far, self.ghosts)
        self._pose_arms(client, poses)
        rgba = self._camera_image(client, self.view, width, height, False)[2]
        image = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()
        if self.legend:
            solid = (START_RGBA, GOAL_RGBA, NEWEST_RGBA)
            ghosts = any(not any(np.array_equal(c, s) for s in solid) for _, c in poses)
            image = legend_band(image, arm_legend(path, path_so_far, ghosts))
        return image if title is None else caption(image, title)
