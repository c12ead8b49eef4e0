"""What the point-world and iiwa renderers share: argument checks, titles and captions.

A picture of a planning episode says whether a solution exists. Before the first solution
the renderers draw the *path so far* (the root path of the newest node, what the policy sees)
in a light dashed style, and the title says "no solution yet"; only a solution is drawn bold
and titled with its cost.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

if TYPE_CHECKING:
    from temp_gym.problem import Problem

DPI = 100


SOLUTION_COLOR = "#e41a1c"
"""A solution: bold red."""
PATH_SO_FAR_COLOR = "#f28e2b"
"""The path to the newest node before a solution: orange, dashed."""
START_COLOR = "#1a9e3a"
"""The start: green."""
GOAL_COLOR = "#1f4fd6"
"""The goal: blue."""
TREE_COLOR = "#4a7ab5"
"""The tree's edges: blue-grey, thin."""
OBSTACLE_COLOR = "#c79461"
"""Boxes: tan (the point pictures draw them grey, under a light tree)."""
ROBOT_COLOR = "#8e44ad"
"""The robot moving along the path in the browser viewer: purple (a hue nothing else has)."""


FLOOR_COLOR = "#cccccc"
"""The floor slab under an arm's base: neutral grey."""


def floor_slabs(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Per 3D box: whether it is a floor slab (thin, its top at or below z = 0, the base's)."""
    lower, upper = np.asarray(lower), np.asarray(upper)
    if len(lower) == 0:
        return np.zeros(0, dtype=bool)
    return (upper[:, 2] <= 0.0) & (upper[:, 2] - lower[:, 2] < 0.2)


def rgb255(color: str) -> tuple[int, int, int]:
    """A ``"#rrggbb"`` colour as ``(r, g, b)`` in 0..255."""
    return tuple(int(color[k : k + 2], 16) for k in (1, 3, 5))


class TreeRenderer(Protocol):
    """What draws a planning episode (a robot spec's ``make_renderer`` builds one)."""

    def draw_tree(
        self,
        problem: Problem,
        positions: np.ndarray | None,
        parents: np.ndarray | None,
        num_nodes: int,
        path: np.ndarray | None = None,
        path_so_far: np.ndarray | None = None,
    ) -> np.ndarray:
        """An RGB picture of ``problem`` and its tree, with a solution or the path so far."""
        ...

    def close(self) -> None:
        """Release what the renderer holds (a simulator client); safe to call twice."""
        ...


def check_size(width: int, height: int) -> tuple[int, int]:
    """``(width, height)`` as ints, at least 16 pixels each."""
    if int(width) < 16 or int(height) < 16:
        raise ValueError(f"width, height: expected at least 16 pixels, got {width}x{height}")
    return int(width), int(height)


def check_path(problem: Problem, path: np.ndarray | None, name: str = "path") -> np.ndarray | None:
    """``path`` as a float ``(K, d)`` array with K >= 1, or None; ``name`` is the argument's."""
    if path is None:
        return None
    path = np.asarray(path, dtype=np.float64)
    if path.ndim != 2 or path.shape[1] != problem.dim or len(path) == 0:
        raise ValueError(f"{name}: expected shape (K, {problem.dim}) with K >= 1, got {path.shape}")
    return path


def check_paths(
    problem: Problem, path: np.ndarray | None, path_so_far: np.ndarray | None
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Both path arguments checked; a solution and a path so far exclude each other."""
    if path is not None and path_so_far is not None:
        raise ValueError("path, path_so_far: give the solution or the path so far, not both")
    return check_path(problem, path), check_path(problem, path_so_far, "path_so_far")


def path_cost(path: np.ndarray) -> float:
    """Length of a polyline ``(K, d)``."""
    return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))


def plan_title(
    problem: Problem, num_nodes: int, solution: np.ndarray | None, path_so_far_shown: str = ""
) -> str:
    """``"point2d: 1 node, no solution yet"`` or ``"point2d: 812 nodes, solution cost 21.37"``.

    ``path_so_far_shown`` names how a drawn path so far looks (e.g. ``"dashed"``); it is
    explained in the title of a picture without a solution.
    """
    nodes = f"{num_nodes} node{'' if num_nodes == 1 else 's'}"
    if solution is not None:
        return f"{problem.robot}: {nodes}, solution cost {path_cost(solution):.2f}"
    title = f"{problem.robot}: {nodes}, no solution yet"
    if path_so_far_shown:
        title += f" ({path_so_far_shown}: path to the newest node)"
    return title


def canvas_to_array(canvas: FigureCanvasAgg, width: int, height: int) -> np.ndarray:
    """The drawn canvas as RGB, cropped or white-padded to exactly ``(height, width)``."""
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    image = np.full((height, width, 3), 255, dtype=np.uint8)
    rows, cols = min(height, rgba.shape[0]), min(width, rgba.shape[1])
    image[:rows, :cols] = rgba[:rows, :cols, :3]
    return image


def caption(image: np.ndarray, text: str) -> np.ndarray:
    """``image`` (uint8 RGB) with ``text`` on a white band across its top; same shape."""
    height, width = image.shape[:2]
    figure = Figure(figsize=(width / DPI, height / DPI), dpi=DPI)
    canvas = FigureCanvasAgg(figure)
    figure.figimage(image, origin="upper")
    band = min(22, height // 4) / height
    figure.add_artist(
        Rectangle((0, 1 - band), 1, band, transform=figure.transFigure, color="white", alpha=0.85)
    )
    figure.text(0.5, 1 - band / 2, text, ha="center", va="center", fontsize=8)
    return canvas_to_array(canvas, width, height)


LegendEntry = tuple[str, str, str]
"""``(label, colour, style)``; style ``"box"`` (a filled square), ``"line"``, ``"dashed"``,
``"dot"`` or ``"star"``."""


def legend_handles(entries: list[LegendEntry]) -> list:
    """Matplotlib artists that stand for ``entries`` in a legend (`LegendEntry`)."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = []
    for label, color, style in entries:
        if style == "box":
            handles.append(Patch(facecolor=color, edgecolor="#555555", linewidth=0.4, label=label))
        elif style in ("dot", "star"):
            marker = "o" if style == "dot" else "*"
            handles.append(
                Line2D([], [], color=color, marker=marker, linestyle="none", label=label)
            )
        else:
            dashes = (0, (4, 2)) if style == "dashed" else "-"
            line = Line2D([], [], color=color, linewidth=2.0, linestyle=dashes, label=label)
            handles.append(line)
    return handles


def legend_band(image: np.ndarray, entries: list[LegendEntry]) -> np.ndarray:
    """``image`` (uint8 RGB) with a legend of ``entries`` on a white band across its bottom."""
    height, width = image.shape[:2]
    figure = Figure(figsize=(width / DPI, height / DPI), dpi=DPI)
    canvas = FigureCanvasAgg(figure)
    figure.figimage(image, origin="upper")
    rows = 1 if len(entries) <= 3 or width >= 120 * len(entries) else 2
    band = min(20 * rows + 4, height // 3) / height
    figure.add_artist(
        Rectangle((0, 0), 1, band, transform=figure.transFigure, color="white", alpha=0.85)
    )
    figure.legend(
        handles=legend_handles(entries),
        loc="center",
        bbox_to_anchor=(0.5, band / 2),
        ncol=-(-len(entries) // rows),
        fontsize=7,
        frameon=False,
        handlelength=1.4,
        columnspacing=1.0,
        borderaxespad=0.0,
    )
    return canvas_to_array(canvas, width, height)
