"""The planner registry: a name -> its function and its settings class.

`register_planner` adds a planner; `plan` (`temp_gym.planning.plan`) looks it up and builds
its settings (`settings_for`). A planner added later (in this package or in a user's) brings
its own settings class, a dataclass extending `temp_gym.planning.settings.PlanSettings`, and
widens no shared class::

    @dataclass(frozen=True)
    class MySettings(PlanSettings):
        range: float | None = None
        '''Longest motion per extension (None: two steering steps).'''

    def my_planner(problem: Problem, settings: MySettings) -> PlanResult: ...

    register_planner("my_planner", my_planner, MySettings)
    plan(problem, planner="my_planner", range=0.5, max_nodes=2000)

`settings_for` turns what a caller gave (a settings object, keyword shortcuts, or both) into
the planner's settings, and refuses, in one line naming the field and the form to use,
a setting that belongs to another planner.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from temp_gym.planning.result import PlanResult
from temp_gym.planning.settings import PlanSettings, field_names
from temp_gym.problem import Problem


@dataclass(frozen=True)
class Planner:
    """A registered planner: its name, its function and the class of its settings."""

    name: str
    """The key of `PLANNERS`: ``plan(problem, planner=name)``."""
    function: Callable[[Problem, Any], PlanResult]
    """``function(problem, settings)``, ``settings`` an instance of `settings`."""
    settings: type[PlanSettings]
    """The planner's settings class: `PlanSettings` or a dataclass extending it."""

    def __call__(self, problem: Problem, settings: PlanSettings) -> PlanResult:
        """Run the planner on ``settings`` (see `settings_for` for what it may be)."""
        return self.function(problem, settings_for(self.name, settings))


PLANNERS: dict[str, Planner] = {}
"""Planner name -> `Planner`; `temp_gym.plan` dispatches through it."""


def register_planner(
    name: str,
    function: Callable[[Problem, Any], PlanResult],
    settings: type[PlanSettings] = PlanSettings,
    overwrite: bool = False,
) -> Planner:
    """Make ``function`` available as ``plan(..., planner=name)``, with its ``settings`` class.

    Raises:
        ValueError: ``name`` is taken (unless ``overwrite``), or ``settings`` is not a
            dataclass extending `PlanSettings`.
    """
    if not isinstance(name, str) or not name:
        raise ValueError(f"name: expected a non-empty string, got {name!r}")
    if not overwrite and name in PLANNERS:
        raise ValueError(f"planner: {name!r} is already registered")
    if not (
        isinstance(settings, type)
        and issubclass(settings, PlanSettings)
        and dataclasses.is_dataclass(settings)
    ):
        raise ValueError(f"settings: expected a dataclass extending PlanSettings, got {settings!r}")
    if not callable(function):
        raise ValueError(f"function: expected a callable, got {function!r}")
    entry = PLANNERS[name] = Planner(name, function, settings)
    return entry


def planner_entry(name: object) -> Planner:
    """The registered planner ``name``, or a `ValueError` listing the known ones."""
    if not isinstance(name, str) or name not in PLANNERS:
        raise ValueError(f"planner: unknown planner {name!r}; expected one of {sorted(PLANNERS)}")
    return PLANNERS[name]


def planner_of(settings: object) -> str | None:
    """The one registered planner whose settings class ``settings`` is exactly, else None.

    Never for a plain `PlanSettings`, which every planner takes.
    """
    if type(settings) is PlanSettings:
        return None
    names = [entry.name for entry in PLANNERS.values() if type(settings) is entry.settings]
    return names[0] if len(names) == 1 else None


def owners_of(name: str) -> list[Planner]:
    """The registered planners whose settings have field ``name`` beyond the common ones."""
    if name in field_names(PlanSettings):
        return []
    return [entry for entry in PLANNERS.values() if name in field_names(entry.settings)]


def settings_for(planner: str, settings: object = None, **options: Any) -> PlanSettings:
    """The settings object ``planner`` runs on: ``settings`` with ``options`` applied.

    ``settings`` may be the planner's own settings class (or a subclass), a base class that no
    planner owns (a plain `PlanSettings`, or `OMPLSettings` for OMPL's RRT*s: its fields are
    kept, the planner's others take their defaults), or
    None (every field's default). ``options`` are keyword shortcuts for fields of the
    planner's settings class, applied on top. A shortcut that belongs to another planner is
    refused naming it, unless it is None (not set), which older calls passed to every
    planner alike.

    Raises:
        ValueError: an unknown planner, settings of another planner, a field no registered
            planner has, another planner's field, or an invalid value; one line each.
    """
    entry = planner_entry(planner)
    cls = entry.settings
    base = type(settings)
    if (
        settings is not None
        and base is not cls
        and issubclass(cls, base)
        and (planner_of(settings) is None)
    ):  # a shared base (`PlanSettings`, `OMPLSettings`): its fields kept, the others' defaults
        settings = cls(**{name: getattr(settings, name) for name in field_names(base)})
    elif settings is not None and (
        not isinstance(settings, cls) or planner_of(settings) not in (None, entry.name)
    ):
        raise ValueError(_other_settings(entry, settings))
    own = field_names(cls)
    given = {}
    for name, value in options.items():
        if name in own:
            given[name] = value
        elif owners_of(name):
            if value is not None:
                raise ValueError(_foreign(entry, name))
        else:
            raise ValueError(_unknown(entry, name))
    if settings is None:
        return cls(**given)
    return dataclasses.replace(settings, **given) if given else settings


def _other_settings(entry: Planner, settings: object) -> str:
    takes = entry.settings.__name__
    message = f"settings: the {entry.name} planner takes {takes}, got {type(settings).__name__}"
    owner = planner_of(settings)
    if owner:
        message += f" (the {owner} planner's); pass planner={owner!r} with it, or {takes}(...)"
    return message


def planners_phrase(owners: list[Planner]) -> str:
    """``the temp planner``, ``the a and b planners``, ``the a, b and c planners``."""
    names = [owner.name for owner in owners]
    if len(names) == 1:
        return f"the {names[0]} planner"
    return f"the {', '.join(names[:-1])} and {names[-1]} planners"


def _foreign(entry: Planner, name: str) -> str:
    owners = owners_of(name)
    return (
        f"{name}: only {planners_phrase(owners)} take{'s' if len(owners) == 1 else ''} it, "
        f"not {entry.name}; use plan(problem, planner={owners[0].name!r}, "
        f"settings={owners[0].settings.__name__}({name}=...))"
    )


def _unknown(entry: Planner, name: str) -> str:
    known = sorted(field_names(entry.settings))
    close = difflib.get_close_matches(name, known, n=1)
    hint = f" (did you mean {close[0]}?)" if close else ""
    return (
        f"{name}: not a setting of the {entry.name} planner{hint}; "
        f"{entry.settings.__name__} has {', '.join(known)}"
    )


__all__ = [
    "PLANNERS",
    "Planner",
    "owners_of",
    "planner_entry",
    "planner_of",
    "register_planner",
    "settings_for",
]
