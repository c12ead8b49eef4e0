"""A body's covering spheres arranged in a tree of bounding spheres, for the compiled kernels.

The leaves are the spheres `temp_gym.worlds.arm.spheres.fit_piece` fits (a few hundred per
body); every inner node's sphere holds all the leaf spheres below it. The kernels walk the tree
from the root and skip a subtree whose sphere misses the obstacle, so a body far from every
box costs one test and a body touching one costs about a dozen.

**Layout.** Nodes are stored depth first (a node, then its first subtree, then its second),
each with ``skip``: the index of the node after its subtree. A walk is then a loop with no
stack: on a miss jump to ``skip``, on a hit step to the next node. A leaf node holds up to
`BUCKET` leaf spheres, tested in turn. Bodies' trees are concatenated; ``body_start[j]`` is
body ``j``'s root, ``body_start[j + 1]`` the end of its tree.

Building is deterministic: split the spheres at the median of their centers along the widest
axis of their bounding box, until at most `BUCKET` remain.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numba
import numpy as np

BUCKET = 4
"""Leaf spheres per leaf node."""


@dataclass(frozen=True)
class SphereTrees:
    """Every body's sphere tree, as arrays (module docstring).

    Attributes:
        node_centers: ``(N, 3)`` node sphere centers in their body's frame.
        node_radii: ``(N,)`` node sphere radii.
        node_skip: ``(N,)`` index after each node's subtree.
        node_first: ``(N,)`` a leaf node's first leaf sphere (inner nodes: -1).
        node_count: ``(N,)`` a leaf node's number of leaf spheres (inner nodes: 0).
        body_start: ``(B + 1,)`` each body's root; the last entry is ``N``.
        centers: ``(K, 3)`` leaf sphere centers.
        radii: ``(K,)`` leaf sphere radii.
        sphere_body: ``(K,)`` each leaf sphere's body.
        inner_centers: ``(I, 3)`` balls inside the bodies' pieces (a box that touches one is
            in the body), body by body.
        inner_radii: ``(I,)`` their radii.
        inner_start: ``(B + 1,)`` each body's first inner ball.
        capsules: ``(B, 7)`` per body a capsule holding all its leaf spheres: segment ends
            ``[0:3]``, ``[3:6]`` in the body's frame, radius ``[6]`` (a body without spheres:
            radius -1). Links are long and thin, so two close bodies' capsules are often apart
            where their root spheres are not.
    """

    node_centers: np.ndarray
    node_radii: np.ndarray
    node_skip: np.ndarray
    node_first: np.ndarray
    node_count: np.ndarray
    body_start: np.ndarray
    centers: np.ndarray
    radii: np.ndarray
    sphere_body: np.ndarray
    inner_centers: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    inner_radii: np.ndarray = field(default_factory=lambda: np.zeros(0))
    inner_start: np.ndarray | None = None
    capsules: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))

    def grown(self, margin: float) -> SphereTrees:
        """A copy with every covering sphere, leaf and node, grown by ``margin``.

        The inner balls are not: they must stay inside the pieces.
        """
        capsules = self.capsules.copy()
        capsules[capsules[:, 6] >= 0, 6] += margin
        return dataclasses.replace(self, node_radii=self.node_radii + margin,
                                   radii=self.radii + margin, capsules=capsules)  # fmt: skip

    def arrays(self) -> tuple[np.ndarray, ...]:
        """The arrays in the order the kernels take them."""
        inner_start = (np.zeros(len(self.body_start), dtype=np.int64)
                       if self.inner_start is None else self.inner_start)  # fmt: skip
        return (self.node_centers, self.node_radii, self.node_skip, self.node_first,
                self.node_count, self.body_start, self.centers, self.radii,
                np.ascontiguousarray(self.inner_centers, dtype=np.float64).reshape(-1, 3),
                np.ascontiguousarray(self.inner_radii, dtype=np.float64),
                np.ascontiguousarray(inner_start, dtype=np.int64),
                np.ascontiguousarray(self.capsules, dtype=np.float64).reshape(-1, 7))  # fmt: skip


def enclosing_capsule(centers: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """``(7,)``: a capsule holding the given spheres, along their centers' principal axis.

    The segment spans the centers' projections on that axis; the radius is the farthest
    sphere's reach from the segment, so every sphere is inside.
    """
    mean = centers.mean(axis=0)
    axis = np.linalg.svd(centers - mean, full_matrices=False)[2][0] if len(centers) > 1 else (
        np.array([0.0, 0.0, 1.0]))  # fmt: skip
    along = (centers - mean) @ axis
    ends = mean + np.outer([along.min(), along.max()], axis)
    t = np.clip(along - along.min(), 0.0, along.max() - along.min())
    nearest = ends[0] + np.outer(t, axis)
    radius = float(np.max(np.linalg.norm(centers - nearest, axis=1) + radii))
    return np.concatenate([ends[0], ends[1], [radius]])


def enclosing_sphere(centers: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, float]:
    """A small sphere holding the given spheres (at least one).

    A few Badoiu-Clarkson steps, then the radius that holds every sphere from that center (any
    center is valid; this one keeps it small). Compiled: a body's tree asks this of every node.
    """
    centers = np.ascontiguousarray(centers, dtype=np.float64).reshape(-1, 3)
    radii = np.ascontiguousarray(radii, dtype=np.float64).reshape(-1)
    if len(radii) == 0 or len(radii) != len(centers):
        raise ValueError(f"spheres: expected matching non-empty centers and radii, got "
                         f"{len(centers)} centers and {len(radii)} radii")  # fmt: skip
    center, radius = _enclosing_sphere(centers, radii)
    return center, float(radius)


@numba.njit(cache=True, nogil=True)
def _enclosing_sphere(centers, radii):
    """`enclosing_sphere`'s steps, in numpy's order of operations (the same bits as numpy)."""
    count = centers.shape[0]
    center = np.empty(3)
    for k in range(3):
        low, high = centers[0, k] - radii[0], centers[0, k] + radii[0]
        for i in range(1, count):
            low = min(low, centers[i, k] - radii[i])
            high = max(high, centers[i, k] + radii[i])
        center[k] = (low + high) / 2
    for step in range(1, 60):
        far, farthest = 0, -np.inf
        for i in range(count):
            reach = _distance(centers, i, center) + radii[i]
            if reach > farthest:  # the first of equals, as argmax
                far, farthest = i, reach
        length = _distance(centers, far, center)
        for k in range(3):
            point = centers[far, k]
            if length > 0:
                point = point + (centers[far, k] - center[k]) / length * radii[far]
            center[k] = center[k] + (point - center[k]) / (step + 1)
    radius = -np.inf
    for i in range(count):
        radius = max(radius, _distance(centers, i, center) + radii[i])
    return center, radius


@numba.njit(cache=True, nogil=True, inline="always")
def _distance(centers, i, center):
    dx = centers[i, 0] - center[0]
    dy = centers[i, 1] - center[1]
    dz = centers[i, 2] - center[2]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


def _build(centers, radii, index, nodes) -> None:
    """Append the subtree over spheres ``index`` to ``nodes`` (depth first)."""
    center, radius = enclosing_sphere(centers[index], radii[index])
    nodes.append([center, radius, 0, -1, 0, index])
    if len(index) <= BUCKET:
        return
    spread = centers[index].max(axis=0) - centers[index].min(axis=0)
    axis = int(np.argmax(spread))
    order = index[np.argsort(centers[index, axis], kind="stable")]
    half = len(order) // 2
    _build(centers, radii, order[:half], nodes)
    _build(centers, radii, order[half:], nodes)


def build_trees(body_spheres: list[tuple[np.ndarray, np.ndarray]]) -> SphereTrees:
    """The trees of each body's ``(centers, radii)`` (an empty body gets an empty tree)."""
    node_centers, node_radii, node_skip, node_first, node_count = [], [], [], [], []
    body_start, centers, radii, sphere_body = [0], [], [], []
    capsules = np.tile([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0], (len(body_spheres), 1))
    for body, (body_centers, body_radii) in enumerate(body_spheres):
        body_centers = np.asarray(body_centers, dtype=np.float64).reshape(-1, 3)
        body_radii = np.asarray(body_radii, dtype=np.float64).reshape(-1)
        offset = len(node_centers)
        if len(body_radii):
            capsules[body] = enclosing_capsule(body_centers, body_radii)
            nodes: list = []
            _build(body_centers, body_radii, np.arange(len(body_radii)), nodes)
            # Skip pointers: a subtree ends where the next node at its depth or above begins.
            ends = [0] * len(nodes)
            depths = _depths(nodes)
            stack: list[int] = []
            for k in range(len(nodes)):
                while stack and depths[stack[-1]] >= depths[k]:
                    ends[stack.pop()] = k
                stack.append(k)
            for k in stack:
                ends[k] = len(nodes)
            for k, (center, radius, _, _, _, index) in enumerate(nodes):
                node_centers.append(center)
                node_radii.append(radius)
                node_skip.append(offset + ends[k])
                leaf = ends[k] == k + 1
                if leaf:
                    node_first.append(len(centers))
                    node_count.append(len(index))
                    for i in index:
                        centers.append(body_centers[i])
                        radii.append(body_radii[i])
                        sphere_body.append(body)
                else:
                    node_first.append(-1)
                    node_count.append(0)
        body_start.append(len(node_centers))
    return SphereTrees(
        np.array(node_centers, dtype=np.float64).reshape(-1, 3),
        np.array(node_radii, dtype=np.float64),
        np.array(node_skip, dtype=np.int64),
        np.array(node_first, dtype=np.int64),
        np.array(node_count, dtype=np.int64),
        np.array(body_start, dtype=np.int64),
        np.array(centers, dtype=np.float64).reshape(-1, 3),
        np.array(radii, dtype=np.float64),
        np.array(sphere_body, dtype=np.int64),
        capsules=capsules,
    )


def _depths(nodes: list) -> list[int]:
    """Each node's depth, from the depth-first order.

    A node with more than `BUCKET` spheres is followed by its two subtrees.
    """
    depths = [0] * len(nodes)
    stack: list[list[int]] = []  # [depth, children still to come]
    for k, node in enumerate(nodes):
        depth = stack[-1][0] + 1 if stack else 0
        depths[k] = depth
        if stack:
            stack[-1][1] -= 1
        while stack and stack[-1][1] == 0:
            stack.pop()
        if len(node[5]) > BUCKET:
            stack.append([depth, 2])
    return depths


__all__ = ["BUCKET", "SphereTrees", "build_trees", "enclosing_capsule", "enclosing_sphere"]
