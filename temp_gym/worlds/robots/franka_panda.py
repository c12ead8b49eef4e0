"""``franka_panda``: the 7-DOF Franka Emika Panda among furniture (`TEMP-Panda-v0`).

An arm like any other: its robot description (``descriptions/franka_panda.yaml``:
pybullet_data's ``franka_panda/panda.urdf`` with MotionBenchMaker's geometry, the fingers
held 6.5 cm out) and the derived data beside it (``temp-robot build`` writes it).
"""

from __future__ import annotations

from pathlib import Path

from temp_gym.worlds.arm.spec import arm_spec

DESCRIPTION = Path(__file__).resolve().parent / "descriptions" / "franka_panda.yaml"
"""The Panda's robot description."""

FRANKA_PANDA = arm_spec(DESCRIPTION)
