"""YAML configs with ``key.sub=value`` command-line overrides.

    >>> config = load_config("configs/2d.yaml", ["train.epochs=3", "data.dir=/tmp/d"])
    >>> config["train"]["epochs"]
    3

Values in overrides are parsed as YAML scalars (``3`` is an int, ``1e-3`` a float, ``null``
None, ``[1, 2]`` a list). Overriding a key that the file does not have is an error, so a typo
never passes silently; ``+key.sub=value`` adds a new key on purpose.

The environment variable ``TEMP_GYM_OVERRIDES`` holds more overrides, separated by spaces, that
every config load applies after the command line's: the same command then runs at another size
(the tests run the README's commands as written, smoke-sized this way)::

    TEMP_GYM_OVERRIDES="train.max_epochs=1 eval.tasks=2" python trainers/bc.py
"""

from __future__ import annotations

import copy
import os
import shlex
from pathlib import Path
from typing import Any

import yaml

CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"


def _parse_value(text: str) -> Any:
    value = yaml.safe_load(text) if text.strip() else ""
    # YAML 1.1 reads "1e-3" as a string; numbers written that way are meant as floats.
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def apply_overrides(config: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """Return a copy of ``config`` with each ``key.sub=value`` override applied."""
    config = copy.deepcopy(config)
    for item in overrides:
        if "=" not in item:
            raise ValueError(f"override {item!r}: expected key.sub=value")
        key, text = item.split("=", 1)
        add = key.startswith("+")
        parts = key.lstrip("+").split(".")
        node = config
        for depth, part in enumerate(parts[:-1]):
            if part not in node or not isinstance(node[part], dict):
                if not add:
                    raise ValueError(
                        f"override {item!r}: no section {'.'.join(parts[: depth + 1])}"
                    )
                node[part] = {}
            node = node[part]
        if parts[-1] not in node and not add:
            raise ValueError(f"override {item!r}: unknown key {key} (use +{key}=... to add one)")
        node[parts[-1]] = _parse_value(text)
    return config


OVERRIDES_VARIABLE = "TEMP_GYM_OVERRIDES"
"""Environment variable with overrides applied after the caller's (see the module docstring)."""


def environment_overrides() -> list[str]:
    """The overrides in ``$TEMP_GYM_OVERRIDES`` (shell-style words; none when unset)."""
    return shlex.split(os.environ.get(OVERRIDES_VARIABLE, ""))


def load_config(path: str | Path, overrides: list[str] | None = None) -> dict[str, Any]:
    """Load a YAML config with `yaml.safe_load`; apply ``overrides``, then the environment's."""
    path = Path(path)
    if not path.exists() and (CONFIG_DIR / path.name).exists():
        path = CONFIG_DIR / path.name
    with open(path) as handle:
        config = yaml.safe_load(handle)
    if not isinstance(config, dict):
        raise ValueError(f"{path}: a config must be a YAML mapping")
    extra = environment_overrides()
    try:
        return apply_overrides(config, [*(overrides or []), *extra])
    except ValueError as error:
        if extra and any(item in str(error) for item in extra):
            raise ValueError(f"${OVERRIDES_VARIABLE}: {error}") from error
        raise
