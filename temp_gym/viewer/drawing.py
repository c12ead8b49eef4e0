"""`draw_content`: a `PlanContent` added to a viser scene, and the robot that moves along it.

Colours are the static pictures' (`temp_gym.worlds.rendering.common`): start green, goal
blue, path red, tree blue-grey, obstacles tan, and the robot along the path purple. Every
obstacle is drawn by its shape: a box (turned or not), a cylinder or a sphere. The arm at
start and goal is drawn translucent in the start and goal colours.

The scene is lit by plain lights, without an environment map: a software renderer (a
browser without a GPU, as in CI) then draws the first frame in seconds rather than
half a minute.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from temp_gym.problem.obstacles import BOX, CYLINDER, KIND_NAMES
from temp_gym.viewer.content import PlanContent
from temp_gym.worlds.rendering.camera import clearest_views, orbit_position
from temp_gym.worlds.rendering.common import (
    FLOOR_COLOR,
    GOAL_COLOR,
    OBSTACLE_COLOR,
    ROBOT_COLOR,
    SOLUTION_COLOR,
    START_COLOR,
    TREE_COLOR,
    rgb255,
)
from temp_gym.worlds.rendering.solids import surface, triangle_mesh

if TYPE_CHECKING:
    import viser

GHOST_OPACITY = 0.35
"""Opacity of the arm drawn at start and goal."""
REGION_COLOR = (150, 150, 150)
PLANE_COLOR = (236, 236, 236)
"""The ground of a 2D world."""
ARM_TREE_LIGHTEN = 0.5
"""An arm's tree (hand positions, a dense web around the arm) is its colour blended this far
towards white, so the arm stays in sight."""
CAMERA_FOV = 50.0
"""Vertical field of view of the first camera, degrees."""
ARM_CAMERA_DISTANCE = 3.2
"""Metres from the camera to the arm scene's centre."""
ARM_VIEWS = [(float(yaw), pitch) for pitch in (-25.0, -45.0) for yaw in range(0, 360, 30)]
"""Candidate (yaw, pitch) views of an arm scene (degrees; `temp_gym.worlds.rendering.camera`)."""


def _region_edges(region: np.ndarray, flat: bool) -> np.ndarray:
    """The region's outline as segments ``(E, 2, 3)``: a rectangle (flat) or a box's 12 edges."""
    low, high = region
    corners = np.array([[(high if (k >> a) & 1 else low)[a] for a in range(3)] for k in range(8)])
    pairs = [(k, k | (1 << a)) for k in range(8) for a in range(3) if not (k >> a) & 1]
    if flat:
        pairs = [(i, j) for i, j in pairs if i < 4 and j < 4]  # the z = low face
    return corners[np.array(pairs)]


def _wxyz(rotation: np.ndarray) -> np.ndarray:
    from viser import transforms

    return transforms.SO3.from_matrix(rotation).wxyz


def _add_arm(scene, name: str, content: PlanContent, poses: np.ndarray, color, opacity):
    """The arm's link meshes at ``poses`` ``(links, 4, 4)``, each under a movable frame."""
    frames = []
    for link, ((vertices, faces), pose) in enumerate(zip(content.arm.meshes, poses)):
        frame = scene.add_frame(
            f"{name}/link_{link}", show_axes=False, wxyz=_wxyz(pose[:3, :3]), position=pose[:3, 3]
        )
        scene.add_mesh_simple(
            f"{name}/link_{link}/mesh", vertices, faces, color=color, opacity=opacity
        )
        frames.append(frame)
    return frames


def _add_obstacle(scene, content: PlanContent, index: int, color, opacity: float | None):
    """Obstacle ``index`` of ``content`` by its shape, under ``/obstacles``.

    An axis-aligned box is added from its corners, as it always was; a turned box and a sphere
    are viser's own shapes, a cylinder a mesh of its facets (`triangle_mesh`).
    """
    solids = content.obstacles
    kind = int(solids.kinds[index])
    name = f"/obstacles/{KIND_NAMES[kind]}_{index}"
    if solids.aligned_boxes[index]:
        lower, upper = solids.lower[index], solids.upper[index]
        center = (lower + upper) / 2
        scene.add_box(name, color=color, dimensions=upper - lower, position=center, opacity=opacity)
        return
    center, half = solids.centers[index], solids.half_extents[index]
    wxyz = _wxyz(solids.rotations[index])
    if kind == BOX:
        scene.add_box(
            name, color=color, dimensions=2 * half, position=center, wxyz=wxyz, opacity=opacity
        )
    elif kind == CYLINDER:
        vertices, faces = triangle_mesh(surface(CYLINDER, np.zeros(3), half, np.eye(3)))
        scene.add_mesh_simple(
            name, vertices, faces, color=color, opacity=opacity, position=center, wxyz=wxyz
        )
    else:
        scene.add_icosphere(name, radius=half[0], color=color, position=center, opacity=opacity)


class RobotMarker:
    """The robot at one playback frame: a purple ball (point robot) or the arm's links.

    ``lift`` raises a ball above a 2D world's tree and path, so it stays in sight.
    """

    def __init__(self, scene, content: PlanContent, lift: np.ndarray) -> None:
        self.content = content
        self.frame = 0
        self._lift = lift
        if content.arm is None:
            radius = 0.015 * content.size
            self._ball = scene.add_icosphere(
                "/robot", radius=radius, color=rgb255(ROBOT_COLOR), position=content.start + lift
            )
            self._links = []
        else:
            poses = content.arm.frame_poses[0]
            self._links = _add_arm(scene, "/robot", content, poses, rgb255(ROBOT_COLOR), None)

    def show(self, frame: int) -> None:
        """Move the robot to playback frame ``frame`` (clamped to the frames there are)."""
        frame = int(np.clip(frame, 0, self.content.frames - 1))
        self.frame = frame
        if self.content.arm is None:
            self._ball.position = self.content.frame_positions[frame] + self._lift
            return
        for handle, pose in zip(self._links, self.content.arm.frame_poses[frame]):
            handle.wxyz = _wxyz(pose[:3, :3])
            handle.position = pose[:3, 3]


def camera_pose(content: PlanContent) -> tuple[np.ndarray, np.ndarray]:
    """``(position, look_at)`` of the first view.

    A 2D world is seen from above; a point robot's 3D world from a corner; an arm from the
    view on an orbit around its start and goal that sees the goal hand past the obstacles
    (`temp_gym.worlds.rendering.camera.clearest_views`), on the hand's side of the arm
    among those.
    """
    low, high = content.region
    if content.flat:
        centre = (low + high) / 2
        return centre + np.array([0.0, -0.05, 1.3]) * content.size, centre
    if content.arm is None:
        centre = (low + high) / 2
        return orbit_position(centre, -35.0, -30.0, 1.9 * content.size), centre
    arm = content.arm
    joints = np.concatenate([arm.start_poses[:, :3, 3], arm.goal_poses[:, :3, 3]])
    centre = (joints.min(axis=0) + joints.max(axis=0)) / 2
    hand = arm.goal_poses[-3:, :3, 3]  # wrist to flange
    views = clearest_views(hand, content.obstacles, ARM_VIEWS, centre, ARM_CAMERA_DISTANCE)
    facing = [
        float(np.dot(orbit_position(centre, yaw, pitch, 1.0)[:2] - centre[:2], hand[-1, :2]))
        for yaw, pitch in views
    ]
    yaw, pitch = views[int(np.argmax(facing))]
    return orbit_position(centre, yaw, pitch, ARM_CAMERA_DISTANCE), centre


def draw_content(
    server: viser.ViserServer, content: PlanContent
) -> tuple[RobotMarker, dict[str, list]]:
    """Add ``content`` to ``server``'s scene and set its first camera.

    Returns:
        The robot along the path, and the layers a viewer may hide: name -> scene handles
        (the tree, the path, an arm at start and goal).
    """
    scene = server.scene
    scene.set_up_direction("+z")
    scene.configure_environment_map(None)
    scene.configure_default_lights(enabled=True, cast_shadow=False)
    scene.add_light_hemisphere("/light/sky", intensity=1.2)
    size = content.size
    layers: dict[str, list] = {}
    scene.add_line_segments(
        "/region", _region_edges(content.region, content.flat), REGION_COLOR, thickness=0.002 * size
    )
    if content.flat:
        low, high = content.region
        scene.add_box(
            "/floor",
            color=PLANE_COLOR,
            dimensions=(high[0] - low[0], high[1] - low[1], 0.002 * size),
            position=((low[0] + high[0]) / 2, (low[1] + high[1]) / 2, -0.001 * size),
        )
    opacity = None if content.flat or content.arm is not None else 0.45
    for index, floor in enumerate(content.box_is_floor):
        _add_obstacle(
            scene, content, index, rgb255(FLOOR_COLOR if floor else OBSTACLE_COLOR), opacity
        )
    lift = np.array([0.0, 0.0, 0.03 * size if content.flat else 0.0])
    if len(content.tree_segments):
        color = np.array(rgb255(TREE_COLOR), dtype=np.float64)
        if content.arm is not None:
            color = (1 - ARM_TREE_LIGHTEN) * color + ARM_TREE_LIGHTEN * 255
        tree = scene.add_line_segments(
            "/tree",
            content.tree_segments + lift,
            tuple(int(c) for c in color),
            thickness=1.0,
            thickness_units="screen",
        )
        layers["Tree"] = [tree]
    if content.path_trace is not None and len(content.path_trace) > 1:
        trace = content.path_trace + 1.2 * lift
        segments = np.stack([trace[:-1], trace[1:]], axis=1)
        thickness = (0.006 if content.flat or content.arm is not None else 0.01) * size
        path = scene.add_line_segments(
            "/path", segments, rgb255(SOLUTION_COLOR), thickness=thickness
        )
        layers["Path"] = [path]
    marker = 0.012 * size
    on_top = 1.5 * lift  # a 2D world's markers lie above its tree and path
    for name, point, color in (
        ("/start", content.start, START_COLOR),
        ("/goal", content.goal, GOAL_COLOR),
    ):
        scene.add_icosphere(name, radius=marker, color=rgb255(color), position=point + on_top)
    if content.goal_radius is not None:
        scene.add_icosphere(
            "/goal_region",
            radius=content.goal_radius,
            color=rgb255(GOAL_COLOR),
            opacity=0.3,
            position=content.goal,
            scale=(1.0, 1.0, 0.05) if content.flat else 1.0,
        )
    if content.arm is not None:
        ghosts = ((content.arm.start_poses, START_COLOR), (content.arm.goal_poses, GOAL_COLOR))
        layers["Arm at start and goal"] = [
            handle
            for name, (poses, color) in zip(("/arm_start", "/arm_goal"), ghosts)
            for handle in _add_arm(scene, name, content, poses, rgb255(color), GHOST_OPACITY)
        ]
    position, look_at = camera_pose(content)
    server.initial_camera.position = position
    server.initial_camera.look_at = look_at
    server.initial_camera.up = (0.0, 0.0, 1.0)
    server.initial_camera.fov = np.radians(CAMERA_FOV)
    return RobotMarker(scene, content, on_top), layers
