"""The iiwa's allowed-collision matrix: which link pairs self-collision checks test.

Run ``python -m temp_gym.worlds.iiwa14.acm`` to regenerate ``acm.json`` next to this
file (deterministic from ``--seed``); the checkers only load that JSON (`enabled_pairs`).

The matrix is computed the way MoveIt's setup assistant computes its "disabled collisions",
on the exact checker's self-collision geometry (`temp_gym.worlds.collision.iiwa_self`: convex
hulls padded like pybullet's). Every pair of the 8 links (link_0 is the base) gets a reason:

* ``adjacent``: joined by a joint. Never checked: their hulls overlap at the joint by design.
* ``default``: in collision in the zero configuration (MoveIt's "default" pairs). Not checked,
  like MoveIt, but *reported*: the script prints a warning, and the file lists them.
* ``always``: in collision in at least `ALWAYS_FRACTION` of the samples. Not checked, reported.
* ``never``: no collision in ``samples`` uniform random configurations (MoveIt's sampling; its
  default is 10,000), nor in a local search from the pair's closest samples, and the closest
  approach found stays above `NEVER_CLEARANCE`. Not checked. The search and the clearance are
  ours: uniform samples rarely reach the folded corners of the joint box where far links meet,
  and a margin keeps a pair that merely came close checked.
* ``enabled``: everything else; these pairs are checked, by both checkers.

Each entry also records the number of colliding samples, the closest approach found and the
distance in the zero configuration, so the file shows why a pair is disabled.
"""

from __future__ import annotations

import argparse
import functools
import json
from pathlib import Path

import numpy as np

from temp_gym.worlds.iiwa14.convex_hulls import SELF_COLLISION_PADDING
from temp_gym.worlds.iiwa14.kinematics import NUM_LINKS, forward_kinematics, joint_limits

ACM_PATH = Path(__file__).with_name("acm.json")
REASONS = ("adjacent", "default", "always", "never", "enabled")
ALWAYS_FRACTION = 0.95
"""A pair in collision in at least this fraction of the samples is "always" (MoveIt's 95%)."""
NEVER_CLEARANCE = 0.01
"""A pair is "never" only if no sample or search step brings it closer than this (m)."""
DEFAULT_SAMPLES = 50_000
SEARCH_STARTS = 8
"""Closest samples of each pair from which the local search starts."""
SEARCH_STEPS = 300
"""Random-perturbation steps of each local search."""


def link_name(link: int) -> str:
    """The URDF name of link ``link`` (``link_0`` is the base)."""
    return f"link_{link}"


def _pair_distances(hulls, configs: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """``(N, P)`` padded-hull distances (<= the gap: collision) of ``pairs`` in ``configs``."""
    distances = np.empty((len(configs), len(pairs)))
    for k, poses in enumerate(forward_kinematics(configs)):
        for p, (a, b) in enumerate(pairs):
            distances[k, p] = hulls.distance(poses, a, b)
    return distances


def _local_search(hulls, start: np.ndarray, pair: tuple[int, int], limits: np.ndarray,
                  rng: np.random.Generator) -> float:  # fmt: skip
    """Closest approach of ``pair`` found by random-perturbation descent from ``start``."""
    a, b = pair
    config = start.copy()
    best = hulls.distance(forward_kinematics(config)[0], a, b)
    spread = 0.3
    for _ in range(SEARCH_STEPS):
        candidate = np.clip(config + rng.normal(0.0, spread, size=config.shape), *limits)
        distance = hulls.distance(forward_kinematics(candidate)[0], a, b)
        if distance < best:
            config, best = candidate, distance
        else:
            spread = max(0.97 * spread, 0.01)
    return best


def compute_acm(samples: int = DEFAULT_SAMPLES, seed: int = 0) -> dict:
    """Sample, search and classify every link pair; returns the JSON-ready matrix."""
    from temp_gym.worlds.collision.iiwa_self import SELF_COLLISION_GAP, LinkHulls

    rng = np.random.default_rng(seed)
    limits = joint_limits()
    candidates = np.array([(a, b) for a in range(NUM_LINKS) for b in range(a + 2, NUM_LINKS)])
    hulls = LinkHulls(candidates)
    configs = rng.uniform(limits[0], limits[1], size=(samples, limits.shape[1]))
    distances = _pair_distances(hulls, configs, candidates)
    zero = _pair_distances(hulls, np.zeros((1, limits.shape[1])), candidates)[0]
    entries = []
    for a in range(NUM_LINKS):
        for b in range(a + 1, NUM_LINKS):
            entry = {"links": [link_name(a), link_name(b)]}
            if b == a + 1:
                entries.append({**entry, "reason": "adjacent"})
                continue
            p = int(np.flatnonzero((candidates[:, 0] == a) & (candidates[:, 1] == b))[0])
            collisions = int(np.sum(distances[:, p] <= SELF_COLLISION_GAP))
            closest = float(distances[:, p].min())
            for k in np.argsort(distances[:, p], kind="stable")[:SEARCH_STARTS]:
                closest = min(closest, _local_search(hulls, configs[k], (a, b), limits, rng))
            if zero[p] <= SELF_COLLISION_GAP:
                reason = "default"
            elif collisions >= ALWAYS_FRACTION * samples:
                reason = "always"
            elif closest > SELF_COLLISION_GAP + NEVER_CLEARANCE:
                reason = "never"
            else:
                reason = "enabled"
            entries.append(
                {
                    **entry,
                    "reason": reason,
                    "colliding_samples": collisions,
                    "closest_approach": round(closest - SELF_COLLISION_GAP, 6),
                    "zero_configuration_distance": round(float(zero[p]) - SELF_COLLISION_GAP, 6),
                }
            )
    return {
        "robot": "kuka_iiwa14",
        "geometry": (
            "convex hulls of the URDF collision meshes, each grown by "
            f"{SELF_COLLISION_PADDING} m (pybullet's collision margin); distances are between "
            "the grown hulls, in metres"
        ),
        "padding": SELF_COLLISION_PADDING,
        "method": (
            f"MoveIt-style: {samples} uniform samples in the joint limits (seed {seed}), a local "
            f"search of {SEARCH_STEPS} steps from each pair's {SEARCH_STARTS} closest samples, "
            f"never_clearance={NEVER_CLEARANCE}, always_fraction={ALWAYS_FRACTION}"
        ),
        "pairs": entries,
        "reported": [e["links"] for e in entries if e["reason"] in ("default", "always")],
    }


@functools.cache
def load_acm(path: str | Path = ACM_PATH) -> dict:
    """The shipped matrix (cached); refuses one made with another padding."""
    data = json.loads(Path(path).read_text())
    if data.get("padding") != SELF_COLLISION_PADDING:
        raise ValueError(
            f"{path}: computed with padding {data.get('padding')}, the checkers use "
            f"{SELF_COLLISION_PADDING}; run python -m temp_gym.worlds.iiwa14.acm"
        )
    return data


def enabled_pairs(path: str | Path = ACM_PATH) -> np.ndarray:
    """``(P, 2)`` link indices of the pairs the checkers test, lower link first (a copy)."""
    pairs = [
        [int(name.removeprefix("link_")) for name in entry["links"]]
        for entry in load_acm(path)["pairs"]
        if entry["reason"] == "enabled"
    ]
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)


def main() -> None:
    """Regenerate ``acm.json`` and print the matrix and any reported pairs."""
    parser = argparse.ArgumentParser(description="Regenerate the iiwa's allowed-collision matrix.")
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=ACM_PATH)
    args = parser.parse_args()
    acm = compute_acm(args.samples, args.seed)
    args.out.write_text(json.dumps(acm, indent=1) + "\n")
    for entry in acm["pairs"]:
        details = {k: v for k, v in entry.items() if k not in ("links", "reason")}
        print(f"{entry['links'][0]} - {entry['links'][1]}: {entry['reason']:9s} {details}")
    for links in acm["reported"]:
        print(f"WARNING: {links[0]} - {links[1]} is not checked: in collision in the zero "
              "configuration or in nearly every sample (see the file)")  # fmt: skip
    if not acm["reported"]:
        print("No pair collides in the zero configuration, and none in nearly every sample.")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
