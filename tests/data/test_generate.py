"""Demonstration generation on configs/tiny.yaml: format, consistency, determinism, resume."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch

from temp_gym.config import apply_overrides, load_config
from temp_gym.data import dataset_exists, generate_dataset, load_split, load_tasks
from temp_gym.data.demonstrations import resample_path
from temp_gym.data.format import SAMPLE_KEYS, SPLITS, TASK_KEYS
from temp_gym.data.generate import read_unit, solve_unit, unit_path
from temp_gym.worlds.normalization import denormalize
from temp_gym.worlds.splits import split_workspace

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "trainers" / "generate.py"
TINY = ROOT / "configs" / "tiny.yaml"
STEP = 1.0  # default_step_size of the [0, 20]^2 worlds (env.step_size is null in tiny.yaml)


def tiny(directory: Path, *overrides: str) -> dict:
    return load_config(TINY, [f"data.dir={directory}", *overrides])


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    directory = tmp_path_factory.mktemp("tiny")
    return generate_dataset(tiny(directory), workers=1, progress=False)


def _as_a_terminal_job() -> None:
    """In the child: a process group of its own and Ctrl-C's default disposition.

    A terminal signals a job's whole process group, so the job gets a group the test can signal
    alone. An ignored SIGINT is inherited across exec, and Python then leaves it ignored, so a
    test process that ignores it (a test runner's worker may) would hand that on to the job.
    """
    os.setpgrp()
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def signal_after_first_unit(command: list[str], root: Path, sig: int) -> tuple[int, str]:
    """Run ``command`` (a generate.py run into ``root``) and send ``sig`` to its process
    group, as a terminal would, once its first unit is on disk; return (status, stderr)."""
    process = subprocess.Popen(
        command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        preexec_fn=_as_a_terminal_job,
    )  # fmt: skip
    units = root / "train" / "units"
    deadline = time.monotonic() + 120
    while not (units.is_dir() and any(units.glob("*.npz"))) and time.monotonic() < deadline:
        assert process.poll() is None, "the run ended before the signal"
        time.sleep(0.01)
    os.killpg(process.pid, sig)
    _, stderr = process.communicate(timeout=120)
    return process.returncode, stderr


def split_contents(directory: Path) -> dict[str, torch.Tensor]:
    contents = {}
    for split in SPLITS:
        buffer, workspaces = load_split(directory, split)
        for key, value in buffer[:].items():
            contents[f"{split}/buffer/{key}"] = value.clone()
        for key, value in workspaces.items():
            contents[f"{split}/workspaces/{key}"] = value.clone()
        for key, value in load_tasks(directory, split).items():
            if key != "plan_time":  # wall times differ between runs
                contents[f"{split}/tasks/{key}"] = value.clone()
    return contents


def assert_same(a: Path, b: Path) -> None:
    first, second = split_contents(a), split_contents(b)
    assert first.keys() == second.keys()
    for key in first:
        assert first[key].dtype == second[key].dtype, key
        assert torch.equal(first[key], second[key]), key


def test_samples_have_every_key_with_its_shape_and_dtype(dataset):
    config = tiny(dataset)
    length, resolution = config.env.max_path_length, config.env.encoding_resolution
    dtypes = {"float32": torch.float32, "int64": torch.int64}
    shapes = {"()": (), "(d,)": (2,), "(1,)": (1,), "(L, d)": (length, 2)}
    for split in SPLITS:
        buffer, workspaces = load_split(dataset, split)
        assert len(buffer) > 0
        batch = buffer.sample(7)
        assert set(batch.keys()) == set(SAMPLE_KEYS)
        for key, doc in SAMPLE_KEYS.items():
            dtype, shape = doc.split(":")[0].split(" ", 1)
            assert batch[key].dtype == dtypes[dtype], key
            assert tuple(batch[key].shape) == (7, *shapes[shape]), key
        assert workspaces["occupancy"].shape == (
            getattr(config.data.workspaces, split),
            resolution,
            resolution,
        )
        assert workspaces["occupancy"].dtype == torch.float32
        assert torch.equal(workspaces["workspace_id"], torch.arange(len(workspaces)))
        occupancy = workspaces["occupancy"][batch["workspace_id"]]
        assert occupancy.shape == (7, resolution, resolution)
        assert set(load_tasks(dataset, split).keys()) == set(TASK_KEYS)


def test_buffer_is_a_torchrl_replay_buffer_of_every_sample(dataset):
    from torchrl.data import ReplayBuffer

    card = json.loads((dataset / "dataset_card.json").read_text())
    for split in SPLITS:
        buffer, _ = load_split(dataset, split)
        assert isinstance(buffer, ReplayBuffer)
        assert len(buffer) == card["splits"][split]["samples"] > 0
        assert torch.equal(buffer[:]["task_id"], buffer.storage[: len(buffer)]["task_id"])


def test_targets_and_paths_follow_the_resampled_expert_paths(dataset):
    config = tiny(dataset)
    for split in SPLITS:
        buffer, _ = load_split(dataset, split)
        samples = buffer[:]
        tasks = load_tasks(dataset, split)
        for row in torch.nonzero(tasks["success"]).flatten().tolist():
            workspace = int(tasks["workspace_id"][row])
            bounds = split_workspace("point2d", split, workspace).bounds
            mine = samples["task_id"] == tasks["task_id"][row]
            steps = samples["step"][mine]
            assert torch.equal(steps, torch.arange(len(steps)))
            assert len(steps) == int(tasks["samples"][row])
            lengths = samples["path_length"][mine][:, 0]
            paths, targets = samples["path"][mine], samples["target"][mine]
            # Full resampled path: first node, then every target.
            nodes = torch.cat([paths[0, :1], targets]).double().numpy()
            world = denormalize(nodes, bounds)
            gaps = np.linalg.norm(np.diff(world, axis=0), axis=1)
            assert gaps.max() <= STEP + 1e-4 and gaps.min() > 0
            assert np.allclose(world[0], tasks["start"][row].numpy(), atol=1e-4)
            goal = tasks["goal"][row].numpy()
            assert np.linalg.norm(world[-1] - goal) <= float(tasks["goal_radius"][row]) + 1e-4
            for k in range(len(steps)):
                valid = int(lengths[k])
                assert valid == min(k + 1, config.env.max_path_length)
                assert torch.equal(paths[k, valid - 1], torch.from_numpy(nodes[k]).float())
                assert torch.all(paths[k, valid:] == 0)
                if k + 1 < len(steps):  # the target is the next prefix's newest node
                    assert torch.equal(targets[k], paths[k + 1, int(lengths[k + 1]) - 1])


def test_resampling_keeps_vertices_and_bounds_gaps():
    path = np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 4.0], [3.0, 5.0], [3.0, 7.5]])
    resampled = resample_path(path, 1.0)
    gaps = np.linalg.norm(np.diff(resampled, axis=0), axis=1)
    assert gaps.max() <= 1.0 + 1e-12 and gaps.min() > 0
    for vertex in path:
        assert np.any(np.all(resampled == vertex, axis=1))
    assert len(resampled) == 1 + 5 + 1 + 3  # 5 pieces, duplicate dropped, 1, 3


def test_failed_plans_are_counted_and_not_stored(tmp_path):
    # 25 nodes rarely reach the goal: some plans fail.
    config = tiny(tmp_path, "data.max_nodes=25", "data.workspaces.val=0")
    root = generate_dataset(config, workers=1, progress=False)
    card = json.loads((root / "dataset_card.json").read_text())
    train = card["splits"]["train"]
    assert train["plans_failed"] > 0 and train["plans_stored"] > 0
    assert train["plans_stored"] + train["plans_failed"] == train["plans_attempted"] == 8
    tasks = load_tasks(root, "train")
    buffer, _ = load_split(root, "train")
    stored = set(buffer[:]["task_id"].tolist())
    assert stored == set(tasks["task_id"][tasks["success"]].tolist())
    assert train["samples"] == len(buffer) == int(tasks["samples"].sum())
    assert torch.all(tasks["samples"][~tasks["success"]] == 0)


def test_a_unit_recomputed_alone_is_identical(dataset):
    settings = json.loads((dataset / "settings.json").read_text())
    stored = read_unit(unit_path(dataset, "train", 1))
    again = solve_unit(settings, "train", 1)
    for key, value in stored.items():
        if key not in ("plan_time", "unit_time", "unit_cpu_time"):
            assert np.array_equal(value, again[key]), key


def test_rerun_is_a_noop_and_other_settings_are_refused(dataset):
    config = tiny(dataset)
    assert dataset_exists(config)
    card = (dataset / "dataset_card.json").read_text()
    generate_dataset(config, workers=1, progress=False)
    assert (dataset / "dataset_card.json").read_text() == card
    assert not dataset_exists(tiny(dataset, "data.seed=1"))
    with pytest.raises(ValueError, match="seed"):
        generate_dataset(tiny(dataset, "data.seed=1"), progress=False)


def test_killed_run_resumes_to_the_uninterrupted_dataset(dataset, tmp_path):
    command = [sys.executable, str(SCRIPT), "--config", str(TINY), "--workers", "1"]
    command += ["--no-progress", f"data.dir={tmp_path}", "data.tasks_per_workspace=12"]
    signal_after_first_unit(command, tmp_path, signal.SIGKILL)
    assert not (tmp_path / "dataset_card.json").exists(), "killed too late to test resuming"
    subprocess.run(command, cwd=ROOT, check=True, capture_output=True)
    uninterrupted = tmp_path.parent / f"{tmp_path.name}-uninterrupted"
    generate_dataset(tiny(uninterrupted, "data.tasks_per_workspace=12"), workers=2, progress=False)
    assert_same(tmp_path, uninterrupted)
    card = json.loads((tmp_path / "dataset_card.json").read_text())
    assert card["timing"]["resumed_units"] >= 1
    assert card["totals"]["plans_attempted"] == 36


def test_same_seed_same_dataset_other_seed_other_dataset(dataset, tmp_path):
    assert_same(dataset, generate_dataset(tiny(tmp_path / "a"), workers=2, progress=False))
    other = generate_dataset(tiny(tmp_path / "b", "data.seed=1"), workers=1, progress=False)
    first, second = load_split(dataset, "train")[0], load_split(other, "train")[0]
    assert len(first) != len(second) or not torch.equal(first[:]["target"], second[:]["target"])


def test_the_expert_retries_a_failed_task_with_a_new_seed(tmp_path, monkeypatch):
    import temp_gym.data.generate as generate
    from temp_gym.data.dataset import data_settings

    config = load_config(
        ROOT / "configs" / "tiny.yaml", [f"data.dir={tmp_path}", "data.tasks_per_workspace=2"]
    )
    settings = data_settings(config)
    assert (
        "attempts" not in settings
    )  # 1, the default, leaves older datasets' settings as they were
    seeds, budgets = [], []
    real_plan = generate.plan

    tried: set[tuple] = set()

    def flaky(problem, **kwargs):  # the first attempt at every task fails
        seeds.append(kwargs["seed"])
        budgets.append(kwargs["max_nodes"])
        result = real_plan(problem, **kwargs)
        task = tuple(problem.start)
        if task not in tried:
            tried.add(task)
            result.success, result.path = False, None
        return result

    monkeypatch.setattr(generate, "plan", flaky)
    once = solve_unit(settings, "train", 0)
    assert list(once["status"]) == [1, 1] and len(seeds) == 2
    seeds.clear()
    budgets.clear()
    tried.clear()
    retried = solve_unit(data_settings(apply_overrides(config, ["data.attempts=3"])), "train", 0)
    assert list(retried["status"]) == [0, 0] and len(seeds) == 4  # one retry per task
    assert seeds[1] == (seeds[0] + generate.RETRY_SEED_STRIDE) % 2**32
    assert budgets[1] == generate.RETRY_BUDGET_GROWTH * budgets[0]
    with pytest.raises(ValueError, match="data.attempts"):
        data_settings(apply_overrides(config, ["data.attempts=0"]))


def _forward_fails(generate, monkeypatch) -> list[tuple[bool, int, int]]:
    """Make every forward plan of the expert fail; record (backwards, seed, budget) per call.

    A backwards call's entry also holds whether its path ends exactly at its goal (the
    original start), so that the expert puts nothing in front of it."""
    real_plan = generate.plan
    calls: list[tuple[bool, int, int]] = []
    forward_starts: set[tuple] = set()

    def forward_fails(problem, **kwargs):
        result = real_plan(problem, **kwargs)
        backwards = tuple(problem.goal) in forward_starts  # a task planned forward before
        if not backwards:
            forward_starts.add(tuple(problem.start))
            result.success, result.path = False, None
        entry = (backwards, kwargs["seed"], kwargs["max_nodes"])
        if backwards:
            entry += (result.success and np.array_equal(result.path[-1], problem.goal),)
        calls.append(entry)
        return result

    monkeypatch.setattr(generate, "plan", forward_fails)
    return calls


def test_the_expert_plans_a_failed_task_backwards_when_asked(tmp_path, monkeypatch):
    import temp_gym.data.generate as generate
    from temp_gym.data.dataset import data_settings
    from temp_gym.worlds.checkers import certify_path

    config = load_config(TINY, [f"data.dir={tmp_path}", "data.tasks_per_workspace=2"])
    assert "expert_reverse" not in data_settings(config)  # older datasets keep their settings
    calls = _forward_fails(generate, monkeypatch)
    assert list(solve_unit(data_settings(config), "train", 0)["status"]) == [1, 1]
    assert [entry[0] for entry in calls] == [False, False]  # never backwards

    calls.clear()
    settings = data_settings(apply_overrides(config, ["data.expert_reverse=true"]))
    assert settings["expert_reverse"] is True
    unit = solve_unit(settings, "train", 0)
    assert list(unit["status"]) == [0, 0] and list(unit["reversed"]) == [True, True]
    assert [entry[0] for entry in calls] == [False, True, False, True]
    assert calls[0][1:] == calls[1][1:3]  # the same attempt: its seed and budget
    workspace = split_workspace("point2d", "train", 0)
    for task in range(2):
        path = unit["path_points"][unit["path_offsets"][task] : unit["path_offsets"][task + 1]]
        assert np.array_equal(path[0], unit["start"][task])  # from the start itself
        assert np.array_equal(path[-1], unit["goal"][task])  # to the goal itself
        problem = generate_task_problem(workspace, unit, task)
        assert certify_path(problem, path)
        assert unit["cost"][task] == pytest.approx(
            np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))
        )


def generate_task_problem(workspace, unit, task):
    from temp_gym.problem import Problem

    return Problem(
        workspace=workspace,
        start=unit["start"][task],
        goal=unit["goal"][task],
        goal_radius=float(unit["goal_radius"][task]),
    )


def test_a_backwards_path_whose_way_to_the_start_collides_is_not_stored(tmp_path, monkeypatch):
    import temp_gym.data.generate as generate
    from temp_gym.data.dataset import data_settings

    config = load_config(
        TINY,
        [f"data.dir={tmp_path}", "data.tasks_per_workspace=2", "data.expert_reverse=true"],
    )
    calls = _forward_fails(generate, monkeypatch)
    monkeypatch.setattr(generate, "certify_path", lambda problem, path: False)
    unit = solve_unit(data_settings(config), "train", 0)
    ended_at_start = [entry[3] for entry in calls if entry[0]]
    assert len(ended_at_start) == 2 and not all(ended_at_start)  # one needs the start in front
    # stored exactly when the planner's own (certified) path reached the start
    assert list(unit["status"] == 0) == ended_at_start
    assert list(unit["reversed"]) == ended_at_start


def test_a_backwards_expert_plan_runs_from_the_start_to_the_goal():
    from dataclasses import replace

    from temp_gym import Problem
    from temp_gym.data.generate import expert_plan
    from temp_gym.worlds.checkers import certify_path

    problem = Problem.load(ROOT / "examples" / "ood" / "2d" / "bug_trap.json")
    into_the_trap = replace(problem, start=problem.goal, goal=problem.start)
    settings = {"planner": "informed_rrt_star", "goal_bias": 0.05}
    result, path, cost = expert_plan(into_the_trap, settings, 0, 600, 2.0, backwards=True)
    assert result.success and path is not None
    assert cost == pytest.approx(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    assert np.array_equal(path[0], into_the_trap.start)
    assert np.array_equal(path[-1], into_the_trap.goal)
    assert certify_path(into_the_trap, path)


SETTINGS_BEFORE_FAMILIES = {
    "robot", "encoding_resolution", "max_path_length", "step_size", "seed", "workspaces",
    "tasks_per_workspace", "difficulty", "planner", "max_nodes", "planner_step_size",
    "goal_bias",
}  # fmt: skip
"""The settings a dataset of the default config recorded before workspace families existed."""


def test_the_default_family_leaves_the_recorded_settings_as_they_were(tmp_path):
    from temp_gym.data.dataset import data_settings

    assert set(data_settings(tiny(tmp_path))) == SETTINGS_BEFORE_FAMILIES
    boxes = data_settings(tiny(tmp_path, "data.workspace_family=boxes"))
    assert set(boxes) == SETTINGS_BEFORE_FAMILIES
    assert data_settings(tiny(tmp_path, "data.workspace_family=mixed"))["workspace_family"] == (
        "mixed"
    )


def test_an_unknown_family_or_one_the_robot_lacks_is_refused(tmp_path):
    from temp_gym.config import ConfigError
    from temp_gym.data.dataset import data_settings

    with pytest.raises(ConfigError, match=r"data.workspace_family: expected one of .*'maze'"):
        data_settings(tiny(tmp_path, "data.workspace_family=spiral"))
    iiwa = load_config(ROOT / "configs" / "7d.yaml", [f"data.dir={tmp_path}"])
    data_settings(iiwa)  # its own generator, the default, is fine
    assert (
        data_settings(apply_overrides(iiwa, ["data.workspace_family=maze"]))["workspace_family"]
        == "maze"
    )  # the arm has structured families too


def test_a_dataset_of_another_family_records_it_and_refuses_to_mix(tmp_path):
    from temp_gym.config import ConfigError
    from temp_gym.data import load_workspaces
    from temp_gym.data.units import STATUS
    from temp_gym.worlds.encoding import occupancy_grid
    from temp_gym.worlds.robots import robot_spec

    small = ("data.tasks_per_workspace=2", "data.workspaces.val=0")
    root = generate_dataset(tiny(tmp_path, "data.workspace_family=maze", *small), workers=1,
                            progress=False)  # fmt: skip
    settings = json.loads((root / "settings.json").read_text())
    card = json.loads((root / "dataset_card.json").read_text())
    assert settings["workspace_family"] == card["settings"]["workspace_family"] == "maze"
    occupancy = load_workspaces(root, "train")["occupancy"].numpy()
    resolution = settings["encoding_resolution"]
    for index in range(settings["workspaces"]["train"]):
        maze = split_workspace("point2d", "train", index, "maze")
        assert np.array_equal(occupancy[index], occupancy_grid(maze, resolution))
        assert not np.array_equal(
            occupancy[index], occupancy_grid(split_workspace("point2d", "train", index), resolution)
        )
        unit = read_unit(unit_path(root, "train", index))
        drawn = unit["status"] != STATUS["no_task"]
        points = np.concatenate([unit["start"][drawn], unit["goal"][drawn]])
        assert robot_spec("point2d").make_checker(maze).states_free(points).all()
    assert not dataset_exists(tiny(tmp_path, *small))
    for other in ("boxes", "clutter"):
        with pytest.raises(ConfigError, match="other settings.*workspace_family"):
            generate_dataset(tiny(tmp_path, f"data.workspace_family={other}", *small),
                             progress=False)  # fmt: skip


def _described_arm_settings(tmp_path):
    """Settings as `data_settings` records them for an arm of a description file."""
    from temp_gym.data.dataset import data_settings

    settings = data_settings(tiny(tmp_path))
    return {**settings, "robot_description": str(tmp_path / "arm.yaml"), "robot_digest": "a" * 64}


def test_a_dataset_of_an_edited_robot_is_refused_and_an_older_one_takes_its_digest(tmp_path):
    from temp_gym.config import ConfigError
    from temp_gym.data.generate import _prepare

    settings = _described_arm_settings(tmp_path)
    root = tmp_path / "data"
    _prepare(root, settings)
    edited = {**settings, "robot_digest": "b" * 64}
    with pytest.raises(ConfigError, match="as it was before its description, URDF or meshes"):
        _prepare(root, edited)
    older = tmp_path / "older"
    older.mkdir()
    stored = {key: value for key, value in settings.items() if key != "robot_digest"}
    (older / "settings.json").write_text(json.dumps(stored))
    _prepare(older, settings)  # made before digests were recorded: resumed, and recorded now
    assert json.loads((older / "settings.json").read_text()) == settings
    with pytest.raises(ConfigError, match="as it was before"):
        _prepare(older, edited)
