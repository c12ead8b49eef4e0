"""trainers/compare_policies.py: policies paired task by task from tune_planner's per-task files."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from temp_gym.jobs import JobError  # noqa: E402
from trainers import compare_policies, tune_planner  # noqa: E402

ARGS = ["--config", "configs/2d.yaml", "--checkpoint", "temp_gym/checkpoints/2d.pt",
        "--attention-nodes", "3000", "--noise-std", "0", "--no-rrt"]  # fmt: skip
PLAIN = ["--local-fallback", "0"]  # the shipped policy carries 5: Algorithm 1's replacements


@pytest.fixture(scope="module")
def per_task(tmp_path_factory) -> dict[str, Path]:
    """Per-task files: two settings on the same 6 tasks, and the first on 3 other tasks."""
    folder = tmp_path_factory.mktemp("per_task")
    files = {
        "plain": folder / "plain.json",
        "near": folder / "near.json",
        "other": folder / "other.json",
    }
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(ROOT)
        tune_planner.main([*ARGS, *PLAIN, "--tasks", "6", "--per-task", str(files["plain"])])
        tune_planner.main([*ARGS, "--tasks", "6", "--local-fallback", "20",
                           "--per-task", str(files["near"])])  # fmt: skip
        tune_planner.main([*ARGS, *PLAIN, "--tasks", "3", "--per-task", str(files["other"])])
    return files


def test_the_per_task_file_holds_every_run_task_by_task(per_task):
    data = json.loads(per_task["plain"].read_text())
    assert data["rrt_star"] is None  # --no-rrt
    assert data["max_nodes"] == 3000 and len(data["seeds"]) == len(data["problems"]) == 6
    [setting] = data["settings"]
    assert setting["setting"]["attention_local_fallback"] == 0
    assert all(len(setting[key]) == 6 for key in ("nodes", "success", "cost"))
    assert all(setting["success"])
    near = json.loads(per_task["near"].read_text())["settings"][0]
    assert near["setting"]["attention_local_fallback"] == 20
    assert near["nodes"] != setting["nodes"]  # the replacements changed the trees


def test_a_policy_against_itself_differs_by_nothing(per_task, capsys):
    rows = compare_policies.main([str(per_task["plain"]), str(per_task["plain"])])
    [row] = rows.values()
    assert row["difference"] == row["low"] == row["high"] == 0.0
    assert row["within_margin"]
    assert row["candidate_capped"] == row["reference_capped"]
    assert "| yes (<= " in capsys.readouterr().out


def test_a_candidate_is_paired_with_the_reference(per_task):
    plain = json.loads(per_task["plain"].read_text())["settings"][0]["nodes"]
    near = json.loads(per_task["near"].read_text())["settings"][0]["nodes"]
    rows = compare_policies.main(
        [str(per_task["plain"]), str(per_task["near"]), "--cap", "60", "--margin", "0"]
    )
    row = rows[str(per_task["near"])]
    capped = [min(b, 60) - min(a, 60) for a, b in zip(plain, near)]
    assert row["difference"] == pytest.approx(sum(capped) / len(capped))
    assert row["low"] <= row["difference"] <= row["high"]
    assert row["within_margin"] == (row["high"] <= 0)
    assert row["candidate_over_cap"] == sum(n > 60 for n in near)


def test_files_of_other_tasks_or_bad_arguments_are_refused(per_task, tmp_path, capsys):
    with pytest.raises(JobError, match="seeds differ"):
        compare_policies.main([str(per_task["plain"]), str(per_task["other"])])
    broken = tmp_path / "broken.json"
    broken.write_text(json.dumps({"settings": []}))
    with pytest.raises(JobError, match="not a tune_planner.py --per-task file"):
        compare_policies.main([str(per_task["plain"]), str(broken)])
    for setting in ("1", "-1"):  # -1 would be the last row by Python's indexing
        with pytest.raises(JobError, match=f"--setting {setting}, but the file holds settings 0"):
            compare_policies.main(
                [str(per_task["plain"]), str(per_task["near"]), "--setting", setting]
            )
    stored = json.loads(per_task["near"].read_text())
    for key, value in (("nodes", "12"), ("success", "false")):  # read as 12 and as True
        copy = json.loads(json.dumps(stored))
        copy["settings"][0][key][0] = value
        typed = tmp_path / f"{key}.json"
        typed.write_text(json.dumps(copy))
        with pytest.raises(JobError, match="not true or false, or a node count that is not a"):
            compare_policies.main([str(per_task["plain"]), str(typed)])
    with pytest.raises(SystemExit):
        compare_policies.main([str(per_task["plain"]), str(per_task["near"]), "--cap", "0"])
    assert "--cap: expected a finite positive number" in capsys.readouterr().err
