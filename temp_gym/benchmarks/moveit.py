"""MoveIt planning scenes and motion-plan requests (as YAML) read into obstacles and joints.

A ``moveit_msgs/PlanningScene`` written as YAML holds the world's collision objects, each a
list of primitives (``box``: full edge lengths ``[x, y, z]``; ``cylinder``: ``[height,
radius]`` along its local z; ``sphere``: ``[radius]``) with a pose per primitive, and
optionally an object-level ``pose`` that the primitive poses are relative to (newer MoveIt
writes both). A ``moveit_msgs/MotionPlanRequest`` holds the start state and goal
constraints.

Points and quaternions may be lists (``[x, y, z]``, ``[x, y, z, w]``) or mappings of their
fields (``{x: .., y: .., z: ..}``), as ROS tools write them. Only what a
`temp_gym.problem.Workspace` can hold is read: primitives in frames that coincide
with the robot's base, a robot base at the world origin, and one joint-space goal. Anything
else (meshes, planes, cones, octomaps, attached objects, frames elsewhere, padded or scaled
links, position or orientation goals, path constraints) is refused with a one-line
`ValueError` that names the file and the field, never silently approximated. Orientations
are quaternions ``[x, y, z, w]``, the order of MoveIt and of the problem format.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from temp_gym.limits import MAX_OBSTACLES
from temp_gym.problem.obstacles import UNIT_TOLERANCE, Box, Cylinder, Obstacle, Sphere
from temp_gym.problem.obstacles import rotation_matrices as _rotations
from temp_gym.problem.parsing import finite_float
from temp_gym.problem.parsing import short_repr as _short

PRIMITIVE_TYPES = {"box": "box", "sphere": "sphere", "cylinder": "cylinder", 1: "box",
                   2: "sphere", 3: "cylinder"}  # fmt: skip
"""``shape_msgs/SolidPrimitive`` types read, by name or by the message's number."""
PRIMITIVE_SIZES = {"box": 3, "cylinder": 2, "sphere": 1}
"""How many ``dimensions`` each primitive has."""
SCENE_KEYS = {"name", "robot_state", "robot_model_name", "fixed_frame_transforms",
              "allowed_collision_matrix", "link_padding", "link_scale", "object_colors",
              "world", "is_diff"}  # fmt: skip
OBJECT_KEYS = {"header", "id", "pose", "type", "primitives", "primitive_poses", "meshes",
               "mesh_poses", "planes", "plane_poses", "subframe_names", "subframe_poses",
               "operation"}  # fmt: skip
REQUEST_KEYS = {"workspace_parameters", "start_state", "goal_constraints", "path_constraints",
                "trajectory_constraints", "reference_trajectories", "pipeline_id",
                "planner_id", "group_name", "num_planning_attempts", "allowed_planning_time",
                "max_velocity_scaling_factor", "max_acceleration_scaling_factor",
                "cartesian_speed_end_effector_link", "max_cartesian_speed"}  # fmt: skip
STATE_KEYS = {"joint_state", "multi_dof_joint_state", "attached_collision_objects", "is_diff"}
JOINT_CONSTRAINT_KEYS = {"joint_name", "position", "tolerance_above", "tolerance_below", "weight"}
HELD_TOLERANCE = 1e-6
"""How far a held joint (the Panda's fingers) may be from the robot's value in a request."""


class MoveItFile:
    """Where a YAML message came from, to name it and its fields in errors."""

    def __init__(self, name: str) -> None:
        self.name = name

    def error(self, field: str, reason: str) -> ValueError:
        """A one-line ``ValueError``: ``file: field: reason``."""
        return ValueError(f"{self.name}: {field}: {reason}")

    def mapping(self, value: Any, field: str, keys: set[str] | None = None) -> Mapping:
        """``value`` as a mapping, refusing keys outside ``keys`` (when given)."""
        if not isinstance(value, Mapping):
            raise self.error(field, f"expected a mapping, got {type(value).__name__}")
        if keys is not None:
            for key in value:
                if key not in keys:
                    name = key if isinstance(key, str) and len(key) <= 40 else _short(key)
                    raise self.error(f"{field}.{name}", "unknown key")
        return value

    def listing(self, value: Any, field: str) -> list:
        """``value`` as a list (an absent one is empty)."""
        if value is None:
            return []
        if not isinstance(value, list):
            raise self.error(field, f"expected a list, got {type(value).__name__}")
        return value

    def number(self, value: Any, field: str) -> float:
        """A finite number (`temp_gym.problem.parsing.finite_float`)."""
        try:
            return finite_float(value, field)
        except ValueError as error:
            raise ValueError(f"{self.name}: {error}") from None

    def vector(self, value: Any, field: str, size: int) -> np.ndarray:
        """A list of ``size`` finite numbers."""
        items = self.listing(value, field)
        if len(items) != size:
            raise self.error(field, f"expected {size} numbers, got {len(items)}")
        return np.array([self.number(v, f"{field}[{i}]") for i, v in enumerate(items)])

    def point(self, value: Any, field: str, size: int = 3) -> np.ndarray:
        """A point or vector ``[x, y, z]`` (or, with ``size`` 4, a quaternion ``[x, y, z, w]``).

        Also as a mapping of its fields, ``{x, y, z}`` or ``{x, y, z, w}``, as ROS tools write
        these messages.
        """
        if isinstance(value, Mapping):
            names = ("x", "y", "z", "w")[:size]
            fields = self.mapping(value, field, set(names))
            missing = [name for name in names if name not in fields]
            if missing:
                raise self.error(f"{field}.{missing[0]}", "missing")
            value = [fields[name] for name in names]
        return self.vector(value, field, size)

    def quaternion(self, value: Any, field: str) -> np.ndarray:
        """A unit quaternion ``[x, y, z, w]`` (within `UNIT_TOLERANCE`), or its mapping."""
        q = self.point(value, field, 4)
        if abs(np.linalg.norm(q) - 1.0) > UNIT_TOLERANCE:
            raise self.error(field, f"not a unit quaternion [x, y, z, w]: {q.tolist()}")
        return q

    def pose(self, value: Any, field: str) -> tuple[np.ndarray, np.ndarray]:
        """A ``geometry_msgs/Pose``: ``(position, orientation)``."""
        pose = self.mapping(value, field, {"position", "orientation"})
        return (
            self.point(pose.get("position", [0, 0, 0]), f"{field}.position"),
            self.quaternion(pose.get("orientation", [0, 0, 0, 1]), f"{field}.orientation"),
        )

    def identity_transform(self, value: Any, field: str) -> None:
        """Refuse a ``geometry_msgs/Transform`` other than the identity."""
        transform = self.mapping(value, field, {"translation", "rotation"})
        translation = self.point(transform.get("translation", [0, 0, 0]), f"{field}.translation")
        rotation = self.quaternion(transform.get("rotation", [0, 0, 0, 1]), f"{field}.rotation")
        if np.any(translation != 0) or not _is_identity(rotation):
            raise self.error(
                field,
                f"translation {translation.tolist()}, rotation {rotation.tolist()}: only frames "
                "at the robot base are supported (the identity transform)",
            )

    def empty(self, value: Any, field: str, what: str) -> None:
        """Refuse anything but an absent, empty or all-empty ``value`` (``what`` names it)."""
        if not _is_empty(value):
            raise self.error(field, f"{what} are not supported")


def _is_empty(value: Any) -> bool:
    """Whether ``value`` is absent or holds nothing but empty values (names and headers aside).

    Walked without recursion: a YAML document may nest as deep as its parser allows.
    """
    stack = [value]
    while stack:
        value = stack.pop()
        if isinstance(value, Mapping):
            stack.extend(v for k, v in value.items() if k not in ("name", "header"))
        elif not (value is None or (isinstance(value, (str, list)) and len(value) == 0)):
            return False
    return True


def _check_name(source: MoveItFile, name: Any, field: str) -> None:
    """Refuse a link, joint or object name that is not a string."""
    if not isinstance(name, str):
        raise source.error(field, f"expected a name, got {_short(name)}")


def _is_identity(q: np.ndarray) -> bool:
    return bool(np.all(q[:3] == 0) and abs(q[3]) == 1)


def compose(
    outer: tuple[np.ndarray, np.ndarray], inner: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """The pose ``outer * inner``: ``inner`` given in ``outer``'s frame, in the world's.

    An identity ``outer`` returns ``inner``'s numbers unchanged (so axis-aligned boxes stay
    exactly axis-aligned).
    """
    (p_out, q_out), (p_in, q_in) = outer, inner
    if _is_identity(q_out):
        return p_out + p_in, q_in
    rotation = _rotations(q_out[None])[0]
    x1, y1, z1, w1 = q_out / np.linalg.norm(q_out)
    x2, y2, z2, w2 = q_in
    q = np.array([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                  w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                  w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
                  w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2])  # fmt: skip
    return p_out + rotation @ p_in, q / np.linalg.norm(q)


def check_robot_state(source: MoveItFile, state: Any, field: str) -> Mapping:
    """Check a ``moveit_msgs/RobotState``: no attached objects, the base at the origin."""
    state = source.mapping(state, field, STATE_KEYS)
    source.empty(
        state.get("attached_collision_objects"), f"{field}.attached_collision_objects",
        "attached collision objects",
    )  # fmt: skip
    multi = source.mapping(
        state.get("multi_dof_joint_state") or {}, f"{field}.multi_dof_joint_state",
        {"header", "joint_names", "transforms", "twist", "wrench"},
    )  # fmt: skip
    transforms = source.listing(
        multi.get("transforms"), f"{field}.multi_dof_joint_state.transforms"
    )
    for i, transform in enumerate(transforms):
        source.identity_transform(
            transform, f"{field}.multi_dof_joint_state.transforms[{i}] (the robot base)"
        )
    return state


def scene_obstacles(
    source: MoveItFile, scene: Any, model_name: str, frames: set[str]
) -> list[Obstacle]:
    """The obstacles of a planning scene, in the robot base's frame.

    ``model_name`` is the robot model the scene must name; ``frames`` are the frame names at
    the robot base (the world and the base link), to which the scene's fixed frames at the
    identity are added. A scene whose allowed-collision matrix lets an object touch the robot
    is refused; the robot's own pairs are not read (its spec's matrix, from its SRDF, holds).
    """
    scene = source.mapping(scene, "scene", SCENE_KEYS)
    if scene.get("robot_model_name", model_name) != model_name:
        raise source.error(
            "robot_model_name",
            f"{_short(scene['robot_model_name'])} is not the {model_name!r} these problems need",
        )
    is_diff = scene.get("is_diff", False)
    if not isinstance(is_diff, bool):
        raise source.error("is_diff", f"expected true or false, got {_short(is_diff)}")
    if is_diff:
        raise source.error("is_diff", "a scene difference cannot be read on its own")
    check_robot_state(source, scene.get("robot_state") or {}, "robot_state")
    frames = set(frames)
    for i, entry in enumerate(source.listing(scene.get("fixed_frame_transforms"), "frames")):
        field = f"fixed_frame_transforms[{i}]"
        entry = source.mapping(entry, field, {"header", "child_frame_id", "transform"})
        parent = _frame(source, entry.get("header"), f"{field}.header")
        if parent not in frames:
            raise source.error(f"{field}.header.frame_id", f"unknown frame {_short(parent)}")
        source.identity_transform(entry.get("transform") or {}, f"{field}.transform")
        frames.add(str(entry.get("child_frame_id", "")).lstrip("/"))
    for key, neutral, what in (("link_padding", "padding", 0.0), ("link_scale", "scale", 1.0)):
        for i, entry in enumerate(source.listing(scene.get(key), key)):
            entry = source.mapping(entry, f"{key}[{i}]", {"link_name", neutral})
            if source.number(entry.get(neutral, what), f"{key}[{i}].{neutral}") != what:
                raise source.error(f"{key}[{i}]", f"a link {neutral} other than {what:g} is "
                                   "not supported (the robot's geometry is fixed)")  # fmt: skip
    world = source.mapping(scene.get("world") or {}, "world", {"collision_objects", "octomap"})
    octomap = source.mapping(world.get("octomap") or {}, "world.octomap")
    tree = source.mapping(octomap.get("octomap") or {}, "world.octomap.octomap")
    source.empty(tree.get("data"), "world.octomap", "octomaps")  # an empty one has no data
    objects = source.listing(world.get("collision_objects"), "world.collision_objects")
    if len(objects) > MAX_OBSTACLES:
        raise source.error("world.collision_objects", f"more than {MAX_OBSTACLES} objects")
    obstacles: list[Obstacle] = []
    names = set()
    for i, entry in enumerate(objects):
        entry = source.mapping(entry, f"world.collision_objects[{i}]", OBJECT_KEYS)
        names.add(str(entry.get("id", "")))
        field = f"world.collision_objects[{i}] ({_short(str(entry.get('id', '')))})"
        obstacles += _object_obstacles(source, entry, field, frames)
        if len(obstacles) > MAX_OBSTACLES:
            raise source.error("world.collision_objects", f"more than {MAX_OBSTACLES} primitives")
    _check_allowed(source, scene.get("allowed_collision_matrix"), names)
    return obstacles


def _frame(source: MoveItFile, header: Any, field: str) -> str:
    """The ``frame_id`` of a ``std_msgs/Header`` (empty when absent)."""
    if header is None:
        return ""
    header = source.mapping(header, field, {"frame_id", "stamp", "seq"})
    frame = header.get("frame_id", "")
    if not isinstance(frame, str):
        raise source.error(f"{field}.frame_id", f"expected a frame name, got {_short(frame)}")
    return frame.lstrip("/")


def _object_obstacles(
    source: MoveItFile, entry: Mapping, field: str, frames: set[str]
) -> list[Obstacle]:
    """One collision object's primitives as obstacles."""
    frame = _frame(source, entry.get("header"), f"{field}.header")
    if frame not in frames:
        raise source.error(
            f"{field}.header.frame_id",
            f"unknown frame {_short(frame)} (known: {', '.join(sorted(f for f in frames if f))})",
        )
    operation = entry.get("operation", 0)
    if operation not in (0, "add", "ADD", b"\x00"):
        raise source.error(f"{field}.operation", f"only ADD (0) is supported, got {operation!r}")
    source.empty(entry.get("meshes"), f"{field}.meshes", "meshes")
    source.empty(entry.get("planes"), f"{field}.planes", "planes")
    identity = (np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]))
    outer = source.pose(entry["pose"], f"{field}.pose") if "pose" in entry else identity
    primitives = source.listing(entry.get("primitives"), f"{field}.primitives")
    poses = source.listing(entry.get("primitive_poses"), f"{field}.primitive_poses")
    if len(poses) != len(primitives):
        raise source.error(
            f"{field}.primitive_poses",
            f"{len(poses)} poses for {len(primitives)} primitives (one each expected)",
        )
    obstacles: list[Obstacle] = []
    for k, (primitive, pose) in enumerate(zip(primitives, poses)):
        where = f"{field}.primitives[{k}]"
        primitive = source.mapping(primitive, where, {"type", "dimensions"})
        kind = primitive.get("type")
        # A name or the message's number; True == 1 in Python, but it is no type.
        name = (PRIMITIVE_TYPES.get(kind.lower()) if isinstance(kind, str) else
                PRIMITIVE_TYPES.get(kind) if type(kind) is int else None)  # fmt: skip
        if name is None:
            raise source.error(
                f"{where}.type", f"{_short(kind)} is not supported (box, cylinder or sphere only)"
            )
        size = source.vector(primitive.get("dimensions"), f"{where}.dimensions",
                             PRIMITIVE_SIZES[name])  # fmt: skip
        if np.any(size <= 0):
            raise source.error(f"{where}.dimensions", f"must be positive, got {size.tolist()}")
        center, orientation = compose(outer, source.pose(pose, f"{field}.primitive_poses[{k}]"))
        center_tuple = tuple(float(c) for c in center)
        turned = None if _is_identity(orientation) else tuple(float(q) for q in orientation)
        if name == "box":
            obstacles.append(Box(center_tuple, tuple(float(s) / 2 for s in size), turned))
        elif name == "cylinder":
            obstacles.append(Cylinder(center_tuple, float(size[1]), float(size[0]), turned))
        else:
            obstacles.append(Sphere(center_tuple, float(size[0])))
    return obstacles


def _check_allowed(source: MoveItFile, matrix: Any, objects: set[str]) -> None:
    """Refuse an allowed-collision matrix that lets a robot link touch a world object."""
    if matrix is None:
        return
    field = "allowed_collision_matrix"
    matrix = source.mapping(matrix, field, {"entry_names", "entry_values", "default_entry_names",
                                            "default_entry_values"})  # fmt: skip
    names = source.listing(matrix.get("entry_names"), f"{field}.entry_names")
    rows = source.listing(matrix.get("entry_values"), f"{field}.entry_values")
    for i, name in enumerate(names):
        _check_name(source, name, f"{field}.entry_names[{i}]")
        if name in objects and i < len(rows):
            row = rows[i].get("enabled", []) if isinstance(rows[i], Mapping) else rows[i]
            if any(v is True for v in source.listing(row, f"{field}.entry_values[{i}]")):
                raise source.error(field, f"object {_short(name)} is allowed to touch the robot; "
                                   "allowed contacts with objects are not supported")  # fmt: skip
    defaults = source.listing(matrix.get("default_entry_names"), f"{field}.default_entry_names")
    values = source.listing(matrix.get("default_entry_values"), f"{field}.default_entry_values")
    for i, (name, value) in enumerate(zip(defaults, values)):
        _check_name(source, name, f"{field}.default_entry_names[{i}]")
        if name in objects and value is True:
            raise source.error(
                field,
                f"object {_short(name)} is allowed to touch the robot by default; allowed "
                "contacts with objects are not supported",
            )


def request_joints(
    source: MoveItFile, request: Any, joints: tuple[str, ...], held: Mapping[str, float]
) -> tuple[np.ndarray, np.ndarray]:
    """The start and goal configurations of a motion-plan request, in ``joints`` order.

    The start is ``start_state.joint_state``; the goal is the one goal's joint constraints
    (their tolerances are not read: a problem's goal region is its goal radius). Each of
    ``held`` (joints the robot holds fixed, such as the Panda's fingers) may appear and must
    then equal the robot's value; any other joint is refused.
    """
    request = source.mapping(request, "request", REQUEST_KEYS)
    for key in ("path_constraints", "trajectory_constraints", "reference_trajectories"):
        source.empty(request.get(key), key, key.replace("_", " "))
    state = check_robot_state(source, request.get("start_state"), "start_state")
    joint_state = source.mapping(
        state.get("joint_state"), "start_state.joint_state",
        {"header", "name", "position", "velocity", "effort"},
    )  # fmt: skip
    names = source.listing(joint_state.get("name"), "start_state.joint_state.name")
    positions = source.listing(joint_state.get("position"), "start_state.joint_state.position")
    if len(names) != len(positions):
        raise source.error(
            "start_state.joint_state", f"{len(names)} names for {len(positions)} positions"
        )
    start = _configuration(
        source, "start_state.joint_state", list(zip(names, positions)), joints, held
    )
    goals = source.listing(request.get("goal_constraints"), "goal_constraints")
    if len(goals) != 1:
        raise source.error("goal_constraints", f"expected one goal, got {len(goals)}")
    goal = source.mapping(goals[0], "goal_constraints[0]", {"name", "joint_constraints",
                          "position_constraints", "orientation_constraints",
                          "visibility_constraints"})  # fmt: skip
    for kind in ("position", "orientation", "visibility"):
        key = f"{kind}_constraints"
        source.empty(goal.get(key), f"goal_constraints[0].{key}", f"{kind} goals")
    pairs = []
    field = "goal_constraints[0].joint_constraints"
    for i, constraint in enumerate(source.listing(goal.get("joint_constraints"), field)):
        constraint = source.mapping(constraint, f"{field}[{i}]", JOINT_CONSTRAINT_KEYS)
        pairs.append((constraint.get("joint_name"), constraint.get("position")))
    return start, _configuration(source, field, pairs, joints, held)


def _configuration(
    source: MoveItFile,
    field: str,
    pairs: list[tuple[Any, Any]],
    joints: tuple[str, ...],
    held: Mapping[str, float],
) -> np.ndarray:
    """``(joint name, position)`` pairs as a configuration in ``joints`` order."""
    values: dict[str, float] = {}
    for i, (name, position) in enumerate(pairs):
        _check_name(source, name, f"{field}[{i}] name")
        if name in values:
            raise source.error(field, f"joint {_short(name)} is given twice")
        if name not in joints and name not in held:
            known = ", ".join(joints + tuple(held))
            raise source.error(field, f"unknown joint {_short(name)} (known: {known})")
        values[name] = source.number(position, f"{field} ({name})")
        if name in held and abs(values[name] - held[name]) > HELD_TOLERANCE:
            raise source.error(
                f"{field} ({name})",
                f"{values[name]:g}, but the robot holds this joint at {held[name]:g}",
            )
    missing = [name for name in joints if name not in values]
    if missing:
        raise source.error(field, f"joint {missing[0]} is missing")
    return np.array([values[name] for name in joints])


__all__ = ["MoveItFile", "compose", "request_joints", "scene_obstacles"]
