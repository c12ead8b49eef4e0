"""The obstacles the arm checkers test: boxes (optionally oriented), cylinders and spheres.

`ArmObstacles` is what `ArmSphereChecker`, `ArmExactChecker` and `base_collides` read: one row
per obstacle, in the world frame (the arm's base at the origin, z up), with the layout of a
`temp_gym.problem.Workspace` (`temp_gym.problem.obstacles`): centers, half extents in the
obstacle's own frame, kinds, rotation matrices, and the tight world bounding boxes.

**Axis-aligned boxes keep their arithmetic.** A box with the identity orientation is stored
as the checkers always read boxes, from its world corners: center ``(lower + upper) / 2`` and
half sides ``(upper - lower) / 2``. Worlds of such boxes are checked with the same numbers,
hence the same verdicts, as before obstacles had kinds; `axis_aligned` marks them, and the
fast checker keeps a separate, unchanged path for them.

Example:
    >>> obstacles = arm_obstacles(problem.workspace)  # any kinds
    >>> obstacles = ArmObstacles.from_corners(lower, upper)  # axis-aligned boxes
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from temp_gym.problem import Workspace
from temp_gym.problem.obstacles import BOX, KIND_NAMES
from temp_gym.worlds.collision.arm_inputs import as_boxes


@dataclass(frozen=True, eq=False)
class ArmObstacles:
    """Obstacles of every kind as read-only arrays, one row per obstacle (module docstring)."""

    centers: np.ndarray
    """``(M, 3)`` centers."""
    half_extents: np.ndarray
    """``(M, 3)`` half sides in the obstacle's own frame (cylinder ``(r, r, l / 2)``)."""
    kinds: np.ndarray
    """``int8 (M,)``: `temp_gym.problem.obstacles` ``BOX``, ``CYLINDER`` or ``SPHERE``."""
    rotations: np.ndarray
    """``(M, 3, 3)``: columns are the obstacle's axes in the world."""
    lower: np.ndarray
    """``(M, 3)`` lower corners of the tight world bounding boxes."""
    upper: np.ndarray
    """``(M, 3)`` upper corners of the tight world bounding boxes."""
    axis_aligned: np.ndarray
    """``bool (M,)``: boxes with exactly the identity orientation."""

    @classmethod
    def from_corners(cls, box_lower: np.ndarray, box_upper: np.ndarray) -> ArmObstacles:
        """Axis-aligned boxes ``[box_lower[i], box_upper[i]]`` (``(M, 3)`` each, validated)."""
        lower, upper = as_boxes(box_lower, box_upper)
        return cls.boxes((lower + upper) / 2, (upper - lower) / 2, lower, upper)

    @classmethod
    def boxes(
        cls,
        centers: np.ndarray,
        half_extents: np.ndarray,
        lower: np.ndarray | None = None,
        upper: np.ndarray | None = None,
    ) -> ArmObstacles:
        """Axis-aligned boxes by ``(M, 3)`` centers and half sides, used as given.

        ``lower`` and ``upper`` default to ``centers -/+ half_extents``.
        """
        centers = np.ascontiguousarray(centers, dtype=np.float64).reshape(-1, 3)
        half_extents = np.ascontiguousarray(half_extents, dtype=np.float64).reshape(-1, 3)
        count = len(centers)
        return cls._frozen(
            centers,
            half_extents,
            np.zeros(count, dtype=np.int8),
            np.broadcast_to(np.eye(3), (count, 3, 3)).copy(),
            centers - half_extents if lower is None else lower,
            centers + half_extents if upper is None else upper,
            np.ones(count, dtype=bool),
        )

    @classmethod
    def _frozen(cls, *arrays: np.ndarray) -> ArmObstacles:
        copies = [np.array(array) for array in arrays]
        for array in copies:
            array.setflags(write=False)
        return cls(*copies)

    def __len__(self) -> int:
        return len(self.centers)

    @property
    def all_axis_aligned(self) -> bool:
        """Whether every obstacle is an axis-aligned box."""
        return bool(np.all(self.axis_aligned))

    def summary(self) -> str:
        """How many of each kind, for checker descriptions: ``"5 boxes"``, ``"2 boxes, 1 sphere"``.

        A world of boxes only reads ``"M boxes"``, as it always has.
        """
        counts = np.bincount(self.kinds, minlength=len(KIND_NAMES))
        if counts[BOX] == len(self):
            return f"{len(self)} boxes"
        return ", ".join(f"{count} {name}{'es' if name == 'box' else 's'}" if count != 1
                         else f"1 {name}" for name, count in zip(KIND_NAMES, counts)
                         if count)  # fmt: skip

    def name(self, index: int) -> str:
        """The obstacle as messages name it: ``"box 0"``, ``"cylinder 3"``, ``"sphere 5"``."""
        return f"{KIND_NAMES[int(self.kinds[index])]} {int(index)}"


def arm_obstacles(workspace: Workspace) -> ArmObstacles:
    """The obstacles of an arm's ``workspace``, every kind, in the checkers' layout.

    Its axis-aligned boxes are read from their world corners (module docstring), so a
    workspace of such boxes gives exactly `ArmObstacles.from_corners` of its corners.
    """
    if workspace.workspace_dim != 3:
        raise ValueError(f"workspace: expected an arm's 3D workspace, got {workspace.robot}'s")
    lower, upper = workspace.obstacle_lower, workspace.obstacle_upper
    aligned = (workspace.obstacle_kinds == BOX) & workspace.unrotated
    centers = np.where(aligned[:, None], (lower + upper) / 2, workspace.obstacle_centers)
    halves = np.where(aligned[:, None], (upper - lower) / 2, workspace.obstacle_half_extents)
    return ArmObstacles._frozen(centers.reshape(-1, 3), halves.reshape(-1, 3),
                                workspace.obstacle_kinds, workspace.obstacle_rotations,
                                lower.reshape(-1, 3), upper.reshape(-1, 3), aligned)  # fmt: skip


def resolve_obstacles(
    box_lower: np.ndarray | None, box_upper: np.ndarray | None, obstacles: ArmObstacles | None
) -> ArmObstacles:
    """A checker's obstacles from its arguments: box corners, or `ArmObstacles`, not both."""
    if obstacles is None:
        if box_lower is None or box_upper is None:
            raise ValueError("box_lower, box_upper: expected both, or obstacles=ArmObstacles")
        return ArmObstacles.from_corners(box_lower, box_upper)
    if box_lower is not None or box_upper is not None:
        raise ValueError("obstacles: give box_lower and box_upper or obstacles, not both")
    if not isinstance(obstacles, ArmObstacles):
        raise ValueError(
            f"obstacles: expected ArmObstacles (arm_obstacles(workspace)), got "
            f"{type(obstacles).__name__}"
        )
    return obstacles


__all__ = ["ArmObstacles", "arm_obstacles", "resolve_obstacles"]
