"""On-policy correction (DAgger): label the states a learned policy reaches with the expert.

Behaviour cloning trains the MPT on the expert's own paths, but in attention-based planning the
policy reads the paths of *its* tree: after a fallback, a rewire or a wrong turn it stands in
states the expert never visited, and its errors compound (Ross et al. 2011, "A reduction of
imitation learning and structured prediction to no-regret online learning"). DAgger closes the
gap: plan with the current policy, record the path so far of every policy call, ask the expert
where it would go from the end of that path, add these samples to the data and train again.

The expert of point worlds is `temp_gym.worlds.reference.GoalField`: shortest lattice paths to
the goal from any state, shortcut, resampled at the steering step like the demonstrations
(`temp_gym.data.demonstrations.resample_path`). A robot without a lattice (the iiwa) is
labelled by `PlannerExpert`: the planner that made the demonstrations (``data.planner``, its
budget and goal bias, certified paths), run from the state to the goal. A sample holds the
policy's own input (its path so far, normalized, exactly as the planner handed it over) and,
as targets, the expert's next ``chunk`` nodes from the path's last node, with a mask where the
expert's path ends sooner.

**Rounds on disk.** `collect_corrections` runs one round over the training workspaces of a
config: per workspace (a unit, written atomically to ``{out}/units/{workspace:03d}.npz`` and
skipped on a rerun, so a killed round resumes), ``tasks_per_workspace`` new tasks drawn from
``SeedSequence([data.seed, CORRECTION_CODE, round, workspace, task])`` (never the
demonstrations' tasks), planned with the policy and labelled. When every unit is there, the
samples are assembled, in workspace and task order, into one table of columns
(`temp_gym.data.tables`) listed with sizes and SHA-256 in ``correction_card.json``; the card
also records the checkpoint's digest and the settings. `load_corrections` reads a round back,
verified, and the trainer adds the rounds listed in ``data.corrections`` to the training
split (`temp_gym.training.batches.make_replay_buffer`).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.config import Config
from temp_gym.data.demonstrations import resample_path
from temp_gym.planning.attention import AttentionLimits, run_attention_phase
from temp_gym.planning.tree import Tree, default_step_size
from temp_gym.problem import Problem
from temp_gym.worlds.normalization import denormalize, goal_radius_ratio, normalize
from temp_gym.worlds.reference import GoalField


class ClearField:
    """Shortest paths that keep ``clearance`` from the boxes where they can (`GoalField`s).

    A shortest path hugs the corners of the boxes it passes; a policy that imitates it
    proposes samples whose steered edges graze those corners and collide. The expert therefore
    plans among boxes grown by ``clearance`` and falls back to the real boxes only from states
    (or to goals) the grown world closes off.
    """

    def __init__(self, workspace, goal: np.ndarray, clearance: float) -> None:
        from temp_gym.worlds.reference import ReferencePlanner

        self.fields = [GoalField(ReferencePlanner(workspace), goal)]
        if clearance > 0:
            grown = workspace.grown(clearance)
            self.fields.insert(0, GoalField(ReferencePlanner(grown), goal))

    def path(self, state: np.ndarray, length: float = np.inf) -> np.ndarray | None:
        """The first field's path from ``state`` (None when none has one)."""
        for field in self.fields:
            path = field.path(state, length)
            if path is not None:
                return path
        return None


class PlannerExpert:
    """The demonstrations' planner, run from a state to the goal: the expert without a lattice.

    Each `path` call plans anew with the next seed of ``seed``'s sequence, so a task's labels
    are reproducible; a state the planner cannot leave within its budget gets no label (None).
    """

    def __init__(
        self, problem: Problem, planner: str, max_nodes: int, goal_bias: float, seed: int,
        step_size: float | None = None,
    ) -> None:  # fmt: skip
        self.problem = problem
        self.planner, self.max_nodes, self.goal_bias = planner, int(max_nodes), float(goal_bias)
        self.step_size = step_size
        self.seeds = np.random.SeedSequence(int(seed))

    def path(self, state: np.ndarray, length: float = np.inf) -> np.ndarray | None:
        """A certified path from ``state`` into the goal region (``length`` is not needed)."""
        from temp_gym.planning.plan import plan

        del length  # a planner's path is whole; the caller resamples what it needs
        seed = int(self.seeds.spawn(1)[0].generate_state(1, dtype=np.uint32)[0])
        problem = self.problem
        query = Problem(problem.workspace, np.asarray(state, dtype=np.float64), problem.goal,
                        problem.goal_radius)  # fmt: skip
        result = plan(query, planner=self.planner, seed=seed, max_nodes=self.max_nodes,
                      goal_bias=self.goal_bias, step_size=self.step_size)  # fmt: skip
        return np.asarray(result.path) if result.success and result.path is not None else None


LATTICE = "lattice"
"""The ``expert`` of a round labelled by lattice paths (`ClearField`); rounds of point worlds
name none."""


def expert_next_nodes(
    field: GoalField, state: np.ndarray, step: float, count: int
) -> tuple[np.ndarray, np.ndarray] | None:
    """The expert's next ``count`` nodes from ``state``: ``(nodes (count, d), mask (count,))``.

    Nodes past the end of the expert's path repeat its last node and are masked out; None when
    the expert finds no path from ``state``.
    """
    path = field.path(state, length=(count + 1) * step)
    if path is None:
        return None
    nodes = resample_path(path, step)[1 : count + 1]
    if len(nodes) == 0:  # the state is the goal itself
        return None
    mask = np.zeros(count, dtype=bool)
    mask[: len(nodes)] = True
    padded = np.concatenate([nodes, np.repeat(nodes[-1:], count - len(nodes), axis=0)])
    return padded, mask


class _Recorder:
    """A policy seen through ``propose_chunk``, keeping each call's input (the Python loop)."""

    def __init__(self, policy) -> None:
        self.policy = policy
        self.encoding_resolution = policy.encoding_resolution
        self.max_path_length = policy.max_path_length
        self.inputs: list[tuple[np.ndarray, int]] = []

    def reset(self, problem: Problem, seed: int | None = None) -> None:
        self.policy.reset(problem, seed=seed)

    def propose_chunk(self, path: np.ndarray, length: int) -> np.ndarray:
        self.inputs.append((np.array(path, dtype=np.float32), int(length)))
        return self.policy.propose_chunk(path, length)

    def __call__(self, observation):
        return self.policy(observation)


def correction_samples(
    policy,
    problem: Problem,
    field: GoalField,
    seed: int,
    max_nodes: int,
    max_samples: int,
    chunk: int,
    goal_bias: float = 0.05,
) -> dict[str, np.ndarray]:
    """Plan ``problem`` with ``policy`` (attention phase only) and label its inputs.

    Every policy call's path so far becomes a sample (at most ``max_samples``, evenly spread
    over the calls) whose targets are the expert's next ``chunk`` nodes from the path's last
    node, unless the expert's next node turns back to a node of the path (within half a
    step): the tree already holds that way, so in a tree planner the label would only make
    the policy propose nodes it has (the random fallback, not the policy, leaves a dead
    end). Keys: ``path`` (m, L, d), ``path_length`` (m, 1), ``start``, ``goal`` (m, d),
    ``goal_radius`` (m, 1), ``targets`` (m, chunk, d), ``target_mask`` (m, chunk),
    ``target`` (m, d, the first target) and ``step`` (m,, the call's index), float32 and
    normalized like the demonstrations (`temp_gym.data.format`).
    """
    recorder = _Recorder(policy)
    recorder.reset(problem, seed=seed)
    tree = Tree(problem)
    limits = AttentionLimits(max_nodes, max_nodes, 100 * max_nodes, patience=0)
    run_attention_phase(tree, recorder, np.random.default_rng(seed), goal_bias, limits, False)
    calls = recorder.inputs
    if len(calls) > max_samples:
        keep = np.unique(np.linspace(0, len(calls) - 1, max_samples).round().astype(int))
        calls = [calls[i] for i in keep]
        indices = keep
    else:
        indices = np.arange(len(calls))
    step = default_step_size(problem)
    rows: dict[str, list] = {key: [] for key in ("path", "path_length", "targets", "target_mask",
                                                  "step")}  # fmt: skip
    for index, (path, length) in zip(indices, calls):
        visited = denormalize(path[:length], problem.bounds)
        labelled = expert_next_nodes(field, visited[-1], step, chunk)
        if labelled is None:
            continue
        nodes, mask = labelled
        if length > 1 and np.min(np.linalg.norm(visited[:-1] - nodes[0], axis=1)) < step / 2:
            continue  # the expert turns back along the path: the tree already holds that part
        rows["path"].append(path)
        rows["path_length"].append([length])
        rows["targets"].append(normalize(nodes, problem.bounds).astype(np.float32))
        rows["target_mask"].append(mask)
        rows["step"].append(int(index))
    count, dim = len(rows["path"]), problem.dim
    out = {
        "path": np.array(rows["path"], dtype=np.float32).reshape(
            count, recorder.max_path_length, dim
        ),
        "path_length": np.array(rows["path_length"], dtype=np.int64).reshape(count, 1),
        "targets": np.array(rows["targets"], dtype=np.float32).reshape(count, chunk, dim),
        "target_mask": np.array(rows["target_mask"], dtype=bool).reshape(count, chunk),
        "step": np.array(rows["step"], dtype=np.int64),
    }
    out["target"] = out["targets"][:, 0].copy()
    for key, value in (("start", problem.start), ("goal", problem.goal)):
        out[key] = np.repeat(normalize(value, problem.bounds)[None].astype(np.float32), count, 0)
    radius = goal_radius_ratio(problem.goal_radius, problem.bounds)
    out["goal_radius"] = np.full((count, 1), radius, dtype=np.float32)
    return out


CORRECTION_CODE = 7
"""Seed-sequence code of correction tasks (the demonstrations use their split's code)."""
CARD_NAME = "correction_card.json"
TABLE = "samples"
"""The table of a round: sample columns (`temp_gym.data.format.SAMPLE_KEYS` plus ``targets``
and ``target_mask``)."""


def correction_unit(settings: dict[str, Any], workspace: int) -> dict[str, np.ndarray]:
    """Plan and label ``settings["tasks_per_workspace"]`` new tasks of one training workspace."""
    from temp_gym.data.dataset import workspace_family
    from temp_gym.models.registry import policy_from_checkpoint
    from temp_gym.worlds.generators import generate_task
    from temp_gym.worlds.splits import split_workspace

    started = time.perf_counter()
    space = split_workspace(settings["robot"], "train", workspace, workspace_family(settings))
    policy = policy_from_checkpoint(
        settings["checkpoint"], settings["robot"], noise_std=settings["noise_std"],
        horizon=settings["horizon"],
    )  # fmt: skip
    parts = []
    count = settings["tasks_per_workspace"]
    for task in range(count):
        sequence = np.random.SeedSequence(
            [settings["seed"], CORRECTION_CODE, settings["round"], workspace, task]
        )
        task_sequence, plan_sequence = sequence.spawn(2)
        try:
            problem = generate_task(space, np.random.default_rng(task_sequence), "any")
        except RuntimeError:
            continue
        plan_seed = int(plan_sequence.generate_state(1, dtype=np.uint32)[0])
        if settings.get("expert", LATTICE) == LATTICE:
            field = ClearField(space, problem.goal, settings.get("clearance", 0.0))
        else:
            field = PlannerExpert(problem, settings["expert"], settings["expert_nodes"],
                                  settings["expert_goal_bias"], plan_seed,
                                  settings.get("expert_step_size"))  # fmt: skip
        samples = correction_samples(
            policy, problem, field, plan_seed,
            settings["max_nodes"], settings["samples_per_task"], settings["chunk"],
        )  # fmt: skip
        rows = len(samples["step"])
        samples["workspace_id"] = np.full(rows, workspace, dtype=np.int64)
        samples["task_id"] = np.full(rows, workspace * count + task, dtype=np.int64)
        parts.append(samples)
    unit = {key: np.concatenate([part[key] for part in parts]) for key in parts[0]} if parts else {}
    unit["unit_time"] = np.array(time.perf_counter() - started)
    return unit


def _unit_job(job: tuple[dict[str, Any], int]) -> dict[str, np.ndarray]:
    return correction_unit(*job)


def correction_settings(
    config: Config,
    checkpoint: str | Path,
    round_index: int,
    tasks_per_workspace: int,
    samples_per_task: int,
    max_nodes: int,
    clearance: float = 0.0,
) -> dict[str, Any]:
    """The JSON-able settings of one round (the card records them; a rerun must match).

    Point robots are labelled by the lattice (``clearance`` from the boxes); other robots by
    the config's expert planner (``data.planner``, ``data.max_nodes``, ``data.goal_bias``,
    ``data.planner_step_size``; one attempt, not ``data.attempts``), which the settings then
    name (``expert``, ``expert_nodes``, ``expert_goal_bias``, ``expert_step_size``).
    """
    from temp_gym.config import ConfigError
    from temp_gym.data.dataset import data_settings
    from temp_gym.models.registry import load_cached
    from temp_gym.worlds.reference import has_lattice
    from temp_gym.worlds.robots import robot_spec

    loaded = load_cached(checkpoint, config.env.robot)
    planner = loaded.meta.get("planner", {})
    noise = config.train_eval.noise_std
    data = data_settings(config)
    family = {"workspace_family": data["workspace_family"]} if "workspace_family" in data else {}
    spec = robot_spec(config.env.robot)
    expert = {}
    if not has_lattice(spec.workspace_dim, spec.dim):
        if clearance:
            raise ConfigError(f"clearance: {spec.name} is labelled by a planner, which keeps none")
        expert = {"expert": data["planner"], "expert_nodes": int(data["max_nodes"]),
                  "expert_goal_bias": float(data["goal_bias"]),
                  "expert_step_size": data["planner_step_size"]}  # fmt: skip
    return {
        "robot": config.env.robot,
        "seed": config.data.seed,
        "round": int(round_index),
        "workspaces": data["workspaces"]["train"],
        **family,
        "tasks_per_workspace": int(tasks_per_workspace),
        "samples_per_task": int(samples_per_task),
        "max_nodes": int(max_nodes),
        "clearance": float(clearance),
        "chunk": int(loaded.core.info.chunk),
        "horizon": planner.get("horizon"),
        "noise_std": float(planner.get("noise_std", 0.0) if noise is None else noise),
        "checkpoint": str(Path(checkpoint).resolve()),
        "checkpoint_digest": loaded.digest,
        **expert,
    }


def collect_corrections(
    settings: dict[str, Any], out_dir: str | Path, workers: int = 1, progress: bool = True
) -> Path:
    """Run (or finish) one correction round into ``out_dir``; return it (module docstring).

    Raises:
        temp_gym.config.ConfigError: ``out_dir`` holds a round made with other settings.
        temp_gym.files.LockedError: another run holds ``out_dir``.
    """
    from tqdm import tqdm

    from temp_gym.config import ConfigError
    from temp_gym.data.generate import write_unit
    from temp_gym.data.tables import close_table, create_table, file_manifest
    from temp_gym.distributed import map_units
    from temp_gym.files import (
        DirectoryLock,
        read_json,
        remove_leftovers,
        write_json_atomic,
    )

    root = Path(out_dir)
    units = root / "units"
    units.mkdir(parents=True, exist_ok=True)
    lock = DirectoryLock(root, "collecting corrections")
    lock.acquire()
    try:
        settings_path = root / "settings.json"
        if settings_path.is_file():
            stored = read_json(settings_path, "delete the round directory and rerun")
            if stored != settings:
                changed = sorted(k for k in stored.keys() | settings.keys()
                                 if stored.get(k) != settings.get(k))  # fmt: skip
                raise ConfigError(f"{root} holds a round made with other settings ({changed})")
        else:
            write_json_atomic(settings_path, settings)
        if (root / CARD_NAME).is_file():
            return root
        remove_leftovers(units)
        paths = [units / f"{w:03d}.npz" for w in range(settings["workspaces"])]
        jobs = [(settings, w) for w, path in enumerate(paths) if not path.is_file()]
        done = len(paths) - len(jobs)
        with tqdm(total=len(paths), initial=done, desc="corrections", unit="workspace",
                  disable=not progress) as bar:  # fmt: skip
            for index, arrays in map_units(_unit_job, jobs, "local", workers):
                write_unit(paths[jobs[index][1]], arrays)
                bar.update()
        parts = [_read_unit(path) for path in paths]
        parts = [part for part in parts if len(part.get("step", ())) > 0]
        total = sum(len(part["step"]) for part in parts)
        columns = {
            key: (value.dtype, (total, *value.shape[1:]))
            for key, value in parts[0].items()
            if key != "unit_time"
        }
        table = root / TABLE
        arrays = create_table(table, columns)
        row = 0
        for part in parts:
            rows = len(part["step"])
            for key in columns:
                arrays[key][row : row + rows] = part[key]
            row += rows
        close_table(table, arrays)
        card = {
            "settings": settings,
            "samples": total,
            "unit_time_s": float(sum(float(part["unit_time"]) for part in parts)),
            "files": file_manifest(root, [table]),
        }
        write_json_atomic(root / CARD_NAME, card)
    finally:
        lock.release()
    return root


def _read_unit(path: Path) -> dict[str, np.ndarray]:
    from temp_gym.files import StoredFileError

    try:
        with np.load(path, allow_pickle=False) as stored:
            return {key: stored[key] for key in stored.files}
    except (OSError, ValueError, EOFError) as error:
        raise StoredFileError(path, f"damaged ({error})", "delete it and rerun") from None


def load_corrections(directory: str | Path) -> dict[str, np.ndarray]:
    """The verified sample columns of a finished round (memory-mapped, never unpickled)."""
    from temp_gym.data.tables import checked_manifest, read_table, verify_table
    from temp_gym.files import read_json

    root = Path(directory)
    card = read_json(root / CARD_NAME, f"no finished correction round in {root}: rerun it")
    verify_table(root, TABLE, checked_manifest(root / CARD_NAME, card, "rerun the round"))
    return read_table(root / TABLE)
