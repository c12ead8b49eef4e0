import time
import urllib.request

import numpy as np
import pytest
from viewer_cases import random_tree, straight_path

from temp_gym.viewer import view_plan
from temp_gym.viewer.plan_viewer import check_address, legend_html, require_viser

pytest.importorskip("viser", reason="the viewer needs temp-gym[view]")


def test_view_plan_serves_the_page_and_returns_a_closable_handle(point2d):
    viewer = view_plan(point2d, path=straight_path(point2d), tree=random_tree(point2d, 20), port=0)
    try:
        assert viewer.url == f"http://127.0.0.1:{viewer.port}" and viewer.port > 0
        with urllib.request.urlopen(viewer.url, timeout=10) as page:
            assert page.status == 200 and b"<html" in page.read().lower()
        assert set(viewer.layers) == {"Tree", "Path"}
    finally:
        viewer.close()
    viewer.close()  # idempotent
    with pytest.raises(OSError):
        urllib.request.urlopen(viewer.url, timeout=5)


def test_the_slider_moves_the_arm_along_the_path(iiwa):
    with view_plan(iiwa, path=straight_path(iiwa), port=0, frames=9) as viewer:
        links = viewer._robot._links
        arm = viewer.content.arm
        for frame in (8, 4, 0):
            viewer.show_frame(frame)
            assert viewer.slider.value == frame and viewer.frame == frame
            positions = np.array([handle.position for handle in links])
            np.testing.assert_allclose(positions, arm.frame_poses[frame, :, :3, 3], atol=1e-6)
        viewer.show_frame(99)  # clamped to the last frame
        assert viewer.frame == 8
        viewer.layers["Arm at start and goal"].value = False
        assert not any(handle.visible for handle in viewer._layer_handles["Arm at start and goal"])


def test_play_steps_through_the_frames(point3d):
    with view_plan(
        point3d, path=straight_path(point3d), port=0, frames=4, playback_seconds=0.4
    ) as viewer:
        seen = set()
        viewer.play.value = True
        deadline = time.monotonic() + 20
        while len(seen) < 4 and time.monotonic() < deadline:
            seen.add(viewer.frame)
            time.sleep(0.05)
        assert seen == {0, 1, 2, 3}  # every frame, looping


def test_a_problem_alone_has_no_playback(point2d):
    with view_plan(point2d, port=0) as viewer:
        assert viewer.slider is None and viewer.play is None and viewer.frame == 0


def test_the_legend_names_what_is_drawn(point2d, iiwa):
    from temp_gym.viewer.content import plan_content

    bare = legend_html(plan_content(point2d))
    assert "goal region" in bare and "path" not in bare
    arm = legend_html(plan_content(iiwa, path=straight_path(iiwa)))
    assert "arm along the path" in arm and "hand trace" in arm


def test_bad_addresses_and_robots_are_refused_before_serving(point2d):
    with pytest.raises(ValueError, match="port: expected an integer in 0..65535"):
        check_address("127.0.0.1", 70000)
    with pytest.raises(ValueError, match="host: cannot listen on 'no.such.host.invalid'"):
        view_plan(point2d, host="no.such.host.invalid")
    with pytest.raises(ValueError, match="path: expected shape"):
        view_plan(point2d, path=np.zeros((2, 5)), port=0)
    with pytest.raises(ValueError, match="frames: expected an integer of at least 2"):
        view_plan(point2d, port=0, frames=1)
    with pytest.raises(ValueError, match="playback_seconds: expected a positive number"):
        view_plan(point2d, port=0, playback_seconds=float("nan"))


def test_without_viser_the_error_says_how_to_install_it(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "viser", None)
    with pytest.raises(ImportError, match=r"pip install 'temp-gym\[view\]'"):
        require_viser()
