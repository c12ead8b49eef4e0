"""pybullet's own verdict on iiwa collisions: the independent referee of our two checkers.

Nothing here shares code with the checkers: pybullet loads ``kuka_iiwa/model.urdf`` itself,
poses it with its own kinematics and collides its own shapes (each STL mesh's convex hull with
Bullet's 1 mm collision margin; boxes as boxes). Tests and benchmarks use it to cross-check
states and paths. It runs in its own DIRECT client, never the global pybullet connection.

Examples:
    >>> with PybulletIiwa(problem) as bullet:
    ...     bullet.states_free(states)  # bool[N]: no box contact, no self-collision
    ...     bullet.self_collisions(states[0])  # [("link_5", "link_7")] or []
"""

from __future__ import annotations

import numpy as np

from temp_gym.worlds.iiwa14.kinematics import NUM_JOINTS, NUM_LINKS, urdf_path

SELF_PAIRS = tuple((a, b) for a in range(NUM_LINKS) for b in range(a + 2, NUM_LINKS))
"""Every pair of links that no joint joins, the base included: what pybullet is asked about."""


class PybulletIiwa:
    """The iiwa (base at the origin) and optionally a problem's boxes, in a pybullet client.

    Args:
        problem: a `temp_gym.Problem` or a `temp_gym.problem.Workspace`; ``None`` for the arm
            alone.
    """

    def __init__(self, problem=None) -> None:
        import pybullet
        from pybullet_utils.bullet_client import BulletClient

        self._client = BulletClient(connection_mode=pybullet.DIRECT)
        self._robot = self._client.loadURDF(str(urdf_path()), [0, 0, 0], useFixedBase=True)
        self._boxes = []
        if problem is not None:
            space = getattr(problem, "workspace", problem)  # a Problem's, or the Workspace
            for center, half in zip(space.obstacle_centers, space.obstacle_half_extents):
                shape = self._client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
                self._boxes.append(self._client.createMultiBody(0, shape, -1, center))

    def close(self) -> None:
        """Disconnect the client."""
        self._client.disconnect()

    def __enter__(self) -> PybulletIiwa:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _pose(self, state: np.ndarray) -> None:
        for joint in range(NUM_JOINTS):
            self._client.resetJointState(self._robot, joint, float(state[joint]))
        self._client.performCollisionDetection()

    def _touch(self, link_a: int, link_b: int) -> bool:
        # pybullet numbers the base -1 and link j as j - 1.
        return bool(
            self._client.getClosestPoints(self._robot, self._robot, 0.0, link_a - 1, link_b - 1)
        )

    def distance(self, state: np.ndarray, link_a: int, link_b: int, within: float = 0.05) -> float:
        """The two links' distance in ``state`` by pybullet (negative: penetration).

        ``inf`` when they are farther apart than ``within``.
        """
        self._pose(state)
        points = self._client.getClosestPoints(
            self._robot, self._robot, within, link_a - 1, link_b - 1
        )
        return min((point[8] for point in points), default=np.inf)

    def self_collisions(self, state: np.ndarray) -> list[tuple[str, str]]:
        """The link pairs (two or more links apart) that touch in ``state``, by link name."""
        self._pose(state)
        return [(f"link_{a}", f"link_{b}") for a, b in SELF_PAIRS if self._touch(a, b)]

    def self_collision_free(self, states: np.ndarray) -> np.ndarray:
        """``bool[N]``: no two links touch, for each state of ``states`` (N x 7)."""
        free = np.empty(len(states), dtype=bool)
        for k, state in enumerate(np.asarray(states, dtype=np.float64).reshape(-1, NUM_JOINTS)):
            self._pose(state)
            free[k] = not any(self._touch(a, b) for a, b in SELF_PAIRS)
        return free

    def boxes_free(self, states: np.ndarray) -> np.ndarray:
        """``bool[N]``: the arm touches no box, for each state of ``states`` (N x 7)."""
        free = np.empty(len(states), dtype=bool)
        for k, state in enumerate(np.asarray(states, dtype=np.float64).reshape(-1, NUM_JOINTS)):
            self._pose(state)
            free[k] = not any(
                self._client.getClosestPoints(self._robot, box, 0.0) for box in self._boxes
            )
        return free

    def states_free(self, states: np.ndarray) -> np.ndarray:
        """``bool[N]``: neither a box contact nor a self-collision."""
        return self.boxes_free(states) & self.self_collision_free(states)


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


__all__ = ["SELF_PAIRS", "PybulletIiwa", "densify"]
