"""Running the evaluation protocol over a test set: resumable, in parallel over processes.

Work unit = one test task. Its record (TEMP's first solution as a user gets it: from the
attention phase, or from classical planning on the same tree once the attention phase stalled,
with ``attention_solved`` saying which; every baseline's time
and nodes to the tolerance cost, and optionally fixed-budget anytime histories for the cost
curves) is written atomically by the driver to ``{out}/tasks/{group}-{index:04d}.json``; a
rerun of the same command skips finished tasks, so a killed evaluation loses nothing and
duplicates nothing. Tasks run on local processes or on Ray (`temp_gym.distributed`).

A record holds the task's wall time (``task_time``), from which a resumed run estimates the
rest; the output directory is locked while a run writes to it (`temp_gym.files.DirectoryLock`).

Records only mix with records of the same run: ``{out}/run.json`` (the manifest) holds the
evaluation settings, `TEST_SET_VERSION` and what the caller adds (`trainers/evaluate.py`: the
checkpoint's weights digest and the policy settings). A rerun whose manifest differs stops
with an error naming the keys, instead of resuming another run's records.

Test tasks come from the ``test`` workspace pool (`temp_gym.worlds.splits`), never seen in
training: task ``i`` of a group lives in workspace ``i mod 50`` and is drawn from its own
generator, so a task can be recomputed alone.
"""

from __future__ import annotations

import functools
import json
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.config import differing_keys
from temp_gym.evaluation.protocol import TAU, reach_tolerance, tolerance_target
from temp_gym.files import (
    DirectoryLock,
    jsonable,
    read_json,
    remove_leftovers,
    write_json_atomic,
)
from temp_gym.jobs import JobError, estimate_line, progress_line, report
from temp_gym.planning.plan import plan
from temp_gym.planning.temp_settings import TEMPSettings
from temp_gym.planning.tree import forget_workspace
from temp_gym.planning.warmup import WARM_UP_NODES
from temp_gym.problem import Problem
from temp_gym.worlds.generators import generate_task
from temp_gym.worlds.splits import SPLITS, split_workspace
from temp_gym.worlds.structured import BOXES

EVAL_ENTROPY = 7_000_001
TEST_SET_VERSION = 3
"""Bumped whenever a code change alters which test tasks are drawn (kept in the manifest).
2: iiwa starts and goals keep a clearance of half the edge resolution (the arm's generator).
3: iiwa self-collision is checked, with that clearance between links, and the sphere model
covers the links' convex hulls (7D test tasks only; 2D and 3D are unchanged)."""
_DIFFICULTY_CODES = {"any": 0, "easy": 1, "challenging": 2}


@dataclass(frozen=True)
class EvaluationSettings:
    """What to run; every field is a key of the config's ``evaluation`` section."""

    robot: str
    groups: dict[str, tuple[str, int]]
    """Row name -> (difficulty, number of tasks), e.g. ``{"2D easy": ("easy", 100)}``."""
    baselines: tuple[str, ...] = ("rrt_star", "informed_rrt_star")
    """Planners compared with TEMP (``ompl_*`` need the ompl extra)."""
    tau: float = TAU
    """Cost tolerance."""
    max_nodes: int = 5000
    """Node budget of every run."""
    time_limit: float = 30.0
    """Seconds per run."""
    temp: dict[str, Any] = field(default_factory=dict)
    """TEMP's own settings for every TEMP run: fields of `temp_gym.planning.TEMPSettings`
    beyond the common ones (its policy aside); absent or None: the policy's own, else the
    planner's defaults."""
    curve_tasks: int = 10
    """Per group, how many tasks also get fixed-budget runs for the cost-vs-nodes curves."""
    curve_nodes: int = 2000
    """Node budget of those runs."""
    seed: int = 0
    """Seed of the test set and the planners."""
    warm_runs: bool = True
    """Before each timed run, the planner first plans `warm_up_problem` briefly, untimed
    (`warm_run`), so that every timed run starts as a user's loop of ``plan`` calls starts
    it: the planner's code and data in the CPU's caches. Without it the order biases the
    times: TEMP, first on each task, starts right after the previous task's OMPL runs, and
    each baseline right after another planner ran the same tree kernels on the same
    workspace. It fills no per-workspace cache a timed run reads (the occupancy grid, the
    EISE encoding, the free volume): the warm-up problem is in a workspace no test task
    uses. Those caches are ``fresh_workspaces``' concern."""
    fresh_workspaces: bool = True
    """Before each timed run, what the planners keep per workspace is forgotten for the
    task's workspace, so that every timed run pays its set-up as a user's first plan on a
    new workspace does: `Tree`'s free volume and its floor
    (`temp_gym.planning.tree.forget_workspace`), and a policy's encoding of it when the
    policy has ``forget_workspace`` (`TEMPPolicy`: the SEI and the occupancy grids). Without
    it only the first planner on a task, TEMP, pays the tree's set-up, the baselines find it
    cached, and TEMP finds its encoding cached when the same worker planned in that
    workspace before (test task ``i`` lives in workspace ``i mod 50``)."""
    workspace_family: str = BOXES
    """Workspace family of the test workspaces (`temp_gym.worlds.structured`); the manifest
    leaves out the default (`_recorded`)."""

    def temp_settings(self, policy: Any, **changes: Any) -> TEMPSettings:
        """Every TEMP run's settings: these budgets and seed, ``temp``, then ``changes``."""
        common = {"seed": self.seed, "max_nodes": self.max_nodes, "time_limit": self.time_limit}
        return TEMPSettings(**{**common, **self.temp, "policy": policy, **changes})


def evaluation_problem(
    robot: str, difficulty: str, index: int, seed: int = 0, family: str = BOXES
) -> Problem:
    """Task ``index`` of a test group: deterministic, independent of the other tasks.

    Its workspace is one of the ``test`` pool of ``family``; other families draw other tasks.
    """
    sequence = np.random.SeedSequence([EVAL_ENTROPY, seed, _DIFFICULTY_CODES[difficulty], index])
    rng = np.random.default_rng(sequence)
    pool = SPLITS["test"]
    for attempt in range(pool):
        workspace = split_workspace(robot, "test", (index + attempt) % pool, family)
        try:
            return generate_task(workspace, rng, difficulty)
        except RuntimeError:  # no task of that difficulty in this workspace: the next one
            continue
    raise RuntimeError(f"no {difficulty} test task found for {robot}")


@functools.lru_cache(maxsize=8)
def warm_up_problem(robot: str) -> Problem:
    """The problem of every warm run: an easy task in the first training workspace.

    Training workspaces are never test workspaces (`temp_gym.worlds.splits`), so a warm run
    fills no per-workspace cache that a timed run reads.
    """
    return generate_task(split_workspace(robot, "train", 0), np.random.default_rng(0), "easy")


def warm_run(planner: str, policy, settings: EvaluationSettings) -> None:
    """Plan `warm_up_problem` briefly with ``planner``, untimed (see ``warm_runs``).

    As short as `plan`'s own warm-up (`WARM_UP_NODES`, half attention-based for TEMP).
    """
    if not settings.warm_runs:
        return
    kwargs = {"policy": policy, "attention_nodes": WARM_UP_NODES // 2} if planner == "temp" else {}
    plan(
        warm_up_problem(settings.robot), planner=planner, seed=settings.seed,
        max_nodes=WARM_UP_NODES, **kwargs,
    )  # fmt: skip


def start_timed_run(planner: str, problem: Problem, policy, settings: EvaluationSettings) -> None:
    """What comes before each timed run: its warm run, then a fresh workspace.

    The settings' ``warm_runs`` and ``fresh_workspaces`` say which.
    """
    warm_run(planner, policy, settings)
    if settings.fresh_workspaces:
        forget_workspace(problem.workspace)
        forget_policy_workspace = getattr(policy, "forget_workspace", None)
        if forget_policy_workspace is not None:  # a TEMPPolicy: its SEI and grids
            forget_policy_workspace(problem.workspace)


def evaluate_task(
    problem: Problem, policy, settings: EvaluationSettings, with_curves: bool
) -> dict[str, Any]:
    """The record of one task: TEMP's AP figures and each baseline's figures at tolerance.

    Each timed run follows `start_timed_run`: a warm run of its planner (``warm_runs``), and
    the workspace's tree set-up forgotten (``fresh_workspaces``).
    """
    seed = settings.seed
    record: dict[str, Any] = {"problem": problem.to_dict(), "planners": {}}
    start_timed_run("temp", problem, policy, settings)
    temp = plan(problem, "temp", settings.temp_settings(policy, stop_at_first=True))
    attention = temp.attention
    solved = bool(temp.success and temp.time_to_first_solution is not None)
    record["planners"]["temp"] = {
        "success": solved,
        "time": temp.time_to_first_solution if solved else None,
        "nodes": temp.nodes_to_first_solution if solved else None,
        "cost": temp.cost if solved else None,
        "attention_solved": bool(attention["solved"]),
        "from_goal_solved": bool(attention.get("from_goal_solved", False)),
        "rounds_solved": bool(attention.get("rounds_solved", False)),
        "sampling_failures": attention["sampling_failures"],
    }
    if record["planners"]["temp"]["success"]:
        target = tolerance_target(temp.cost, settings.tau)
        record["target_cost"] = target
        for name in settings.baselines:
            start_timed_run(name, problem, None, settings)
            result = plan(
                problem, planner=name, seed=seed, max_nodes=settings.max_nodes,
                time_limit=settings.time_limit, target_cost=target,
            )  # fmt: skip
            reached = reach_tolerance(result.history, target)
            reached["sampling_failures"] = result.sampling_failures
            record["planners"][name] = reached
    if with_curves:
        record["curves"] = {}
        for name in ("temp", *settings.baselines):
            chosen = settings.temp_settings(policy) if name == "temp" else None
            result = plan(
                problem, name, chosen, seed=seed, max_nodes=settings.curve_nodes,
                time_limit=settings.time_limit,
            )  # fmt: skip
            record["curves"][name] = {k: np.asarray(v).tolist() for k, v in result.history.items()}
    return record


RECORD_JSON = {"indent": None, "sort_keys": False, "allow_nan": False}
"""How records and the manifest are written (`write_json_atomic`): compact, in their own key
order, NaN refused."""


RERUN_TASK = "delete it and rerun the same command: that task is evaluated again"


_POLICIES: dict[str, Any] = {}
"""Per worker process: the policy built by each ``make_policy`` (built once, reused)."""


def _run_job(job: tuple[EvaluationSettings, Callable[[], Any], str, str, int]) -> dict:
    settings, make_policy, group, difficulty, index = job
    key = repr(make_policy)
    problem = evaluation_problem(
        settings.robot, difficulty, index, settings.seed, settings.workspace_family
    )
    if key not in _POLICIES:  # plan() warms itself up before its first timed run
        _POLICIES[key] = make_policy()
    started = time.perf_counter()
    record = evaluate_task(problem, _POLICIES[key], settings, index < settings.curve_tasks)
    record.update({"group": group, "difficulty": difficulty, "index": index})
    record["task_time"] = time.perf_counter() - started
    return record


RECORD_VERSION = 2
"""What a record means; records of another version never mix. 2: TEMP's figures are the whole
planner's first solution (the attention phase hands over to Informed RRT* when it stalls, see
`temp_gym.planning.attention.default_patience`), no longer the attention phase's alone."""


def _recorded(settings: EvaluationSettings) -> dict[str, Any]:
    """The settings as the manifest holds them: the default family left out.

    Manifests written before the setting existed hold none, so that those runs still resume.
    """
    recorded = asdict(settings)
    if recorded["workspace_family"] == BOXES:
        del recorded["workspace_family"]
    return recorded


class ManifestMismatchError(JobError, ValueError):
    """An output directory holds the records of an evaluation with another manifest."""


def _check_manifest(out_dir: Path, manifest: dict[str, Any]) -> None:
    """Write ``run.json`` on a first run; on a rerun, raise if it describes another run."""
    path = out_dir / "run.json"
    manifest = json.loads(json.dumps(manifest, default=jsonable))  # tuples -> lists, as stored
    if not path.exists():
        out_dir.mkdir(parents=True, exist_ok=True)
        write_json_atomic(path, manifest, **RECORD_JSON)
        return
    stored = read_json(
        path,
        "it records which checkpoint and settings made the records beside it; delete the "
        "whole directory (or choose another output directory) and rerun",
    )
    differ = differing_keys(stored, manifest)
    if differ:
        raise ManifestMismatchError(
            f"{out_dir} holds records of another evaluation (differs in: {', '.join(differ)}); "
            "resuming would mix them. Delete it or choose another output directory."
        )


def run_evaluation(
    settings: EvaluationSettings,
    make_policy: Callable[[], Any],
    out_dir: str | Path,
    workers: int = 2,
    progress: bool = True,
    backend: str = "local",
    address: str | None = None,
    identity: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """Evaluate every missing task of every group, then return all task records in order.

    ``make_policy`` builds the TEMP policy inside each worker (a picklable function, e.g.
    ``functools.partial(TEMPPolicy.from_checkpoint, path)``). Tasks run on local processes or
    as Ray tasks (`temp_gym.distributed`); the driver writes each record as it arrives.
    ``identity`` (JSON-able, e.g. the checkpoint's weights digest) joins the settings in the
    manifest ``run.json``.

    Raises:
        ManifestMismatchError: ``out_dir`` holds records of an evaluation with another manifest.
    """
    out_dir = Path(out_dir)
    lock = DirectoryLock(out_dir, "evaluating")
    lock.acquire()  # a second run on the same directory stops, naming this one
    try:
        _check_manifest(
            out_dir,
            {
                "test_set_version": TEST_SET_VERSION,
                "record_version": RECORD_VERSION,
                "settings": _recorded(settings),
                **(identity or {}),
            },
        )
        tasks_dir = out_dir / "tasks"
        tasks_dir.mkdir(parents=True, exist_ok=True)
        remove_leftovers(tasks_dir)  # records whose writer was killed
        jobs, paths, targets = [], [], []
        for group, (difficulty, count) in settings.groups.items():
            slug = group.replace(" ", "_")
            for index in range(count):
                path = tasks_dir / f"{slug}-{index:04d}.json"
                paths.append(path)
                if not path.exists():
                    jobs.append((settings, make_policy, group, difficulty, index))
                    targets.append(path)
        _evaluate_missing(jobs, targets, paths, workers, progress, backend, address)
        return [read_json(path, RERUN_TASK) for path in paths]
    finally:
        lock.release()


def _evaluate_missing(jobs, targets, paths, workers, progress, backend, address) -> None:
    """Run the missing tasks; report what is done and how long the rest should take."""
    from tqdm import tqdm

    from temp_gym.distributed import map_units

    done = len(paths) - len(jobs)
    report(progress_line(done, len(paths), "tasks"))
    if not jobs:
        return
    missing = set(targets)
    stored = [path for path in paths if path not in missing][-20:]
    times = [read_json(path, RERUN_TASK).get("task_time") for path in stored]
    times = [seconds for seconds in times if isinstance(seconds, (int, float))]
    if len(times) >= 3:
        basis = f"measured on {len(times)} stored tasks"
        report(estimate_line(len(jobs), float(np.median(times)), workers, "tasks", basis))
    bar = tqdm(total=len(paths), initial=done, desc="evaluating", disable=not progress)
    with bar:
        for count, (index, record) in enumerate(
            map_units(_run_job, jobs, backend, workers, address)
        ):
            write_json_atomic(targets[index], record, **RECORD_JSON)
            if count == 0 and len(times) < 3 and len(jobs) > 1:
                line = estimate_line(
                    len(jobs) - 1, record["task_time"], workers, "tasks", "measured on the first"
                )
                bar.write(line, file=sys.stderr)
            bar.update()


def attention_example(
    settings: EvaluationSettings, make_policy: Callable[[], Any], group: str | None = None
) -> dict[str, Any] | None:
    """TEMP's attention along one example plan: task 0 of ``group`` (default: the first row).

    Plans with the policy's attention read-out on (``record_attention``) and returns the
    group, the task, the AP figures and, per token group (SEI, Goal, Start, HPD), the raw
    head-averaged weight of the output token's query at every sampling step of the last layer
    and its min-max normalization (the paper's Eq. 7-8, `temp_gym.models.attention`).

    The policy plans from the start only (no phase from the goal, so no rounds): the phase
    from the goal resets the policy to the swapped problem and back, and each reset starts
    its record afresh, so a plan joined from the goal would leave none of the phase shown.
    None when the policy was never asked for a sample (a node budget of one, say).
    """
    from temp_gym.models.attention import GROUPS, normalized_group_attention

    group = group or next(iter(settings.groups))
    difficulty, _ = settings.groups[group]
    problem = evaluation_problem(settings.robot, difficulty, 0, settings.seed)
    policy = make_policy()
    policy.record_attention = True
    result = plan(
        problem, "temp", settings.temp_settings(policy, stop_at_first=True, time_limit=None,
                                                attention_from_goal=False, attention_rounds=0),
    )  # fmt: skip
    if len(policy.attentions) == 0:
        return None
    weights = normalized_group_attention(policy.attentions, policy.info.num_sei_tokens)
    return {
        "group": group,
        "index": 0,
        "problem": problem.to_dict(),
        "attention_phase": {
            key: value.item() if isinstance(value, np.generic) else value
            for key, value in result.attention.items()
        },
        "normalized": {g: weights[g].tolist() for g in GROUPS},
        "raw": {g: weights["raw_" + g].tolist() for g in GROUPS},
    }
