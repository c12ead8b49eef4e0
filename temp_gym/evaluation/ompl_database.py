"""Benchmark logs into the SQLite database that Planner Arena (plannerarena.org) loads.

The schema and the values are those of OMPL's ``ompl_benchmark_statistics.py``: tables
``experiments`` (one row per log), ``plannerConfigs`` (a planner's name and its common
properties as one text), ``enums`` (the status names), ``runs`` (one column per run property,
named by its words joined with ``_``: ``best cost REAL`` is ``best_cost``) and ``progress``
(``runid``, ``time`` and the other progress properties). Values go in as the log's text, so
SQLite's column affinity stores them as OMPL's script does; empty, ``nan`` and ``inf`` values
are NULL. Logs of OMPL's own Benchmark read the same way, so a database can join both.

This reader needs no OMPL; with OMPL's Python package installed, its script gives the same
tables (``ompl_benchmark_statistics -d benchmark.db logs/*.log``).

Example:
    >>> logs_to_database(["results/bench/logs/walls.log"], "results/bench/benchmark.db")
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterable
from pathlib import Path

from temp_gym.limits import MAX_PROBLEM_BYTES

SCHEMA = """
CREATE TABLE IF NOT EXISTS experiments
    (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512), totaltime REAL, timelimit REAL,
     memorylimit REAL, runcount INTEGER, version VARCHAR(128), hostname VARCHAR(1024),
     cpuinfo TEXT, date DATETIME, seed VARCHAR(24), setup TEXT);
CREATE TABLE IF NOT EXISTS plannerConfigs
    (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512) NOT NULL, settings TEXT);
CREATE TABLE IF NOT EXISTS enums
    (name VARCHAR(512), value INTEGER, description TEXT, PRIMARY KEY (name, value));
CREATE TABLE IF NOT EXISTS runs
    (id INTEGER PRIMARY KEY AUTOINCREMENT, experimentid INTEGER, plannerid INTEGER,
     FOREIGN KEY (experimentid) REFERENCES experiments(id) ON DELETE CASCADE,
     FOREIGN KEY (plannerid) REFERENCES plannerConfigs(id) ON DELETE CASCADE);
CREATE TABLE IF NOT EXISTS progress
    (runid INTEGER, time REAL, PRIMARY KEY (runid, time),
     FOREIGN KEY (runid) REFERENCES runs(id) ON DELETE CASCADE);
"""
"""The tables of ``ompl_benchmark_statistics.py``; columns of properties are added per log."""
MAX_LOG_BYTES = 64 * MAX_PROBLEM_BYTES
"""The largest log read (a log of many runs with progress is megabytes, not gigabytes)."""


class LogFormatError(ValueError):
    """A log that is not in OMPL's benchmark format; the message names the file and line."""


class _Lines:
    """The log's lines with a cursor, for one-line errors naming the line."""

    def __init__(self, path: Path, text: str) -> None:
        self.path = path
        self.lines = text.split("\n")
        self.index = 0

    def peek(self) -> str:
        return self.lines[self.index] if self.index < len(self.lines) else ""

    def next(self) -> str:
        if self.index >= len(self.lines):
            self.fail("ends early")
        line = self.lines[self.index]
        self.index += 1
        return line

    def fail(self, reason: str) -> None:
        raise LogFormatError(f"{self.path}: line {self.index + 1}: {reason}")

    def counted(self, suffix: str) -> int:
        """The leading count of a ``<n> <suffix>`` line."""
        line = self.next()
        count, _, rest = line.partition(" ")
        if rest != suffix or not count.isdigit():
            self.fail(f"expected '<count> {suffix}', got {line[:80]!r}")
        return int(count)

    def ending(self, suffix: str) -> str:
        """The first word of a ``<value> <suffix>`` line."""
        line = self.next()
        value, _, rest = line.partition(" ")
        if rest != suffix:
            self.fail(f"expected '<value> {suffix}', got {line[:80]!r}")
        return value

    def block(self) -> str:
        """The text between a ``<<<|`` line and a line starting with ``|>>>``."""
        if not self.next().startswith("<<<|"):
            self.fail("expected '<<<|'")
        body = []
        while not self.peek().startswith("|>>>"):
            body.append(self.next() + "\n")
        self.next()
        return "".join(body)


def _value(text: str) -> str | None:
    return None if text in ("", "nan", "inf") else text


def _column(property_line: str) -> tuple[str, str]:
    words = property_line.split()
    return "_".join(words[:-1]), words[-1]


def _add_columns(cursor: sqlite3.Cursor, table: str, columns: list[tuple[str, str]]) -> None:
    cursor.execute(f"PRAGMA table_info({table})")
    known = {row[1] for row in cursor.fetchall()}
    for name, kind in columns:
        if name not in known:
            cursor.execute(f'ALTER TABLE {table} ADD "{name}" {kind}')
            known.add(name)


def _read_experiment(cursor: sqlite3.Cursor, lines: _Lines) -> None:
    first = lines.peek().split()
    version = "OMPL 0.0.0"
    if len(first) >= 3 and first[1] == "version":
        lines.next()
        version = f"{first[0]} {first[-1]}"
    line = lines.next()
    if not line.startswith("Experiment "):
        lines.fail(f"expected 'Experiment <name>', got {line[:80]!r}")
    name = line.split()[-1]
    properties = {}
    if lines.peek().endswith(" experiment properties"):
        for _ in range(lines.counted("experiment properties")):
            key, _, value = lines.next().strip().partition(" = ")
            words = key.split()
            properties["".join(words[:-1]).replace("-", "_")] = (value, words[-1])
    _add_columns(cursor, "experiments", [(key, properties[key][1]) for key in sorted(properties)])
    line = lines.next()
    if not line.startswith("Running on "):
        lines.fail(f"expected 'Running on <host>', got {line[:80]!r}")
    host = line.split()[-1]
    line = lines.next()
    if not line.startswith("Starting at"):
        lines.fail(f"expected 'Starting at <date>', got {line[:80]!r}")
    date = " ".join(line.split()[2:])
    setup = lines.block()
    cpu_info = lines.block() if lines.peek().startswith("<<<|") else None
    seed = lines.ending("is the random seed")
    time_limit = float(lines.ending("seconds per run"))
    memory_limit = float(lines.ending("MB per run"))
    run_count = -1
    if lines.peek().endswith(" runs per planner"):
        run_count = int(lines.ending("runs per planner"))
    total_time = float(lines.ending("seconds spent to collect the data"))
    if lines.peek().endswith(" enum type") or lines.peek().endswith(" enum types"):
        words = lines.next().split()
        for _ in range(int(words[0])):
            enum, *descriptions = lines.next().split("|")
            cursor.execute("SELECT 1 FROM enums WHERE name = ?", (enum,))
            if cursor.fetchone() is None:
                cursor.executemany(
                    "INSERT INTO enums VALUES (?, ?, ?)",
                    [(enum, value, text) for value, text in enumerate(descriptions)],
                )
    columns = ["name", "totaltime", "timelimit", "memorylimit", "runcount", "version",
               "hostname", "cpuinfo", "date", "seed", "setup", *properties]  # fmt: skip
    values = [name, total_time, time_limit, memory_limit, run_count, version, host, cpu_info,
              date, seed, setup, *(value for value, _ in properties.values())]  # fmt: skip
    cursor.execute(
        f"INSERT INTO experiments ({', '.join(columns)}) VALUES ({', '.join('?' * len(values))})",
        values,
    )
    experiment = cursor.lastrowid
    for _ in range(lines.counted("planners")):
        _read_planner(cursor, lines, experiment)


def _read_planner(cursor: sqlite3.Cursor, lines: _Lines, experiment: int) -> None:
    name = lines.next()
    settings = "".join(lines.next() + "\n;" for _ in range(lines.counted("common properties")))
    cursor.execute(
        "SELECT id FROM plannerConfigs WHERE name = ? AND settings = ?", (name, settings)
    )
    row = cursor.fetchone()
    if row is None:
        cursor.execute("INSERT INTO plannerConfigs VALUES (?, ?, ?)", (None, name, settings))
        planner = cursor.lastrowid
    else:
        planner = row[0]
    columns = [_column(lines.next()) for _ in range(lines.counted("properties for each run"))]
    _add_columns(cursor, "runs", columns)
    names = ", ".join(["experimentid", "plannerid", *(f'"{c}"' for c, _ in columns)])
    insert = f"INSERT INTO runs ({names}) VALUES ({', '.join('?' * (len(columns) + 2))})"
    runs = []
    for _ in range(lines.counted("runs")):
        values = lines.next().split("; ")[:-1]
        if len(values) != len(columns):
            lines.fail(f"expected {len(columns)} values, got {len(values)}")
        cursor.execute(insert, [experiment, planner, *map(_value, values)])
        runs.append(cursor.lastrowid)
    line = lines.next().strip()
    if line == ".":
        return
    lines.index -= 1
    count = lines.counted("progress properties for each run")
    columns = [_column(lines.next()) for _ in range(count)]
    _add_columns(cursor, "progress", columns)
    names = ", ".join(["runid", *(f'"{c}"' for c, _ in columns)])
    marks = ", ".join("?" * (len(columns) + 1))
    insert = f"INSERT OR IGNORE INTO progress ({names}) VALUES ({marks})"
    count = lines.counted("runs")
    if count != len(runs):
        lines.fail(f"expected progress of {len(runs)} runs, got {count}")
    for run in runs:
        for sample in lines.next().split(";")[:-1]:
            values = sample.split(",")[:-1]
            if len(values) != len(columns):
                lines.fail(f"expected {len(columns)} progress values, got {len(values)}")
            cursor.execute(insert, [run, *map(_value, values)])
    if lines.next().strip() != ".":
        lines.fail("expected '.' after the progress rows")


def logs_to_database(logs: Iterable[str | Path], database: str | Path) -> Path:
    """Read benchmark ``logs`` into the SQLite file ``database`` (appending to its tables).

    Raises:
        LogFormatError: a log not in the format, naming the file and the line.
    """
    database = Path(database)
    connection = sqlite3.connect(database)
    try:
        cursor = connection.cursor()
        cursor.execute("PRAGMA FOREIGN_KEYS = ON")
        cursor.executescript(SCHEMA)
        for log in logs:
            path = Path(log)
            if path.stat().st_size > MAX_LOG_BYTES:
                raise LogFormatError(f"{path}: larger than a log may be ({MAX_LOG_BYTES:,} bytes)")
            try:
                _read_experiment(cursor, _Lines(path, path.read_text(encoding="utf-8")))
            except (ValueError, IndexError) as error:  # a number that is not one, a short line
                if isinstance(error, LogFormatError):
                    raise
                raise LogFormatError(f"{path}: not a benchmark log ({error})") from None
        connection.commit()
    finally:
        connection.close()
    return database


__all__ = ["SCHEMA", "LogFormatError", "logs_to_database"]
