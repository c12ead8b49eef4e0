"""Joint-space tables of the self-collision clearance of body pairs two joints apart.

**Why a table.** Bodies ``a`` and ``a + 2`` (a wrist's, say) may sit a few centimetres apart in
every pose, so their sphere models come within reach of each other everywhere and a sphere
test would walk both trees on every state. But the pose of body ``a + 2`` relative to body
``a`` depends only on the two joints between them (``q[a]`` and ``q[a + 1]``, 0-based), so
their distance is a function of those two joint values: a table over both.

**What is stored.** The two joints' ranges are cut into cells of widths ``h1`` and ``h2``,
about `CELLS` of them, shaped so that both joints contribute the same slack (below); entry
``(i, k)`` is a certified lower bound, over every pose of that cell, of the padded piece
distance (the exact checker's geometry, `temp_gym.worlds.collision.arm_self`) less the gap:

    bound[i, k] = min over the cell's sub-cells of d(sub-cell center)
                  - R1 * h1 / (2 r) - R2 * h2 / (2 r)

where each cell is cut into ``r x r`` sub-cells (`REFINE`), ``d`` is fcl's distance less its
tolerance and the gap, and ``R1``, ``R2`` bound how fast body ``a + 2`` moves relative to body
``a`` per unit of each joint (`ArmModel.motion_radii`): every pose of a sub-cell is within
that of its center. Sub-cells make the slack ``r`` times smaller at the same table size. A
pose is free for the pair when its entry exceeds the growth of the two bodies' spheres
(`temp_gym.worlds.collision.arm_fast_self`). So the fast checker refuses a pose for the pair
only within about ``(R1 * h1 + R2 * h2) / r`` (a millimetre or two) of the gap.

The bounds are stored rounded down to `UNIT` as little-endian int16, base64-encoded, so that a
table of tens of thousands of cells stays small in the JSON file.

Only pairs whose bodies come within `TABLE_BELOW` of each other in some sample get a table;
the others are tested sphere against sphere.
"""

from __future__ import annotations

import base64

import numpy as np

from temp_gym.worlds.arm.model import ArmModel

CELLS = 65_536
"""Cells per table (about)."""
REFINE = 3
"""Sub-cells per cell along each joint, whose worst distance the cell keeps."""
TABLE_BELOW = 0.05
"""A pair two joints apart whose bodies come this close (m) in the samples gets a table."""
UNIT = 1e-4
"""Resolution (m) of the stored bounds; each is rounded down to a multiple of it."""


def _cells(lower: float, upper: float, count: int) -> tuple[np.ndarray, float]:
    """Centers of ``count`` equal cells covering ``[lower, upper]``, and their width."""
    step = (upper - lower) / count
    return lower + step * (np.arange(count) + 0.5), step


def encode_bounds(bounds: np.ndarray) -> str:
    """``bounds`` (m) rounded down to `UNIT`, as base64 of little-endian int16.

    Values beyond the int16 range are clipped: a large bound is lowered (still a lower bound),
    a very negative one stays negative (the pose is refused either way).
    """
    units = np.clip(np.floor(np.asarray(bounds, dtype=np.float64) / UNIT), -32768, 32767)
    return base64.b64encode(units.astype("<i2").tobytes()).decode("ascii")


def decode_bounds(text: str, shape: tuple[int, int]) -> np.ndarray:
    """The bounds (m) `encode_bounds` stored, as float64 of ``shape``.

    Raises:
        ValueError: the text is not base64 of ``shape`` int16 values.
    """
    raw = base64.b64decode(text.encode("ascii"), validate=True)
    if len(raw) != 2 * shape[0] * shape[1]:
        raise ValueError(f"pair table: {len(raw)} bytes of bounds, expected {shape} int16")
    return np.frombuffer(raw, dtype="<i2").astype(np.float64).reshape(shape) * UNIT


def compute_table(arm: ArmModel, pair: tuple[int, int], cells: int = CELLS) -> dict:
    """The table of ``pair`` ``(a, a + 2)``: JSON-ready, see the module docstring."""
    from temp_gym.worlds.collision.arm_self import SELF_COLLISION_GAP, BodyHulls

    a, b = pair
    if b - a != 2:
        raise ValueError(f"pair: expected two bodies two joints apart, got {pair}")
    limits = arm.joint_limits()
    radii = arm.motion_radii()
    # The slack R1 L1 / (2 n1) + R2 L2 / (2 n2) with n1 n2 = cells is least when both terms
    # are equal.
    reach = np.maximum(radii[[a, a + 1], b] * (limits[1, [a, a + 1]] - limits[0, [a, a + 1]]),
                       1e-9)  # fmt: skip
    first_count = max(1, round(float(np.sqrt(cells * reach[0] / reach[1]))))
    second_count = max(1, cells // first_count)
    first, step = _cells(limits[0, a], limits[1, a], first_count * REFINE)
    second, second_step = _cells(limits[0, a + 1], limits[1, a + 1], second_count * REFINE)
    slack = radii[a, b] * step / 2 + radii[a + 1, b] * second_step / 2
    hulls = BodyHulls(arm, np.array([pair]))
    configs = np.zeros((len(second), arm.dim))
    configs[:, :] = np.clip(0.0, limits[0], limits[1])
    configs[:, a + 1] = second
    fine = np.empty((len(first), len(second)))
    for i, value in enumerate(first):
        configs[:, a] = value
        poses = arm.forward_kinematics(configs)
        fine[i] = [hulls.distance(pose, a, b) for pose in poses]
    # Each cell keeps the worst of its REFINE x REFINE sub-cells.
    bounds = fine.reshape(first_count, REFINE, second_count, REFINE).min(axis=(1, 3))
    bounds -= SELF_COLLISION_GAP + slack
    return {
        "bodies": [a, b],
        "joints": [a, a + 1],
        "lower": [float(limits[0, a]), float(limits[0, a + 1])],
        "cell": [float(step * REFINE), float(second_step * REFINE)],
        "shape": [first_count, second_count],
        "bounds": encode_bounds(bounds),
    }


def tabulated_pairs(acm: dict) -> list[tuple[int, int]]:
    """The enabled pairs two joints apart whose closest approach is below `TABLE_BELOW`."""
    return [
        tuple(entry["bodies"]) for entry in acm["pairs"]
        if entry["reason"] == "enabled" and entry["bodies"][1] - entry["bodies"][0] == 2
        and entry.get("closest_approach", 0.0) < TABLE_BELOW
    ]  # fmt: skip


def table_arrays(tables: list[dict]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tables as kernel arrays ``(pairs (P, 2), grid (P, 7), bounds (P, C))``.

    ``grid[p] = (first joint, its lower limit, its cell width, its cells, the second joint's
    lower limit, cell width, cells)``; row ``p`` of ``bounds`` is the table flattened (first
    joint major), padded with ``-inf``.
    """
    pairs = np.array([t["bodies"] for t in tables], dtype=np.int64).reshape(-1, 2)
    grid = np.array([[t["joints"][0], t["lower"][0], t["cell"][0], t["shape"][0],
                      t["lower"][1], t["cell"][1], t["shape"][1]] for t in tables],
                    dtype=np.float64).reshape(-1, 7)  # fmt: skip
    width = max((t["shape"][0] * t["shape"][1] for t in tables), default=1)
    bounds = np.full((len(tables), width), -np.inf)
    for p, table in enumerate(tables):
        flat = decode_bounds(table["bounds"], tuple(table["shape"])).reshape(-1)
        bounds[p, : len(flat)] = flat
    return pairs, grid, bounds


__all__ = ["CELLS", "REFINE", "TABLE_BELOW", "UNIT", "compute_table", "decode_bounds",
           "encode_bounds", "table_arrays", "tabulated_pairs"]  # fmt: skip
