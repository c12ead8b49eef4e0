import numpy as np
import pytest

from temp_gym.problem.obstacles import BOX as BOX_KIND
from temp_gym.problem.obstacles import CYLINDER, SPHERE, rotation_matrices
from temp_gym.quiet import import_pybullet
from temp_gym.worlds.rendering.camera import (
    clearest_views,
    orbit_position,
    segments_hit_boxes,
    segments_hit_solids,
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


def _inside(points: np.ndarray, kind: int, half: np.ndarray) -> np.ndarray:
    """Whether points ``(..., 3)`` in an obstacle's frame are inside it."""
    if kind == SPHERE:
        return np.linalg.norm(points, axis=-1) <= half[0]
    if kind == CYLINDER:
        radial = np.linalg.norm(points[..., :2], axis=-1) <= half[0]
        return radial & (np.abs(points[..., 2]) <= half[2])
    return np.all(np.abs(points) <= half, axis=-1)


@pytest.mark.parametrize("kind", [BOX_KIND, CYLINDER, SPHERE])
def test_segments_meet_a_turned_solid_as_dense_samples_along_them_do(kind):
    rng = np.random.default_rng(kind)
    half = np.array([0.3, 0.3, 0.8]) if kind != BOX_KIND else np.array([0.2, 0.5, 0.9])
    if kind == SPHERE:
        half = np.full(3, 0.6)
    center = np.array([0.2, -0.1, 0.5])
    axis = rng.normal(size=3)
    quaternion = np.append(np.sin(0.6) * axis / np.linalg.norm(axis), np.cos(0.6))
    rotation = rotation_matrices(quaternion[None])[0]
    solids = Solids(
        *(center[None] - 1.5, center[None] + 1.5),  # a loose bounding box, never read
        np.array([kind], dtype=np.int8),
        center[None],
        half[None],
        rotation[None],
    )
    starts = center + rng.uniform(-1.5, 1.5, size=(400, 3))
    ends = center + rng.uniform(-1.5, 1.5, size=(400, 3))
    ends[:20] = starts[:20]  # points
    ends[20:40, :2] = starts[20:40, :2]  # along world z
    hits = segments_hit_solids(starts, ends, solids)
    t = np.linspace(0.0, 1.0, 4001)[None, :, None]
    samples = ((starts[:, None] + t * (ends - starts)[:, None]) - center) @ rotation
    assert np.all(hits[np.any(_inside(samples, kind, half - 1e-3), axis=1)])
    assert not np.any(hits[~np.any(_inside(samples, kind, half + 1e-2), axis=1)])
    assert 50 < hits.sum() < 350  # both verdicts are tried


def test_a_turned_box_or_a_ball_hides_less_than_its_bounding_box():
    ball = Solids(
        np.array([[-1.0, -1, -1]]), np.array([[1.0, 1, 1]]), np.array([SPHERE], dtype=np.int8),
        np.zeros((1, 3)), np.ones((1, 3)), np.eye(3)[None],
    )  # fmt: skip
    corner = np.array([[0.9, 0.9, -3.0]]), np.array([[0.9, 0.9, 3.0]])  # in the box, not the ball
    assert segments_hit_boxes(*corner, ball.lower, ball.upper).tolist() == [True]
    assert segments_hit_solids(*corner, ball).tolist() == [False]
    assert segments_hit_solids(np.array([[0.0, 0, -3]]), np.array([[0.0, 0, 3]]), ball).all()
    # A box turned 45 degrees about z: its bounding box's corner is outside it.
    turned = Solids(
        np.array([[-1.0, -1, -1]]), np.array([[1.0, 1, 1]]), np.array([BOX_KIND], dtype=np.int8),
        np.zeros((1, 3)), np.array([[np.sqrt(0.5), np.sqrt(0.5), 1.0]]),
        rotation_matrices(np.array([[0.0, 0.0, np.sin(np.pi / 8), np.cos(np.pi / 8)]])),
    )  # fmt: skip
    assert segments_hit_solids(*corner, turned).tolist() == [False]
    assert segments_hit_solids(np.array([[0.9, 0, -3]]), np.array([[0.9, 0, 3]]), turned).all()
