"""Pictures of worlds with every obstacle kind: each is drawn where it is, by its shape."""

import numpy as np
import pytest

from temp_gym.problem import Problem, Workspace
from temp_gym.problem.obstacles import Box, Cylinder, Sphere
from temp_gym.quiet import import_pybullet
from temp_gym.worlds.rendering import ArmRenderer, render_point_world

SIZE = 480
GREY = np.array([140, 140, 140])  # the point pictures' obstacles, #8c8c8c
QUARTER_TURN_Z = (0.0, 0.0, np.sin(np.pi / 8), np.cos(np.pi / 8))  # 45 degrees about z


def problem_of(robot: str, bounds, obstacles, start, goal) -> Problem:
    workspace = Workspace.from_obstacles(robot, bounds, obstacles)
    return Problem(workspace, start=start, goal=goal, goal_radius=0.5)


def draw_2d(obstacles) -> np.ndarray:
    """A 2D picture without a legend (whose swatch would count as an obstacle)."""
    problem = problem_of("point2d", [[0, 0], [20, 20]], obstacles, [1, 1], [19, 1])
    return render_point_world(problem, legend=False)


def grey(image: np.ndarray) -> np.ndarray:
    return np.all(np.abs(image.astype(int) - GREY) <= 12, axis=2)


def pixel_map(image: np.ndarray, lower, upper):
    """Data -> pixel ``(row, column)`` of a 2D picture, from where a known box was drawn."""
    mask = grey(image)
    # Inside the box: grey two pixels away on every side (text and ticks are thinner).
    inner = mask[2:-2, 2:-2] & mask[:-4, 2:-2] & mask[4:, 2:-2] & mask[2:-2, :-4] & mask[2:-2, 4:]
    rows, cols = np.nonzero(inner)
    left, right, top, bottom = cols.min(), cols.max() + 4, rows.min(), rows.max() + 4
    scale_x = (right - left) / (upper[0] - lower[0])
    scale_y = (bottom - top) / (upper[1] - lower[1])

    def to_pixel(point) -> tuple[int, int]:
        column = left + (point[0] - lower[0]) * scale_x
        row = bottom - (point[1] - lower[1]) * scale_y
        return int(round(row)), int(round(column))

    return to_pixel


@pytest.fixture(scope="module")
def to_pixel():
    reference = draw_2d([Box((10, 10), (5, 5))])  # an axis-aligned box: drawn as it always was
    return pixel_map(reference, (5, 5), (15, 15))


def test_a_disc_is_drawn_round_where_it_is(to_pixel):
    image = draw_2d([Sphere((12, 9), 3)])
    assert grey(image)[to_pixel((12, 9))]
    assert grey(image)[to_pixel((12 + 2.5, 9))] and grey(image)[to_pixel((12, 9 - 2.5))]
    # Its bounding square's corner and beyond its rim: background.
    for point in ((12 + 2.6, 9 + 2.6), (12 - 2.6, 9 - 2.6), (12 + 3.5, 9), (12, 9 + 3.5)):
        assert tuple(image[to_pixel(point)]) == (255, 255, 255), point


def test_a_turned_rectangle_is_drawn_turned(to_pixel):
    half = (4.0, 1.0)
    turned = draw_2d([Box((10, 10), half, np.pi / 4)])
    straight = draw_2d([Box((10, 10), half)])
    along = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4)])
    assert grey(turned)[to_pixel((10, 10))]
    assert grey(turned)[to_pixel(np.array([10, 10]) + 3.5 * along)]  # along its long side
    assert not grey(straight)[to_pixel(np.array([10, 10]) + 3.5 * along)]
    corner = (10 + 3.7, 10 + 0.8)  # the unturned rectangle's corner
    assert grey(straight)[to_pixel(corner)] and not grey(turned)[to_pixel(corner)]
    assert grey(turned).sum() == pytest.approx(grey(straight).sum(), rel=0.1)  # same area


def changed(image: np.ndarray, empty: np.ndarray) -> np.ndarray:
    return np.any(image != empty, axis=2)


def test_3d_solids_are_drawn_within_their_bounding_boxes():
    bounds = [[0, 0, 0], [20, 20, 20]]

    def draw(obstacles):
        problem = problem_of("point3d", bounds, obstacles, [1, 1, 1], [19, 1, 1])
        return render_point_world(problem, legend=False)

    empty = draw([])
    cases = [
        (Sphere((10, 12, 10), 4), Box((10, 12, 10), (4, 4, 4))),
        (Cylinder((10, 12, 10), 3, 8), Box((10, 12, 10), (3, 3, 4))),
        (Box((10, 12, 10), (5, 2, 4), QUARTER_TURN_Z), Box((10, 12, 10), (5, 2, 4))),
    ]
    for solid, box in cases:
        drawn, boxed = changed(draw([solid]), empty), changed(draw([box]), empty)
        assert drawn.sum() > 2000, solid  # something is drawn ...
        rows, cols = np.nonzero(drawn)
        box_rows, box_cols = np.nonzero(boxed)
        # ... where the box is (the pictures' obstacles are pale: their edges show) ...
        assert abs(rows.mean() - box_rows.mean()) < 12 and abs(cols.mean() - box_cols.mean()) < 12
        assert not np.array_equal(drawn, boxed), solid  # ... and by its own shape
    sphere, bounding = changed(draw([cases[0][0]]), empty), changed(draw([cases[0][1]]), empty)
    assert sphere.sum() < bounding.sum()
    assert (sphere & ~bounding).sum() < 0.02 * sphere.sum()  # within its bounding box's picture


# ---------------------------------------------------------------------- arms
FAR = [  # well beyond the iiwa's reach (about 1.3 m), so start and goal are free
    Sphere((1.9, 0.0, 0.4), 0.3),
    Cylinder((0.0, 1.9, 0.4), 0.2, 0.8, (np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4))),
    Box((-1.9, 0.0, 0.4), (0.35, 0.1, 0.3), QUARTER_TURN_Z),
]
ARM = {"start": [0, 0, 0, 0, 0, 0, 0], "goal": [1, 0.5, 0, -1, 0, 0.5, 0]}


def iiwa(obstacles) -> Problem:
    bounds = Problem.from_dict({"robot": "kuka_iiwa14", "obstacles": [], **ARM,
                                "goal_radius": 0.1}).bounds  # fmt: skip
    return problem_of("kuka_iiwa14", bounds, obstacles, ARM["start"], ARM["goal"])


def projected(point, yaw: float, pitch: float, distance: float, target) -> tuple[int, int]:
    """Pixel ``(row, column)`` of a world point in an `ArmRenderer` picture of side `SIZE`."""
    pybullet = import_pybullet()
    view = (
        np.array(pybullet.computeViewMatrixFromYawPitchRoll(target, distance, yaw, pitch, 0.0, 2))
        .reshape(4, 4)
        .T
    )
    projection = (
        np.array(pybullet.computeProjectionMatrixFOV(45.0, 1.0, 0.05, 20.0)).reshape(4, 4).T
    )
    clip = projection @ view @ np.append(point, 1.0)
    x, y = clip[:2] / clip[3]
    return int(round((1 - y) / 2 * SIZE)), int(round((x + 1) / 2 * SIZE))


def tan(pixel: np.ndarray) -> bool:
    """The obstacles' tan, lit or shaded: red over green over blue, clearly coloured."""
    r, g, b = (int(c) for c in pixel)
    return r > g > b and r - b > 40


@pytest.mark.parametrize("index", range(len(FAR)))
def test_the_arm_picture_draws_each_kind_where_it_is(index):
    solid = FAR[index]
    yaw = 90.0 + 90.0 * index  # looking at the solid from beyond it, the arm behind
    target = tuple(float(c) for c in solid.center)
    problem = iiwa([solid])
    with ArmRenderer(yaw=yaw, pitch=-20.0, distance=1.6, target=target, legend=False) as renderer:
        image = renderer.render(problem, width=SIZE, height=SIZE)
        row, col = projected(solid.center, yaw, -20.0, 1.6, target)
        assert tan(image[row, col])
        if isinstance(solid, Sphere):
            # Inside its bounding box, outside the ball: no obstacle there.
            corner = np.array(solid.center) + 0.27 * np.array([0.0, 1.0, 1.0])
            assert not tan(image[projected(corner, yaw, -20.0, 1.6, target)])
        if isinstance(solid, Box):
            straight = renderer.render(iiwa([Box(solid.center, solid.half_extents)]),
                                       width=SIZE, height=SIZE)  # fmt: skip
            assert not np.array_equal(image, straight)
