"""The enclosure test: a point inside a mesh's solid, by its hull and its winding number."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from temp_gym.worlds.collision.arm_enclosure import encloses, mesh_solid, winding_number


def _solid(mesh: trimesh.Trimesh):
    return mesh_solid(np.asarray(mesh.vertices), np.asarray(mesh.faces))


def test_the_winding_number_is_one_inside_a_closed_mesh_and_zero_outside():
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    triangles = np.asarray(mesh.triangles)
    assert winding_number(triangles, np.zeros(3)) == pytest.approx(1.0, abs=1e-9)
    assert winding_number(triangles, np.array([0.0, 0.0, 0.3])) == pytest.approx(0.0, abs=1e-9)
    flipped = triangles[:, ::-1]  # wound inwards: -1, still inside
    assert winding_number(flipped, np.zeros(3)) == pytest.approx(-1.0, abs=1e-9)
    assert _solid(mesh.copy()).encloses(np.zeros(3))
    open_mesh = mesh.copy()
    open_mesh.update_faces(np.arange(len(mesh.faces)) != 0)  # one triangle missing: still inside
    assert not open_mesh.is_watertight and _solid(open_mesh).encloses(np.zeros(3))


def test_a_point_in_a_hollow_the_hull_covers_is_not_enclosed():
    """An L of two boxes: the notch is inside the hull, outside the solid."""
    arm = trimesh.creation.box(extents=[0.2, 0.05, 0.05])
    arm.apply_translation([0.1, 0.025, 0.025])
    leg = trimesh.creation.box(extents=[0.05, 0.2, 0.05])
    leg.apply_translation([0.025, 0.1, 0.025])
    ell = trimesh.util.concatenate([arm, leg])
    solid = _solid(ell)
    notch = np.array([0.1, 0.1, 0.025])
    assert np.all(solid.planes[:, :3] @ notch + solid.planes[:, 3] <= 0)  # in the hull
    assert not solid.encloses(notch)
    assert solid.encloses(np.array([0.15, 0.02, 0.02]))
    assert not solid.encloses(np.array([0.3, 0.02, 0.02]))  # outside the hull


def test_a_posed_body_reads_the_point_in_its_own_frame():
    solids = (_solid(trimesh.creation.box(extents=[0.1, 0.1, 0.1])),)
    pose = np.eye(4)
    pose[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    pose[:3, 3] = [1.0, 2.0, 3.0]
    assert encloses(solids, pose, np.array([1.02, 2.0, 3.0]))
    assert not encloses(solids, pose, np.array([1.0, 2.0, 3.2]))
    assert not encloses((), pose, np.array([1.0, 2.0, 3.0]))
