"""`PlanSettings`: the settings every planner shares, and the base of each planner's own.

A planner declares its settings as a frozen dataclass that extends `PlanSettings` with its
own fields (`temp_gym.planning.temp_settings.TEMPSettings`,
`temp_gym.planning.planners.RRTStarSettings`, ...) and registers it with its function
(`temp_gym.planning.registry.register_planner`). The common fields stay here, and nothing
that only one planner reads: a new planner with new settings widens no shared class.

Building a settings object checks and normalizes every field (plain ``int`` and ``float``),
so a planner never meets a negative budget, a NaN or a bool where a number belongs; a bad
value is a `ValueError` of one line that names the field. A field the class does not have is
a `TypeError` that names the class that has it, when a registered planner's does:
``PlanSettings(attention_patience=30)`` says "PlanSettings has no field attention_patience:
it is a setting of the temp planner; use TEMPSettings(attention_patience=...)".

The checks of single values (`count`, `share`, `seed_value`, ...) are public, so that other
entry points (a policy's declared settings, a script's flags) refuse a value as a planner
would, naming their own field.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, fields
from typing import Any, TypeVar

import numpy as np

MAX_COUNT = 2**53
"""Largest node or sample budget: counts above it no longer convert to float exactly (and
no tree that large fits in memory)."""

Settings = TypeVar("Settings", bound="PlanSettings")


def count(value: object, name: str, minimum: int = 1) -> int:
    """An integer in ``[minimum, MAX_COUNT]``, or a `ValueError` naming ``name``."""
    if not isinstance(value, numbers.Integral) or isinstance(value, bool):
        raise ValueError(f"{name}: expected an integer of at least {minimum}, got {value!r}")
    if not minimum <= value <= MAX_COUNT:
        shown = value if abs(value) < 10**20 else f"an integer of {len(str(value))} digits"
        raise ValueError(f"{name}: expected an integer in [{minimum}, 2**53], got {shown}")
    return int(value)


def real(value: object, name: str, expected: str) -> float:
    """``float(value)`` for a real number (not bool), or a `ValueError` naming ``name``."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        raise ValueError(f"{name}: expected {expected}, got {value!r}")
    try:
        return float(value)
    except OverflowError:
        raise ValueError(f"{name}: expected {expected}, got a number beyond float range") from None


def finite_at_least(value: object, name: str, least: float) -> float:
    """``float(value)`` for a finite real number of at least ``least`` (not bool).

    Anything else is a `ValueError` naming ``name``.
    """
    expected = f"a finite number of at least {least:g}"
    number = real(value, name, expected)
    if not (math.isfinite(number) and number >= least):
        raise ValueError(f"{name}: expected {expected}, got {value!r}")
    return number


def positive(value: object, name: str) -> float:
    """A finite real number above 0 (a length: a steering step, OMPL's range)."""
    number = real(value, name, "a positive number or None")
    if not (math.isfinite(number) and number > 0):
        raise ValueError(f"{name}: expected a positive number or None, got {number}")
    return number


def flag(value: object, name: str) -> bool:
    """True or False (numpy's bool too); anything else is a `ValueError` naming ``name``."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name}: expected True or False, got {value!r}")
    return bool(value)


def seed_value(value: object, name: str = "seed") -> int:
    """A seed of a generator: a non-negative integer (not bool), as numpy takes it."""
    if not isinstance(value, numbers.Integral) or isinstance(value, bool) or value < 0:
        raise ValueError(f"{name}: expected a non-negative integer, got {value!r}")
    return int(value)


def noise_level(value: object, name: str = "noise_std") -> float:
    """A standard deviation of output noise: a finite real number of at least 0 (not bool)."""
    return finite_at_least(value, name, 0.0)


def share(value: object, name: str) -> float:
    """A probability: a real number in ``[0, 1]``."""
    number = real(value, name, "a number in [0, 1]")
    if not 0.0 <= number <= 1.0:
        raise ValueError(f"{name}: expected a number in [0, 1], got {value!r}")
    return number


@dataclass(frozen=True)
class PlanSettings:
    """The settings every planner takes; a planner's own settings class extends it.

    Raises:
        ValueError: naming the first invalid field and what it expected.
        TypeError: a field this class does not have (naming the planner whose class has it).
    """

    seed: int = 0
    """Seed of the planner's random generator."""
    max_nodes: int = 5000
    """Stop once the tree has this many nodes (root included; 1 to 2**53)."""
    time_limit: float | None = None
    """Stop after this many seconds of wall time (None: no limit; `temp_gym.plan` says what
    it covers)."""
    stop_at_first: bool = False
    """Stop at the first solution."""
    step_size: float | None = None
    """Steering step, in the robot's units (world units; radians for an arm); None picks
    `temp_gym.planning.tree.default_step_size`."""
    goal_bias: float = 0.05
    """Probability of sampling the goal itself."""
    target_cost: float | None = None
    """Stop once a solution at most this costly is found."""
    max_samples: int | None = None
    """Stop after this many samples; None means ``100 * max_nodes`` (a walled-in start)."""

    def __new__(cls, *args: Any, **kwargs: Any) -> PlanSettings:
        """Refuse a keyword that is no field, naming the planner whose settings have it.

        Checked before the dataclass's ``__init__``, whose `TypeError` would not say where
        the setting went.
        """
        names = field_names(cls)
        for name in kwargs:
            if name not in names:
                raise TypeError(_not_a_field(cls, name))
        return super().__new__(cls)

    def __post_init__(self) -> None:
        self._normalize("seed", seed_value(self.seed))
        self._normalize("max_nodes", count(self.max_nodes, "max_nodes"))
        if self.time_limit is not None:
            limit = real(self.time_limit, "time_limit", "a non-negative number or None")
            if not limit >= 0:
                raise ValueError(f"time_limit: expected a non-negative number or None, got {limit}")
            self._normalize("time_limit", limit)
        self._normalize("stop_at_first", flag(self.stop_at_first, "stop_at_first"))
        if self.step_size is not None:
            self._normalize("step_size", positive(self.step_size, "step_size"))
        self._normalize("goal_bias", share(self.goal_bias, "goal_bias"))
        if self.target_cost is not None:
            target = real(self.target_cost, "target_cost", "a number or None")
            if math.isnan(target):
                raise ValueError("target_cost: expected a number or None, got nan")
            self._normalize("target_cost", target)
        if self.max_samples is not None:
            self._normalize("max_samples", count(self.max_samples, "max_samples"))

    def _normalize(self, name: str, value: object) -> None:
        """Store a checked value in the frozen instance (its normalized form)."""
        object.__setattr__(self, name, value)

    def derived(self: Settings, **changes: Any) -> Settings:
        """A copy with ``changes``, which are not checked again.

        For the budgets a planner derives from its checked settings in its inner loops (a
        turn's node budget, the samples left), where `dataclasses.replace`, which checks
        every field again, would cost more than a short turn.
        """
        unknown = changes.keys() - self.__dict__.keys()
        if unknown:
            raise TypeError(f"derived(): unknown settings {sorted(unknown)}")
        copy = object.__new__(type(self))
        copy.__dict__.update(self.__dict__)
        copy.__dict__.update(changes)
        return copy

    def common(self) -> PlanSettings:
        """The shared settings alone, as a plain `PlanSettings` (what every planner takes)."""
        return PlanSettings(**{name: getattr(self, name) for name in field_names(PlanSettings)})

    def deadline(self, started: float) -> float:
        """When a run started at ``started`` runs out of time (a perf_counter value; inf: never)."""
        return math.inf if self.time_limit is None else started + self.time_limit

    @property
    def sample_limit(self) -> int:
        """The effective sample limit."""
        return 100 * self.max_nodes if self.max_samples is None else self.max_samples


_FIELD_NAMES: dict[type, frozenset[str]] = {}


def field_names(cls: type) -> frozenset[str]:
    """The field names of a settings class (cached: `PlanSettings.__new__` asks per object)."""
    names = _FIELD_NAMES.get(cls)
    if names is None:
        names = _FIELD_NAMES[cls] = frozenset(field.name for field in fields(cls))
    return names


def _not_a_field(cls: type, name: str) -> str:
    """The one-line message for a keyword ``cls`` lacks, naming the class that has it."""
    import temp_gym.planning.plan  # noqa: F401  (registers the built-in planners)
    from temp_gym.planning.registry import owners_of, planners_phrase  # it imports this one

    owners = owners_of(name)
    if not owners:
        return f"{cls.__name__} has no field {name}"
    return (
        f"{cls.__name__} has no field {name}: it is a setting of {planners_phrase(owners)}; "
        f"use {owners[0].settings.__name__}({name}=...)"
    )


__all__ = [
    "MAX_COUNT",
    "PlanSettings",
    "count",
    "field_names",
    "finite_at_least",
    "flag",
    "noise_level",
    "positive",
    "real",
    "seed_value",
    "share",
]
