"""pybullet's own verdict on arm collisions: the independent referee of our two checkers.

Nothing here shares collision code with the checkers: pybullet loads the arm's URDF itself
(`temp_gym.worlds.arm.bullet`), poses it with its own kinematics and collides its own shapes
(each collision mesh's convex hull with Bullet's 1 mm collision margin; obstacles as Bullet's
boxes, cylinders and spheres, posed by their quaternions, which pybullet orders ``[x, y, z, w]``
as a workspace does). Tests
and benchmarks use it to cross-check states and paths. It runs in its own DIRECT client, never
the global pybullet connection.

**Margins.** Bullet grows every convex mesh by its collision margin, and reports distances
between the grown shapes. A link and a box therefore count as touching here when pybullet's
distance is below ``-BULLET_MARGIN``: when the URDF's own shapes overlap (`obstacles_free`). Two
links count as touching as pybullet says, margins included, which is the geometry our
self-collision test uses (pieces padded by the same 1 mm).

Example:
    >>> with PybulletArm(arm, problem) as bullet:
    ...     bullet.states_free(states)  # bool[N]: no obstacle contact, no self-collision
    ...     bullet.self_collisions(states[0])  # [("lbr_iiwa_link_5", "lbr_iiwa_link_7")] or []
"""

from __future__ import annotations

import numpy as np

from temp_gym.problem.obstacles import BOX, CYLINDER
from temp_gym.worlds.arm.model import ArmModel

BULLET_MARGIN = 0.001
"""Bullet's collision margin of a convex mesh (m)."""


class PybulletArm:
    """An arm (base at the origin) and optionally a problem's obstacles, in a pybullet client.

    Args:
        arm: the arm (`temp_gym.worlds.arm.load_arm`).
        problem: a `temp_gym.Problem` or a `temp_gym.problem.Workspace`; ``None`` for the arm
            alone.
    """

    def __init__(self, arm: ArmModel, problem=None) -> None:
        import pybullet
        from pybullet_utils.bullet_client import BulletClient

        from temp_gym.worlds.arm.bullet import load_bullet_arm

        self.arm = arm
        self._client = BulletClient(connection_mode=pybullet.DIRECT)
        self._loaded = load_bullet_arm(self._client, arm)
        self._robot = self._loaded.body
        # Every pair of links on different bodies that no joint of the chain joins.
        links = self._loaded.links
        bodies = arm.chain.link_bodies
        with_shapes = [name for name in links if name in bodies and any(
            e.link == name for e in arm.chain.elements[bodies[name]])]  # fmt: skip
        self.self_pairs = tuple(
            (a, b) for i, a in enumerate(with_shapes) for b in with_shapes[i + 1 :]
            if abs(bodies[a] - bodies[b]) >= 2
        )  # fmt: skip
        self._obstacles = []
        if problem is not None:
            space = getattr(problem, "workspace", problem)  # a Problem's, or the Workspace
            self._obstacles = [self._add_obstacle(space, b) for b in range(space.num_obstacles)]

    def _add_obstacle(self, space, b: int) -> int:
        """Obstacle ``b`` of ``space`` as a pybullet body: a box, a cylinder or a sphere."""
        import pybullet

        kind, half = int(space.obstacle_kinds[b]), space.obstacle_half_extents[b]
        center = space.obstacle_centers[b]
        if kind == BOX:
            shape = self._client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
        elif kind == CYLINDER:
            shape = self._client.createCollisionShape(pybullet.GEOM_CYLINDER, radius=half[0],
                                                      height=2 * half[2])  # fmt: skip
        else:
            shape = self._client.createCollisionShape(pybullet.GEOM_SPHERE, radius=half[0])
        if space.unrotated[b]:
            return self._client.createMultiBody(0, shape, -1, center)
        return self._client.createMultiBody(0, shape, -1, center, space.obstacle_orientations[b])

    def close(self) -> None:
        """Disconnect the client."""
        self._client.disconnect()

    def __enter__(self) -> PybulletArm:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _pose(self, state: np.ndarray) -> None:
        from temp_gym.worlds.arm.bullet import set_configuration

        set_configuration(self._client, self._loaded, state)
        self._client.performCollisionDetection()

    def _touch(self, link_a: str, link_b: str) -> bool:
        links = self._loaded.links
        return bool(self._client.getClosestPoints(self._robot, self._robot, 0.0, links[link_a],
                                                  links[link_b]))  # fmt: skip

    def self_collisions(self, state: np.ndarray) -> list[tuple[str, str]]:
        """The link pairs (on bodies two or more joints apart) that touch in ``state``."""
        self._pose(state)
        return [(a, b) for a, b in self.self_pairs if self._touch(a, b)]

    def self_collision_free(self, states: np.ndarray) -> np.ndarray:
        """``bool[N]``: no two links touch, for each state of ``states`` (N x dim)."""
        states = np.asarray(states, dtype=np.float64).reshape(-1, self.arm.dim)
        free = np.empty(len(states), dtype=bool)
        for k, state in enumerate(states):
            self._pose(state)
            free[k] = not any(self._touch(a, b) for a, b in self.self_pairs)
        return free

    def obstacle_distances(self, state: np.ndarray, moving_only: bool = False) -> list[float]:
        """Pybullet's distance from the arm to each obstacle in ``state``, less its margin.

        Negative: the URDF's shapes overlap the obstacle; ``inf`` beyond 5 cm. With
        ``moving_only``, the links of the base (which stands on the floor) are left out.
        """
        self._pose(state)
        bodies = self.arm.chain.link_bodies
        base = {index for name, index in self._loaded.links.items() if bodies.get(name) == 0}
        out = []
        for obstacle in self._obstacles:
            points = self._client.getClosestPoints(self._robot, obstacle, 0.05)
            out.append(min((p[8] + BULLET_MARGIN for p in points
                            if not (moving_only and p[3] in base)), default=np.inf))  # fmt: skip
        return out

    def obstacles_free(self, states: np.ndarray) -> np.ndarray:
        """``bool[N]``: the arm's shapes touch no obstacle, for each state of ``states``."""
        states = np.asarray(states, dtype=np.float64).reshape(-1, self.arm.dim)
        free = np.empty(len(states), dtype=bool)
        for k, state in enumerate(states):
            self._pose(state)
            free[k] = not any(
                p[8] + BULLET_MARGIN < 0
                for obstacle in self._obstacles
                for p in self._client.getClosestPoints(self._robot, obstacle, 0.0)
            )
        return free

    def states_free(self, states: np.ndarray) -> np.ndarray:
        """``bool[N]``: neither an obstacle contact nor a self-collision."""
        return self.obstacles_free(states) & self.self_collision_free(states)


def densify(path: np.ndarray, max_step: float) -> np.ndarray:
    """The polyline ``path`` (K x d) with points added, ``max_step`` or less per joint apart.

    Sampled, not certified: a referee's view of a path.
    """
    path = np.asarray(path, dtype=np.float64)
    rows = [path[:1]]
    for a, b in zip(path[:-1], path[1:]):
        count = max(1, int(np.ceil(np.max(np.abs(b - a)) / max_step)))
        rows.append(a + (b - a) * (np.arange(1, count + 1) / count)[:, None])
    return np.concatenate(rows)


__all__ = ["BULLET_MARGIN", "PybulletArm", "densify"]
