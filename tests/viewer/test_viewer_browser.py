"""The viewer in a real browser: headless Chromium loads the page; the picture shows the scene.

Skipped only where no Chromium is installed (CI installs Debian's, `.ci/run`).
"""

import numpy as np
import pytest
from matplotlib.colors import rgb_to_hsv
from viewer_cases import random_tree, straight_path

from temp_gym.viewer import view_plan
from temp_gym.viewer.browser import find_chromium, screenshot
from temp_gym.worlds.rendering.common import (
    OBSTACLE_COLOR,
    ROBOT_COLOR,
    SOLUTION_COLOR,
    TREE_COLOR,
    rgb255,
)

pytestmark = pytest.mark.skipif(
    find_chromium() is None, reason="no Chromium on PATH (apt-get install chromium)"
)
WIDTH, HEIGHT = 960, 640
SCENE_WIDTH = 600
"""Columns left of the control panel (its legend has a swatch of every colour)."""


def colour_pixels(image: np.ndarray, color: str, degrees: float = 10.0) -> int:
    """Pixels of the scene of ``color``'s hue (lit or shaded), clearly coloured, not grey."""
    hsv = rgb_to_hsv(image[:, :SCENE_WIDTH] / 255.0)
    target = rgb_to_hsv(np.array(rgb255(color)) / 255.0)
    turn = np.abs(hsv[..., 0] - target[0])
    close = np.minimum(turn, 1.0 - turn) * 360.0 < degrees
    return int(np.sum(close & (hsv[..., 1] > 0.3) & (hsv[..., 2] > 0.25)))


def test_the_arm_scene_shows_in_headless_chromium(tmp_path, iiwa):
    path = straight_path(iiwa)
    with view_plan(iiwa, path=path, tree=random_tree(iiwa, 30), port=0) as viewer:
        viewer.show_frame(viewer.content.frames // 2)

        def ready(image):
            return (
                colour_pixels(image, OBSTACLE_COLOR) > 1000
                and colour_pixels(image, ROBOT_COLOR) > 300
            )

        image = screenshot(viewer.url, tmp_path / "arm.png", WIDTH, HEIGHT, ready, timeout=25)
    assert image.shape == (HEIGHT, WIDTH, 3)
    assert colour_pixels(image, OBSTACLE_COLOR) > 1000  # the box beside the arm
    assert colour_pixels(image, ROBOT_COLOR) > 300  # the arm along the path
    assert colour_pixels(image, SOLUTION_COLOR) > 30  # the hand's trace


def test_the_2d_scene_shows_in_headless_chromium(tmp_path, point2d):
    path = np.array([point2d.start, [2, 18], point2d.goal])
    with view_plan(point2d, path=path, tree=random_tree(point2d, 200), port=0) as viewer:

        def ready(image):
            return colour_pixels(image, OBSTACLE_COLOR) > 1000

        image = screenshot(viewer.url, tmp_path / "2d.png", WIDTH, HEIGHT, ready, timeout=25)
    assert colour_pixels(image, OBSTACLE_COLOR) > 1000  # the wall in the middle
    assert colour_pixels(image, SOLUTION_COLOR) > 300  # the path around it
    assert colour_pixels(image, TREE_COLOR) > 300  # the tree's edges
