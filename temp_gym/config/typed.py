"""Dataclasses from plain mappings and back, with every key and type checked.

A config section is a frozen dataclass whose fields carry types and defaults
(`temp_gym.config.sections`). `build` makes one from a mapping (a YAML section): absent keys
take their defaults, a key the dataclass does not declare or a value of the wrong type is a
`ConfigError` naming the dotted key. `replace_key` sets one dotted key of a built config (an
override), with the same checks; `to_dict` gives the plain nested dict back (what checkpoints
store and TensorBoard shows).

Values are converted only where nothing can be lost: an int where a float is declared becomes
that float, a float with an integral value where an int is declared becomes that int, and a
number written as YAML 1.1 reads it as text (``1e-3``) becomes the float where a float is
declared (and stays text where a string is).

    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Section:
    ...     lr: float = 1e-3
    ...     betas: list[float] | None = None
    >>> build(Section, {"lr": "1e-4"}, "optim")
    Section(lr=0.0001, betas=None)
    >>> build(Section, {"lr": "fast"}, "optim")
    Traceback (most recent call last):
    ...
    temp_gym.config.errors.ConfigError: optim.lr: expected a number, got 'fast'
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import re
import types
import typing
from collections.abc import Mapping, Sequence
from typing import Any, TypeVar

from temp_gym.config.errors import ConfigError
from temp_gym.jobs import brief

T = TypeVar("T")

_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")
"""A decimal number as text (``1e-3``, which YAML 1.1 reads as a string); no nan or inf."""


@functools.cache
def field_types(cls: type) -> dict[str, Any]:
    """The declared type of each field of the dataclass ``cls``, in declaration order."""
    hints = typing.get_type_hints(cls)
    return {field.name: hints[field.name] for field in dataclasses.fields(cls)}


def dotted(prefix: str, name: str) -> str:
    """``prefix.name`` (just ``name`` at the top level)."""
    return f"{prefix}.{name}" if prefix else name


def unknown_key_message(key: str, known: Sequence[str]) -> str:
    """``unknown key train.max_epoch (did you mean train.max_epochs?)``."""
    prefix, _, name = key.rpartition(".")
    close = difflib.get_close_matches(name, list(known), n=1)
    hint = f" (did you mean {dotted(prefix, close[0])}?)" if close else ""
    return f"unknown key {key}{hint}"


def build(cls: type[T], values: Mapping[str, Any] | None, where: str = "") -> T:
    """An instance of the dataclass ``cls`` from ``values``; absent keys take their defaults.

    ``where`` is the section's dotted name, for the messages; ``None`` stands for an empty
    section (a YAML heading with nothing under it).

    Raises:
        ConfigError: a key ``cls`` does not declare, a value of the wrong type, a field
            without default that ``values`` lacks; the message names the dotted key.
    """
    if values is None:
        values = {}
    if not isinstance(values, Mapping):
        raise ConfigError(f"{where or 'config'}: expected a mapping of keys, got {brief(values)}")
    declared = field_types(cls)
    for key in values:
        if key not in declared:
            name = str(key) if len(str(key)) <= 60 else brief(str(key), 60)
            raise ConfigError(unknown_key_message(dotted(where, name), list(declared)))
    arguments = {}
    for field in dataclasses.fields(cls):
        key = dotted(where, field.name)
        if field.name in values:
            arguments[field.name] = convert(values[field.name], declared[field.name], key)
        elif field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING:
            raise ConfigError(f"{key}: missing (it has no default)")
    return cls(**arguments)


def convert(value: Any, kind: Any, key: str) -> Any:
    """``value`` as the declared type ``kind`` (see the module docstring), or a ConfigError."""
    if dataclasses.is_dataclass(kind):
        return value if isinstance(value, kind) else build(kind, value, key)
    origin = typing.get_origin(kind)
    if origin in (typing.Union, types.UnionType):
        options = typing.get_args(kind)
        if value is None and type(None) in options:
            return None
        for option in options:
            if option is not type(None):
                try:
                    return convert(value, option, key)
                except ConfigError:
                    continue
        raise ConfigError(f"{key}: expected {describe(kind)}, got {brief(value)}")
    if origin is list:
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{key}: expected {describe(kind)}, got {brief(value)}")
        (item,) = typing.get_args(kind)
        return [convert(entry, item, f"{key}[{index}]") for index, entry in enumerate(value)]
    if kind is bool and isinstance(value, bool):
        return value
    if kind is int and not isinstance(value, bool):
        if isinstance(value, int):
            return value
        if isinstance(value, float) and value.is_integer():
            return int(value)
    if kind is float and not isinstance(value, bool):
        if isinstance(value, (int, float)):
            return float(value)
        if isinstance(value, str) and _NUMBER.match(value.strip()):
            return float(value)
    if kind is str and isinstance(value, str):
        return value
    if kind is Any:
        return value
    raise ConfigError(f"{key}: expected {describe(kind)}, got {brief(value)}")


def describe(kind: Any) -> str:
    """A declared type in words: ``an integer or null``, ``a list of strings``."""
    if dataclasses.is_dataclass(kind):
        return f"a mapping of {', '.join(field_types(kind))}"
    origin = typing.get_origin(kind)
    if origin in (typing.Union, types.UnionType):
        options = [option for option in typing.get_args(kind) if option is not type(None)]
        words = " or ".join(describe(option) for option in options)
        return f"{words} or null" if len(options) < len(typing.get_args(kind)) else words
    if origin is list:
        (item,) = typing.get_args(kind)
        return f"a list of {_PLURALS.get(item, describe(item))}"
    return _WORDS.get(kind, getattr(kind, "__name__", str(kind)))


_WORDS = {bool: "true or false", int: "an integer", float: "a number", str: "a string"}
_PLURALS = {bool: "booleans", int: "integers", float: "numbers", str: "strings"}


def replace_key(config: T, key: str, value: Any, where: str = "") -> T:
    """A copy of the dataclass ``config`` with the dotted ``key`` set to ``value`` (converted).

    A mapping given for a section is merged into it, key by key, as Hydra merges a mapping
    override: ``data.workspaces={train: 5}`` keeps ``data.workspaces.val``.

    Raises:
        ConfigError: ``key`` names nothing ``config`` declares, or descends into a value, or
            ``value`` has the wrong type; the message names the key.
    """
    name, _, rest = key.partition(".")
    here = dotted(where, name)
    declared = field_types(type(config))
    if name not in declared:
        raise ConfigError(unknown_key_message(here, list(declared)))
    inner = getattr(config, name)
    if not rest and dataclasses.is_dataclass(inner) and isinstance(value, Mapping):
        new = inner
        for key_inside, value_inside in value.items():
            if not isinstance(key_inside, str):
                raise ConfigError(f"{here}: keys must be names, got {key_inside!r}")
            new = replace_key(new, key_inside, value_inside, here)
    elif not rest:
        new = convert(value, declared[name], here)
    else:
        if not dataclasses.is_dataclass(inner):
            raise ConfigError(
                f"unknown key {dotted(here, rest)} ({here} is a value, not a section)"
            )
        new = replace_key(inner, rest, value, here)
    return dataclasses.replace(config, **{name: new})


def to_dict(config: Any) -> dict[str, Any]:
    """The plain nested dict of a dataclass config (lists stay lists), in field order."""
    return dataclasses.asdict(config)


def fill_defaults(cls: type, values: Mapping[str, Any]) -> dict[str, Any]:
    """``values`` with each key ``cls`` declares and ``values`` lacks set to its default.

    Nothing is converted or checked, and keys ``cls`` does not declare stay: this completes a
    dict written by an older version (see `temp_gym.config.loading.upgrade_stored`), so that
    a comparison with today's config sees the defaults, and still sees keys that are gone.
    """
    out = dict(values)
    for field in dataclasses.fields(cls):
        kind = field_types(cls)[field.name]
        present = values.get(field.name)
        if dataclasses.is_dataclass(kind) and (present is None or isinstance(present, Mapping)):
            out[field.name] = fill_defaults(kind, present or {})
        elif field.name in values:
            continue
        elif field.default is not dataclasses.MISSING:
            out[field.name] = field.default
        elif field.default_factory is not dataclasses.MISSING:
            out[field.name] = to_plain(field.default_factory())
    return out


def to_plain(value: Any) -> Any:
    """A default value as `to_dict` would give it (a dataclass becomes its dict)."""
    return to_dict(value) if dataclasses.is_dataclass(value) else value
