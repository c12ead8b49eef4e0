"""trainers/tune_planner.py: the node budget every run gets, stated and enforced."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from temp_gym.jobs import run_script  # noqa: E402
from trainers import tune_planner  # noqa: E402

ARGS = ["--config", "configs/2d.yaml", "--checkpoint", "temp_gym/checkpoints/2d.pt"]


def _table(out: list[str]) -> tuple[list[str], list[list[str]]]:
    """The printed table's column names and its rows of n = 3000, split into cells."""
    header = [name.strip() for name in next(line for line in out if line.startswith("| n |"))
              .split("|")]  # fmt: skip
    return header, [line.split("|") for line in out if line.startswith("| 3000 |")]


def test_max_nodes_sets_the_budget_of_every_run_and_is_printed(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    best = tune_planner.main(
        [*ARGS, "--attention-nodes", "40", "--max-nodes", "40", "--noise-std", "0",
         "--tasks", "3", "--min-attention-success", "0"]
    )  # fmt: skip
    out = capsys.readouterr().out
    assert "budget 40 nodes per run" in out
    header = next(line for line in out.splitlines() if line.startswith("| n |"))
    column = [name.strip() for name in header.split("|")].index("nodes mean")
    row = next(line for line in out.splitlines() if line.startswith("| 40 |"))
    mean_nodes = float(row.split("|")[column])
    assert 1 < mean_nodes <= 40  # a failure counts as the budget, never more
    assert best["attention_nodes"] == 40


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--attention-nodes", "10000"], "exceeds the node budget 3000"),
        (["--max-nodes", "0"], "--max-nodes: must be at least 1"),
        (["train_eval.max_nodes=0"], "train_eval.max_nodes: must be at least 2"),
        (["--near-goal-factor", "0.5"],
         "--near-goal-factor: expected a finite number of at least 1, got 0.5"),
        (["--follow-fallback", "1.5"], "--follow-fallback: expected a number in [0, 1], got 1.5"),
        (["--local-fallback", "-1"], "--local-fallback"),
        (["--baseline", "temp"], "--baseline: unknown classical planner 'temp'"),
        (["--baseline", "rrt"], "--baseline: unknown classical planner 'rrt'"),
    ],
)  # fmt: skip
def test_a_bad_setting_is_refused_and_named(capsys, monkeypatch, args, message):
    monkeypatch.chdir(ROOT)
    code = run_script("tune_planner.py", tune_planner.main, [*ARGS, "--tasks", "1", *args])
    err = capsys.readouterr().err
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1


def test_near_goal_factors_are_tried(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    best = tune_planner.main(
        [*ARGS, "--attention-nodes", "40", "--max-nodes", "40", "--noise-std", "0",
         "--near-goal-factor", "1", "4",
         "--tasks", "2", "--min-attention-success", "0"]
    )  # fmt: skip
    out = capsys.readouterr().out.splitlines()
    header = [name.strip() for name in next(line for line in out if line.startswith("| n |"))
              .split("|")]  # fmt: skip
    rows = [line.split("|") for line in out if line.startswith("| 40 |")]
    assert [row[header.index("near goal")].strip() for row in rows] == ["1", "4"]
    assert best["attention_near_goal_factor"] in (1.0, 4.0)


def test_path_windows_are_tried_and_checked(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    best = tune_planner.main(
        [*ARGS, "--attention-nodes", "3000", "--noise-std", "0", "--path-window", "0", "2",
         "--tasks", "4", "--min-attention-success", "0"]
    )  # fmt: skip
    header, rows = _table(capsys.readouterr().out.splitlines())
    assert [row[header.index("window")].strip() for row in rows] == ["64", "2"]
    nodes = [float(row[header.index("nodes mean")]) for row in rows]
    assert nodes[0] != nodes[1]  # a window of 2 reads too little of the path: other trees
    assert best["path_window"] in (None, 2)
    with pytest.raises(SystemExit):
        tune_planner.main([*ARGS, "--tasks", "1", "--path-window", "65"])
    assert "--path-window: path_window: expected an integer in 1..64" in capsys.readouterr().err


def test_the_goal_tree_is_tried_both_ways(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    tune_planner.main(
        [*ARGS, "--attention-nodes", "3000", "--noise-std", "0", "--patience", "5",
         "--goal-tree", "1", "0", "--tasks", "3", "--min-attention-success", "0"]
    )  # fmt: skip
    out = capsys.readouterr().out.splitlines()
    header, rows = _table(out)
    assert [row[header.index("goal tree")].strip() for row in rows] == ["1", "0"]
    nodes = [float(row[header.index("nodes mean")]) for row in rows]
    assert nodes[0] != nodes[1]  # a patience of 5 stalls: the classical phases differ


def test_the_attention_phase_from_the_goal_is_tried_both_ways(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    tune_planner.main(
        [*ARGS, "--attention-nodes", "3000", "--noise-std", "0", "--patience", "5",
         "--goal-tree", "1", "0", "--from-goal", "1", "0", "--tasks", "3",
         "--min-attention-success", "0"]
    )  # fmt: skip
    out = capsys.readouterr().out.splitlines()
    header, rows = _table(out)
    # Without the goal tree, --from-goal changes nothing: one row for both.
    pairs = [(row[header.index("goal tree")].strip(), row[header.index("from goal")].strip())
             for row in rows]  # fmt: skip
    assert pairs == [("1", "1"), ("1", "0"), ("0", "-")]
    forward, both = (
        [float(row[header.index(name)]) for row in rows] for name in ("AP solved", "AP both ways")
    )
    assert forward[0] == forward[1] == forward[2]  # the first phase is the same in every row
    assert both[0] >= forward[0] and both[1] == forward[1] and both[2] == forward[2]


def test_rounds_after_stalls_both_ways_are_tried(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    tune_planner.main(
        [*ARGS, "--attention-nodes", "3000", "--noise-std", "0", "--patience", "5",
         "--from-goal", "1", "0", "--rounds", "-1", "0", "2", "--tasks", "8",
         "--min-attention-success", "0"]
    )  # fmt: skip
    out = capsys.readouterr().out.splitlines()
    header, rows = _table(out)
    # Without the phase from the goal, --rounds changes nothing: one row for all three.
    pairs = [(row[header.index("from goal")].strip(), row[header.index("rounds")].strip())
             for row in rows]  # fmt: skip
    assert pairs == [("1", "default"), ("1", "0"), ("1", "2"), ("0", "-")]
    both = [float(row[header.index("AP both ways")]) for row in rows]
    # With a patience of 5 the phases stall both ways on some tasks; a round solves one more.
    assert both[1] < both[0] <= both[2]
    recommended = next(line for line in out if line.startswith("recommended:"))
    assert "'attention_rounds'" in recommended


def test_a_follow_probability_of_zero_is_reported_as_zero(capsys, monkeypatch):
    """``value or 1.0`` used to report (and recommend) 1 for a row that ran with 0."""
    monkeypatch.chdir(ROOT)
    best = tune_planner.main(
        [*ARGS, "--attention-nodes", "3000", "--noise-std", "0", "--follow-fallback", "0", "1",
         "--tasks", "2", "--min-attention-success", "0"]
    )  # fmt: skip
    out = capsys.readouterr().out.splitlines()
    header, rows = _table(out)
    assert [row[header.index("follow")].strip() for row in rows] == ["0", "1"]
    assert best["attention_follow_fallback"] in (0.0, 1.0)


def test_replacements_near_the_proposal_are_tried(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    best = tune_planner.main(
        [*ARGS, "--attention-nodes", "3000", "--noise-std", "0", "--local-fallback", "0", "20",
         "--tasks", "6", "--min-attention-success", "0"]
    )  # fmt: skip
    out = capsys.readouterr().out.splitlines()
    header, rows = _table(out)
    assert [row[header.index("local")].strip() for row in rows] == ["0", "20"]
    nodes = [row[header.index("nodes mean")] for row in rows]
    assert nodes[0] != nodes[1]  # the replacements changed the trees
    assert best["attention_local_fallback"] in (0, 20)


def test_the_tuning_pool_is_a_split_of_its_own(capsys, monkeypatch):
    """``--split tune`` plans tasks in the planner-tuning pool, not in the validation one."""
    from temp_gym.training import episodes
    from temp_gym.worlds.splits import SPLITS, split_workspace

    monkeypatch.chdir(ROOT)
    drawn = []
    draw = episodes.draw_problems

    def recording(config, split, count, seed, **kwargs):
        problems = draw(config, split, count, seed, **kwargs)
        drawn.append((split, problems))
        return problems

    from temp_gym import training

    monkeypatch.setattr(training, "draw_problems", recording)
    tune_planner.main(
        [*ARGS, "--split", "tune", "--attention-nodes", "40", "--max-nodes", "40",
         "--noise-std", "0", "--tasks", "4", "--min-attention-success", "0"]
    )  # fmt: skip
    assert "4 tune tasks (boxes)" in capsys.readouterr().out
    [(split, problems)] = drawn
    pool = [split_workspace("point2d", "tune", i) for i in range(SPLITS["tune"])]
    val = [split_workspace("point2d", "val", i) for i in range(SPLITS["val"])]
    assert split == "tune"
    assert all(p.workspace in pool and p.workspace not in val for p in problems)


def test_with_no_setting_flag_the_policy_is_measured_as_it_ships(capsys, monkeypatch):
    """No flag gives the node counts of the model card's flags: the tools default to what
    ships. (The card's command: trainers/tune_planner.py ... --noise-std 0 --horizon 4
    --path-window 16 --patience 30 --resume-growth 2 --rounds 16 --local-fallback 5.)"""
    monkeypatch.chdir(ROOT)
    common = ["--config", "configs/2d.yaml", "--split", "test", "--tasks", "6", "--no-rrt",
              "--min-attention-success", "0"]  # fmt: skip
    card = ["--noise-std", "0", "--horizon", "4", "--path-window", "16", "--patience", "30",
            "--resume-growth", "2", "--rounds", "16", "--local-fallback", "5"]  # fmt: skip
    shipped = tune_planner.main(common)  # no --checkpoint either: the one shipped for 2D
    as_shipped = capsys.readouterr().out.splitlines()
    by_hand = tune_planner.main([*common, "--checkpoint", "temp_gym/checkpoints/2d.pt", *card])
    by_flags = capsys.readouterr().out.splitlines()
    other = tune_planner.main([*common, "--local-fallback", "0"])
    told_otherwise = capsys.readouterr().out.splitlines()
    header, _ = _table(as_shipped)

    def figures(out):
        [row] = [line.split("|") for line in out if line.startswith("| 3000 |")]
        return [row[header.index(name)].strip() for name in ("nodes mean", "median", "cost")]

    assert figures(as_shipped) == figures(by_flags)
    assert shipped == by_hand and shipped["attention_local_fallback"] == 5
    assert other["attention_local_fallback"] == 0 and other["attention_patience"] == 30
    assert figures(told_otherwise) != figures(as_shipped)


def test_the_baseline_is_paired_task_by_task_and_named(capsys, monkeypatch, tmp_path):
    """``--baseline`` plans the same tasks and seeds; its name heads the column and the file."""
    import json

    monkeypatch.chdir(ROOT)
    per_task = tmp_path / "runs.json"
    tune_planner.main(
        [*ARGS, "--baseline", "informed_rrt_star", "--max-nodes", "300", "--tasks", "3",
         "--per-task", str(per_task)]
    )  # fmt: skip
    out = capsys.readouterr().out
    assert "informed_rrt_star: nodes mean" in out
    assert "fewer than informed_rrt_star" in out
    data = json.loads(per_task.read_text())
    assert data["baseline"] == "informed_rrt_star"
    assert len(data["informed_rrt_star"]["nodes"]) == 3


@pytest.mark.parametrize("flag", ["--no-baseline", "--no-rrt"])
def test_the_baseline_is_left_out_under_either_name_of_the_flag(capsys, monkeypatch, flag):
    """``--no-baseline`` (and its older name, ``--no-rrt``) plans no baseline; its columns: -."""
    monkeypatch.chdir(ROOT)
    tune_planner.main([*ARGS, "--baseline", "informed_rrt_star", "--tasks", "1", flag])
    out = capsys.readouterr().out
    assert "informed_rrt_star: not run (--no-baseline)" in out
    [row] = [line for line in out.splitlines() if line.startswith("| ") and line[2].isdigit()]
    assert row.rstrip().endswith("| - | - |")


def test_a_per_task_file_that_cannot_be_written_is_refused_before_the_sweep(tmp_path):
    from temp_gym.config import ConfigError

    (tmp_path / "afile").write_text("x")
    inputs = [Path("configs/2d.yaml")]
    with pytest.raises(ConfigError, match=r"--per-task: .*afile is a file, so .*x\.json cannot"):
        tune_planner.check_per_task_file(tmp_path / "afile" / "deeper" / "x.json", inputs)
    with pytest.raises(ConfigError, match="is a directory"):
        tune_planner.check_per_task_file(tmp_path, inputs)
    tune_planner.check_per_task_file(tmp_path / "new" / "x.json", inputs)  # folders get made
