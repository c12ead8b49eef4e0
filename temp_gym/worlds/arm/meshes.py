"""The collision geometry of an arm's bodies, read with trimesh: meshes and convex pieces.

Each ``<collision>`` element of a body (`temp_gym.worlds.arm.urdf.CollisionElement`) becomes

* a **mesh** (vertices and triangles in the body frame), which the exact checker tests
  against obstacles, and
* a **convex piece**: the convex hull of the element's mesh (all its objects) or primitive.
  That is what pybullet collides for a URDF mesh (one hull per collision element, measured:
  points inside the hull of a multi-object OBJ but outside every object's hull touch), what
  the exact checker tests for self-collision, and what the fast checker's spheres cover. A
  body's pieces are never merged, so the gap between two fingers stays a gap.

Mesh files are STL, OBJ, DAE or anything else trimesh reads, in metres unless the file
declares its unit (a COLLADA file's ``<unit meter=..>``, which is applied); ``filename`` may
be absolute, relative to the URDF, ``file://...`` or ``package://pkg/path``, which is looked
up beside the URDF and in its ancestor folders (the folder named ``pkg``, or the path as it
is). Boxes, cylinders and spheres are exact in the exact checker (fcl primitives) and, as
pieces, polytopes that contain them (a cylinder's polygon circumscribes its circle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from temp_gym.worlds.arm.urdf import CollisionElement, UrdfError

CYLINDER_SIDES = 24
"""Sides of the polygon that circumscribes a cylinder's circle in its convex piece."""
SPHERE_SUBDIVISIONS = 2
MAX_MESH_BYTES = 256 << 20


@dataclass(frozen=True)
class BodyGeometry:
    """One body's collision geometry in its frame.

    Attributes:
        meshes: per collision element, ``(vertices (V, 3), faces (F, 3))`` (primitives as
            their polytopes; `primitives` says which are exact shapes).
        primitives: per element, None for a mesh, else ``(kind, size, (4, 4) transform)``.
        pieces: convex pieces as point sets ``(V, 3)``, one per element.
        piece_elements: per piece, the index of its element.
    """

    meshes: tuple[tuple[np.ndarray, np.ndarray], ...]
    primitives: tuple[tuple[str, np.ndarray, np.ndarray] | None, ...]
    pieces: tuple[np.ndarray, ...]
    piece_elements: tuple[int, ...]


def resolve_mesh(filename: str, urdf: Path) -> Path:
    """The file a URDF ``<mesh filename>`` names (module docstring).

    Raises:
        UrdfError: no such file.
    """
    if filename.startswith("file://"):
        candidates = [Path(filename[len("file://") :])]
    elif filename.startswith("package://"):
        rest = Path(filename[len("package://") :])
        package, inner = rest.parts[0], Path(*rest.parts[1:]) if len(rest.parts) > 1 else Path()
        candidates = []
        for folder in (urdf.parent, *urdf.parent.parents):
            candidates.append(folder / rest)
            if folder.name == package:
                candidates.append(folder / inner)
            candidates.append(folder / package / inner)
    else:
        path = Path(filename)
        candidates = [path if path.is_absolute() else urdf.parent / path]
    for candidate in candidates:
        if candidate.is_file():
            return candidate.resolve()
    raise UrdfError(f"{urdf.name}: mesh {filename!r}: file not found")


def _load_objects(path: Path) -> list[tuple[np.ndarray, np.ndarray]]:
    """The objects of a mesh file as ``(vertices, faces)``, each placed by its scene graph."""
    import trimesh

    if path.stat().st_size > MAX_MESH_BYTES:
        raise UrdfError(f"mesh {path.name}: larger than {MAX_MESH_BYTES} bytes")
    options = (
        {"split_object": True, "group_material": False} if path.suffix.lower() == ".obj" else {}
    )
    try:
        loaded = trimesh.load(str(path), force="scene", process=False, **options)
    except Exception as error:  # trimesh raises many types for unreadable files
        raise UrdfError(f"mesh {path.name}: cannot read ({type(error).__name__}: "
                        f"{str(error)[:80]})") from None  # fmt: skip
    metres = _metres_per_unit(loaded, path)
    objects = []
    for node in loaded.graph.nodes_geometry:
        transform, name = loaded.graph[node]
        geometry = loaded.geometry[name]
        vertices = np.asarray(getattr(geometry, "vertices", np.zeros((0, 3))), dtype=np.float64)
        faces = np.asarray(getattr(geometry, "faces", np.zeros((0, 3))), dtype=np.int64)
        if len(vertices) == 0 or len(faces) == 0:
            continue
        vertices = vertices @ np.asarray(transform)[:3, :3].T + np.asarray(transform)[:3, 3]
        objects.append((vertices * metres, faces.reshape(-1, 3)))
    if not objects:
        raise UrdfError(f"mesh {path.name}: no triangles")
    return objects


def _metres_per_unit(scene, path: Path) -> float:
    """Metres per unit of a mesh file that declares its unit (COLLADA's ``<unit meter=..>``).

    A URDF's meshes are in metres; a file in centimetres or inches is scaled as pybullet,
    RViz and MoveIt scale it. STL and OBJ declare no unit and are read as metres.
    """
    from trimesh.units import unit_conversion

    units = getattr(scene, "units", None)
    if not units:
        return 1.0
    try:
        factor = float(unit_conversion(units, "meters"))
    except Exception:  # trimesh raises several types for a unit it does not know
        raise UrdfError(f"mesh {path.name}: unknown unit {str(units)[:40]!r}") from None
    if not (math.isfinite(factor) and factor > 0):
        raise UrdfError(f"mesh {path.name}: unit {str(units)[:40]!r} is not a positive length")
    return factor


def box_vertices(size: np.ndarray) -> np.ndarray:
    """The 8 corners of a box of full ``size`` centred at the origin."""
    half = np.asarray(size, dtype=np.float64) / 2
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    return signs * half


def cylinder_vertices(radius: float, length: float, sides: int = CYLINDER_SIDES) -> np.ndarray:
    """Corners of a prism around the z-axis cylinder whose polygon circumscribes its circle."""
    outer = radius / math.cos(math.pi / sides)
    angles = 2 * math.pi * np.arange(sides) / sides
    ring = np.column_stack([outer * np.cos(angles), outer * np.sin(angles)])
    return np.vstack(
        [np.column_stack([ring, np.full(sides, z)]) for z in (-length / 2, length / 2)]
    )


def sphere_vertices(radius: float) -> np.ndarray:
    """Vertices of a polytope containing the sphere: an icosphere pushed out past it."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=SPHERE_SUBDIVISIONS, radius=1.0)
    first_vertices = sphere.vertices[sphere.faces[:, 0]]
    offsets = np.einsum("ij,ij->i", sphere.face_normals, first_vertices)
    return np.asarray(sphere.vertices) * (radius / float(offsets.min()))


def _primitive(kind: str, size: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    from scipy.spatial import ConvexHull

    if kind == "box":
        vertices = box_vertices(size)
    elif kind == "cylinder":
        vertices = cylinder_vertices(float(size[0]), float(size[1]))
    else:
        vertices = sphere_vertices(float(size[0]))
    hull = ConvexHull(vertices)
    return vertices, hull.simplices.astype(np.int64)


def body_geometry(elements: tuple[CollisionElement, ...], urdf: Path) -> BodyGeometry:
    """Load the geometry of one body's collision ``elements`` (module docstring)."""
    meshes, primitives, pieces, piece_elements = [], [], [], []
    for index, element in enumerate(elements):
        rotation, shift = element.transform[:3, :3], element.transform[:3, 3]
        if element.kind == "mesh":
            objects = _load_objects(resolve_mesh(element.mesh, urdf))
            scale = np.asarray(element.scale, dtype=np.float64)
            placed = [(v * scale @ rotation.T + shift, f) for v, f in objects]
            offsets = np.cumsum([0] + [len(v) for v, _ in placed])
            vertices = np.concatenate([v for v, _ in placed])
            faces = np.concatenate([f + o for (_, f), o in zip(placed, offsets)])
            meshes.append((vertices, faces))
            primitives.append(None)
            pieces.append(vertices[np.unique(faces)])
            piece_elements.append(index)
        else:
            vertices, faces = _primitive(element.kind, element.size)
            placed = vertices @ rotation.T + shift
            meshes.append((placed, faces))
            primitives.append((element.kind, np.asarray(element.size, dtype=np.float64),
                               element.transform))  # fmt: skip
            pieces.append(placed)
            piece_elements.append(index)
    for vertices, faces in meshes:
        vertices.setflags(write=False)
        faces.setflags(write=False)
    return BodyGeometry(tuple(meshes), tuple(primitives), tuple(pieces), tuple(piece_elements))


__all__ = [
    "CYLINDER_SIDES",
    "BodyGeometry",
    "body_geometry",
    "box_vertices",
    "cylinder_vertices",
    "resolve_mesh",
    "sphere_vertices",
]
