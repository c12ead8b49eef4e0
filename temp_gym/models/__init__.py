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
| `temp_gym.models.attention` | per-group attention (SEI, Goal, Start, HPD), Eq. 7-8 |
"""

from temp_gym.models.attention import GROUPS, group_attention, normalized_group_attention
from temp_gym.models.eise import EISE
from temp_gym.models.fast_eise import FastEISE
from temp_gym.models.fast_mpt import FastMPT
from temp_gym.models.loss import TEMPLoss
from temp_gym.models.mpt import MPT
from temp_gym.models.policy import TEMPPolicy
from temp_gym.models.temp import TEMPModel, load_checkpoint

__all__ = [
    "EISE",
    "FastEISE",
    "FastMPT",
    "GROUPS",
    "MPT",
    "TEMPLoss",
    "TEMPModel",
    "TEMPPolicy",
    "group_attention",
    "load_checkpoint",
    "normalized_group_attention",
]
