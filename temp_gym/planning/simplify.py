"""Path simplification: a shorter certified path with the same ends, as MoveIt and VAMP give.

A sampling-based planner's first path zig-zags: it follows the tree's random edges. MoveIt
runs OMPL's path simplifier after every plan, and VAMP ships a simplifier beside its
planners; `simplify_path` (or ``plan(problem, simplify=True)``) does the same here, for any
planner's path. Three passes, each of which only ever replaces a part of the path by one
straight motion that the problem's fast checker certifies free:

1. **vertex reduction**: from each kept waypoint, the farthest later waypoint that a free
   straight motion reaches. Tried farthest first, then halfway back, and so on down to the
   next waypoint but one, so a path of K waypoints costs O(K log K) motion checks, not K².
2. **shortcuts**: ``steps`` times, two random points of the path (uniform in its length, on
   different segments) are joined by a straight motion when it is free and shorter; a point
   lies on a segment of the path, so the pieces it cuts off stay free. The pass stops early
   after ``patience`` tries in a row that shortened nothing.
3. **vertex reduction again**, when a shortcut was kept: the waypoints a shortcut adds often
   line up with their neighbours, and a jump past them is shorter still.

The fast checker is conservative: what it calls free, the exact checker calls free too, but for
rare disagreements. The simplified path is therefore certified by the exact checker at the end
(`temp_gym.worlds.checkers.certify_path`), like every path a planner returns; should it be
refused, the path given is returned instead, after it is certified in its turn.

The passes never lengthen the path and keep its first and last state exactly. All randomness is
``seed``'s generator: the same path and seed give the same result.
"""

from __future__ import annotations

import numpy as np

from temp_gym.planning.settings import count, seed_value
from temp_gym.problem import Problem

DEFAULT_STEPS = 200
"""Shortcut attempts at most."""
DEFAULT_PATIENCE = 50
"""Shortcut attempts in a row without a gain that end the pass early."""
_GAIN = 1e-9
"""A shortcut must shorten the path by more than this share of its length."""


def path_length(path: np.ndarray) -> float:
    """The length of a polyline ``(K, d)``: what planners report as a path's cost."""
    return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))


def _checked_path(problem: Problem, path: object) -> np.ndarray:
    """``path`` as a float64 ``(K, d)`` copy with K >= 2 and every number finite."""
    if not isinstance(problem, Problem):
        raise ValueError(f"problem: expected a Problem, got {type(problem).__name__}")
    if path is None:
        raise ValueError("path: expected a (K, d) array of numbers, got None")
    try:
        raw = np.asarray(path)
        array = np.array(raw, dtype=np.float64) if raw.dtype.kind not in "bc" else None
    except (TypeError, ValueError):
        raise ValueError("path: expected a (K, d) array of numbers") from None
    if array is None:  # numpy would read True as 1 and drop imaginary parts
        raise ValueError(f"path: expected a (K, d) array of real numbers, got {raw.dtype}")
    if array.ndim != 2 or array.shape[1] != problem.dim or len(array) < 2:
        raise ValueError(f"path: expected shape (K >= 2, {problem.dim}), got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError("path: every number must be finite")
    return array


def reduce_vertices(path: np.ndarray, motion_free) -> np.ndarray:
    """The waypoints kept when each one jumps to the farthest later one it reaches freely.

    ``motion_free(a, b)`` certifies the straight motion ``a -> b``. From waypoint ``i`` the
    candidates are tried farthest first, then halfway back, and so on down to ``i + 2``: the
    first free one is kept (a jump to ``i + 1`` is the path's own segment).
    """
    last = len(path) - 1
    kept = [0]
    i = 0
    while i < last:
        reach = i + 1
        candidate = last
        while candidate > i + 1:
            if motion_free(path[i], path[candidate]):
                reach = candidate
                break
            candidate = i + 1 + (candidate - i - 1) // 2
        kept.append(reach)
        i = reach
    return path[kept]


def shortcut(
    path: np.ndarray,
    motion_free,
    rng: np.random.Generator,
    steps: int = DEFAULT_STEPS,
    patience: int = DEFAULT_PATIENCE,
) -> np.ndarray:
    """Random shortcuts between points of the path, each kept when free and shorter.

    Each attempt draws two arc lengths uniformly; the points there, on segments ``a < b``,
    are joined by a straight motion and replace the path between them when ``motion_free``
    certifies it and it is shorter. Attempts whose points share a segment shorten nothing.
    """
    path = np.array(path, dtype=np.float64)
    fruitless = 0
    for _ in range(steps):
        if fruitless >= patience or len(path) < 3:
            break
        fruitless += 1
        lengths = np.linalg.norm(np.diff(path, axis=0), axis=1)
        ends = np.cumsum(lengths)
        total = float(ends[-1])
        if total <= 0.0:
            break
        u, v = np.sort(rng.uniform(0.0, total, size=2))
        a = min(int(np.searchsorted(ends, u, side="right")), len(lengths) - 1)
        b = min(int(np.searchsorted(ends, v, side="right")), len(lengths) - 1)
        if a == b:
            continue
        p = _point_on(path, a, lengths[a], u - (ends[a] - lengths[a]))
        q = _point_on(path, b, lengths[b], v - (ends[b] - lengths[b]))
        along = (ends[a] - u) + float(np.sum(lengths[a + 1 : b])) + (v - (ends[b] - lengths[b]))
        if along - float(np.linalg.norm(q - p)) <= _GAIN * total:
            continue
        if not motion_free(p, q):
            continue
        middle = [point for point, corner in ((p, path[a]), (q, path[b + 1]))
                  if not np.array_equal(point, corner)]  # fmt: skip
        path = np.vstack([path[: a + 1], *middle, path[b + 1 :]])
        fruitless = 0
    return path


def _point_on(path: np.ndarray, segment: int, length: float, offset: float) -> np.ndarray:
    """The point ``offset`` along segment ``segment`` (of ``length``) of ``path``."""
    if length <= 0.0:
        return path[segment].copy()
    share = min(max(offset / length, 0.0), 1.0)
    return path[segment] + share * (path[segment + 1] - path[segment])


def simplify_path(
    problem: Problem,
    path: object,
    seed: int = 0,
    steps: int = DEFAULT_STEPS,
    patience: int = DEFAULT_PATIENCE,
) -> np.ndarray:
    """A shorter path from ``path``'s first state to its last, certified by the exact checker.

    Vertex reduction, random shortcuts and vertex reduction again (the module docstring says
    how), each motion checked by the problem's fast checker; the result is certified by the
    exact checker. It is never longer than ``path`` and keeps its two ends exactly.

    Args:
        problem: The problem the path belongs to (its workspace and robot).
        path: ``(K, d)`` states, K >= 2.
        seed: Seed of the shortcuts' generator.
        steps: Shortcut attempts at most (0: vertex reduction alone).
        patience: Attempts in a row without a gain that end the shortcuts early.

    Returns:
        A new ``(K', d)`` array, 2 <= K' <= K + 2 * steps.

    Raises:
        ValueError: A malformed argument; or ``path`` itself is refused by the exact checker
            (a state or motion in collision, or outside the bounds), so that no valid
            path between its ends is known. (A refused path whose shortening the exact
            checker certifies gives that shortening.)
    """
    from temp_gym.worlds.checkers import certify_path

    given = _checked_path(problem, path)
    shorter = shorter_path(problem, given, seed, steps, patience)
    if shorter is not None:
        return shorter
    if certify_path(problem, given):
        return given
    raise ValueError(
        "path: the exact checker finds it in collision or outside the bounds, so it "
        "cannot be simplified"
    )


def shorter_path(
    problem: Problem,
    path: object,
    seed: int = 0,
    steps: int = DEFAULT_STEPS,
    patience: int = DEFAULT_PATIENCE,
) -> np.ndarray | None:
    """`simplify_path`'s shorter path, or None when it finds none the exact checker certifies.

    For a path already certified (a planner's result): None means keep it, and ``path`` is
    not certified again.
    """
    from temp_gym.worlds.checkers import certify_path, make_checker

    given = _checked_path(problem, path)
    seed = seed_value(seed)
    steps = count(steps, "steps", minimum=0)
    patience = count(patience, "patience")
    checker = make_checker(problem)

    def motion_free(a: np.ndarray, b: np.ndarray) -> bool:
        return bool(checker.edge_free(a, b))

    reduced = reduce_vertices(given, motion_free)
    shorter = shortcut(reduced, motion_free, np.random.default_rng(seed), steps, patience)
    if shorter.shape != reduced.shape or not np.array_equal(shorter, reduced):
        shorter = reduce_vertices(shorter, motion_free)
    if path_length(shorter) < path_length(given) and certify_path(problem, shorter):
        return shorter
    return None


__all__ = [
    "DEFAULT_PATIENCE",
    "DEFAULT_STEPS",
    "path_length",
    "reduce_vertices",
    "shortcut",
    "shorter_path",
    "simplify_path",
]
