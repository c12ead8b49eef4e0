"""OMPL's benchmark log format: what ``ompl::tools::Benchmark::saveResultsToStream`` writes.

A log holds one experiment: a header (library version, experiment name and properties, host,
start time, the setup and CPU blocks between ``<<<|`` and ``|>>>``, the random seed, the time
and memory limits, the run count, the total time), one enum type (the planner status), then
per planner its name, its common properties (``name = value``), the names of its run
properties with their types (``time REAL``, ``solved BOOLEAN``, ``best cost REAL``, ...),
the runs as rows of values each followed by ``"; "``, optionally the progress properties
(samples ``value,`` per property, ``;`` per sample, one line per run), and a ``.`` line.

``ompl_benchmark_statistics.py`` (shipped with OMPL's Python package) and
`temp_gym.evaluation.ompl_database` read it into the SQLite database Planner Arena
(plannerarena.org) loads.

Example:
    >>> planner = LogPlanner("rrt_star", {"goal_bias": "0.05"},
    ...                      [{"time REAL": real(0.2), "solved BOOLEAN": boolean(True)}])
    >>> text = format_log(LogExperiment("walls", planners=[planner], time_limit=1.0))
    >>> "1; 0.2; " in text.splitlines()
    True
"""

from __future__ import annotations

import math
import platform
import socket
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

from temp_gym.files import atomic_write

PLANNER_STATUS = (
    "Unknown status",
    "Invalid start",
    "Invalid goal",
    "Unrecognized goal type",
    "Timeout",
    "Approximate solution",
    "Exact solution",
    "Crash",
    "Abort",
    "Infeasible",
)
"""OMPL's ``base::PlannerStatus`` names in the order of their values (the ``status ENUM``)."""
TIMEOUT = PLANNER_STATUS.index("Timeout")
EXACT_SOLUTION = PLANNER_STATUS.index("Exact solution")
CRASH = PLANNER_STATUS.index("Crash")

TYPES = ("REAL", "INTEGER", "BOOLEAN", "ENUM", "STRING")
"""The types a property name may end with (the column types of the database)."""
SEPARATORS = ("; ", "\n", "\r", ",", ";")
"""What no run or progress value may hold: the format's separators."""


def real(value: float | None) -> str:
    """A REAL value as OMPL writes one: shortest round-trip digits, ``inf``, ``nan``."""
    if value is None:
        return ""
    value = float(value)
    if math.isnan(value):
        return "nan"
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return repr(value)


def boolean(value: bool) -> str:
    """A BOOLEAN value as OMPL writes one (``std::to_string(bool)``): ``1`` or ``0``."""
    return "1" if value else "0"


def header_number(value: float) -> str:
    """A header number as a C++ stream prints a double by default (6 significant digits)."""
    return f"{float(value):g}"


@dataclass
class LogPlanner:
    """One planner's block of a log."""

    name: str
    """The planner's name, a line of its own (OMPL's are ``geometric_RRTstar`` and alike)."""
    common: dict[str, str] = field(default_factory=dict)
    """Its settings: name -> value, written sorted by name."""
    runs: list[dict[str, str]] = field(default_factory=list)
    """One dictionary per run: ``"<property name> <TYPE>"`` -> value (`real`, `boolean`)."""
    progress: list[list[dict[str, str]]] | None = None
    """Per run, its progress samples (``"time REAL"`` -> value, ...); None: no progress."""

    def run_properties(self) -> list[str]:
        """Every property any run has, sorted (the column order of the rows)."""
        return sorted({name for run in self.runs for name in run})

    def progress_properties(self) -> list[str]:
        """Every property of any progress sample, sorted."""
        samples = (sample for run in self.progress or () for sample in run)
        return sorted({name for sample in samples for name in sample})


@dataclass
class LogExperiment:
    """One experiment: what one log file holds."""

    name: str
    """Experiment name; a single word (the readers keep the line's last word)."""
    planners: list[LogPlanner] = field(default_factory=list)
    properties: dict[str, str] = field(default_factory=dict)
    """Experiment properties: ``"<name> <TYPE>"`` -> value (one word per name)."""
    version: str = "temp-gym 0.0.0"
    """``<library> <version>``: the first line reads ``<library> version <version>``."""
    host: str = field(default_factory=socket.gethostname)
    start: datetime = field(default_factory=datetime.now)
    setup: str = ""
    """Free text describing the problem and the planners (the setup block)."""
    cpu_info: str = field(default_factory=platform.processor)
    seed: int = 0
    time_limit: float = 0.0
    """Seconds per run."""
    memory_limit: float = 0.0
    """MB per run (0: none enforced)."""
    run_count: int = 0
    """Runs per planner."""
    total_time: float = 0.0
    """Seconds spent to collect the data."""


def _check_name(text: str, what: str) -> None:
    if not text or any(c.isspace() for c in text):
        raise ValueError(f"{what}: expected one word without spaces, got {text!r}")


def _check_property(name: str, what: str) -> None:
    words = name.split()
    if len(words) < 2 or words[-1] not in TYPES or " ".join(words) != name:
        raise ValueError(f"{what}: expected '<name> <TYPE>' with TYPE in {TYPES}, got {name!r}")


def _check_value(value: str, what: str, separators: tuple[str, ...] = SEPARATORS) -> None:
    if any(separator in value for separator in separators):
        raise ValueError(f"{what}: {value!r} holds a separator of the log format")


def _block(text: str) -> str:
    """A ``<<<|`` ... ``|>>>`` block; its text ends with a line break, as OMPL's do."""
    if any(line.startswith("|>>>") for line in text.splitlines()):
        raise ValueError("setup: a line may not start with '|>>>', which ends the block")
    body = text if not text or text.endswith("\n") else text + "\n"
    return f"<<<|\n{body}|>>>\n"


def format_log(experiment: LogExperiment) -> str:
    """The text of ``experiment``'s log, line for line as OMPL's Benchmark writes it.

    Raises:
        ValueError: a name with spaces, a property without a type, a value holding a
            separator, or a planner whose progress list does not have one entry per run.
    """
    _check_name(experiment.name, "experiment name")
    library, _, version = experiment.version.partition(" ")
    _check_name(library, "version")
    lines = [f"{library} version {version}", f"Experiment {experiment.name}"]
    lines.append(f"{len(experiment.properties)} experiment properties")
    for name, value in experiment.properties.items():
        _check_property(name, "experiment property")
        _check_name(name.split()[0], "experiment property")
        _check_value(value, f"experiment property {name}", ("\n", "\r", " = "))
        lines.append(f"{name} = {value}")
    lines += [
        f"Running on {experiment.host or 'UNKNOWN'}",
        f"Starting at {experiment.start.isoformat()}",
    ]
    text = "\n".join(lines) + "\n" + _block(experiment.setup) + _block(experiment.cpu_info)
    lines = [
        f"{int(experiment.seed)} is the random seed",
        f"{header_number(experiment.time_limit)} seconds per run",
        f"{header_number(experiment.memory_limit)} MB per run",
        f"{int(experiment.run_count)} runs per planner",
        f"{header_number(experiment.total_time)} seconds spent to collect the data",
        "1 enum type",
        "|".join(("status", *PLANNER_STATUS)),
        f"{len(experiment.planners)} planners",
    ]
    for planner in experiment.planners:
        lines += _planner_lines(planner)
    return text + "\n".join(lines) + "\n"


def _table_head(names: list[str], what: str, label: str, runs: int) -> list[str]:
    """A table's header lines: ``"<n> <label> for each run"``, the names, ``"<runs> runs"``."""
    for name in names:
        _check_property(name, what)
    return [f"{len(names)} {label} for each run", *names, f"{runs} runs"]


def _planner_lines(planner: LogPlanner) -> list[str]:
    if not planner.name.strip() or "\n" in planner.name:
        raise ValueError(f"planner name: expected one non-empty line, got {planner.name!r}")
    lines = [planner.name, f"{len(planner.common)} common properties"]
    for name in sorted(planner.common):
        _check_value(planner.common[name], f"{planner.name} setting {name}", ("\n", "\r"))
        lines.append(f"{name} = {planner.common[name]}")
    properties = planner.run_properties()
    lines += _table_head(properties, f"{planner.name} run property", "properties",
                         len(planner.runs))  # fmt: skip
    for run in planner.runs:
        for name, value in run.items():
            _check_value(value, f"{planner.name} {name}")
        lines.append("".join(f"{run.get(name, '')}; " for name in properties))
    if planner.progress is not None:
        if len(planner.progress) != len(planner.runs):
            raise ValueError(
                f"{planner.name} progress: expected one entry per run ({len(planner.runs)}), "
                f"got {len(planner.progress)}"
            )
        names = planner.progress_properties()
        lines += _table_head(names, f"{planner.name} progress property",
                             "progress properties", len(planner.progress))  # fmt: skip
        for samples in planner.progress:
            row = ""
            for sample in samples:
                for name in names:
                    _check_value(sample.get(name, ""), f"{planner.name} progress {name}")
                row += "".join(f"{sample.get(name, '')}," for name in names) + ";"
            lines.append(row)
    lines.append(".")
    return lines


def write_log(experiment: LogExperiment, path: str | Path) -> Path:
    """Write ``experiment``'s log to ``path`` atomically (`format_log`); returns the path."""
    text = format_log(experiment)
    with atomic_write(path, "w") as handle:
        handle.write(text)
    return Path(path)


__all__ = [
    "CRASH",
    "EXACT_SOLUTION",
    "PLANNER_STATUS",
    "TIMEOUT",
    "LogExperiment",
    "LogPlanner",
    "boolean",
    "format_log",
    "real",
    "write_log",
]
