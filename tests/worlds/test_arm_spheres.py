"""Covering spheres: they hold the whole convex piece, bulge little, and their trees are sound."""

from __future__ import annotations

import math

import numpy as np
import pytest

from temp_gym.worlds.arm.sphere_tree import build_trees, enclosing_sphere
from temp_gym.worlds.arm.spheres import depth, fit_piece, hull_planes


def _capsule_points():
    import trimesh

    return np.asarray(trimesh.creation.capsule(height=0.1, radius=0.03, count=[10, 10]).vertices)


def _box_points():
    return np.array([[x, y, z] for x in (0, 0.2) for y in (0, 0.05) for z in (0, 0.03)], float)


@pytest.mark.parametrize("points", [_capsule_points(), _box_points()], ids=["capsule", "box"])
def test_spheres_hold_every_point_of_the_solid_and_bulge_at_most_as_reported(points):
    fitted = fit_piece(points, tolerance=0.004)
    corners, _, planes = hull_planes(points)
    rng = np.random.default_rng(0)
    # Points of the solid: random convex combinations of the hull's corners, and the corners.
    weights = rng.dirichlet(np.full(len(corners), 0.3), size=20_000)
    inside = np.concatenate([weights @ corners, corners])
    reach = np.linalg.norm(inside[:, None] - fitted.centers[None], axis=2) - fitted.radii[None]
    assert reach.min(axis=1).max() <= 1e-12
    # Every sphere's surface stays within the reported bulge of the piece.
    directions = rng.normal(size=(200, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    for center, radius in zip(fitted.centers, fitted.radii):
        outside = -depth(center + radius * directions, planes)  # a lower bound on the gap
        assert outside.max() <= fitted.bulge + 1e-9
    assert fitted.bulge < 3 * 0.004


def test_a_flat_piece_is_covered_too():
    plate = np.array([[x, y, 0.0] for x in (0, 0.1) for y in (0, 0.1)])
    fitted = fit_piece(plate, tolerance=0.004)
    probe = np.random.default_rng(1).uniform(0, 0.1, size=(2000, 3)) * [1, 1, 0]
    reach = np.linalg.norm(probe[:, None] - fitted.centers[None], axis=2) - fitted.radii[None]
    assert reach.min(axis=1).max() <= 1e-12


def test_trees_hold_their_leaves_and_skip_whole_subtrees():
    rng = np.random.default_rng(2)
    bodies = [(rng.normal(size=(n, 3)), rng.uniform(0.05, 0.2, n)) for n in (0, 1, 9, 57)]
    trees = build_trees(bodies)
    assert trees.body_start.tolist()[0] == 0 and trees.body_start[-1] == len(trees.node_radii)
    assert np.bincount(trees.sphere_body, minlength=4).tolist() == [0, 1, 9, 57]
    for body in range(4):
        start, end = trees.body_start[body], trees.body_start[body + 1]
        for node in range(start, end):
            assert node < trees.node_skip[node] <= end
            leaves = [k for m in range(node, trees.node_skip[node])
                      for k in range(trees.node_first[m], trees.node_first[m] + trees.node_count[m])
                      if trees.node_count[m]]  # fmt: skip
            reach = np.linalg.norm(trees.centers[leaves] - trees.node_centers[node], axis=1)
            assert np.all(reach + trees.radii[leaves] <= trees.node_radii[node] + 1e-12)
        # Walking the whole tree meets every leaf sphere of the body exactly once.
        met = [
            k
            for m in range(start, end)
            if trees.node_count[m]
            for k in range(trees.node_first[m], trees.node_first[m] + trees.node_count[m])
        ]
        assert sorted(met) == np.flatnonzero(trees.sphere_body == body).tolist()


def _enclosing_sphere_python(centers, radii):
    """The enclosing sphere's steps in plain Python floats, row by row: the compiled one must
    give the same bits. (numpy's ``linalg.norm`` rounds by the CPU's SIMD width: on an
    AVX-512 machine its last bit differs from an AVX2 one's, so it cannot be the reference.)"""
    centers, radii = centers.tolist(), radii.tolist()

    def distance(point, center):
        dx, dy, dz = (point[k] - center[k] for k in range(3))
        return math.sqrt(dx * dx + dy * dy + dz * dz)

    center = [(min(c[k] - r for c, r in zip(centers, radii))
               + max(c[k] + r for c, r in zip(centers, radii))) / 2 for k in range(3)]  # fmt: skip
    for step in range(1, 60):
        reach = [distance(c, center) + r for c, r in zip(centers, radii)]
        far = reach.index(max(reach))  # the first of equals
        length = distance(centers[far], center)
        for k in range(3):
            point = centers[far][k]
            if length > 0:
                point = point + (centers[far][k] - center[k]) / length * radii[far]
            center[k] = center[k] + (point - center[k]) / (step + 1)
    radius = max(distance(c, center) + r for c, r in zip(centers, radii))
    return np.array(center), radius


def test_the_enclosing_sphere_is_the_same_to_the_last_bit_as_its_steps_and_holds_its_spheres():
    """Trees built before the sphere was compiled stay the same (and so do the fast checker's
    verdicts): the same bits on sets of every size, coincident centers and zero radii too."""
    rng = np.random.default_rng(3)
    cases = [(rng.normal(size=(n, 3)) * rng.uniform(0.01, 1.0), rng.uniform(0.0, 0.05, n))
             for n in rng.integers(1, 300, 400)]  # fmt: skip
    cases += [(np.zeros((5, 3)), np.full(5, 0.1)), (np.ones((1, 3)), np.zeros(1))]
    for centers, radii in cases:
        center, radius = enclosing_sphere(centers, radii)
        expected_center, expected_radius = _enclosing_sphere_python(centers, radii)
        assert center.tobytes() == expected_center.tobytes() and radius == expected_radius
        assert np.all(np.linalg.norm(centers - center, axis=1) + radii <= radius)
    with pytest.raises(ValueError, match="spheres"):
        enclosing_sphere(np.zeros((0, 3)), np.zeros(0))
