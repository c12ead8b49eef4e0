"""Joint-space tables of the self-collision clearance of link pairs two joints apart.

Run ``python -m temp_gym.worlds.iiwa14.pair_tables`` to regenerate ``pair_tables.json``
next to this file (after the allowed-collision matrix, `temp_gym.worlds.iiwa14.acm`); the fast
checker only loads the JSON (`load_pair_tables`).

**Why a table.** Links ``a`` and ``a + 2`` (for the iiwa, the enabled pair link_5 - link_7) sit
a few centimetres apart in every pose, so sphere models of their hulls overlap everywhere
unless the spheres are tiny and many. But the pose of link ``a + 2`` relative to link ``a``
depends only on the two joints between them (``q[a]`` and ``q[a + 1]``, 0-based), so their
distance is a function of two angles, and one of one angle once the other is minimized over.

**What is stored.** The range of joint ``a`` (0-based ``q[a]``) is cut into cells of width
``h1``; entry ``i`` is a certified lower bound, over every angle of cell ``i`` and *every*
angle of the next joint, on the padded hull distance of the pair (the exact checker's
geometry, `temp_gym.worlds.collision.iiwa_self`), i.e. the hull distance less the padding gap:

    bound[i] = min_k d(c_i, s_k) - R1 * h1 / 2 - R2 * h2 / 2

where ``c_i`` is the cell's center, ``s_k`` the centers of cells of width ``h2`` covering the
next joint's range, ``d`` fcl's hull distance less its tolerance and the gap, and ``R1``,
``R2`` the largest distance of link ``a + 2``'s mesh from each joint's axis
(`temp_gym.worlds.iiwa14.kinematics.motion_radii`; hull points are convex combinations of mesh
vertices). Turning a joint by ``x`` moves link ``a + 2`` relative to link ``a`` by at most
``R |x|``, so every pose of the cell is within that of a sampled one. Entries are rounded down.
A pose is free for the pair when its entry exceeds the growth of the two links' spheres
(`temp_gym.worlds.collision.iiwa_fast_self`).
"""

from __future__ import annotations

import argparse
import functools
import json
from pathlib import Path

import numpy as np

from temp_gym.worlds.iiwa14.acm import enabled_pairs
from temp_gym.worlds.iiwa14.convex_hulls import SELF_COLLISION_PADDING
from temp_gym.worlds.iiwa14.kinematics import forward_kinematics, joint_limits, motion_radii

TABLES_PATH = Path(__file__).with_name("pair_tables.json")
CELL = 0.002
"""Width (rad) of a table cell of the first joint between the pair."""
SWEEP_CELL = 0.01
"""Width (rad) of the cells that cover the second joint, whose worst angle each entry takes."""
_DECIMALS = 6


def tabulated_pairs() -> np.ndarray:
    """``(P, 2)`` the enabled pairs two joints apart, which get a table (a fresh array)."""
    pairs = enabled_pairs()
    return pairs[pairs[:, 1] - pairs[:, 0] == 2]


def _cells(lower: float, upper: float, width: float) -> tuple[np.ndarray, float]:
    """Centers of equal cells of at most ``width`` covering ``[lower, upper]``, and their width."""
    count = int(np.ceil((upper - lower) / width))
    step = (upper - lower) / count
    return lower + step * (np.arange(count) + 0.5), step


def compute_table(pair: tuple[int, int], cell: float = CELL, sweep_cell: float = SWEEP_CELL):
    """The table of ``pair`` ``(a, a + 2)``: JSON-ready, see the module docstring."""
    from temp_gym.worlds.collision.iiwa_self import SELF_COLLISION_GAP, LinkHulls
    from temp_gym.worlds.iiwa14.sphere_fit import load_mesh_radii

    a, b = pair
    if b - a != 2:
        raise ValueError(f"pair: expected two links two joints apart, got {pair}")
    limits = joint_limits()
    first, step = _cells(limits[0, a], limits[1, a], cell)
    second, sweep_step = _cells(limits[0, a + 1], limits[1, a + 1], sweep_cell)
    radii = motion_radii(load_mesh_radii())
    slack = radii[a, b] * step / 2 + radii[a + 1, b] * sweep_step / 2
    hulls = LinkHulls(np.array([pair]))
    configs = np.zeros((len(second), limits.shape[1]))
    configs[:, a + 1] = second
    bounds = np.empty(len(first))
    for i, angle in enumerate(first):
        configs[:, a] = angle
        poses = forward_kinematics(configs)
        closest = min(hulls.distance(pose, a, b) for pose in poses)
        bounds[i] = closest - SELF_COLLISION_GAP - slack
    scale = 10**_DECIMALS
    return {
        "links": [a, b],
        "joint": a,
        "lower": float(limits[0, a]),
        "cell": float(step),
        "sweep_cell": float(sweep_step),
        "bounds": (np.floor(bounds * scale) / scale).tolist(),
    }


def compute_tables() -> dict:
    """Every tabulated pair's table, JSON-ready."""
    return {
        "robot": "kuka_iiwa14",
        "padding": SELF_COLLISION_PADDING,
        "meaning": (
            "bounds[i]: lower bound (m) on the padded hull distance of the pair over cell i of "
            "joint q[joint] (0-based) and every angle of q[joint + 1]"
        ),
        "tables": [compute_table(tuple(int(x) for x in pair)) for pair in tabulated_pairs()],
    }


@functools.cache
def _load(path: Path) -> dict:
    data = json.loads(path.read_text())
    expected = tabulated_pairs().tolist()
    found = [table["links"] for table in data["tables"]]
    if data.get("padding") != SELF_COLLISION_PADDING or found != expected:
        raise ValueError(
            f"{path}: made for padding {data.get('padding')} and pairs {found}, the checkers "
            f"use {SELF_COLLISION_PADDING} and {expected}; run "
            "python -m temp_gym.worlds.iiwa14.pair_tables"
        )
    return data


def load_pair_tables(path: str | Path = TABLES_PATH) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tables as kernel arrays ``(pairs (P, 2), grid (P, 4), bounds (P, C))`` (copies).

    ``grid[p] = (joint, lower, cell width, cells)``; rows of ``bounds`` shorter than ``C`` are
    padded with ``-inf``.
    """
    tables = _load(Path(path))["tables"]
    pairs = np.array([t["links"] for t in tables], dtype=np.int64).reshape(-1, 2)
    grid = np.array(
        [[t["joint"], t["lower"], t["cell"], len(t["bounds"])] for t in tables]
    ).reshape(-1, 4)
    width = max((len(t["bounds"]) for t in tables), default=1)
    bounds = np.full((len(tables), width), -np.inf)
    for p, table in enumerate(tables):
        bounds[p, : len(table["bounds"])] = table["bounds"]
    return pairs, grid, bounds


def main() -> None:
    """Regenerate ``pair_tables.json`` and print each table's range."""
    parser = argparse.ArgumentParser(description="Regenerate the iiwa's joint-space pair tables.")
    parser.add_argument("--out", type=Path, default=TABLES_PATH)
    args = parser.parse_args()
    data = compute_tables()
    args.out.write_text(json.dumps(data) + "\n")
    for table in data["tables"]:
        bounds = np.array(table["bounds"])
        a, b = table["links"]
        print(
            f"link_{a} - link_{b}: {len(bounds)} cells of q[{table['joint']}], clearance "
            f"{bounds.min():.4f} to {bounds.max():.4f} m, {np.mean(bounds <= 0):.1%} of cells "
            "in collision"
        )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
