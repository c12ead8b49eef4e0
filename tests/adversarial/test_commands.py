"""Bad values of every command: one line on stderr, exit status 2, and no file written.

Each case runs the real command in a child process (`harness.run`: address space capped, peak
memory measured) from an empty folder, with every output pointed into it, and compares the
folder before and after.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from harness import ROOT, assert_refused, files_under, run

TINY = str(ROOT / "configs" / "tiny.yaml")
SHIPPED_2D = str(ROOT / "temp_gym" / "checkpoints" / "2d.pt")
PROBLEM = {
    "robot": "point2d",
    "bounds": [[0, 0], [20, 20]],
    "obstacles": [{"center": [10, 10], "half_extents": [1, 6]}],
    "start": [2, 2],
    "goal": [18, 18],
    "goal_radius": 0.5,
}


def bc(*overrides: str) -> tuple:
    """bc.py on the tiny config, its outputs in the working folder."""
    return ("bc.py", "--config", TINY, "--skip-eval", "data.dir=data", "logger.dir=runs",
            *overrides)  # fmt: skip


# (command and arguments; words the one line must hold). "{folder}" is the working folder,
# which holds problem.json (a problem) and file.txt (a file that is not a folder).
CASES = {
    "bc: env id of wrong case": (bc("env.id=TEMP-2d-v0"), ["env.id", "TEMP-2D-v0"]),
    "bc: env id of another robot": (bc("env.id=TEMP-3D-v0"), ["env.robot"]),
    "bc: run name climbing out": (bc("train.exp_name=../../.."), ["train.exp_name", "letters"]),
    "bc: run name of 300 characters": (bc("train.exp_name=" + "a" * 300), ["at most 100"]),
    "bc: tasks per workspace 10^12": (
        bc("data.tasks_per_workspace=1000000000000"),
        ["data.tasks_per_workspace", "at most"],
    ),
    "bc: data.dir /dev/null": (bc("data.dir=/dev/null"), ["data.dir", "not a folder"]),
    "bc: data.dir a file": (bc("data.dir={folder}/file.txt"), ["data.dir", "not a folder"]),
    "bc: data.dir /proc/x": (bc("data.dir=/proc/x"), ["data.dir", "system folder"]),
    "bc: logger.dir a file": (bc("logger.dir={folder}/file.txt"), ["logger.dir"]),
    "bc: learning rate NaN": (bc("optim.lr=.nan"), ["optim.lr", "finite"]),
    "bc: unknown key": (bc("train.max_epoch=3"), ["did you mean train.max_epochs"]),
    "bc: a key that is not key=value": (("bc.py", "--config", TINY, "--bogus"), ["--bogus"]),
    "bc: missing config file": (("bc.py", "--config", "{folder}/none.yaml"), ["none.yaml"]),
    "bc: resume without last.pt": (bc("--resume"), ["--resume"]),
    "bc: model of billions of weights": (
        bc("model.num_layers=48", "model.token_dim=4096", "model.ffn_dim=4096"),
        ["model", "weights, at most"],
    ),
    "generate: data.dir /proc/x": (
        ("generate.py", "--config", TINY, "data.dir=/proc/x"),
        ["data.dir", "system folder"],
    ),
    "generate: no workers": (("generate.py", "--config", TINY, "--workers", "0"), ["--workers"]),
    "evaluate: no config": (("evaluate.py",), ["--config"]),
    "evaluate: /dev/zero as checkpoint": (
        ("evaluate.py", "--config", TINY, "--checkpoint", "/dev/zero", "evaluation.out=out"),
        ["--checkpoint", "not a regular file"],
    ),
    "evaluate: zero tasks": (
        ("evaluate.py", "--config", TINY, "evaluation.tasks=0", "evaluation.out=out"),
        ["evaluation.tasks"],
    ),
    "evaluate: a TEMP setting under its old flat key": (
        ("evaluate.py", "--config", TINY, "evaluation.attention_rounds=2", "evaluation.out=out"),
        ["evaluation.temp.attention_rounds"],
    ),
    "evaluate: a TEMP setting out of range": (
        (
            "evaluate.py",
            "--config",
            TINY,
            "evaluation.temp.attention_uniform=2",
            "evaluation.out=out",
        ),
        ["evaluation.temp.attention_uniform", "at most 1"],
    ),
    "temp-plan: planner unknown": (
        ("temp-plan", "{folder}/problem.json", "--planner", "rrt"),
        ["--planner", "rrt_star"],
    ),
    "temp-plan: time limit NaN": (
        ("temp-plan", "{folder}/problem.json", "--time-limit", "nan"),
        ["--time-limit"],
    ),
    "temp-plan: no node budget": (
        ("temp-plan", "{folder}/problem.json", "--max-nodes", "0"),
        ["--max-nodes"],
    ),
    "temp-plan: negative step": (
        ("temp-plan", "{folder}/problem.json", "--step-size", "-1"),
        ["--step-size"],
    ),
    "temp-plan: output is the input": (
        ("temp-plan", "{folder}/problem.json", "--out", "{folder}/problem.json"),
        ["is the problem file"],
    ),
    "temp-plan: out-dir is the inputs' folder": (
        ("temp-plan", "{folder}/problem.json", "--out-dir", "{folder}"),
        ["is the problem file"],
    ),
    "temp-plan: output replaces another file": (
        ("temp-plan", "{folder}/problem.json", "--out", "{folder}/file.txt"),
        ["not a temp-plan result"],
    ),
    "temp-plan: a setting of another planner": (
        (
            "temp-plan",
            "{folder}/problem.json",
            "--planner",
            "rrt_star",
            "--set",
            "attention_patience=30",
        ),
        ["--set attention_patience", "--planner temp --set attention_patience="],
    ),
    "temp-plan: a setting out of range": (
        ("temp-plan", "{folder}/problem.json", "--set", "goal_bias=2"),
        ["--set goal_bias", "[0, 1]"],
    ),
    "temp-plan: a setting that is not KEY=VALUE": (
        ("temp-plan", "{folder}/problem.json", "--set", "goal_bias"),
        ["--set", "KEY=VALUE"],
    ),
    "temp-plan: /dev/zero as checkpoint": (
        ("temp-plan", "{folder}/problem.json", "--checkpoint", "/dev/zero"),
        ["not a regular file"],
    ),
    "tune_planner: no tasks": (
        ("tune_planner.py", "--config", TINY, "--checkpoint", SHIPPED_2D, "--tasks", "0"),
        ["--tasks"],
    ),
    "tune_planner: no attention-phase budget in the config": (
        ("tune_planner.py", "--config", TINY, "train_eval.temp.attention_nodes=0"),
        ["train_eval.temp.attention_nodes", "at least 1"],
    ),
    "tune_planner: per-task file over the config": (
        (
            "tune_planner.py",
            "--config",
            "{folder}/tiny.yaml",
            "--checkpoint",
            SHIPPED_2D,
            "--attention-nodes",
            "50",
            "--per-task",
            "{folder}/tiny.yaml",
        ),
        ["--per-task", "an input"],
    ),  # fmt: skip
    "correct: negative clearance": (
        (
            "correct.py",
            "--config",
            TINY,
            "--checkpoint",
            SHIPPED_2D,
            "--round",
            "1",
            "--clearance",
            "-1",
        ),
        ["--clearance"],
    ),  # fmt: skip
    "compare_policies: /dev/zero as a per-task file": (
        ("compare_policies.py", "/dev/zero", "{folder}/problem.json"),
        ["not a regular file"],
    ),
    "compare_policies: a problem as a per-task file": (
        ("compare_policies.py", "{folder}/problem.json", "{folder}/problem.json"),
        ["not a tune_planner.py --per-task file"],
    ),
    "ship: negative noise": (
        (
            "ship.py",
            "--config",
            TINY,
            "--checkpoint",
            SHIPPED_2D,
            "--noise-std",
            "-1",
            "--out-dir",
            "out",
        ),
        ["--noise-std"],
    ),  # fmt: skip
    "ship: unknown env id": (
        ("ship.py", "--update-planner", "TEMP-9D-v0", "noise_std=0", "--out-dir", "out"),
        ["expected one of"],
    ),
    "ood: output over a device": (("ood", "--out", "/dev/null"), ["--out", "not a folder"]),
    "make_results: no task draws": (
        ("make_results.py", "--task-draws", "0", "--docs-dir", "docs"),
        ["--task-draws"],
    ),
    "make_images: unknown picture": (("make_images.py", "--only", "9d"), ["--only"]),
}


@pytest.fixture
def folder(tmp_path) -> Path:
    (tmp_path / "problem.json").write_text(json.dumps(PROBLEM))
    (tmp_path / "file.txt").write_text("not a folder\n")
    (tmp_path / "tiny.yaml").write_text(Path(TINY).read_text())
    return tmp_path


def test_there_are_more_than_twenty_cases_across_the_commands():
    assert len(CASES) > 20
    assert len({args[0] for args, _ in CASES.values()}) >= 10


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_bad_value_gets_one_line_exit_2_and_writes_nothing(folder, case):
    (command, *args), words = CASES[case]
    args = [arg.replace("{folder}", str(folder)) for arg in args]
    before = files_under(folder)
    outcome = run(command, *args, cwd=folder)
    assert_refused(outcome, *words)
    assert files_under(folder) == before
