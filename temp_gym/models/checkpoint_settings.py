"""The settings a policy checkpoint carries, and the ``PATH@key=value`` entries that replace them.

A shipped checkpoint stores, under ``planner``, what its policy was tuned with
(``trainers/ship.py`` writes it): the policy's own construction settings (`POLICY_SETTINGS`:
output noise, proposals per MPT call, path window) and the ``temp`` planner's settings a
policy may carry (`temp_gym.planning.temp_settings.DECLARED`). `policy_keywords` turns that
entry into `TEMPPolicy`'s keywords, so that every tool that loads the checkpoint plans with
them unless told otherwise.

`CHECKPOINT_SETTINGS` lists both with their types, derived from `TEMPSettings`: a setting
added to the planner is a setting a checkpoint may carry, with no list to update here.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from temp_gym.jobs import brief
from temp_gym.planning.temp_settings import DECLARED, TEMPSettings

POLICY_SETTINGS: dict[str, type] = {"noise_std": float, "horizon": int, "path_window": int}
"""The policy's own construction settings a checkpoint carries, with their types."""


def _plain_type(kind: Any) -> type:
    """``int`` of ``int | None``; the one non-None type of a field's annotation."""
    if typing.get_origin(kind) in (typing.Union, types.UnionType):
        (kind,) = [option for option in typing.get_args(kind) if option is not type(None)]
    return kind


CHECKPOINT_SETTINGS: dict[str, type] = {
    **POLICY_SETTINGS,
    **{name: _plain_type(typing.get_type_hints(TEMPSettings)[name]) for name in DECLARED},
}
"""Every setting a checkpoint's ``planner`` entry may carry, and a checkpoint entry may give
after its ``@`` (`checkpoint_entry`), with its type."""


CARRIED_KEYS = (*CHECKPOINT_SETTINGS, "chosen_by")
"""The keys a checkpoint's ``planner`` entry may hold: the settings, and how they were chosen."""


def check_carried(carried: object) -> None:
    """Refuse a checkpoint's ``planner`` entry that is no mapping of known, valid settings.

    Raises:
        ValueError: one line naming the entry (``planner``) or its key (``planner.<key>``).
    """
    from temp_gym.planning.temp_settings import check

    if not isinstance(carried, Mapping) or not all(isinstance(key, str) for key in carried):
        raise ValueError(f"planner: expected a mapping of settings, got {brief(carried)}")
    unknown = sorted(set(carried) - set(CARRIED_KEYS))
    if unknown:
        raise ValueError(f"planner: unknown settings {unknown}; expected some of "
                         f"{list(CARRIED_KEYS)}")  # fmt: skip
    for name, value in carried.items():
        if value is None or name == "chosen_by":
            continue
        if name in DECLARED:
            check(name, value, f"planner.{name}")
            continue
        kind = POLICY_SETTINGS[name]
        numeric = isinstance(value, (int, float)) and not isinstance(value, bool)
        if not numeric or (kind is int and not isinstance(value, int)) or not value >= 0:
            raise ValueError(f"planner.{name}: expected a non-negative {kind.__name__}, "
                             f"got {brief(value)}")  # fmt: skip


def policy_keywords(carried: Mapping[str, Any]) -> dict[str, Any]:
    """`TEMPPolicy`'s keywords from a checkpoint's ``planner`` entry (absent keys: None).

    ``noise_std`` defaults to 0 (no noise); every other absent key to None, the planner's or
    the model's default.
    """
    keywords = {name: carried.get(name) for name in CHECKPOINT_SETTINGS}
    if keywords["noise_std"] is None:
        keywords["noise_std"] = 0.0  # TEMPPolicy checks a given one
    return keywords


def checkpoint_entry(
    entry: str, flag: str = "--checkpoints"
) -> tuple[Path, dict[str, float | int]]:
    """``PATH[@key=value,...]`` -> the checkpoint and the settings that replace its own.

    The keys are `CHECKPOINT_SETTINGS`'. The benchmarks that compare checkpoints with the
    shipped policy take such entries, each with the settings `trainers/tune_planner.py` chose
    for a run not yet shipped.

    Raises:
        ValueError: an item that is not ``key=value`` with a known key, or a value of the
            wrong type, naming ``flag`` and the entry.
    """
    path, _, spec = entry.partition("@")
    settings: dict[str, float | int] = {}
    for item in filter(None, spec.split(",")):
        key, sep, value = item.partition("=")
        if not sep or key not in CHECKPOINT_SETTINGS:
            raise ValueError(f"{flag} {entry}: expected key=value with a key of "
                             f"{sorted(CHECKPOINT_SETTINGS)}, got {brief(item)}")  # fmt: skip
        kind = CHECKPOINT_SETTINGS[key]
        try:
            settings[key] = kind(value)
        except ValueError:
            raise ValueError(f"{flag} {entry}: {key} must be a {kind.__name__}, "
                             f"got {brief(value)}") from None  # fmt: skip
    return Path(path), settings


__all__ = ["CHECKPOINT_SETTINGS", "POLICY_SETTINGS", "checkpoint_entry", "policy_keywords"]
