"""YAML configs with ``key.sub=value`` command-line overrides.

    >>> from temp_gym.config import load_config
    >>> config = load_config("configs/2d.yaml", ["train.max_epochs=3", "data.dir=/tmp/d"])
    >>> config["train"]["max_epochs"], config["data"]["dir"]
    (3, '/tmp/d')

Values in overrides are parsed as YAML scalars (``3`` is an int, ``1e-3`` a float, ``null``
None, ``[1, 2]`` a list). Overriding a key that the file does not have is an error, so a typo
never passes silently; ``+key.sub=value`` adds a new key on purpose.

Scripts parse their command line with `parse_args`: overrides may stand anywhere, also
after an option flag that takes several values (``--noise-std 0 0.03 train.seed=1``).

The environment variable ``TEMP_GYM_OVERRIDES`` holds more overrides, separated by spaces, that
every config load applies after the command line's: the same command then runs at another size
(the tests run the README's commands as written, smoke-sized this way)::

    TEMP_GYM_OVERRIDES="train.max_epochs=1 eval.tasks=2" python trainers/bc.py
"""

from __future__ import annotations

import argparse
import copy
import os
import re
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from temp_gym.jobs import JobError


class ConfigError(JobError, ValueError):
    """A config file or override that cannot be used; the message names it."""


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


OVERRIDE = re.compile(r"^\+?[A-Za-z_][\w-]*(\.[\w-]+)*=")
"""A ``key.sub=value`` (or ``+key.sub=value``) command-line override."""


def script_parser(description: str) -> argparse.ArgumentParser:
    """An `argparse.ArgumentParser` whose help shows every flag's default."""
    return argparse.ArgumentParser(
        description=description, formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )


def parse_args(
    parser: argparse.ArgumentParser, argv: Sequence[str] | None = None
) -> argparse.Namespace:
    """Parse ``argv``, taking every ``key.sub=value`` token as an override, wherever it is.

    The overrides end up in ``args.overrides`` (the parser may declare that positional for
    its help text). Tokens starting with ``-`` are never overrides, so ``--flag=value``
    stays a flag.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    overrides = [token for token in argv if OVERRIDE.match(token)]
    args = parser.parse_args([token for token in argv if not OVERRIDE.match(token)])
    args.overrides = list(getattr(args, "overrides", None) or []) + overrides
    return args


def apply_overrides(config: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """Return a copy of ``config`` with each ``key.sub=value`` override applied."""
    config = copy.deepcopy(config)
    for item in overrides:
        if "=" not in item:
            raise ConfigError(f"override {item!r}: expected key.sub=value")
        key, text = item.split("=", 1)
        add = key.startswith("+")
        parts = key.lstrip("+").split(".")
        node = config
        for depth, part in enumerate(parts[:-1]):
            if part not in node or not isinstance(node[part], dict):
                if not add:
                    raise ConfigError(
                        f"override {item!r}: no section {'.'.join(parts[: depth + 1])}"
                    )
                node[part] = {}
            node = node[part]
        if parts[-1] not in node and not add:
            raise ConfigError(f"override {item!r}: unknown key {key} (use +{key}=... to add one)")
        node[parts[-1]] = _parse_value(text)
    return config


def flatten(config: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` -> ``{"a.b": 1}``: nested mappings as dotted keys."""
    flat: dict[str, Any] = {}
    for key, value in config.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            flat.update(flatten(value, f"{name}."))
        else:
            flat[name] = value
    return flat


def differing_keys(
    stored: dict[str, Any], current: dict[str, Any], may_change: tuple[str, ...] = ()
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
    try:
        with open(path) as handle:
            config = yaml.safe_load(handle)
    except OSError as error:
        raise ConfigError(f"{path}: cannot read the config ({error.strerror})") from None
    except yaml.YAMLError as error:
        raise ConfigError(f"{path}: not valid YAML ({error})") from None
    if not isinstance(config, dict):
        raise ConfigError(f"{path}: a config must be a YAML mapping")
    extra = environment_overrides()
    try:
        return apply_overrides(config, [*(overrides or []), *extra])
    except ConfigError as error:
        if extra and any(item in str(error) for item in extra):
            raise ConfigError(f"${OVERRIDES_VARIABLE}: {error}") from error
        raise
