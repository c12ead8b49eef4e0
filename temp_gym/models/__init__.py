"""The learned planner: EISE, MPT, the TEMP policy and the attention read-out.

| module | what |
|---|---|
| `temp_gym.models.eise` | `EISE`: occupancy grid -> SEI tokens, and the reconstruction decoder |
| `temp_gym.models.mpt` | `MPT`: SEI, goal, start, path so far -> next sample; attention weights |
| `temp_gym.models.temp` | `TEMPModel` (both; sizes: `temp_gym.config.ModelConfig`), checkpoints |
| `temp_gym.models.loss` | `TEMPLoss`: λ·L_recons + η·L_semantic |
| `temp_gym.models.fast_mpt` | `FastMPT`: single-sample MPT forward pass in numba (CPU) |
| `temp_gym.models.fast_eise` | `FastEISE`: one grid's EISE encoding in numba (CPU) |
| `temp_gym.models.policy` | `TEMPPolicy`: a `SamplingPolicy` (env, `temp` planner) |
| `temp_gym.models.registry` | the shipped policies: `load_policy`, `shipped_checkpoint` |
| `temp_gym.models.checkpoint_settings` | the planner settings a checkpoint carries |
| `temp_gym.models.attention` | per-group attention (SEI, Goal, Start, HPD), Eq. 7-8 |
| `temp_gym.models.snapshot` | a checkpoint's inference snapshot (numpy), stored beside it |
| `temp_gym.models.array_backed` | `ArrayBacked`: what `FastMPT` and `FastEISE` build on |

Importing this package imports nothing heavy: each name is imported from its module when first
used, so a CPU policy on a stored snapshot runs without PyTorch.
"""

from importlib import import_module

_HOMES = {
    "EISE": "eise",
    "FastEISE": "fast_eise",
    "FastMPT": "fast_mpt",
    "GROUPS": "attention",
    "MPT": "mpt",
    "TEMPLoss": "loss",
    "TEMPModel": "temp",
    "TEMPPolicy": "policy",
    "group_attention": "attention",
    "load_checkpoint": "temp",
    "normalized_group_attention": "attention",
}

__all__ = sorted(_HOMES)


def __getattr__(name: str):
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'temp_gym.models' has no attribute {name!r}")
    return getattr(import_module(f"temp_gym.models.{home}"), name)


def __dir__() -> list[str]:
    return sorted([*globals(), *_HOMES])
