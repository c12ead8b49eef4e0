"""A `Config` from a YAML file and ``key.sub=value`` overrides; older stored configs upgraded.

Values in overrides are parsed as YAML scalars (``3`` is an int, ``1e-3`` a float, ``null``
None, ``[1, 2]`` a list, ``{train: 2, val: 1}`` a mapping) and then checked against the
field's type. Every key a section declares can be overridden, whether the file lists it or
not; a key no section declares is an error, so a typo never passes silently. A leading ``+``
(``+train_eval.seed=3``), which once added a key the file lacked, is still accepted and means
the same.

The environment variable ``TEMP_GYM_OVERRIDES`` holds more overrides, separated by spaces,
that every config load applies after the caller's: the same command then runs at another size
(the tests run the README's commands as written, smoke-sized this way).

YAML is read with `ConfigLoader`: ``yaml.safe_load``'s loader without anchors and aliases
(``&a``, ``*a``: a few kB of them expand into gigabytes) and with nesting bounded by
`temp_gym.limits.MAX_CONFIG_DEPTH`; a file is read up to `temp_gym.limits.MAX_CONFIG_BYTES`.
After the overrides, every value is checked against its bounds (`temp_gym.config.checks`).
"""

from __future__ import annotations

import dataclasses
import os
import shlex
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from temp_gym.config.checks import check_config, registered_env_robots
from temp_gym.config.errors import ConfigError
from temp_gym.config.sections import Config, TEMPConfig
from temp_gym.config.typed import build, field_types, fill_defaults, replace_key
from temp_gym.jobs import brief
from temp_gym.limits import MAX_CONFIG_BYTES, MAX_CONFIG_DEPTH

CONFIG_DIR = Path(__file__).resolve().parents[2] / "configs"
"""The repository's ``configs/``: a config named by a path that does not exist is looked up
there by its file name."""

OVERRIDES_VARIABLE = "TEMP_GYM_OVERRIDES"
"""Environment variable with overrides applied after the caller's (see the module docstring)."""

RENAMED_SECTIONS = {"eval": "train_eval"}
"""Sections that older configs named otherwise (old name -> new), for `upgrade_stored` and the
error that names the new section."""

MOVED_KEYS = {
    f"{section}.{name}": f"{section}.temp.{name}"
    for section in ("train_eval", "evaluation")
    for name in field_types(TEMPConfig)
}
"""Keys that older configs held elsewhere (old dotted key -> new): TEMP's planner settings,
now one ``temp`` section (`TEMPConfig`) in each section that plans with TEMP; for
`upgrade_stored` and the error that names the new key."""


class ConfigLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses anchors and aliases and bounds the nesting depth.

    Both are checked as nodes are composed, before any value is built, so neither an alias
    bomb nor a file nested thousands deep costs more than reading its text.
    """

    def __init__(self, stream: Any) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        """Compose one node, refusing an alias, an anchor, or a nesting too deep."""
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None) is not None:
            raise ConfigError(
                f"YAML anchors and aliases (&{event.anchor} / *{event.anchor}) are not "
                "supported in configs; write the value out"
            )
        self._depth += 1
        try:
            if self._depth > MAX_CONFIG_DEPTH:
                raise ConfigError(
                    f"nested more than {MAX_CONFIG_DEPTH} levels deep (a config is a few levels)"
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def safe_yaml(text: str | bytes) -> Any:
    """The value of a YAML text, read with `ConfigLoader`.

    Raises:
        ConfigError: an anchor, an alias, a nesting too deep, a number of too many digits.
        yaml.YAMLError: text that is not YAML.
    """
    loader = ConfigLoader(text)
    try:
        return loader.get_single_data()
    except (ValueError, OverflowError) as error:  # an integer of thousands of digits
        if isinstance(error, ConfigError):
            raise
        raise ConfigError(f"a value YAML cannot hold ({brief(str(error))})") from None
    finally:
        loader.dispose()


def environment_overrides() -> list[str]:
    """The overrides in ``$TEMP_GYM_OVERRIDES`` (shell-style words; none when unset)."""
    return shlex.split(os.environ.get(OVERRIDES_VARIABLE, ""))


def parse_value(text: str) -> Any:
    """An override's value: a YAML scalar, list or mapping, as a YAML file would hold it.

    Numbers YAML 1.1 reads as text (``1e-3``) stay text here: the field's declared type
    decides (`temp_gym.config.typed.convert`), so ``train.exp_name=1e5`` stays a name.
    """
    try:
        return safe_yaml(text) if text.strip() else ""
    except yaml.YAMLError:
        return text


def _renamed_hint(key: str) -> str:
    if key in MOVED_KEYS:
        return f" (the key is now {MOVED_KEYS[key]})"
    section = key.split(".", 1)[0]
    new = RENAMED_SECTIONS.get(section)
    return f" (the {section} section is now {new})" if new else ""


def apply_overrides(config: Config, overrides: Sequence[str]) -> Config:
    """A copy of ``config`` with each ``key.sub=value`` override applied, in order.

    Raises:
        ConfigError: an override without ``=``, a key no section declares, a value of the
            wrong type; the message quotes the override.
    """
    for item in overrides:
        if "=" not in item:
            raise ConfigError(f"override {brief(item)}: expected key.sub=value")
        key, text = item.split("=", 1)
        try:
            config = replace_key(config, key.lstrip("+"), parse_value(text))
        except ConfigError as error:
            hint = _renamed_hint(key.lstrip("+"))
            raise ConfigError(f"override {brief(item)}: {error}{hint}") from None
    return config


def config_from_dict(values: Mapping[str, Any] | None, source: str = "config") -> Config:
    """A `Config` from a nested mapping (a YAML file's), checked key by key.

    Raises:
        ConfigError: an unknown section or key, a wrong type, a missing ``env.id``,
            ``env.robot`` or ``data.dir``; the message starts with ``source``.
    """
    if not isinstance(values, Mapping):
        raise ConfigError(f"{source}: a config must be a YAML mapping")
    try:
        return build(Config, values)
    except ConfigError as error:
        hint = next(
            (
                _renamed_hint(key)
                for key in [*values, *_dotted_keys(values)]
                if key in RENAMED_SECTIONS or key in MOVED_KEYS
                if f"unknown key {key}" in str(error)
            ),
            "",
        )
        raise ConfigError(f"{source}: {error}{hint}") from None


def _dotted_keys(values: Mapping[str, Any]) -> list[str]:
    """``section.key`` of every key one level down (where `MOVED_KEYS` looks)."""
    return [
        f"{section}.{key}"
        for section, inner in values.items()
        if isinstance(inner, Mapping)
        for key in inner
    ]


def read_config_file(path: str | Path) -> tuple[Path, Any]:
    """The path actually read (see `CONFIG_DIR`) and its YAML content (`yaml.safe_load`)."""
    path = Path(path)
    if not path.exists() and (CONFIG_DIR / path.name).exists():
        path = CONFIG_DIR / path.name
    try:
        with open(path, "rb") as handle:
            raw = handle.read(MAX_CONFIG_BYTES + 1)
    except OSError as error:
        raise ConfigError(f"{path}: cannot read the config ({error.strerror or error})") from None
    if len(raw) > MAX_CONFIG_BYTES:
        raise ConfigError(f"{path}: larger than {MAX_CONFIG_BYTES // 2**10} kB, not a config")
    try:
        return path, safe_yaml(raw.decode("utf-8-sig"))
    except UnicodeDecodeError as error:
        raise ConfigError(f"{path}: not UTF-8 text (byte {error.start})") from None
    except ConfigError as error:
        raise ConfigError(f"{path}: {error}") from None
    except yaml.YAMLError as error:
        raise ConfigError(f"{path}: not valid YAML ({error})") from None


def load_config(path: str | Path, overrides: Sequence[str] | None = None) -> Config:
    """Load a YAML config; apply ``overrides``, then ``$TEMP_GYM_OVERRIDES``.

    Raises:
        ConfigError: an unreadable file, invalid YAML, an unknown key or a wrong type in the
            file or an override (see `config_from_dict`, `apply_overrides`).
    """
    path, values = read_config_file(path)
    config = config_from_dict(values, str(path))
    extra = environment_overrides()
    config = apply_overrides(config, list(overrides or []))
    try:
        config = apply_overrides(config, extra)
    except ConfigError as error:
        raise ConfigError(f"${OVERRIDES_VARIABLE}: {error}") from error
    given_id = any(item.split("=", 1)[0].lstrip("+") == "env.id"
                   for item in [*(overrides or []), *extra])  # fmt: skip
    config = resolve_robot_description(config, keep_id=given_id)
    check_config(config)
    return config


def resolve_robot_description(config: Config, keep_id: bool = False) -> Config:
    """``config`` with its ``env.robot`` description file registered.

    An ``env.robot`` that names a description file (``.yaml``/``.yml``, a path with a folder, or an
    existing file that no robot is named after) is replaced by the arm's name (the file kept as
    ``env.description``); a file that is no description is refused with the loader's reason.

    ``env.id`` becomes the arm's env unless ``keep_id`` (it was given explicitly; then it must
    match, `check_config`). A config loaded again from a stored copy (``env.description`` set)
    registers the same file.

    Raises:
        ConfigError: an unreadable or invalid description (one line naming ``env.robot``).
    """
    from temp_gym import hooks

    robot, description = config.env.robot, config.env.description
    if _names_a_file(str(robot)):
        description = robot
    if description is None:
        return config
    if hooks.robot_file_loader is None:
        raise ConfigError("env.robot: a robot description needs `import temp_gym` first")
    try:
        spec = hooks.robot_file_loader(description)
    except (OSError, ValueError) as error:
        raise ConfigError(f"env.robot: {brief(str(error), 300)}") from None
    env = dataclasses.replace(
        config.env,
        robot=spec.name,
        description=str(Path(description).expanduser().resolve()),
        id=config.env.id if keep_id else spec.env_id,
    )
    return dataclasses.replace(config, env=env)


def _names_a_file(robot: str) -> bool:
    """Whether ``env.robot`` names a description file rather than a registered robot.

    A ``.yaml``/``.yml`` name, a path with a folder in it, or an existing file that is not the
    robot of a registered temp-gym env.
    """
    if robot.endswith((".yaml", ".yml")) or "/" in robot:
        return True
    robots = set(registered_env_robots().values())
    return robot not in robots and Path(robot).expanduser().is_file()


def upgrade_stored(stored: Mapping[str, Any]) -> dict[str, Any]:
    """A config dict stored by an older temp-gym (``last.pt``), in today's layout.

    Renamed sections take their new names (`RENAMED_SECTIONS`), moved keys their new places
    (`MOVED_KEYS`) and keys added since their defaults, so that a run started before any of
    these changes compares equal to the same config today. Values are kept as stored, and
    keys this version no longer declares stay, so a comparison still names them.
    """
    renamed = {RENAMED_SECTIONS.get(key, key): value for key, value in stored.items()}
    renamed = {
        key: dict(value) if isinstance(value, Mapping) else value for key, value in renamed.items()
    }
    for old, new in MOVED_KEYS.items():
        section, name = old.split(".")
        inner = renamed.get(section)
        if isinstance(inner, dict) and name in inner:
            moved = inner.setdefault("temp", {})
            if isinstance(moved, Mapping):
                inner["temp"] = {**moved, new.rsplit(".", 1)[1]: inner.pop(name)}
    return fill_defaults(Config, renamed)
