"""Joint-space tables of the self-collision clearance of body pairs two joints apart.

**Why a table.** Bodies ``a`` and ``a + 2`` (a wrist's, say) may sit a few centimetres apart in
every pose, so their sphere models come within reach of each other everywhere and a sphere
test would walk both trees on every state. But the pose of body ``a + 2`` relative to body
``a`` depends only on the two joints between them (``q[a]`` and ``q[a + 1]``, 0-based), so
their distance is a function of two joint values, and of one once the other's worst value is
taken.

**What is stored.** Joint ``a``'s range is cut into cells of width ``h1``; entry ``i`` is a
certified lower bound, over every value of cell ``i`` and *every* value of joint ``a + 1``,
of the padded piece distance (the exact checker's geometry,
`temp_gym.worlds.collision.arm_self`) less the gap:

    bound[i] = min_k d(c_i, s_k) - R1 * h1 / 2 - R2 * h2 / 2

where ``c_i`` is the cell's center, ``s_k`` the centers of cells of width ``h2`` covering the
next joint's range, ``d`` fcl's distance less its tolerance and the gap, and ``R1``, ``R2``
bounds on how fast body ``a + 2`` moves relative to body ``a`` per unit of each joint
(`ArmModel.motion_radii`). Every pose of the cell is within that of a sampled one. A pose is
free for the pair when its entry exceeds the growth of the two bodies' spheres
(`temp_gym.worlds.collision.arm_fast_self`).

Only pairs whose bodies come within `TABLE_BELOW` of each other in some sample get a table;
the others are tested sphere against sphere.
"""

from __future__ import annotations

import numpy as np

from temp_gym.worlds.arm.model import ArmModel

CELL = 0.005
"""Width (rad, or m) of a table cell of the first joint between the pair."""
SWEEP_CELL = 0.02
"""Width of the cells that cover the second joint, whose worst value each entry takes."""
TABLE_BELOW = 0.05
"""A pair two joints apart whose bodies come this close (m) in the samples gets a table."""
_DECIMALS = 6


def _cells(lower: float, upper: float, width: float) -> tuple[np.ndarray, float]:
    """Centers of equal cells of at most ``width`` covering ``[lower, upper]``, their width."""
    count = max(1, int(np.ceil((upper - lower) / width)))
    step = (upper - lower) / count
    return lower + step * (np.arange(count) + 0.5), step


def compute_table(arm: ArmModel, pair: tuple[int, int], cell: float = CELL,
                  sweep_cell: float = SWEEP_CELL) -> dict:  # fmt: skip
    """The table of ``pair`` ``(a, a + 2)``: JSON-ready, see the module docstring."""
    from temp_gym.worlds.collision.arm_self import SELF_COLLISION_GAP, BodyHulls

    a, b = pair
    if b - a != 2:
        raise ValueError(f"pair: expected two bodies two joints apart, got {pair}")
    limits = arm.joint_limits()
    first, step = _cells(limits[0, a], limits[1, a], cell)
    second, sweep_step = _cells(limits[0, a + 1], limits[1, a + 1], sweep_cell)
    radii = arm.motion_radii()
    slack = radii[a, b] * step / 2 + radii[a + 1, b] * sweep_step / 2
    hulls = BodyHulls(arm, np.array([pair]))
    configs = np.zeros((len(second), arm.dim))
    configs[:, :] = np.clip(0.0, limits[0], limits[1])
    configs[:, a + 1] = second
    bounds = np.empty(len(first))
    for i, value in enumerate(first):
        configs[:, a] = value
        poses = arm.forward_kinematics(configs)
        closest = min(hulls.distance(pose, a, b) for pose in poses)
        bounds[i] = closest - SELF_COLLISION_GAP - slack
    scale = 10**_DECIMALS
    return {
        "bodies": [a, b],
        "joint": a,
        "lower": float(limits[0, a]),
        "cell": float(step),
        "sweep_cell": float(sweep_step),
        "bounds": (np.floor(bounds * scale) / scale).tolist(),
    }


def tabulated_pairs(acm: dict) -> list[tuple[int, int]]:
    """The enabled pairs two joints apart whose closest approach is below `TABLE_BELOW`."""
    return [
        tuple(entry["bodies"]) for entry in acm["pairs"]
        if entry["reason"] == "enabled" and entry["bodies"][1] - entry["bodies"][0] == 2
        and entry.get("closest_approach", 0.0) < TABLE_BELOW
    ]  # fmt: skip


def table_arrays(tables: list[dict]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tables as kernel arrays ``(pairs (P, 2), grid (P, 4), bounds (P, C))``.

    ``grid[p] = (joint, lower, cell width, cells)``; rows of ``bounds`` shorter than ``C`` are
    padded with ``-inf``.
    """
    pairs = np.array([t["bodies"] for t in tables], dtype=np.int64).reshape(-1, 2)
    grid = np.array([[t["joint"], t["lower"], t["cell"], len(t["bounds"])] for t in tables],
                    dtype=np.float64).reshape(-1, 4)  # fmt: skip
    width = max((len(t["bounds"]) for t in tables), default=1)
    bounds = np.full((len(tables), width), -np.inf)
    for p, table in enumerate(tables):
        bounds[p, : len(table["bounds"])] = table["bounds"]
    return pairs, grid, bounds


__all__ = ["CELL", "SWEEP_CELL", "TABLE_BELOW", "compute_table", "table_arrays",
           "tabulated_pairs"]  # fmt: skip
