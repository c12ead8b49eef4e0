import numpy as np
import pytest

from temp_gym.quiet import import_pybullet
from temp_gym.worlds.rendering.camera import (
    clearest_views,
    orbit_position,
    segments_hit_boxes,
    views_seeing,
    visible_points,
)
from temp_gym.worlds.rendering.solids import Solids

LOWER = np.array([[0.9, -0.5, 0.0]])
UPPER = np.array([[1.1, 0.5, 1.0]])
BOX = Solids.boxes(LOWER, UPPER)


@pytest.mark.parametrize(
    "yaw, pitch", [(0.0, -30.0), (50.0, -28.0), (135.0, -50.0), (270.0, -10.0)]
)
def test_orbit_position_is_pybullets_camera_eye(yaw, pitch):
    pybullet = import_pybullet()
    target = (0.1, 0.2, 0.4)
    view = (
        np.array(pybullet.computeViewMatrixFromYawPitchRoll(target, 3.3, yaw, pitch, 0.0, 2))
        .reshape(4, 4)
        .T
    )
    eye = -view[:3, :3].T @ view[:3, 3]
    np.testing.assert_allclose(orbit_position(target, yaw, pitch, 3.3), eye, atol=1e-5)


def test_segments_hit_boxes_by_the_slab_test():
    starts = np.array([[0.0, 0, 0.5], [0.0, 0, 0.5], [0.0, 0, 1.5], [1.0, 0, 0.5], [0.0, 0.7, 0.5]])
    ends = np.array([[2.0, 0, 0.5], [0.8, 0, 0.5], [2.0, 0, 1.5], [1.0, 0, 0.6], [2.0, 0.7, 0.5]])
    hits = segments_hit_boxes(starts, ends, LOWER, UPPER)
    # through; stops short; passes above; inside (parallel to two axes); passes beside
    assert hits.tolist() == [True, False, False, True, False]
    assert (
        segments_hit_boxes(starts, ends, np.empty((0, 3)), np.empty((0, 3))).tolist() == [False] * 5
    )


def test_views_behind_a_box_do_not_see_the_point():
    point = np.array([[0.5, 0.0, 0.5]])
    views = [(90.0, -10.0), (270.0, -10.0)]  # from +x (behind the box) and from -x
    assert views_seeing(point, BOX, views, (0, 0, 0.4), 3.0) == [0, 1]
    assert clearest_views(point, BOX, views, (0, 0, 0.4), 3.0) == [(270.0, -10.0)]
    eye = orbit_position((0, 0, 0.4), 90.0, -10.0, 3.0)
    assert visible_points(eye, np.array([[0.5, 0, 0.5], [0.5, 0, 2.5]]), BOX).tolist() == [
        False,
        True,
    ]
