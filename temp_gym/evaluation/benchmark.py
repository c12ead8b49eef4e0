"""Benchmark registered planners over a problem set: resumable runs, one record per run.

A work unit is one run: a planner on a problem with its own seed, stopped by the time limit
(or a node budget high enough that the time limit ends it), or at its first solution with
``stop_at_first``. Runs go to local processes or Ray (`temp_gym.distributed`); the driver
appends each record, as it arrives, to ``{out}/runs.jsonl`` (one JSON object per line,
flushed and fsynced), so a killed benchmark loses at most the runs in flight. The same
command again skips every stored run and duplicates none; a line cut short by the kill is
dropped. ``{out}/benchmark.json`` holds the settings every run shares (time limit, node
budget, seed, ``stop_at_first``, ``simplify``): a rerun with others stops with an error instead
of mixing runs. Planners and runs per problem may grow between reruns.

A run counts as solved only when its path passes the exact checker here, whatever the planner
reported: it starts at the start, ends in the goal region, and `certify_path` (the exact
checker, self-collision and joint limits included for an arm) accepts every state and
motion. A run that raises is recorded as a crash, as OMPL's Benchmark records one, and is run
again by the next rerun.

Each run starts on a workspace the planners have forgotten (`forget_workspace`), so every run
pays the per-workspace set-up as a user's first plan there does; `plan` compiles its kernels
before the clock starts. Seeds: run ``r`` of problem ``name`` gets
``SeedSequence([seed, crc32(name), r])``, the same for every planner, whatever other
problems the set holds.

`temp_gym.evaluation.benchmark_report` turns the records into OMPL benchmark logs, the
database, the summary and the plots; `temp_gym.evaluation.benchmark_command` is
``temp-benchmark``.
"""

from __future__ import annotations

import functools
import json
import math
import os
import socket
import time
import zlib
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.config import differing_keys
from temp_gym.evaluation.benchmark_problems import NamedProblem, problem_digest
from temp_gym.files import DirectoryLock, StoredFileError, read_json, write_json_atomic
from temp_gym.jobs import JobError, one_line, progress_line, report
from temp_gym.problem import Problem

RECORDS = "runs.jsonl"
MANIFEST = "benchmark.json"
FORMAT = "temp-gym benchmark"
RECORD_VERSION = 1
"""What a record means; bumped when a change alters what a stored run holds."""
DEFAULT_MAX_NODES = 1_000_000
"""The node budget of a run: high enough that the time limit ends it."""
REMEDY = "delete the file (every run is then done again) or choose another output folder"


@dataclass(frozen=True)
class BenchmarkSettings:
    """What every run of a benchmark shares, and which planners run how often."""

    planners: tuple[str, ...]
    """Registered planner names (`temp_gym.planning.PLANNERS`)."""
    time_limit: float = 10.0
    """Seconds per run."""
    runs: int = 10
    """Runs per planner and problem."""
    seed: int = 0
    """Seed of the runs' seeds."""
    max_nodes: int = DEFAULT_MAX_NODES
    """Node budget per run."""
    stop_at_first: bool = False
    """End each run at its first solution (for time to a first solution), not the time limit."""
    simplify: bool = False
    """Simplify each solved run's path (`temp_gym.planning.simplify`), as OMPL's Benchmark does
    when asked: the run's time, cost and path states stay the planner's, and the record adds
    the simplified path's length, states and the simplification's time."""
    checkpoint: str | None = None
    """A trained policy file (`trainers/bc.py`'s ``best.pt``) for the ``temp`` planner; None:
    each robot's shipped policy. Stored as an absolute path; the manifest keeps its content's
    digest, so that a resume with another policy is refused."""

    def __post_init__(self) -> None:
        from temp_gym.planning.plan import PLANNERS  # the built-in planners registered
        from temp_gym.planning.settings import count, flag, seed_value

        planners = tuple(self.planners)
        if not planners:
            raise ValueError("planners: expected at least one planner")
        for name in planners:
            if name not in PLANNERS:
                raise ValueError(
                    f"planners: unknown planner {name!r}; expected some of {sorted(PLANNERS)}"
                )
        if len(set(planners)) != len(planners):
            raise ValueError(f"planners: a planner is named twice in {list(planners)}")
        object.__setattr__(self, "planners", planners)
        limit = self.time_limit
        if (
            isinstance(limit, bool)
            or not isinstance(limit, (int, float))
            or not (math.isfinite(limit) and limit > 0)
        ):
            raise ValueError(f"time_limit: expected a positive number of seconds, got {limit!r}")
        object.__setattr__(self, "time_limit", float(limit))
        object.__setattr__(self, "runs", count(self.runs, "runs"))
        object.__setattr__(self, "seed", seed_value(self.seed))
        object.__setattr__(self, "max_nodes", count(self.max_nodes, "max_nodes"))
        object.__setattr__(self, "stop_at_first", flag(self.stop_at_first, "stop_at_first"))
        object.__setattr__(self, "simplify", flag(self.simplify, "simplify"))
        if self.checkpoint is not None:
            if not isinstance(self.checkpoint, (str, os.PathLike)):
                raise ValueError(f"checkpoint: expected a file path, got {self.checkpoint!r}")
            if "temp" not in planners:
                raise ValueError("checkpoint: a policy for the temp planner, which is not among "
                                 f"the planners {list(planners)}")  # fmt: skip
            path = os.path.abspath(os.fspath(self.checkpoint))
            if not os.path.isfile(path):
                raise ValueError(f"checkpoint: no such file: {self.checkpoint}")
            object.__setattr__(self, "checkpoint", path)

    def manifest(self) -> dict[str, Any]:
        """What ``benchmark.json`` holds: the settings a stored run depends on."""
        shared = asdict(self)
        del shared["planners"], shared["runs"]  # may grow between reruns
        checkpoint = shared.pop("checkpoint")
        for name in ("stop_at_first", "simplify"):  # off: as stored before the setting existed
            if not shared[name]:
                del shared[name]
        if checkpoint is not None:  # the policy, wherever its file lies
            from temp_gym.models.snapshot import file_digest

            shared["checkpoint"] = file_digest(checkpoint)
        return {"format": FORMAT, "record_version": RECORD_VERSION, **shared}


def run_seed(seed: int, problem: str, run: int) -> int:
    """The seed of run ``run`` on the problem named ``problem``, the same for every planner."""
    sequence = np.random.SeedSequence([seed, zlib.crc32(problem.encode()), run])
    return int(sequence.generate_state(1)[0])


def reaches_goal(problem: Problem, path: np.ndarray) -> bool:
    """Whether ``path`` starts at the start and ends in the goal region (a closed ball)."""
    return problem.path_ends_error(path) is None


@functools.lru_cache(maxsize=4)
def _loaded_policy(path: str):
    from temp_gym.models.registry import policy_from_checkpoint

    return policy_from_checkpoint(path)


def checkpoint_policy(path: str, problem: Problem | None = None):
    """The policy of the checkpoint at ``path``, loaded once per process.

    Loaded as `temp-plan` loads it, with the planner settings it carries.

    Raises:
        ValueError: it was trained for another robot than ``problem``'s (one line).
    """
    from temp_gym.planning.policy import check_compatible

    policy = _loaded_policy(path)
    if problem is not None:
        check_compatible(policy.robot, policy.dim, problem.robot, problem.dim,
                         f"checkpoint {path}")  # fmt: skip
    return policy


def run_once(job: tuple[str, Problem, str, int, int, BenchmarkSettings]) -> dict[str, Any]:
    """One run's record: `plan`, then the exact checker's verdict on its path."""
    import temp_gym  # noqa: F401  (the temp planner's default, the shipped policy, comes with it)
    from temp_gym.planning.plan import plan
    from temp_gym.planning.tree import forget_workspace
    from temp_gym.worlds.checkers import certify_path

    name, problem, planner, run, seed, settings = job
    record: dict[str, Any] = {"problem": name, "digest": problem_digest(problem),
                              "planner": planner, "run": run, "seed": seed,
                              "host": socket.gethostname()}  # fmt: skip
    forget_workspace(problem.workspace)
    started = time.perf_counter()
    try:
        options = {}
        if planner == "temp" and settings.checkpoint is not None:
            options["policy"] = checkpoint_policy(settings.checkpoint, problem)
        result = plan(problem, planner, seed=seed, time_limit=settings.time_limit,
                      max_nodes=settings.max_nodes, stop_at_first=settings.stop_at_first,
                      simplify=settings.simplify, **options)  # fmt: skip
    except Exception as error:  # recorded as OMPL's Benchmark records a crash; rerun later
        return {**record, "status": "crash", "solved": False, "error": one_line(error),
                "time": time.perf_counter() - started, "finished": time.time()}  # fmt: skip
    path = None if result.path is None else np.asarray(result.path, dtype=np.float64)
    certified = bool(
        result.success and path is not None and reaches_goal(problem, path)
        and certify_path(problem, path)
    )  # fmt: skip
    history = {key: np.asarray(value).tolist() for key, value in result.history.items()}
    # With simplification the planner's own figures stay the run's, as OMPL's Benchmark keeps
    # them, and the simplified path's are added.
    own = result.simplification
    if certified and own is not None:
        record.update(simplified_cost=float(result.cost), simplified_states=len(path),
                      simplification_time=float(own["time"]))  # fmt: skip
    first = certified and result.time_to_first_solution is not None and history.get("best_cost")
    record.update(
        status="solved" if certified else ("uncertified" if result.success else "unsolved"),
        solved=certified,
        time=float(result.wall_time - (own["time"] if own else 0.0)),
        first_time=float(result.time_to_first_solution) if first else None,
        first_cost=float(history["best_cost"][0]) if first else None,
        first_nodes=result.nodes_to_first_solution if first else None,
        cost=float(own["cost"] if own else result.cost) if certified else None,
        path_states=int(own["waypoints"] if own else len(path)) if certified else None,
        nodes=int(result.nodes),
        samples=int(result.samples),
        collision_checks=int(result.collision_checks),
        sampling_failures=int(result.sampling_failures),
        certification_failures=int(result.certification_failures),
        history=history if certified else {},
        finished=time.time(),
    )
    return record


def check_manifest(out: str | Path, settings: BenchmarkSettings, write: bool = False) -> None:
    """Refuse an ``out`` whose stored runs had other shared settings (`JobError`).

    With ``write``, a folder without a manifest gets one.
    """
    path = Path(out) / MANIFEST
    manifest = settings.manifest()
    if not path.exists():
        if write:
            write_json_atomic(path, manifest)
        return
    differ = differing_keys(read_json(path, REMEDY), manifest)
    if differ:
        raise JobError(
            f"{out} holds runs of a benchmark with other settings (differs in: "
            f"{', '.join(differ)}); resuming would mix them. Delete it or choose another "
            "output folder."
        )


def read_records(path: str | Path, repair: bool = False) -> list[dict[str, Any]]:
    """The records stored in ``path`` (none if it is missing).

    A last line cut short (a kill while writing) is dropped; with ``repair`` it is also cut
    from the file, so that the next record starts on a line of its own.

    Raises:
        StoredFileError: a damaged line before the last.
    """
    path = Path(path)
    if not path.exists():
        return []
    data = path.read_bytes()
    complete = data[: data.rfind(b"\n") + 1]  # a line without its "\n" was cut short
    records = []
    for number, line in enumerate(complete.split(b"\n")[:-1], 1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except ValueError:
            record = None
        if not isinstance(record, dict):
            raise StoredFileError(path, f"line {number} is damaged", REMEDY)
        records.append(record)
    if repair and len(complete) < len(data):
        with open(path, "r+b") as handle:
            handle.truncate(len(complete))
    return records


def _append(handle, record: dict[str, Any]) -> None:
    handle.write(json.dumps(record, allow_nan=False) + "\n")
    handle.flush()
    os.fsync(handle.fileno())


def run_benchmark(
    problems: Sequence[NamedProblem],
    settings: BenchmarkSettings,
    out: str | Path,
    workers: int = 1,
    backend: str = "local",
    address: str | None = None,
    progress: bool = True,
) -> list[dict[str, Any]]:
    """Run every missing run of every planner on ``problems``; return their records.

    The records come in the order problem, run, planner; stored ones are reused.

    Raises:
        JobError: ``out`` holds runs of other settings, or of another problem under a name
            of ``problems``, or is in use by another benchmark.
    """
    from tqdm import tqdm

    from temp_gym.distributed import map_units

    out = Path(out)
    lock = DirectoryLock(out, "benchmarking")
    lock.acquire()
    try:
        check_manifest(out, settings, write=True)
        stored: dict[tuple[str, str, int], dict[str, Any]] = {}
        for record in read_records(out / RECORDS, repair=True):
            if record.get("status") != "crash":
                stored[(record["problem"], record["planner"], record["run"])] = record
        digests = {name: problem_digest(problem) for name, problem in problems}
        for (name, _, _), record in stored.items():
            if name in digests and record.get("digest") != digests[name]:
                raise JobError(
                    f"{out / RECORDS} holds runs of another problem named {name!r}; "
                    "rename the problem, or choose another output folder"
                )
        keys, jobs = [], []
        for name, problem in problems:
            for run in range(settings.runs):
                seed = run_seed(settings.seed, name, run)
                for planner in settings.planners:
                    keys.append((name, planner, run))
                    if keys[-1] not in stored:
                        jobs.append((name, problem, planner, run, seed, settings))
        report(progress_line(len(keys) - len(jobs), len(keys), "runs"))
        bar = tqdm(total=len(keys), initial=len(keys) - len(jobs), desc="benchmarking",
                   disable=not progress)  # fmt: skip
        with bar, open(out / RECORDS, "a", encoding="utf-8") as handle:
            for _, record in map_units(run_once, jobs, backend, workers, address):
                _append(handle, record)
                stored[(record["problem"], record["planner"], record["run"])] = record
                if record["status"] == "crash":
                    bar.write(f"{record['planner']} crashed on {record['problem']}: "
                              f"{record['error']}")  # fmt: skip
                bar.update()
        return [stored[key] for key in keys if key in stored]
    finally:
        lock.release()


__all__ = [
    "DEFAULT_MAX_NODES",
    "BenchmarkSettings",
    "check_manifest",
    "read_records",
    "reaches_goal",
    "run_benchmark",
    "run_once",
    "run_seed",
]
