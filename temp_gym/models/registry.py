"""The pretrained policies shipped inside the package, and `load_policy`.

Checkpoints live in ``temp_gym/checkpoints/{2d,3d,7d}.pt`` with a model card beside each
(``{2d,3d,7d}.md``: data, config, metrics). They are ordinary `TEMPModel` checkpoints, read with
``torch.load(..., weights_only=True)``.
"""

from __future__ import annotations

from pathlib import Path

from temp_gym.problem import ROBOTS

CHECKPOINT_DIR = Path(__file__).resolve().parent.parent / "checkpoints"
SHIPPED = {"TEMP-2D-v0": "2d", "TEMP-3D-v0": "3d", "TEMP-7D-v0": "7d"}
"""Env id -> checkpoint stem."""
_ROBOT_IDS = {"point2d": "TEMP-2D-v0", "point3d": "TEMP-3D-v0", "kuka_iiwa14": "TEMP-7D-v0"}


def shipped_checkpoint(name: str) -> Path:
    """Path of the shipped checkpoint for an env id (``TEMP-7D-v0``) or a robot (``point2d``).

    Raises:
        ValueError: for an unknown name.
        FileNotFoundError: when this build ships no checkpoint for it.
    """
    env_id = _ROBOT_IDS.get(name, name)
    if env_id not in SHIPPED:
        raise ValueError(
            f"policy: unknown name {name!r}; expected one of {list(SHIPPED) + list(ROBOTS)}"
        )
    path = CHECKPOINT_DIR / f"{SHIPPED[env_id]}.pt"
    if not path.is_file():
        raise FileNotFoundError(
            f"no pretrained policy for {env_id} ships with this build ({path} is missing); "
            "train one with trainers/bc.py and pass it as policy=TEMPPolicy.from_checkpoint(...)"
        )
    return path


def load_policy(name: str, noise_std: float | None = None, seed: int | None = None):
    """The shipped `TEMPPolicy` for an env id or robot, e.g. ``load_policy("TEMP-7D-v0")``.

    The checkpoint carries the planner settings it was shipped with (its model card says how
    they were chosen): the attention-phase budget n of Algorithm 1, which the ``temp``
    planner uses when ``attention_nodes`` is not given, and the output noise, used unless
    ``noise_std`` is given.
    """
    from temp_gym.models.policy import TEMPPolicy
    from temp_gym.models.temp import load_checkpoint

    env_id = _ROBOT_IDS.get(name, name)
    robot = {v: k for k, v in _ROBOT_IDS.items()}.get(env_id)
    model, checkpoint = load_checkpoint(shipped_checkpoint(name), robot=robot)
    planner = checkpoint.get("planner", {})
    if noise_std is None:
        noise_std = float(planner.get("noise_std", 0.0))
    return TEMPPolicy(
        model, noise_std=noise_std, seed=seed, attention_nodes=planner.get("attention_nodes")
    )
