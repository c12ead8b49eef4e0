"""An arm's allowed-collision matrix: which body pairs self-collision checks test.

Computed by ``temp-robot build`` (`temp_gym.worlds.arm.build`) the way MoveIt's setup
assistant computes its "disabled collisions", on the exact checker's self-collision geometry
(convex pieces padded like pybullet's, `temp_gym.worlds.collision.arm_self`). Every pair of
bodies gets a reason:

* ``adjacent``: joined by a joint. Never checked: their pieces meet at the joint by design.
* ``srdf``: every link pair across the two bodies is disabled by the description's SRDF
  (MoveIt's own matrix, when one is given). Not checked.
* ``always``: in collision in at least `ALWAYS_FRACTION` of the samples (pieces that overlap by
  design). Not checked, like MoveIt, but *reported* in the file and by the build.
* ``never``: no collision in the uniform samples, nor in a local search from the pair's
  closest samples, and the closest approach found stays above `NEVER_CLEARANCE`. Not checked.
  The search and the clearance are ours: uniform samples rarely reach the folded corners of
  the joint box where far bodies meet, and a margin keeps a pair that merely came close
  checked.
* ``enabled``: everything else; these pairs are checked, by both checkers. Unlike MoveIt's
  assistant, a pair in collision in the zero configuration stays checked unless it is
  ``always`` so: the zero configuration is then simply not free (the Panda's wrist folds its
  hand onto link 5 there, and can anywhere near it).
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from pathlib import Path

import numpy as np

from temp_gym.worlds.arm.model import ArmModel

ALWAYS_FRACTION = 0.95
"""A pair in collision in at least this fraction of the samples is "always" (MoveIt's 95%)."""
NEVER_CLEARANCE = 0.01
"""A pair is "never" only if no sample or search step brings it closer than this (m)."""
DEFAULT_SAMPLES = 20_000
SEARCH_STARTS = 8
SEARCH_STEPS = 300


def srdf_disabled(path: Path) -> set[frozenset[str]]:
    """The link pairs an SRDF's ``<disable_collisions>`` lists."""
    try:
        root = ElementTree.fromstring(path.read_bytes())
    except ElementTree.ParseError as error:
        raise ValueError(f"{path.name}: not valid XML ({error})") from None
    return {
        frozenset((entry.get("link1"), entry.get("link2")))
        for entry in root.findall("disable_collisions")
    }


def _distances(hulls, arm: ArmModel, configs: np.ndarray, pairs: np.ndarray,
               beyond: float) -> np.ndarray:  # fmt: skip
    """``(N, P)`` padded piece distances of the pairs at each configuration.

    Pairs whose bounding spheres are more than ``beyond`` apart get that lower bound instead
    (no fcl call).
    """
    poses = arm.forward_kinematics(configs)
    out = hulls.sphere_gaps(poses)
    for k, p in zip(*np.nonzero(out <= beyond)):
        a, b = pairs[p]
        out[k, p] = hulls.distance(poses[k], a, b)
    return out


def _local_search(hulls, arm: ArmModel, start: np.ndarray, pair: tuple[int, int],
                  limits: np.ndarray, rng: np.random.Generator) -> float:  # fmt: skip
    """Closest approach of ``pair`` found by random-perturbation descent from ``start``."""
    a, b = pair
    config = start.copy()
    best = hulls.distance(arm.forward_kinematics(config)[0], a, b)
    spread = 0.3
    for _ in range(SEARCH_STEPS):
        candidate = np.clip(config + rng.normal(0.0, spread, size=config.shape), *limits)
        distance = hulls.distance(arm.forward_kinematics(candidate)[0], a, b)
        if distance < best:
            config, best = candidate, distance
        else:
            spread = max(0.97 * spread, 0.01)
    return best


def compute_acm(arm: ArmModel, samples: int = DEFAULT_SAMPLES, seed: int = 0) -> dict:
    """Classify every body pair (module docstring); returns the JSON-ready matrix."""
    from temp_gym.worlds.collision.arm_self import SELF_COLLISION_GAP, BodyHulls

    rng = np.random.default_rng(seed)
    limits = arm.joint_limits()
    bodies = arm.num_bodies
    disabled = srdf_disabled(arm.description.srdf) if arm.description.srdf else set()
    links_of = [[] for _ in range(bodies)]
    for link, body in arm.chain.link_bodies.items():
        links_of[body].append(link)
    with_geometry = [
        {e.link for e in arm.chain.elements[body]} for body in range(bodies)
    ]  # fmt: skip
    candidates = np.array([(a, b) for a in range(bodies) for b in range(a + 2, bodies)
                           if arm.geometry[a].pieces and arm.geometry[b].pieces],
                          dtype=np.int64).reshape(-1, 2)  # fmt: skip
    hulls = BodyHulls(arm, candidates)
    configs = rng.uniform(limits[0], limits[1], size=(samples, arm.dim))
    beyond = SELF_COLLISION_GAP + NEVER_CLEARANCE
    distances = _distances(hulls, arm, configs, candidates, beyond)
    zero = _distances(hulls, arm, np.clip(np.zeros((1, arm.dim)), *limits), candidates,
                      np.inf)[0]  # fmt: skip
    entries = []
    for a in range(bodies):
        for b in range(a + 1, bodies):
            entry = {"bodies": [a, b], "links": [arm.body_names[a], arm.body_names[b]]}
            if b == a + 1:
                entries.append({**entry, "reason": "adjacent"})
                continue
            if not (arm.geometry[a].pieces and arm.geometry[b].pieces):
                entries.append({**entry, "reason": "never", "note": "a body without geometry"})
                continue
            link_pairs = [frozenset((x, y)) for x in with_geometry[a] for y in with_geometry[b]]
            if disabled and link_pairs and all(pair in disabled for pair in link_pairs):
                entries.append({**entry, "reason": "srdf"})
                continue
            p = int(np.flatnonzero((candidates[:, 0] == a) & (candidates[:, 1] == b))[0])
            collisions = int(np.sum(distances[:, p] <= SELF_COLLISION_GAP))
            closest = float(distances[:, p].min())
            if closest <= beyond:
                for k in np.argsort(distances[:, p], kind="stable")[:SEARCH_STARTS]:
                    closest = min(closest, _local_search(hulls, arm, configs[k], (a, b),
                                                         limits, rng))  # fmt: skip
            if collisions >= ALWAYS_FRACTION * samples:
                reason = "always"
            elif closest > beyond:
                reason = "never"
            else:
                reason = "enabled"
            entries.append({
                **entry,
                "reason": reason,
                "colliding_samples": collisions,
                "closest_approach": round(closest - SELF_COLLISION_GAP, 6),
                "zero_configuration_distance": round(float(zero[p]) - SELF_COLLISION_GAP, 6),
            })  # fmt: skip
    return {
        "method": (
            f"MoveIt-style: {samples} uniform samples in the joint limits (seed {seed}), a local "
            f"search of {SEARCH_STEPS} steps from each pair's {SEARCH_STARTS} closest samples, "
            f"never_clearance={NEVER_CLEARANCE}, always_fraction={ALWAYS_FRACTION}; geometry: "
            f"convex pieces grown by {SELF_COLLISION_GAP / 2} m; distances in metres"
        ),
        "pairs": entries,
        "reported": [e["links"] for e in entries if e["reason"] == "always"],
    }


__all__ = ["ALWAYS_FRACTION", "NEVER_CLEARANCE", "compute_acm", "srdf_disabled"]
