"""A robot description file: which URDF, which chain, and the planning defaults of an arm.

A description is a small YAML file. Four keys are required, the rest optional::

    name: franka_panda                 # the name problem files use ("robot": ...)
    urdf: pybullet_data://franka_panda/panda.urdf   # or a path relative to this file
    base_link: panda_link0             # the chain starts here (at the world origin, z up)
    tip_link: panda_hand               # and ends here; links fixed below it ride along
    srdf: panda.srdf                   # MoveIt's disabled collision pairs (optional)
    fixed_joints:                      # joints outside the chain, held at these values
      panda_finger_joint1: 0.04
    joint_limits:                      # override the URDF's limits of any joint
      panda_joint4: [-3.0718, -0.0698]
    env_id: TEMP-Panda-v0              # optional planning defaults, see `RobotDescription`
    planning: {step_size: 0.5, goal_radius: 0.1, max_nodes: 5000}

Paths are relative to the description's folder; ``pybullet_data://`` names a file shipped
with pybullet. `load_description` checks every key and value and says, in one line, which
one is wrong and why. The derived data (`temp_gym.worlds.arm.build`) is written beside the
description as ``<stem>.derived.json``.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from temp_gym.limits import MAX_ENCODING_CELLS, MIN_ENCODING_RESOLUTION
from temp_gym.problem.parsing import finite_float

PYBULLET_DATA = "pybullet_data://"
"""Prefix of a path inside pybullet's data folder (``pybullet_data.getDataPath()``)."""
MAX_DESCRIPTION_BYTES = 1 << 20
"""Largest description file read (bytes)."""
NAME_PATTERN = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,63}$")
"""A robot name: a letter, then letters, digits or underscores (64 characters at most)."""
ENV_ID_PATTERN = re.compile(r"^[A-Za-z][A-Za-z0-9_.-]{0,63}-v[0-9]+$")

REQUIRED = ("name", "urdf", "base_link", "tip_link")
OPTIONAL = (
    "srdf",
    "fixed_joints",
    "joint_limits",
    "env_id",
    "short_name",
    "seed_code",
    "planning",
    "encoding",
    "spheres",
    "evaluation",
)
PLANNING_KEYS = ("step_size", "goal_radius", "max_nodes")
ENCODING_KEYS = ("resolution", "region")
MAX_ARM_RESOLUTION = round(MAX_ENCODING_CELLS ** (1 / 3))
"""The most cells per axis of an arm's 3D occupancy grid (`temp_gym.limits`: 64)."""
SPHERE_KEYS = ("tolerance",)
EVALUATION_KEYS = ("rows", "tasks")


class DescriptionError(ValueError):
    """A robot description that cannot be used; the message names the field and the reason."""


@dataclass(frozen=True, eq=False)
class RobotDescription:
    """A robot description, validated (`load_description`).

    Attributes:
        path: the description file (absolute).
        name: the robot's name.
        urdf: the URDF file (absolute).
        base_link: the first link of the chain, placed at the world origin.
        tip_link: the last link of the chain.
        srdf: MoveIt SRDF whose ``disable_collisions`` pairs are never checked, or None.
        fixed_joints: values of joints outside the chain (default: 0 clipped to their limits).
        joint_limits: ``{joint: (lower, upper)}`` overriding the URDF's.
        env_id: the Gymnasium id (default ``TEMP-<Name>-v0``, e.g. ``TEMP-FrankaPanda-v0``).
        short_name: a short name for files and flags (default: ``name``).
        seed_code: the robot's entry in the seed sequence of fixed workspace pools (default:
            derived from the name, stable across runs and machines).
        step_size: the steering step in joint space (rad, or m for a prismatic joint).
        goal_radius: the goal ball's radius of generated tasks (joint space).
        max_nodes: the env's default node budget.
        encoding_resolution: cells per axis of the occupancy grid.
        encoding_region: ``(2, 3)`` box (m) the grid covers; None: derived from the reach.
        sphere_tolerance: how far (m) the fast checker's spheres may bulge out of the links.
        evaluation_rows: evaluation table rows, row name -> task difficulty.
        evaluation_tasks: test tasks per row.
    """

    path: Path
    name: str
    urdf: Path
    base_link: str
    tip_link: str
    srdf: Path | None = None
    fixed_joints: Mapping[str, float] = field(default_factory=dict)
    joint_limits: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    env_id: str = ""
    short_name: str = ""
    seed_code: int = 0
    step_size: float = 0.5
    goal_radius: float = 0.1
    max_nodes: int = 5000
    encoding_resolution: int = 16
    encoding_region: np.ndarray | None = None
    sphere_tolerance: float = 0.001
    evaluation_rows: Mapping[str, str] = field(default_factory=lambda: {"any": "any"})
    evaluation_tasks: int = 200

    def digest(self) -> str:
        """SHA-256 of the description's meaning (its validated values, not its formatting)."""
        values = {
            "name": self.name,
            "urdf": portable_name(self.urdf, self.path.parent),
            "base_link": self.base_link,
            "tip_link": self.tip_link,
            "srdf": None if self.srdf is None else portable_name(self.srdf, self.path.parent),
            "fixed_joints": dict(sorted(self.fixed_joints.items())),
            "joint_limits": {k: list(v) for k, v in sorted(self.joint_limits.items())},
            "sphere_tolerance": self.sphere_tolerance,
        }
        return hashlib.sha256(json.dumps(values, sort_keys=True).encode()).hexdigest()

    @property
    def derived_path(self) -> Path:
        """Where the build step writes this robot's derived data."""
        return self.path.with_name(self.path.stem + ".derived.json")


def portable_name(file: Path, folder: Path) -> str:
    """``file`` named the same on every machine.

    Inside pybullet_data as ``pybullet_data://...``, else relative to ``folder`` (the
    description's) when it lies below it, else its path. The derived data's digest uses these
    names, so that it stays valid wherever pybullet or the description's folder is installed.
    """
    import pybullet_data

    for root, prefix in ((Path(pybullet_data.getDataPath()).resolve(), PYBULLET_DATA),
                         (folder.resolve(), "")):  # fmt: skip
        try:
            return prefix + file.resolve().relative_to(root).as_posix()
        except ValueError:
            continue
    return str(file)


def _fail(path: Path, field_name: str, reason: str) -> DescriptionError:
    return DescriptionError(f"{path.name}: {field_name}: {reason}")


def _short(value: object, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def resolve_file(path: Path, field_name: str, value: object) -> Path:
    """``value`` of ``field_name`` as an existing file.

    Relative to ``path``'s folder, or in pybullet_data (``pybullet_data://...``).
    """
    if not isinstance(value, str) or not value.strip():
        raise _fail(path, field_name, f"expected a file path, got {_short(value)}")
    if value.startswith(PYBULLET_DATA):
        import pybullet_data

        resolved = Path(pybullet_data.getDataPath()) / value[len(PYBULLET_DATA) :]
    else:
        resolved = Path(value).expanduser()
        if not resolved.is_absolute():
            resolved = path.parent / resolved
    resolved = resolved.resolve()
    if not resolved.is_file():
        raise _fail(path, field_name, f"no such file: {resolved}")
    return resolved


def _number(path: Path, field_name: str, value: object, positive: bool = False) -> float:
    try:
        number = finite_float(value, field_name)
    except ValueError as error:
        raise DescriptionError(f"{path.name}: {error}") from None
    if positive and number <= 0:
        raise _fail(path, field_name, f"must be positive, got {number}")
    return number


def _integer(path: Path, field_name: str, value: object, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise _fail(
            path, field_name, f"expected an integer in [{low}, {high}], got {_short(value)}"
        )
    return int(value)


def _name(path: Path, field_name: str, value: object) -> str:
    if not isinstance(value, str) or not value.strip() or len(value) > 256:
        raise _fail(path, field_name, f"expected a link or joint name, got {_short(value)}")
    return value


def _section(path: Path, name: str, value: object, keys: tuple[str, ...]) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise _fail(path, name, f"expected a mapping with keys {list(keys)}, got {_short(value)}")
    unknown = [k for k in value if k not in keys]
    if unknown:
        raise _fail(path, f"{name}.{unknown[0]}", f"unknown key; expected one of {list(keys)}")
    return value


def default_env_id(name: str) -> str:
    """``TEMP-<CamelName>-v0`` for a robot ``name`` (``my_arm`` -> ``TEMP-MyArm-v0``)."""
    return "TEMP-" + "".join(part.capitalize() for part in name.split("_") if part) + "-v0"


def default_seed_code(name: str) -> int:
    """A seed code derived from the name: the same on every machine, away from the built-ins."""
    return 1000 + int(hashlib.sha256(name.encode()).hexdigest()[:7], 16)


def parse_description(path: Path, data: object) -> RobotDescription:
    """Validate the mapping ``data`` read from ``path`` into a `RobotDescription`.

    Raises:
        DescriptionError: a missing, unknown or invalid key (the message names it).
    """
    if not isinstance(data, dict):
        raise _fail(path, "description", f"expected a mapping of keys, got {_short(data)}")
    for key in data:
        if key not in REQUIRED + OPTIONAL:
            raise _fail(path, str(key), f"unknown key; expected one of {list(REQUIRED + OPTIONAL)}")
    for key in REQUIRED:
        if key not in data:
            raise _fail(path, key, "missing (required: name, urdf, base_link, tip_link)")
    name = data["name"]
    if not isinstance(name, str) or not NAME_PATTERN.match(name):
        raise _fail(
            path, "name", f"expected a letter, then letters, digits or '_' (64 at most), got "
            f"{_short(name)}"
        )  # fmt: skip
    values: dict = {
        "path": path,
        "name": name,
        "urdf": resolve_file(path, "urdf", data["urdf"]),
        "base_link": _name(path, "base_link", data["base_link"]),
        "tip_link": _name(path, "tip_link", data["tip_link"]),
    }
    if data.get("srdf") is not None:
        values["srdf"] = resolve_file(path, "srdf", data["srdf"])
    fixed = data.get("fixed_joints") or {}
    if not isinstance(fixed, dict):
        raise _fail(path, "fixed_joints", f"expected a mapping joint -> value, got {_short(fixed)}")
    values["fixed_joints"] = {
        _name(path, "fixed_joints", k): _number(path, f"fixed_joints.{k}", v)
        for k, v in fixed.items()
    }
    limits = data.get("joint_limits") or {}
    if not isinstance(limits, dict):
        raise _fail(path, "joint_limits", f"expected a mapping joint -> [lower, upper], got "
                    f"{_short(limits)}")  # fmt: skip
    parsed_limits = {}
    for joint, pair in limits.items():
        where = f"joint_limits.{joint}"
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise _fail(path, where, f"expected [lower, upper], got {_short(pair)}")
        lower, upper = (_number(path, where, v) for v in pair)
        if lower > upper:
            raise _fail(path, where, f"lower {lower} is above upper {upper}")
        parsed_limits[_name(path, "joint_limits", joint)] = (lower, upper)
    values["joint_limits"] = parsed_limits
    env_id = data.get("env_id", default_env_id(name))
    if not isinstance(env_id, str) or not ENV_ID_PATTERN.match(env_id):
        raise _fail(path, "env_id", f"expected an id like TEMP-MyArm-v0, got {_short(env_id)}")
    values["env_id"] = env_id
    short_name = data.get("short_name", name)
    if not isinstance(short_name, str) or not NAME_PATTERN.match(short_name):
        if not (isinstance(short_name, str) and re.match(r"^[A-Za-z0-9_]{1,64}$", short_name)):
            raise _fail(path, "short_name", f"expected letters, digits or '_', got "
                        f"{_short(short_name)}")  # fmt: skip
    values["short_name"] = short_name
    values["seed_code"] = (
        _integer(path, "seed_code", data["seed_code"], 0, 2**31 - 1)
        if "seed_code" in data
        else default_seed_code(name)
    )
    planning = _section(path, "planning", data.get("planning"), PLANNING_KEYS)
    if "step_size" in planning:
        values["step_size"] = _number(path, "planning.step_size", planning["step_size"], True)
    if "goal_radius" in planning:
        values["goal_radius"] = _number(path, "planning.goal_radius", planning["goal_radius"], True)
    if "max_nodes" in planning:
        values["max_nodes"] = _integer(path, "planning.max_nodes", planning["max_nodes"], 1,
                                       10_000_000)  # fmt: skip
    encoding = _section(path, "encoding", data.get("encoding"), ENCODING_KEYS)
    if "resolution" in encoding:
        values["encoding_resolution"] = _integer(
            path,
            "encoding.resolution",
            encoding["resolution"],
            MIN_ENCODING_RESOLUTION,
            MAX_ARM_RESOLUTION,
        )
    if encoding.get("region") is not None:
        region = encoding["region"]
        try:
            array = np.array(region, dtype=np.float64)
        except (TypeError, ValueError):
            array = np.zeros(0)
        if array.shape != (2, 3) or not np.all(np.isfinite(array)) or np.any(array[0] >= array[1]):
            raise _fail(path, "encoding.region", f"expected [[x0, y0, z0], [x1, y1, z1]] with "
                        f"lower < upper, got {_short(region)}")  # fmt: skip
        array.setflags(write=False)
        values["encoding_region"] = array
    spheres = _section(path, "spheres", data.get("spheres"), SPHERE_KEYS)
    if "tolerance" in spheres:
        tolerance = _number(path, "spheres.tolerance", spheres["tolerance"], True)
        if not 1e-4 <= tolerance <= 0.05:
            raise _fail(path, "spheres.tolerance", f"expected metres in [0.0001, 0.05], got "
                        f"{tolerance}")  # fmt: skip
        values["sphere_tolerance"] = tolerance
    evaluation = _section(path, "evaluation", data.get("evaluation"), EVALUATION_KEYS)
    if "rows" in evaluation:
        rows = evaluation["rows"]
        if (
            not isinstance(rows, dict)
            or not rows
            or not all(
                isinstance(k, str) and v in ("easy", "challenging", "any") for k, v in rows.items()
            )
        ):
            raise _fail(path, "evaluation.rows", "expected a mapping row name -> easy, "
                        f"challenging or any, got {_short(rows)}")  # fmt: skip
        values["evaluation_rows"] = dict(rows)
    if "tasks" in evaluation:
        values["evaluation_tasks"] = _integer(path, "evaluation.tasks", evaluation["tasks"], 1,
                                              100_000)  # fmt: skip
    return RobotDescription(**values)


def load_description(path: str | Path) -> RobotDescription:
    """Read and validate the robot description at ``path`` (YAML).

    Raises:
        DescriptionError: unreadable file, invalid YAML, or a bad key or value (one line).
    """
    from temp_gym.yaml_input import load_yaml

    path = Path(path).expanduser().resolve()
    if not path.is_file():
        raise DescriptionError(f"{path}: no such robot description file")
    if path.stat().st_size > MAX_DESCRIPTION_BYTES:
        raise DescriptionError(f"{path.name}: larger than {MAX_DESCRIPTION_BYTES} bytes")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise DescriptionError(f"{path.name}: cannot read ({type(error).__name__})") from None
    try:
        # Reads 6e-3 as a number, as YAML 1.2 does; a description is written out, no anchors.
        data = load_yaml(text, path.name, anchors=False)
    except ValueError as error:
        raise DescriptionError(str(error)) from None
    return parse_description(path, data)


__all__ = [
    "PYBULLET_DATA",
    "DescriptionError",
    "RobotDescription",
    "default_env_id",
    "default_seed_code",
    "load_description",
    "parse_description",
    "resolve_file",
]
