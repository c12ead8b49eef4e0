"""A serial arm read from its URDF: the chain between a base and a tip link, as arrays.

What `read_chain` does with a URDF:

* **Bodies.** The movable joints on the path from ``base_link`` to ``tip_link`` are the
  arm's degrees of freedom (revolute, continuous or prismatic, about any axis). Every other
  link below ``base_link`` rides rigidly on one of them: links behind fixed joints are folded
  into their parent's body, and so are links behind movable joints off the chain (fingers),
  held at the description's ``fixed_joints`` values (a ``mimic`` joint follows the joint it
  mimics; otherwise 0, clipped to its limits). Body 0 is the base, fixed at the world origin;
  body ``j + 1`` is moved by joint ``j``. Links above ``base_link`` (a mobile base, a torso,
  a mount) and their other branches ride on the base too, held the same way
  (`_fold_above`): the arm must not pass through them.
* **Canonical frames.** Each body's frame is its chain link's URDF frame turned so that the
  joint's axis is z: then every joint turns (or slides) about z, which keeps the compiled
  kinematics short. Where an axis is a coordinate axis the turn is a signed permutation, so a
  URDF whose joint origins are right angles keeps origins that are signed permutations.
  `ArmChain.link_transforms` maps each URDF link frame into its body's frame, for callers that
  need URDF frames (rendering, pybullet).
* **Collision elements.** Each link's ``<collision>`` elements (meshes with their scale,
  boxes, cylinders, spheres), placed in the body frame. `temp_gym.worlds.arm.meshes` loads
  their geometry.

Errors name the URDF element and the reason in one line (`UrdfError`).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REVOLUTE = 0
PRISMATIC = 1
MOVABLE = ("revolute", "continuous", "prismatic")
CONTINUOUS_LIMIT = math.pi
"""A continuous joint without a ``joint_limits`` override is planned within ``[-pi, pi]``."""
MAX_URDF_BYTES = 16 << 20


class UrdfError(ValueError):
    """A URDF the arm cannot be built from; the message names the element and the reason."""


@dataclass(frozen=True)
class CollisionElement:
    """One ``<collision>`` element of a link, placed in its body's frame.

    Attributes:
        link: the URDF link it belongs to.
        kind: ``"mesh"``, ``"box"``, ``"cylinder"`` or ``"sphere"``.
        transform: ``(4, 4)`` pose of the element's own frame in the body frame.
        mesh: the mesh's ``filename`` as written in the URDF (``kind == "mesh"``).
        scale: the mesh's ``(3,)`` scale.
        size: a box's full ``(3,)`` size, a cylinder's ``(radius, length)``, a sphere's
            ``(radius,)``.
    """

    link: str
    kind: str
    transform: np.ndarray
    mesh: str = ""
    scale: np.ndarray | None = None
    size: np.ndarray | None = None


@dataclass(frozen=True)
class ArmChain:
    """The kinematic chain and collision elements of an arm (`read_chain`).

    Attributes:
        urdf: the URDF file.
        joint_names: the ``d`` movable chain joints, base to tip.
        joint_types: ``(d,)`` `REVOLUTE` or `PRISMATIC`.
        joint_origins: ``(d, 4, 4)`` pose of joint ``j``'s canonical frame in body ``j``'s
            frame; body ``j + 1``'s frame is that frame turned (slid) by ``q[j]`` about z.
        joint_limits: ``(2, d)`` lower and upper limits (rad, or m for prismatic joints).
        body_names: the ``d + 1`` bodies' chain links (base first).
        link_bodies: each URDF link of the arm -> the body it rides on.
        link_transforms: each URDF link -> ``(4, 4)`` its frame in its body's frame.
        elements: per body, its links' collision elements.
        fixed_values: the values given to movable joints off the chain.
        tip_link: the chain's last link.
        above_base: the links above ``base_link`` (and their branches), folded into the base.
    """

    urdf: Path
    joint_names: tuple[str, ...]
    joint_types: np.ndarray
    joint_origins: np.ndarray
    joint_limits: np.ndarray
    body_names: tuple[str, ...]
    link_bodies: dict[str, int]
    link_transforms: dict[str, np.ndarray]
    elements: tuple[tuple[CollisionElement, ...], ...]
    fixed_values: dict[str, float]
    tip_link: str
    above_base: tuple[str, ...] = ()

    @property
    def dim(self) -> int:
        """Number of movable joints in the chain."""
        return len(self.joint_names)


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw: ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``."""
    roll, pitch, yaw = rpy
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _floats(text: str | None, count: int, where: str, default: str) -> np.ndarray:
    text = default if text is None else text
    try:
        values = np.array(text.split(), dtype=np.float64)
    except ValueError:
        raise UrdfError(f"{where}: expected {count} numbers, got {text[:40]!r}") from None
    if values.shape != (count,) or not np.all(np.isfinite(values)):
        raise UrdfError(f"{where}: expected {count} finite numbers, got {text[:40]!r}")
    return values


def origin_transform(element: ElementTree.Element | None, where: str) -> np.ndarray:
    """4x4 transform of a URDF ``<origin xyz=.. rpy=..>`` element (identity when absent)."""
    transform = np.eye(4)
    if element is not None:
        transform[:3, :3] = rpy_matrix(_floats(element.get("rpy"), 3, f"{where} rpy", "0 0 0"))
        transform[:3, 3] = _floats(element.get("xyz"), 3, f"{where} xyz", "0 0 0")
    return transform


def axis_frame(axis: np.ndarray) -> np.ndarray:
    """A rotation ``R`` with ``R @ z = axis`` (unit); a signed permutation for coordinate axes."""
    for k in range(3):
        for sign in (1.0, -1.0):
            if np.allclose(axis, sign * np.eye(3)[k], atol=1e-12):
                # Columns (x, y, z) of R: z is the axis, x and y complete a right-handed frame.
                z = sign * np.eye(3)[k]
                x = np.eye(3)[(k + 1) % 3]
                y = np.cross(z, x)
                return np.column_stack([x, y, z])
    z = axis / np.linalg.norm(axis)
    helper = np.eye(3)[int(np.argmin(np.abs(z)))]
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


XACRO_NAMESPACE = "{http://www.ros.org/wiki/xacro}"
"""Elements of this namespace make a file xacro, a macro language over URDF, not URDF."""


_PREFIXED = re.compile(rb"(?:<|\s)([A-Za-z_][\w.-]*):[A-Za-z_][\w.-]*")
_DECLARED = re.compile(rb"xmlns:([A-Za-z_][\w.-]*)\s*=")
_ROBOT_TAG = re.compile(rb"<robot(?=[\s>/])")


def _declare_prefixes(text: bytes) -> bytes | None:
    """``text`` with its undeclared namespace prefixes declared on ``<robot>``, or None.

    URDFs exported by some tools carry attributes such as ``drake:acceleration`` without
    declaring ``xmlns:drake``. pybullet, RViz and MoveIt read them (their parsers ignore
    namespaces), so this reader does too: each prefix gets a namespace of its own, ``xacro``
    its real one (so that a xacro file is still recognised as one).
    """
    used = set(_PREFIXED.findall(text)) - set(_DECLARED.findall(text)) - {b"xmlns", b"xml"}
    match = _ROBOT_TAG.search(text)
    if not used or match is None:
        return None
    declarations = b"".join(
        b' xmlns:%s="%s"' % (prefix, (XACRO_NAMESPACE.strip("{}") if prefix == b"xacro"
                                      else f"urn:undeclared:{prefix.decode()}").encode())
        for prefix in sorted(used)
    )  # fmt: skip
    return text[: match.end()] + declarations + text[match.end() :]


def _parse(urdf: Path) -> ElementTree.Element:
    if not urdf.is_file():
        raise UrdfError(f"urdf: no such file: {urdf}")
    if urdf.stat().st_size > MAX_URDF_BYTES:
        raise UrdfError(f"{urdf.name}: larger than {MAX_URDF_BYTES} bytes")
    text = urdf.read_bytes()
    try:
        root = ElementTree.fromstring(text)
    except ElementTree.ParseError as error:
        declared = _declare_prefixes(text) if "unbound prefix" in str(error) else None
        if declared is None:
            raise UrdfError(f"{urdf.name}: not valid XML ({error})") from None
        try:
            root = ElementTree.fromstring(declared)
        except ElementTree.ParseError as other:  # what is wrong besides the prefixes
            raise UrdfError(f"{urdf.name}: not valid XML ({other})") from None
    if root.tag != "robot":
        raise UrdfError(f"{urdf.name}: the root element is <{root.tag}>, not <robot>")
    if any(element.tag.startswith(XACRO_NAMESPACE) for element in root.iter()):
        raise UrdfError(f"{urdf.name}: a xacro file (it has xacro: elements); expand it to a "
                        f"URDF first, e.g. xacro {urdf.name} > robot.urdf")  # fmt: skip
    return root


def _limits(joint: ElementTree.Element, kind: str, where: str) -> tuple[float, float]:
    if kind == "continuous":
        return -CONTINUOUS_LIMIT, CONTINUOUS_LIMIT
    limit = joint.find("limit")
    if limit is None or limit.get("lower") is None or limit.get("upper") is None:
        raise UrdfError(f"{where}: a {kind} joint needs <limit lower=.. upper=..>")
    lower, upper = (
        _floats(limit.get(k), 1, f"{where} limit {k}", "0")[0] for k in ("lower", "upper")
    )
    if lower > upper:
        raise UrdfError(f"{where}: limit lower {lower} is above upper {upper}")
    return lower, upper


def _collision_elements(link: ElementTree.Element, name: str) -> list[tuple[str, dict]]:
    elements = []
    for k, collision in enumerate(link.findall("collision")):
        where = f"link {name!r} collision {k}"
        transform = origin_transform(collision.find("origin"), where)
        geometry = collision.find("geometry")
        shape = None if geometry is None or len(geometry) == 0 else geometry[0]
        if shape is None:
            raise UrdfError(f"{where}: no <geometry>")
        if shape.tag == "mesh":
            filename = shape.get("filename")
            if not filename:
                raise UrdfError(f"{where}: <mesh> without a filename")
            scale = _floats(shape.get("scale"), 3, f"{where} scale", "1 1 1")
            if np.any(scale == 0):
                raise UrdfError(f"{where}: <mesh> scale must be nonzero on every axis (a "
                                f"negative one mirrors), got {shape.get('scale')!r}")  # fmt: skip
            elements.append(("mesh", {"transform": transform, "mesh": filename, "scale": scale}))
        elif shape.tag == "box":
            size = _floats(shape.get("size"), 3, f"{where} size", "")
            elements.append(("box", {"transform": transform, "size": size}))
        elif shape.tag == "cylinder":
            size = np.array([_floats(shape.get(k), 1, f"{where} {k}", "")[0]
                             for k in ("radius", "length")])  # fmt: skip
            elements.append(("cylinder", {"transform": transform, "size": size}))
        elif shape.tag == "sphere":
            size = _floats(shape.get("radius"), 1, f"{where} radius", "")
            elements.append(("sphere", {"transform": transform, "size": size}))
        else:
            raise UrdfError(f"{where}: unsupported geometry <{shape.tag}>; expected mesh, box, "
                            "cylinder or sphere")  # fmt: skip
        if "size" in elements[-1][1] and np.any(elements[-1][1]["size"] <= 0):
            raise UrdfError(f"{where}: <{shape.tag}> sizes must be positive")
    return elements


def _named(root: ElementTree.Element, tag: str, urdf: Path) -> dict[str, ElementTree.Element]:
    """The ``<link>`` or ``<joint>`` elements by name; a missing or repeated name is refused."""
    elements: dict[str, ElementTree.Element] = {}
    for element in root.findall(tag):
        name = element.get("name")
        if not name:
            raise UrdfError(f"{urdf.name}: a <{tag}> without a name")
        if name in elements:
            raise UrdfError(f"{urdf.name}: {tag} {name!r} is defined twice")
        elements[name] = element
    return elements


def _tree(
    links: dict[str, ElementTree.Element], joints: dict[str, ElementTree.Element], urdf: Path
) -> tuple[dict[str, list[ElementTree.Element]], dict[str, ElementTree.Element]]:
    """Each link's child joints and each link's parent joint, checked to form a tree.

    As urdfdom checks: every joint joins two existing links, no link has two parents, and no
    chain of joints leads back to where it started (which would hang a walk of the tree).
    """
    children: dict[str, list[ElementTree.Element]] = {}
    parent_joint: dict[str, ElementTree.Element] = {}
    for name, joint in joints.items():
        parent, child = joint.find("parent"), joint.find("child")
        if parent is None or child is None:
            raise UrdfError(f"joint {name!r}: needs <parent> and <child>")
        for role, element in (("parent", parent), ("child", child)):
            if element.get("link") not in links:
                raise UrdfError(f"joint {name!r}: its {role} link {element.get('link')!r} is "
                                f"not a link of {urdf.name}")  # fmt: skip
        if child.get("link") in parent_joint:
            other = parent_joint[child.get("link")].get("name")
            raise UrdfError(f"{urdf.name}: link {child.get('link')!r} is the child of two joints, "
                            f"{other!r} and {name!r}; a URDF's links form a tree")  # fmt: skip
        children.setdefault(parent.get("link"), []).append(joint)
        parent_joint[child.get("link")] = joint
    for start in parent_joint:
        seen, link = {start}, start
        while link in parent_joint:
            link = parent_joint[link].find("parent").get("link")
            if link in seen:
                joint = parent_joint[link].get("name")
                raise UrdfError(f"{urdf.name}: the joints close a loop through link {link!r} "
                                f"(joint {joint!r}); a URDF's links form a tree")  # fmt: skip
            seen.add(link)
    return children, parent_joint


def _mimic_terms(mimic: ElementTree.Element, where: str) -> tuple[float, float]:
    """A ``<mimic>``'s ``(multiplier, offset)`` (defaults 1 and 0)."""
    multiplier = _floats(mimic.get("multiplier"), 1, f"{where} multiplier", "1")[0]
    offset = _floats(mimic.get("offset"), 1, f"{where} offset", "0")[0]
    return float(multiplier), float(offset)


def _check_mimics(
    arm_joints: dict[str, ElementTree.Element],
    joints: dict[str, ElementTree.Element],
    chain_names: set[str],
    fixed_joints: dict[str, float],
    urdf: Path,
) -> None:
    """Refuse the ``<mimic>`` joints of the arm (``arm_joints``) it cannot model, naming them.

    A mimic joint off the chain is held at its source's held value times the multiplier plus
    the offset. One in the chain, or one that follows a joint of the chain, would move with
    the planned joints: the arm's bodies are rigid between its planned joints, so its
    geometry would be wrong. A mimic of a missing joint, and mimics that go round in a loop,
    are errors in the URDF.
    """
    for name, joint in arm_joints.items():
        mimic = joint.find("mimic")
        if mimic is None or joint.get("type") not in MOVABLE:
            continue
        where = f"joint {name!r}"
        source = mimic.get("joint")
        if source not in joints:
            raise UrdfError(f"{where}: mimics {source!r}, which is not a joint of {urdf.name}")
        if joints[source].get("type") not in MOVABLE:
            raise UrdfError(f"{where}: mimics {source!r}, a {joints[source].get('type')} joint")
        if name in chain_names:
            raise UrdfError(f"{where}: a mimic joint (of {source!r}) in the chain is not "
                            "supported; end the chain before it")  # fmt: skip
        if name in fixed_joints:
            continue  # held where the description says
        seen, current = {name}, source
        while True:
            if current in chain_names:
                raise UrdfError(f"{where}: mimics {current!r}, a joint of the chain, so its link "
                                "moves with the arm, which is not supported; hold it with "
                                "fixed_joints if it may stay put")  # fmt: skip
            if current in seen:
                raise UrdfError(f"{where}: its mimic joints go round in a loop")
            seen.add(current)
            if current in fixed_joints:
                break
            inner = joints[current].find("mimic")
            if inner is None:
                break
            current = inner.get("joint")
            if current not in joints:
                break  # refused when that joint's own turn comes


def _axis(joint: ElementTree.Element, where: str) -> np.ndarray:
    """A movable joint's unit axis (``<axis xyz>``, default x)."""
    axis = _floats(joint.find("axis").get("xyz") if joint.find("axis") is not None else None,
                   3, f"{where} axis", "1 0 0")  # fmt: skip
    if np.linalg.norm(axis) < 1e-9:
        raise UrdfError(f"{where}: zero axis")
    return axis / np.linalg.norm(axis)


def _held_motion(kind: str, axis: np.ndarray, value: float) -> np.ndarray:
    """``(4, 4)``: a movable joint held at ``value``: a slide along or a turn about ``axis``."""
    motion = np.eye(4)
    if kind == "prismatic":
        motion[:3, 3] = axis * value
    else:
        c, s = math.cos(value), math.sin(value)
        skew = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]],
                         [-axis[1], axis[0], 0]])  # fmt: skip
        motion[:3, :3] = np.eye(3) + s * skew + (1 - c) * skew @ skew
    return motion


def _fold_above(
    base_link: str,
    children: dict[str, list[ElementTree.Element]],
    parent_joint: dict[str, ElementTree.Element],
    link_bodies: dict[str, int],
    link_transforms: dict[str, np.ndarray],
    held_value,
    fixed_values: dict[str, float],
) -> None:
    """Fold every link that is not below ``base_link`` into the base (body 0).

    A mobile manipulator's base, torso or mount carries the arm rigidly while it plans: the
    links above ``base_link``, and every branch off them (wheels, a head, a second arm), are
    placed in the base's frame with their movable joints at ``held_value(joint)`` (the
    description's ``fixed_joints`` value, else 0; a ``<mimic>`` there is not followed), and
    floating or planar joints at their zero pose. Without them the arm would pass through its
    own base unseen. Fills ``link_bodies``, ``link_transforms`` and ``fixed_values``.
    """

    def step(joint: ElementTree.Element) -> np.ndarray:
        """The child link's frame in its parent's, the joint held."""
        name, kind = joint.get("name"), joint.get("type")
        where = f"joint {name!r}"
        origin = origin_transform(joint.find("origin"), where)
        if kind not in MOVABLE:
            return origin
        value = held_value(joint)
        fixed_values[name] = value
        return origin @ _held_motion(kind, _axis(joint, where), value)

    link, frame = base_link, np.eye(4)
    while link in parent_joint:
        joint = parent_joint[link]
        parent = joint.find("parent").get("link")
        frame = frame @ np.linalg.inv(step(joint))
        link_bodies[parent] = 0
        link_transforms[parent] = frame
        pending = [(other, frame) for other in children.get(parent, []) if other is not joint]
        while pending:  # the parent's other branches
            branch, parent_frame = pending.pop()
            child = branch.find("child").get("link")
            link_bodies[child] = 0
            link_transforms[child] = parent_frame @ step(branch)
            pending += [(other, link_transforms[child]) for other in children.get(child, [])]
        link = parent


def read_chain(
    urdf: Path,
    base_link: str,
    tip_link: str,
    fixed_joints: dict[str, float] | None = None,
    joint_limits: dict[str, tuple[float, float]] | None = None,
) -> ArmChain:
    """Read the arm between ``base_link`` and ``tip_link`` of ``urdf`` (module docstring).

    Raises:
        UrdfError: unreadable URDF, unknown links or joints, a chain joint of an unsupported
            type, missing limits, or a fixed value outside its joint's limits.
    """
    fixed_joints = dict(fixed_joints or {})
    overrides = dict(joint_limits or {})
    root = _parse(urdf)
    links = _named(root, "link", urdf)
    joints = _named(root, "joint", urdf)
    for name in (base_link, tip_link):
        if name not in links:
            known = ", ".join(sorted(links)[:12])
            raise UrdfError(f"{urdf.name}: no link {name!r}; links: {known}")
    children, parent_joint = _tree(links, joints, urdf)
    # The chain: from the tip up to the base (the links form a tree: no loop to go round).
    chain_joints: list[ElementTree.Element] = []
    link = tip_link
    while link != base_link:
        joint = parent_joint.get(link)
        if joint is None:
            raise UrdfError(f"{urdf.name}: tip_link {tip_link!r} is not below base_link "
                            f"{base_link!r}")  # fmt: skip
        chain_joints.append(joint)
        link = joint.find("parent").get("link")
    chain_joints.reverse()
    chain_names = {j.get("name") for j in chain_joints}
    for field_name, names in (("joint_limits", overrides), ("fixed_joints", fixed_joints)):
        for name in names:
            if name not in joints:
                raise UrdfError(f"{field_name}: no joint {name!r} in {urdf.name}")
            if joints[name].get("type") == "fixed":
                raise UrdfError(f"{field_name}: {name!r} is a fixed joint in {urdf.name}; it has "
                                "no value to set or limit")  # fmt: skip
    for name in fixed_joints:
        if name in chain_names and joints[name].get("type") in MOVABLE:
            raise UrdfError(f"fixed_joints: {name!r} is a joint of the chain; planning sets it")
    below, pending = set(), [base_link]  # the arm's joints: those below the base
    while pending:
        for joint in children.get(pending.pop(), []):
            below.add(joint.get("name"))
            pending.append(joint.find("child").get("link"))
    _check_mimics({name: joints[name] for name in below}, joints, chain_names, fixed_joints,
                  urdf)  # fmt: skip

    def limits_of(joint: ElementTree.Element) -> tuple[float, float]:
        name, kind = joint.get("name"), joint.get("type")
        if name in overrides:
            return overrides[name]
        return _limits(joint, kind, f"joint {name!r}")

    def fixed_value(joint: ElementTree.Element, above: bool = False) -> float:
        """The value a movable joint off the chain is held at.

        Its ``fixed_joints`` value, else as it mimics (below the base), else 0, within its
        limits. Above the base (``above``) a joint without limits, which pybullet loads too,
        is held without them.
        """
        name = joint.get("name")
        try:
            lower, upper = limits_of(joint)
        except UrdfError:
            if not above:
                raise
            lower, upper = -math.inf, math.inf
        if name in fixed_joints:
            value = fixed_joints[name]
            if not lower - 1e-12 <= value <= upper + 1e-12:
                raise UrdfError(
                    f"fixed_joints.{name}: {value} is outside its limits [{lower}, {upper}] "
                    "(override them with joint_limits)"
                )
            return value
        mimic = joint.find("mimic")
        if mimic is not None and not above:  # its source is off the chain (`_check_mimics`)
            multiplier, offset = _mimic_terms(mimic, f"joint {name!r} mimic")
            source = joints[mimic.get("joint")]
            return float(np.clip(multiplier * fixed_value(source) + offset, lower, upper))
        return float(np.clip(0.0, lower, upper))

    names, types, origins, limits, bodies = [], [], [], [], [base_link]
    link_bodies = {base_link: 0}
    link_transforms = {base_link: np.eye(4)}
    fixed_values: dict[str, float] = {}
    # Walk the tree below the base. A link's frame in its body's frame is known when its
    # parent's is; a chain joint starts a new body whose frame turns its axis to z.
    pending = [base_link]
    while pending:
        parent = pending.pop()
        for joint in children.get(parent, []):
            name, kind = joint.get("name"), joint.get("type")
            child = joint.find("child").get("link")
            where = f"joint {name!r}"
            origin = link_transforms[parent] @ origin_transform(joint.find("origin"), where)
            body = link_bodies[parent]
            if kind in MOVABLE:
                axis = _axis(joint, where)
                turn = np.eye(4)
                turn[:3, :3] = axis_frame(axis)
            if name in chain_names:
                if kind not in MOVABLE and kind != "fixed":
                    raise UrdfError(f"{where}: a {kind} joint in the chain; expected revolute, "
                                    "continuous, prismatic or fixed")  # fmt: skip
                if kind == "fixed":
                    link_bodies[child] = body
                    link_transforms[child] = origin
                else:
                    names.append(name)
                    types.append(PRISMATIC if kind == "prismatic" else REVOLUTE)
                    origins.append(origin @ turn)
                    lower, upper = limits_of(joint)
                    if not lower < upper:
                        raise UrdfError(
                            f"{where}: its limits [{lower}, {upper}] leave a joint of the chain "
                            "no motion; planning needs lower < upper (override them with "
                            "joint_limits, or end the chain before it)"
                        )
                    limits.append((lower, upper))
                    bodies.append(child)
                    link_bodies[child] = len(bodies) - 1
                    # The child's URDF frame in its canonical body frame: turn^-1.
                    link_transforms[child] = np.linalg.inv(turn)
            else:
                link_bodies[child] = body
                if kind in MOVABLE:
                    value = fixed_value(joint)
                    fixed_values[name] = value
                    link_transforms[child] = origin @ _held_motion(kind, axis, value)
                elif kind == "fixed":
                    link_transforms[child] = origin
                else:
                    raise UrdfError(f"{where}: a {kind} joint below the base is not supported")
            pending.append(child)

    below_base = set(link_bodies)
    _fold_above(base_link, children, parent_joint, link_bodies, link_transforms,
                lambda joint: fixed_value(joint, above=True), fixed_values)  # fmt: skip
    if not names:
        raise UrdfError(f"{urdf.name}: no movable joint between {base_link!r} and {tip_link!r}")
    elements: list[list[CollisionElement]] = [[] for _ in bodies]
    for link_name, body in link_bodies.items():
        for kind, values in _collision_elements(links[link_name], link_name):
            values["transform"] = link_transforms[link_name] @ values["transform"]
            elements[body].append(CollisionElement(link=link_name, kind=kind, **values))
    joint_origins = np.stack(origins)
    joint_limits_array = np.array(limits, dtype=np.float64).T.copy()
    for array in (joint_origins, joint_limits_array):
        array.setflags(write=False)
    return ArmChain(
        urdf=urdf,
        joint_names=tuple(names),
        joint_types=np.array(types, dtype=np.int64),
        joint_origins=joint_origins,
        joint_limits=joint_limits_array,
        body_names=tuple(bodies),
        link_bodies=link_bodies,
        link_transforms=link_transforms,
        elements=tuple(tuple(e) for e in elements),
        fixed_values=fixed_values,
        tip_link=tip_link,
        above_base=tuple(sorted(set(link_bodies) - below_base)),
    )


__all__ = [
    "PRISMATIC",
    "REVOLUTE",
    "ArmChain",
    "CollisionElement",
    "UrdfError",
    "axis_frame",
    "origin_transform",
    "read_chain",
    "rpy_matrix",
]
