"""`view_plan`: a plan in the browser, served by viser; `PlanViewer` is its handle.

`view_plan` returns at once with the server running in the background (tests, notebooks,
scripts that go on); `serve_plan` blocks until Ctrl-C (the commands). The page shows the
scene, the tree and the path (`temp_gym.viewer.content`), a legend, the plan's summary and,
with a path, a playback control: *Play* moves the robot along the path, the *Along the path*
slider scrubs it.

The server listens on ``127.0.0.1`` by default: only this machine can open the page. Pass
``host="0.0.0.0"`` to share it on a network you trust.

Example:
    >>> result = plan(problem, planner="informed_rrt_star", max_nodes=1000)
    >>> with view_plan(problem, result=result, port=0) as viewer:  # port 0: any free port
    ...     print(viewer.url)
    http://127.0.0.1:40731
"""

from __future__ import annotations

import contextlib
import io
import numbers
import socket
import threading
from typing import TYPE_CHECKING

import numpy as np

from temp_gym.viewer.content import PLAYBACK_FRAMES, PlanContent, plan_content
from temp_gym.worlds.rendering.common import (
    GOAL_COLOR,
    OBSTACLE_COLOR,
    ROBOT_COLOR,
    SOLUTION_COLOR,
    START_COLOR,
    TREE_COLOR,
)

if TYPE_CHECKING:
    from temp_gym.planning.result import PlanResult, PlanTree
    from temp_gym.problem import Problem

PLAYBACK_SECONDS = 6.0
"""Seconds *Play* takes from start to goal."""
INSTALL_HINT = "the viewer needs viser: pip install 'temp-gym[view]'"


def require_viser():
    """The viser module, or an `ImportError` that says how to install it."""
    try:
        import viser
    except ImportError as error:
        raise ImportError(INSTALL_HINT) from error
    return viser


def check_address(host: str, port: int) -> None:
    """Raise a `ValueError` unless this machine can listen on ``host`` (any port from ``port``).

    viser retries a busy port on the next one, but waits forever on an address it can never
    bind, so the address is tried here first.
    """
    if not isinstance(port, int) or isinstance(port, bool) or not 0 <= port <= 65535:
        raise ValueError(f"port: expected an integer in 0..65535, got {port!r}")
    try:
        family, kind, proto, _, address = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)[0]
        with socket.socket(family, kind, proto) as probe:
            probe.bind(address)
    except (OSError, UnicodeError) as error:
        reason = getattr(error, "strerror", None) or error
        raise ValueError(f"host: cannot listen on {host!r} ({reason})") from None


def legend_html(content: PlanContent) -> str:
    """The legend as HTML: a swatch and a line per thing drawn."""
    robot = "arm" if content.arm is not None else "robot"
    where = "hand " if content.arm is not None else ""
    entries = [
        (START_COLOR, f"start{' (arm: translucent)' if content.arm is not None else ''}"),
        (GOAL_COLOR, f"goal{' (arm: translucent)' if content.arm is not None else ' region'}"),
        (TREE_COLOR, f"tree edges{' (hand positions)' if content.arm is not None else ''}"),
        (OBSTACLE_COLOR, "obstacles"),
    ]
    if content.path_trace is not None:
        entries.insert(2, (SOLUTION_COLOR, f"path ({where}trace)" if where else "path"))
        entries.append((ROBOT_COLOR, f"{robot} along the path (Play, slider)"))
    rows = "".join(
        f'<div><span style="display:inline-block;width:0.9em;height:0.9em;'
        f'background:{color};margin-right:0.5em;vertical-align:middle"></span>{text}</div>'
        for color, text in entries
    )
    return f'<div style="font-size:0.85em;line-height:1.5">{rows}</div>'


class PlanViewer:
    """A running viewer: its `url`, its playback, and `close`.

    Made by `view_plan`; use it as a context manager, or call `close` (idempotent).
    """

    def __init__(
        self,
        server,
        content: PlanContent,
        summary: str,
        playback_seconds: float = PLAYBACK_SECONDS,
    ) -> None:
        from temp_gym.viewer.drawing import draw_content

        self.server = server
        """The `viser.ViserServer`."""
        self.content = content
        """What is drawn (`temp_gym.viewer.content.PlanContent`)."""
        self._robot, layers = draw_content(server, content)
        gui = server.gui
        gui.configure_theme(show_share_button=False, control_width="medium")
        gui.add_markdown(f"**{content.robot}**: {summary}")
        gui.add_html(legend_html(content))
        self._layer_handles = layers
        self.layers = {name: self._layer_toggle(name, handles) for name, handles in layers.items()}
        """Layer name (``Tree``, ``Path``, ...) -> its *Show* checkbox."""
        self.playback_seconds = float(playback_seconds)
        """Seconds *Play* takes from start to goal."""
        self._closed = threading.Event()
        self._thread: threading.Thread | None = None
        self.slider = None
        """The *Along the path* slider (None without a path)."""
        self.play = None
        """The *Play* checkbox (None without a path)."""
        if content.path_trace is not None and content.frames > 1:
            self.play = gui.add_checkbox("Play", initial_value=False)
            self.slider = gui.add_slider(
                "Along the path", min=0, max=content.frames - 1, step=1, initial_value=0
            )
            self.slider.on_update(lambda _: self._robot.show(self.slider.value))
            self._thread = threading.Thread(target=self._playback, daemon=True)
            self._thread.start()

    def _layer_toggle(self, name: str, handles: list):
        """A ticked checkbox that shows and hides ``handles``."""
        checkbox = self.server.gui.add_checkbox(f"Show: {name.lower()}", initial_value=True)

        def toggle(_) -> None:
            for handle in handles:
                handle.visible = checkbox.value

        checkbox.on_update(toggle)
        return checkbox

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return int(self.server.get_port())

    @property
    def url(self) -> str:
        """The page's address."""
        host = self.server.get_host()
        shown = "127.0.0.1" if host in ("0.0.0.0", "::") else host
        if ":" in shown:  # an IPv6 address
            shown = f"[{shown}]"
        return f"http://{shown}:{self.port}"

    @property
    def frame(self) -> int:
        """The playback frame the robot is shown at."""
        return self._robot.frame

    def show_frame(self, frame: int) -> None:
        """Move the robot (and the slider) to playback frame ``frame``."""
        if self.slider is None:
            self._robot.show(frame)
        else:
            self.slider.value = int(np.clip(frame, 0, self.content.frames - 1))

    def _playback(self) -> None:
        """While *Play* is ticked, step the slider once per frame period, looping."""
        while not self._closed.wait(self.playback_seconds / self.content.frames):
            if self.play.value:
                self.slider.value = (self.slider.value + 1) % self.content.frames

    def close(self) -> None:
        """Stop the playback and the server (idempotent)."""
        if self._closed.is_set():
            return
        self._closed.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        with contextlib.redirect_stdout(io.StringIO()):  # "(viser) Server stopped"
            self.server.stop()

    def __enter__(self) -> PlanViewer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def view_plan(
    problem: Problem,
    result: PlanResult | None = None,
    path: np.ndarray | None = None,
    tree: PlanTree | None = None,
    host: str = "127.0.0.1",
    port: int = 8080,
    frames: int = PLAYBACK_FRAMES,
    playback_seconds: float = PLAYBACK_SECONDS,
) -> PlanViewer:
    """Serve ``problem`` with a plan in the browser; returns at once (`PlanViewer`).

    Args:
        problem: The problem (any point robot, or an arm `temp_gym.viewer.arm_geometry`
            knows).
        result: A `temp_gym.planning.result.PlanResult`: its path and tree are shown, and its
            summary.
        path: States ``(K, dim)`` to show instead of ``result``'s path.
        tree: A tree to show instead of ``result``'s.
        host: The address to listen on (``127.0.0.1``: this machine only).
        port: The port; 0 picks a free one, a busy one the next free above it.
        frames: States the playback steps through along the path.
        playback_seconds: Seconds *Play* takes from start to goal.

    Raises:
        ImportError: viser is not installed (`INSTALL_HINT`).
        ValueError: a misshaped path or tree, a robot the viewer cannot draw, or an address
            this machine cannot listen on.
    """
    viser = require_viser()
    check_address(host, port)
    if not (isinstance(frames, int) and frames >= 2):
        raise ValueError(f"frames: expected an integer of at least 2, got {frames!r}")
    seconds = playback_seconds
    if isinstance(seconds, bool) or not isinstance(seconds, numbers.Real) or not 0 < seconds < 1e6:
        raise ValueError(f"playback_seconds: expected a positive number, got {seconds!r}")
    if result is not None:
        path = result.path if path is None else path
        tree = result.tree if tree is None else tree
    content = plan_content(problem, path=path, tree=tree, frames=frames)
    if result is not None:
        summary = result.summary()
    elif path is not None:
        summary = f"a path of {len(path)} states"
    else:
        summary = "the problem (no path)"
    with contextlib.redirect_stdout(io.StringIO()):  # viser's banner: the caller announces
        server = viser.ViserServer(host=host, port=port, verbose=False)
    try:
        return PlanViewer(server, content, summary, playback_seconds)
    except BaseException:
        server.stop()
        raise


def serve_plan(problem: Problem, announce=print, **kwargs) -> None:
    """`view_plan`, announced by ``announce`` (a line with the address), until Ctrl-C.

    ``kwargs`` are `view_plan`'s.
    """
    viewer = view_plan(problem, **kwargs)
    try:
        announce(f"viewer: {viewer.url} (Ctrl-C to stop)")
        threading.Event().wait()
    except KeyboardInterrupt:
        pass
    finally:
        viewer.close()
