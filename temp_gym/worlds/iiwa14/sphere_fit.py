"""A few spheres per iiwa link that provably cover the link's solid convex hull.

Run ``python -m temp_gym.worlds.iiwa14.sphere_fit`` to regenerate ``spheres.json``
next to this file; the fast collision checker only loads that JSON (`load_sphere_model`), so
importing it costs no fitting.

Meshes are read with the small numpy binary-STL reader in `temp_gym.worlds.iiwa14.kinematics`
rather than trimesh: the runtime (the exact checker needs the meshes too) then depends on no
mesh library, and nothing here needs more than vertices and triangles.

What is covered: the *solid* convex hull of each link's collision mesh
(`temp_gym.worlds.iiwa14.convex_hulls`). It contains the mesh, so the spheres cover the mesh
that the exact checker tests against boxes, and it is the geometry the exact checker uses for
self-collision (a hull is a solid, so the cover must be one too: a link inside another's hull
is a collision).

Why the cover is exact, not sampled:

1. The solid hull is tiled exactly by tetrahedra, its centroid joined to each face.
2. A tetrahedron whose four corners lie in one sphere lies in it entirely (a ball is convex).
   Every tetrahedron that no single sphere holds is bisected at the midpoint of its longest
   edge (the halves tile it exactly), and so on until its longest edge is at most
   ``max_edge``; a piece still held by no sphere then grows the sphere that needs the least
   growth to hold it. So every point of the solid, not just samples, is inside a sphere.
3. Only the centers come from a fit: every hull face is split into four (edge midpoints)
   until its longest edge is at most ``max_edge``; area-weighted k-means on the small
   triangles' centroids, refined by alternating "move each center to its cluster's
   (approximate) minimal enclosing ball center" and "give each triangle to the sphere whose
   radius it grows least", places the spheres and sizes them to cover the surface; step 2
   then makes them cover the inside as well. The best of a few seeded restarts (smallest
   total sphere volume) is kept.

A margin of ``1e-4`` m is added on top, only to absorb floating-point error (the meshes are
float32).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

SPHERES_PATH = Path(__file__).with_name("spheres.json")
SPHERES_PER_LINK = (6, 5, 5, 5, 5, 5, 4, 3)
"""Spheres per link, link_0 first. Link_0 never moves, so its count costs nothing at runtime."""
MARGIN = 1e-4
MAX_EDGE = 0.01


def subdivide(vertices: np.ndarray, faces: np.ndarray, max_edge: float) -> np.ndarray:
    """Split triangles 1-to-4 until every edge is at most ``max_edge``: ``(T, 3, 3)`` corners."""
    triangles = vertices[faces]
    done = []
    while len(triangles):
        edges = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(axis=1)
        small = edges <= max_edge
        done.append(triangles[small])
        big = triangles[~small]
        a, b, c = big[:, 0], big[:, 1], big[:, 2]
        ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
        triangles = np.concatenate(
            [np.stack(t, axis=1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))]
        )
    return np.concatenate(done)


def _farthest_corner(triangles: np.ndarray, centers: np.ndarray) -> np.ndarray:
    """``(T, K)``: distance from each center to the farthest corner of each triangle."""
    diff = triangles[:, None, :, :] - centers[None, :, None, :]
    return np.sqrt((diff**2).sum(axis=3)).max(axis=2)


def _enclosing_center(points: np.ndarray, iterations: int = 200) -> np.ndarray:
    """Approximate minimal-enclosing-ball center (Badoiu-Clarkson steps toward the farthest)."""
    points = np.unique(points, axis=0)  # triangles share corners: each counts once
    center = points.mean(axis=0)
    for step in range(1, iterations + 1):
        far = points[np.argmax(((points - center) ** 2).sum(axis=1))]
        center = center + (far - center) / (step + 1)
    return center


def _bisect_longest_edge(cells: np.ndarray) -> np.ndarray:
    """Split tetrahedra ``(T, 4, 3)`` in two at their longest edge's midpoint: ``(2T, 4, 3)``."""
    first, second = np.array(_TETRA_EDGES).T
    lengths = np.linalg.norm(cells[:, first] - cells[:, second], axis=2)
    longest = np.argmax(lengths, axis=1)
    i, j = first[longest], second[longest]
    rows = np.arange(len(cells))
    middle = (cells[rows, i] + cells[rows, j]) / 2
    low, high = cells.copy(), cells.copy()
    low[rows, i] = middle  # the half on j's side
    high[rows, j] = middle  # the half on i's side
    return np.concatenate([low, high])


_TETRA_EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))


def cover_solid(
    tetrahedra: np.ndarray, centers: np.ndarray, radii: np.ndarray, max_edge: float
) -> np.ndarray:
    """Radii, grown where needed, such that the spheres hold every tetrahedron ``(T, 4, 3)``.

    Tetrahedra held by no single sphere are bisected until their longest edge is at most
    ``max_edge``; a piece that small still held by none grows the sphere that needs the least
    growth (module docstring, step 2).
    """
    radii = radii.astype(np.float64).copy()
    pending = tetrahedra
    while len(pending):
        reach = _farthest_corner(pending, centers)
        held = np.any(reach <= radii[None], axis=1)
        pending, reach = pending[~held], reach[~held]
        first, second = np.array(_TETRA_EDGES).T
        longest = np.linalg.norm(pending[:, first] - pending[:, second], axis=2).max(axis=1)
        small = longest <= max_edge
        if small.any():
            reach_small = reach[small]
            cheapest = np.argmin(reach_small - radii[None], axis=1)
            np.maximum.at(radii, cheapest, reach_small[np.arange(len(cheapest)), cheapest])
        pending = _bisect_longest_edge(pending[~small])
    return radii


def fit_link(
    vertices: np.ndarray,
    faces: np.ndarray,
    count: int,
    rng: np.random.Generator,
    max_edge: float = MAX_EDGE,
    restarts: int = 4,
) -> tuple[np.ndarray, np.ndarray]:
    """Fit ``count`` spheres covering a solid convex hull ``(vertices, faces)``.

    Returns ``(centers (K, 3), radii (K,))``, the margin included.
    """
    from temp_gym.worlds.iiwa14.convex_hulls import hull_tetrahedra

    tetrahedra = hull_tetrahedra(vertices, faces)
    triangles = subdivide(vertices, faces, max_edge)
    centroids = triangles.mean(axis=1)
    areas = 0.5 * np.linalg.norm(
        np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]), axis=1
    )
    weights = areas / areas.sum()
    best = None
    for _ in range(restarts):
        centers = centroids[rng.choice(len(centroids), size=count, replace=False, p=weights)]
        for _ in range(30):  # area-weighted k-means
            labels = np.argmin(((centroids[:, None] - centers[None]) ** 2).sum(axis=2), axis=1)
            for k in range(count):
                mask = labels == k
                if mask.any():
                    centers[k] = np.average(centroids[mask], axis=0, weights=areas[mask])
        for _ in range(15):  # minimax refinement
            radii = np.zeros(count)
            labels = np.argmin(_farthest_corner(triangles, centers), axis=1)
            for k in range(count):
                mask = labels == k
                if mask.any():
                    centers[k] = _enclosing_center(triangles[mask].reshape(-1, 3))
            # Greedy reassignment: triangles go where the resulting radius grows least.
            reach = _farthest_corner(triangles, centers)
            labels = np.argmin(reach, axis=1)
            for k in range(count):
                mask = labels == k
                radii[k] = reach[mask, k].max() if mask.any() else 0.0
            labels = np.argmin(np.maximum(reach - radii[None], 0.0) + 1e-9 * reach, axis=1)
        reach = _farthest_corner(triangles, centers)
        radii = np.array(
            [reach[labels == k, k].max() if np.any(labels == k) else 0.0 for k in range(count)]
        )
        used = radii > 0
        centers = centers[used]
        radii = cover_solid(tetrahedra, centers, radii[used], max_edge) + MARGIN
        volume = float((radii**3).sum())
        if best is None or volume < best[0]:
            best = (volume, centers.copy(), radii.copy())
    assert best is not None
    return best[1], best[2]


def fit_model(seed: int = 0) -> dict:
    """Fit every link's solid hull and return the JSON-ready sphere model."""
    from temp_gym.worlds.iiwa14.convex_hulls import link_hulls
    from temp_gym.worlds.iiwa14.kinematics import load_model

    rng = np.random.default_rng(seed)
    links = []
    for j, (vertices, faces) in enumerate(link_hulls()):
        centers, radii = fit_link(vertices, faces, SPHERES_PER_LINK[j], rng)
        links.append(
            {
                "mesh": load_model().mesh_files[j].name,
                "centers": centers.round(6).tolist(),
                # Rounding the centers moves them by at most 0.5e-6 * sqrt(3) < 1e-6.
                "radii": (radii + 1e-6).round(6).tolist(),
                "mesh_radius": float(np.linalg.norm(vertices, axis=1).max()),
            }
        )
    return {
        "robot": "kuka_iiwa14",
        "frame": "link frame (URDF joint frame); meters",
        "method": (
            f"exact cover of the solid convex hull, max_edge={MAX_EDGE}, margin={MARGIN}, "
            f"seed={seed}"
        ),
        "links": links,
    }


def load_sphere_model(path: str | Path = SPHERES_PATH) -> list[tuple[np.ndarray, np.ndarray]]:
    """Load the shipped sphere model: per link ``(centers (K, 3), radii (K,))``, link_0 first."""
    data = json.loads(Path(path).read_text())
    return [
        (np.array(link["centers"], dtype=np.float64).reshape(-1, 3),
         np.array(link["radii"], dtype=np.float64))
        for link in data["links"]
    ]  # fmt: skip


def load_mesh_radii(path: str | Path = SPHERES_PATH) -> np.ndarray:
    """``(8,)`` largest distance of a collision-mesh vertex from its link's frame origin."""
    data = json.loads(Path(path).read_text())
    return np.array([link["mesh_radius"] for link in data["links"]])


def main() -> None:
    """Regenerate ``spheres.json`` and print the radii."""
    model = fit_model()
    SPHERES_PATH.write_text(json.dumps(model, indent=1) + "\n")
    for j, link in enumerate(model["links"]):
        print(f"link_{j}: radii {link['radii']}")
    print(f"wrote {SPHERES_PATH}")


if __name__ == "__main__":
    main()
