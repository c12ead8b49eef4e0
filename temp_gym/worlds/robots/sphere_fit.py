"""A few spheres per iiwa link that provably cover the link's collision mesh.

Run ``python -m temp_gym.worlds.robots.sphere_fit`` to regenerate ``iiwa14_spheres.json``
next to this file; the fast collision checker only loads that JSON (`load_sphere_model`), so
importing it costs no fitting.

Meshes are read with the small numpy binary-STL reader in `temp_gym.worlds.robots.iiwa14`
rather than trimesh: the runtime (the exact checker needs the meshes too) then depends on no
mesh library, and nothing here needs more than vertices and triangles.

Why the cover is exact, not sampled:

1. Every triangle is split into four (edge midpoints) until its longest edge is at most
   ``max_edge``. The small triangles tile the original surface exactly.
2. Each small triangle is assigned to one sphere, and that sphere's radius is the largest
   distance from its center to any corner of its assigned triangles.
3. A ball is convex, so a triangle whose three corners lie in the ball lies in it entirely.
   Hence every point of every triangle, not just the samples, is inside a sphere of its link.

A margin of ``1e-4`` m is added on top, only to absorb floating-point error (the meshes are
float32). Subdividing does not change what is covered; it only lets nearby surface go to the
sphere that covers it most cheaply, which keeps the radii small.

The centers come from area-weighted k-means on the small triangles' centroids, refined by
alternating "move each center to its cluster's (approximate) minimal enclosing ball center"
and "give each triangle to the sphere whose radius it grows least"; the best of a few seeded
restarts (smallest total sphere volume) is kept.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

SPHERES_PATH = Path(__file__).with_name("iiwa14_spheres.json")
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
    center = points.mean(axis=0)
    for step in range(1, iterations + 1):
        far = points[np.argmax(((points - center) ** 2).sum(axis=1))]
        center = center + (far - center) / (step + 1)
    return center


def fit_link(
    vertices: np.ndarray,
    faces: np.ndarray,
    count: int,
    rng: np.random.Generator,
    max_edge: float = MAX_EDGE,
    restarts: int = 4,
) -> tuple[np.ndarray, np.ndarray]:
    """Fit ``count`` spheres covering the mesh; returns ``(centers (K, 3), radii (K,))``."""
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
        centers, radii = centers[used], radii[used] + MARGIN
        volume = float((radii**3).sum())
        if best is None or volume < best[0]:
            best = (volume, centers.copy(), radii.copy())
    assert best is not None
    return best[1], best[2]


def fit_model(seed: int = 0) -> dict:
    """Fit every link and return the JSON-ready sphere model."""
    from temp_gym.worlds.robots.iiwa14 import link_meshes, load_model

    rng = np.random.default_rng(seed)
    links = []
    for j, (vertices, faces) in enumerate(link_meshes()):
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
        "method": f"exact triangle cover, max_edge={MAX_EDGE}, margin={MARGIN}, seed={seed}",
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
    """Regenerate ``iiwa14_spheres.json`` and print the radii."""
    model = fit_model()
    SPHERES_PATH.write_text(json.dumps(model, indent=1) + "\n")
    for j, link in enumerate(model["links"]):
        print(f"link_{j}: radii {link['radii']}")
    print(f"wrote {SPHERES_PATH}")


if __name__ == "__main__":
    main()
