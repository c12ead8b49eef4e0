"""Task difficulties: what every robot's task generator can be asked for.

What makes a task easy or challenging is the generator's to define (a detour ratio in point
worlds, `temp_gym.worlds.point_world`; a blocked straight motion for an arm,
`temp_gym.worlds.arm_world`); ``"any"`` takes whatever is drawn.
"""

from __future__ import annotations

DIFFICULTIES = ("any", "easy", "challenging")


def check_difficulty(difficulty: str) -> None:
    """Raise a `ValueError` naming ``difficulty`` unless it is one of `DIFFICULTIES`."""
    if difficulty not in DIFFICULTIES:
        raise ValueError(f"difficulty: expected one of {DIFFICULTIES}, got {difficulty!r}")
