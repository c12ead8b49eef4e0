"""The iiwa's self-collision data: hulls, the solid sphere cover, the ACM and the pair tables."""

from __future__ import annotations

import json

import numpy as np
import pytest

from temp_gym.worlds.collision.iiwa_self import SELF_COLLISION_GAP, LinkHulls
from temp_gym.worlds.iiwa14 import acm, pair_tables
from temp_gym.worlds.iiwa14.convex_hulls import convex_hull, hull_tetrahedra, link_hulls
from temp_gym.worlds.iiwa14.kinematics import forward_kinematics, joint_limits, link_meshes
from temp_gym.worlds.iiwa14.sphere_fit import cover_solid, load_sphere_model

LIMITS = joint_limits()


def test_hulls_contain_their_meshes_and_face_outward():
    for (vertices, _), (corners, faces) in zip(link_meshes(), link_hulls()):
        center = corners.mean(axis=0)
        a, b, c = (corners[faces[:, k]] for k in range(3))
        normals = np.cross(b - a, c - a)
        assert np.all(np.einsum("ij,ij->i", normals, a - center) > 0)  # outward
        # Every mesh vertex is on the inner side of every face.
        inside = np.einsum("fk,vfk->vf", normals, vertices[:, None, :] - a[None])
        assert inside.max() <= 1e-9


def test_spheres_cover_the_solid_hulls():
    rng = np.random.default_rng(5)
    for j, ((corners, faces), (centers, radii)) in enumerate(
        zip(link_hulls(), load_sphere_model())
    ):
        cells = hull_tetrahedra(corners, faces)
        weights = rng.dirichlet(np.ones(4), size=(len(cells), 20))  # points inside each cell
        points = np.einsum("tsk,tkd->tsd", weights, cells).reshape(-1, 3)
        points = np.concatenate([points, corners, cells[:, 0]])
        covered = np.zeros(len(points), dtype=bool)
        for center, radius in zip(centers, radii):
            covered |= np.linalg.norm(points - center, axis=1) <= radius
        assert covered.all(), f"link_{j}: {np.sum(~covered)} points of the hull uncovered"


def test_cover_solid_grows_spheres_until_the_solid_is_held():
    cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    corners, faces = convex_hull(cube)
    centers = np.array([[0.25, 0.5, 0.5], [0.75, 0.5, 0.5]])
    radii = cover_solid(hull_tetrahedra(corners, faces), centers, np.full(2, 0.1), 0.1)
    # Each half-cube's farthest corner is sqrt(0.25^2 + 0.5^2 + 0.5^2) = 0.75 from its center.
    assert np.all(radii >= 0.75 - 1e-12) and np.all(radii <= 0.75 + 0.1)


def test_shipped_acm_is_consistent():
    data = acm.load_acm()
    pairs = [tuple(entry["links"]) for entry in data["pairs"]]
    assert len(pairs) == len(set(pairs)) == 28  # every pair of the 8 links, once
    for entry in data["pairs"]:
        a, b = (int(name.removeprefix("link_")) for name in entry["links"])
        assert entry["reason"] in acm.REASONS
        assert (entry["reason"] == "adjacent") == (b == a + 1)
        if entry["reason"] == "never":
            assert entry["colliding_samples"] == 0
            assert entry["closest_approach"] > acm.NEVER_CLEARANCE
        if entry["reason"] == "enabled":
            assert entry["zero_configuration_distance"] > 0
    assert data["reported"] == []  # nothing collides in the zero configuration
    np.testing.assert_array_equal(acm.enabled_pairs(), [[0, 5], [0, 6], [0, 7], [5, 7]])


def test_acm_is_reproducible_from_its_seed(monkeypatch):
    monkeypatch.setattr(acm, "SEARCH_STARTS", 1)
    monkeypatch.setattr(acm, "SEARCH_STEPS", 20)
    first, second = acm.compute_acm(samples=100, seed=3), acm.compute_acm(samples=100, seed=3)
    assert first == second
    shipped = {tuple(e["links"]): e for e in acm.load_acm()["pairs"]}
    for entry in first["pairs"]:
        if entry["reason"] != "adjacent":  # the zero configuration does not depend on samples
            expected = shipped[tuple(entry["links"])]["zero_configuration_distance"]
            assert entry["zero_configuration_distance"] == expected


def test_acm_with_another_padding_is_refused(tmp_path):
    data = acm.load_acm()
    path = tmp_path / "acm.json"
    path.write_text(json.dumps({**data, "padding": 0.002}))
    with pytest.raises(ValueError, match="padding"):
        acm.load_acm(path)


def test_pair_table_bounds_the_hull_distance_from_below():
    pairs, grid, bounds = pair_tables.load_pair_tables()
    np.testing.assert_array_equal(pairs, [[5, 7]])
    joint, lower, width, cells = grid[0]
    hulls = LinkHulls(pairs)
    states = np.random.default_rng(6).uniform(LIMITS[0], LIMITS[1], size=(600, 7))
    states[:300, 5] = np.linspace(LIMITS[0, 5], LIMITS[1, 5], 300)  # the whole range, densely
    margins = []
    for state, poses in zip(states, forward_kinematics(states)):
        cell = min(int((state[int(joint)] - lower) / width), int(cells) - 1)
        distance = hulls.distance(poses, 5, 7) - SELF_COLLISION_GAP
        assert bounds[0, cell] <= distance
        margins.append(distance - bounds[0, cell])
    assert np.median(margins) < 0.002  # and tight: within 2 mm on the typical pose
