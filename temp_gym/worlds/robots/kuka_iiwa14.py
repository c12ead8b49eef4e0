"""``kuka_iiwa14``: the 7-DOF KUKA LBR iiwa 14 among furniture (`TEMP-7D-v0`).

An arm like any other: its robot description (``descriptions/kuka_iiwa14.yaml``: pybullet_data's
``kuka_iiwa/model.urdf``, its chain and planning defaults) and the derived data beside it
(covering spheres, allowed-collision matrix, pair tables; ``temp-robot build`` writes it).
Its checkers, generators and renderer are the generic arm's (`temp_gym.worlds.arm`).
"""

from __future__ import annotations

from pathlib import Path

from temp_gym.worlds.arm.spec import arm_spec

DESCRIPTION = Path(__file__).resolve().parent / "descriptions" / "kuka_iiwa14.yaml"
"""The iiwa's robot description."""

KUKA_IIWA14 = arm_spec(DESCRIPTION)
