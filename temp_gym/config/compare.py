"""Which keys two nested configs (or settings) disagree on."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


def flatten(config: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` -> ``{"a.b": 1}``: nested mappings as dotted keys."""
    flat: dict[str, Any] = {}
    for key, value in config.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping) and value:
            flat.update(flatten(value, f"{name}."))
        else:
            flat[name] = value
    return flat


def differing_keys(
    stored: Mapping[str, Any], current: Mapping[str, Any], may_change: tuple[str, ...] = ()
) -> list[str]:
    """Dotted keys whose values differ between two nested mappings, sorted.

    Keys equal to, or under, an entry of ``may_change`` (``"logger"``, ``"train.threads"``)
    are ignored.
    """
    first, second = flatten(stored), flatten(current)

    def allowed(key: str) -> bool:
        return any(key == name or key.startswith(f"{name}.") for name in may_change)

    return sorted(
        key
        for key in first.keys() | second.keys()
        if first.get(key) != second.get(key) and not allowed(key)
    )
