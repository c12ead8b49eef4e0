"""Typed configs: YAML files and ``key.sub=value`` overrides into one dataclass per section.

    >>> from temp_gym.config import ConfigError, load_config
    >>> config = load_config("configs/2d.yaml", ["train.max_epochs=3", "data.dir=/tmp/d"])
    >>> config.train.max_epochs, config.data.dir, config.model.chunk
    (3, '/tmp/d', 1)
    >>> try:
    ...     load_config("configs/2d.yaml", ["train.max_epoch=3"])
    ... except ConfigError as error:
    ...     print(error)
    override 'train.max_epoch=3': unknown key train.max_epoch (did you mean train.max_epochs?)

Every default lives in `temp_gym.config.sections` (a YAML file may restate it); code reads
attributes (``config.train.max_epochs``). Unknown keys and wrong types, in a file or an
override, are a `ConfigError` naming the key. Scripts parse their command line with
`parse_args`: overrides may stand anywhere, also after an option flag that takes several
values. ``TEMP_GYM_OVERRIDES`` holds overrides that every load applies last::

    TEMP_GYM_OVERRIDES="train.max_epochs=1 train_eval.tasks=2" python trainers/bc.py

| module | job |
|---|---|
| `temp_gym.config.sections` | the dataclasses, their defaults and what each key means |
| `temp_gym.config.typed` | a dataclass from a mapping and back, keys and types checked |
| `temp_gym.config.loading` | `load_config`, overrides, `upgrade_stored` for older stored configs |
| `temp_gym.config.command_line` | `script_parser`, `parse_args`, `count`, `number` and kin |
| `temp_gym.config.compare` | `differing_keys`: what a resumed run or a rerun would change |
"""

from temp_gym.config.command_line import (
    OVERRIDE,
    count,
    labelled_entry,
    number,
    parse_args,
    script_parser,
)
from temp_gym.config.compare import differing_keys, flatten
from temp_gym.config.errors import ConfigError
from temp_gym.config.loading import (
    CONFIG_DIR,
    MOVED_KEYS,
    OVERRIDES_VARIABLE,
    RENAMED_SECTIONS,
    apply_overrides,
    config_from_dict,
    environment_overrides,
    load_config,
    upgrade_stored,
)
from temp_gym.config.sections import (
    Config,
    DataConfig,
    EnvConfig,
    EvaluationConfig,
    LoggerConfig,
    LossConfig,
    ModelConfig,
    OptimConfig,
    TEMPConfig,
    TrainConfig,
    TrainEvalConfig,
    Workspaces,
)

__all__ = [
    "CONFIG_DIR",
    "OVERRIDE",
    "OVERRIDES_VARIABLE",
    "RENAMED_SECTIONS",
    "Config",
    "ConfigError",
    "DataConfig",
    "EnvConfig",
    "EvaluationConfig",
    "LoggerConfig",
    "LossConfig",
    "MOVED_KEYS",
    "ModelConfig",
    "OptimConfig",
    "TEMPConfig",
    "TrainConfig",
    "TrainEvalConfig",
    "Workspaces",
    "apply_overrides",
    "count",
    "labelled_entry",
    "config_from_dict",
    "differing_keys",
    "environment_overrides",
    "flatten",
    "load_config",
    "number",
    "parse_args",
    "script_parser",
    "upgrade_stored",
]
