import csv
import json
import sqlite3

import numpy as np
import pytest

from temp_gym.evaluation.benchmark import (
    BenchmarkSettings,
    read_records,
    run_once,
)
from temp_gym.evaluation.benchmark_command import main
from temp_gym.evaluation.benchmark_problems import group_experiments
from temp_gym.files import StoredFileError
from temp_gym.planning.plan import PLANNERS, register_planner
from temp_gym.planning.result import PlanResult
from temp_gym.problem import Problem

WALLS = {"robot": "point2d", "bounds": [[0, 0], [20, 20]],
         "obstacles": [{"center": [10, 10], "half_extents": [1, 6]}],
         "start": [2, 10], "goal": [18, 10], "goal_radius": 0.5}  # fmt: skip
OPEN = {**WALLS, "obstacles": [{"center": [10, 18], "half_extents": [1, 1]}]}
START_IN_A_WALL = {**WALLS, "start": [10, 10]}
PLANNER_NAMES = ["rrt_star", "informed_rrt_star"]


def command(problems, out, *extra):
    return ["--problems", str(problems), "--planners", *PLANNER_NAMES, "--runs", "2",
            "--time-limit", "1", "--max-nodes", "300", "--out", str(out), "--no-progress",
            *extra]  # fmt: skip


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    root = tmp_path_factory.mktemp("bench")
    problems = root / "problems"
    for name, data in [("walls/0000", WALLS), ("walls/0001", START_IN_A_WALL),
                       ("open/0000", OPEN)]:  # fmt: skip
        path = problems / f"{name}.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(data))
    out = root / "out"
    assert main(command(problems, out)) == 0
    return problems, out


def runs_table(database):
    with sqlite3.connect(database) as connection:
        return connection.execute(
            "SELECT experiments.name, plannerConfigs.name, runs.problem, runs.run, runs.seed, "
            "runs.time, runs.solved, runs.best_cost, runs.first_solution_time FROM runs "
            "JOIN plannerConfigs ON plannerConfigs.id = runs.plannerid "
            "JOIN experiments ON experiments.id = runs.experimentid ORDER BY runs.id"
        ).fetchall()


def expected_rows(out):
    """The runs table the stored records imply: one row per run, experiment by experiment."""
    records = read_records(out / "runs.jsonl")
    rows = []
    for experiment, problem in [("open", "open/0000"), ("walls", "walls/0000")]:
        for planner in PLANNER_NAMES:
            for r in records:
                if r["problem"] == problem and r["planner"] == planner:
                    cost = r["cost"] if r["solved"] else None
                    rows.append((experiment, planner, 0, r["run"], r["seed"], r["time"],
                                 int(r["solved"]), cost, r["first_time"]))  # fmt: skip
    return rows


def test_the_database_rows_are_the_stored_runs(bench):
    _, out = bench
    rows = runs_table(out / "benchmark.db")
    assert len(rows) == 2 * 2 * 2  # two experiments, two planners, two runs each
    assert sorted(rows) == sorted(expected_rows(out))
    assert any(row[6] for row in rows)  # the point problems are solved in a second


def test_ompls_own_script_reads_the_logs_into_the_same_rows(bench, tmp_path):
    tools = pytest.importorskip("ompl.tools")
    _, out = bench
    logs = sorted(str(path) for path in (out / "logs").glob("*.log"))
    tools.readBenchmarkLog(str(tmp_path / "ompl.db"), logs, False)
    assert sorted(runs_table(tmp_path / "ompl.db")) == sorted(expected_rows(out))
    with (
        sqlite3.connect(tmp_path / "ompl.db") as theirs,
        sqlite3.connect(out / "benchmark.db") as ours,
    ):
        for table in ("experiments", "plannerConfigs", "enums", "runs", "progress"):
            query = f"SELECT * FROM {table} ORDER BY 1, 2"
            assert theirs.execute(query).fetchall() == ours.execute(query).fetchall(), table
            info = f"PRAGMA table_info({table})"
            assert theirs.execute(info).fetchall() == ours.execute(info).fetchall(), table


def test_rerunning_skips_finished_runs_and_redoes_a_cut_one(bench):
    problems, out = bench
    stored = (out / "runs.jsonl").read_bytes()
    assert main(command(problems, out)) == 0
    assert (out / "runs.jsonl").read_bytes() == stored  # nothing run again, nothing added
    lines = stored.splitlines(keepends=True)
    (out / "runs.jsonl").write_bytes(b"".join(lines[:-1]) + lines[-1][:40])  # killed mid-write
    assert main(command(problems, out)) == 0
    records = read_records(out / "runs.jsonl")
    keys = [(r["problem"], r["planner"], r["run"]) for r in records]
    assert len(keys) == len(set(keys)) == len(lines)
    assert records[:-1] == [json.loads(line) for line in lines[:-1]]
    assert keys[-1] == tuple(json.loads(lines[-1])[k] for k in ("problem", "planner", "run"))


def test_the_summary_lists_each_planner_and_the_skipped_problem_and_plots_exist(bench):
    _, out = bench
    with open(out / "summary.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert [(row["experiment"], row["planner"]) for row in rows] == [
        (experiment, planner) for experiment in ("open", "walls") for planner in PLANNER_NAMES
    ]
    records = read_records(out / "runs.jsonl")
    for row in rows:
        mine = [r for r in records if r["problem"].startswith(row["experiment"] + "/")
                and r["planner"] == row["planner"]]  # fmt: skip
        assert float(row["solved"]) == sum(r["solved"] for r in mine) / len(mine)
    summary = (out / "summary.md").read_text()
    assert "walls/0001" in summary and "Skipped problems (1)" in summary
    for experiment in ("open", "walls"):
        assert (out / "plots" / f"{experiment}.png").read_bytes()[:4] == b"\x89PNG"


def test_a_stored_solved_run_without_its_first_solution_is_still_reported(bench, tmp_path):
    # Earlier versions could store one (an improvement dropped at the deadline); the report
    # crashed on it at every resume, so its folder could never be summarised.
    import shutil

    problems, out = bench
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    records = read_records(copy / "runs.jsonl")
    solved = next(r for r in records if r["solved"])
    solved.update(first_time=None, first_cost=None, first_nodes=None, history={})
    (copy / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records))
    (copy / "summary.csv").unlink()
    assert main(command(problems, copy)) == 0
    with open(copy / "summary.csv") as handle:
        rows = list(csv.DictReader(handle))
    experiment = solved["problem"].split("/")[0]
    row = next(r for r in rows if (r["experiment"], r["planner"]) == (experiment,
                                                                    solved["planner"]))  # fmt: skip
    assert float(row["solved"]) > 0 and row["median_first_time"] not in ("", "nan")


def test_a_path_through_an_obstacle_does_not_count_as_solved():
    def straight_line(problem, settings):
        path = np.stack([problem.start, problem.goal])
        return PlanResult("straight_line", True, path, 16.0, 2, 1, 0, 1, 0.0, 0.0, 2)

    register_planner("straight_line", straight_line)
    try:
        problem = Problem.from_dict(WALLS)
        settings = BenchmarkSettings(("straight_line",), time_limit=1.0, runs=1)
        record = run_once(("walls/0000", problem, "straight_line", 0, 0, settings))
    finally:
        PLANNERS.pop("straight_line")
    assert record["status"] == "uncertified" and record["solved"] is False
    assert record["first_time"] is None and record["cost"] is None


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--planners", "no_such_planner"], "--planners: unknown planner 'no_such_planner'"),
        (["--time-limit", "0"], "--time-limit: expected a finite number above 0, got 0.0"),
        (["--time-limit", "nan"], "--time-limit: expected a finite number above 0, got nan"),
    ],
)
def test_bad_flags_are_one_line(bench, tmp_path, capsys, flags, message):
    problems, _ = bench
    argv = command(problems, tmp_path / "out")
    for flag, value in zip(flags[::2], flags[1::2]):
        at = argv.index(flag)
        argv[at + 1 : at + 1 + (2 if flag == "--planners" else 1)] = [value]
    try:
        code = main(argv)
    except SystemExit as exit:  # a flag's own type refuses it while parsing
        code = exit.code
    assert code == 2
    error = capsys.readouterr().err.strip()
    assert message in error and "\n" not in error
    assert not (tmp_path / "out").exists()


def test_bad_paths_are_one_line(bench, tmp_path, capsys):
    problems, out = bench
    for argv, message in [
        (command(tmp_path / "missing", tmp_path / "o1"), "does not exist"),
        (command(problems, problems / "inside"), "inside the problem folder"),
        (command(problems, out, "--seed", "5"), "other settings"),
        (command(problems, tmp_path / "o2", "--robot", str(tmp_path / "arm.yaml")), "--robot: "),
    ]:
        assert main(argv) == 2
        error = capsys.readouterr().err.strip()
        assert error.startswith("temp-benchmark: error:") and message in error, error
        assert "\n" not in error


def test_a_generated_split_writes_into_the_working_folder(tmp_path, monkeypatch):
    """A split reads no folder, so ``--out`` may lie anywhere, the working folder included."""
    monkeypatch.chdir(tmp_path)
    argv = ["--split", "point2d:easy:1", "--planners", "rrt_star", "--runs", "1",
            "--time-limit", "1", "--max-nodes", "200", "--out", "out", "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    assert (tmp_path / "out" / "runs.jsonl").exists()


@pytest.mark.parametrize(
    "split, message",
    [("point2d:easy:0", "COUNT >= 1"), ("point2d:easy:1000000000", "at most 1,000,000"),
     ("point2d:hard:5", "difficulty 'hard'"), ("point9d:easy:5", "split: ")],
)  # fmt: skip
def test_a_bad_split_is_one_line_before_any_task_is_drawn(tmp_path, capsys, split, message):
    argv = ["--split", split, "--planners", "rrt_star", "--out", str(tmp_path / "out")]
    assert main(argv) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("temp-benchmark: error:") and message in error, error
    assert "\n" not in error and not (tmp_path / "out").exists()


def test_a_run_on_other_problems_leaves_no_log_or_plot_of_the_earlier_ones(bench, tmp_path):
    problems, _ = bench
    out = tmp_path / "out"
    assert main(command(problems, out, "--runs", "1")) == 0
    assert sorted(p.name for p in (out / "logs").iterdir()) == ["open.log", "walls.log"]
    only_open = tmp_path / "only_open"
    (only_open / "open").mkdir(parents=True)
    (only_open / "open" / "0000.json").write_text((problems / "open" / "0000.json").read_text())
    (out / "plots" / "notes.txt").write_text("mine")  # not an experiment's: kept
    assert main(command(only_open, out, "--runs", "1")) == 0
    assert sorted(p.name for p in (out / "logs").iterdir()) == ["open.log"]
    assert sorted(p.name for p in (out / "plots").iterdir()) == ["notes.txt", "open.png"]
    with sqlite3.connect(out / "benchmark.db") as db:
        assert db.execute("SELECT name FROM experiments").fetchall() == [("open",)]


def test_a_damaged_record_before_the_last_line_is_refused(tmp_path):
    path = tmp_path / "runs.jsonl"
    path.write_text('{"problem": "a"}\n{damaged\n{"problem": "b"}\n')
    with pytest.raises(StoredFileError, match="line 2"):
        read_records(path)
    path.write_text('{"problem": "a"}\n{"problem": "b", "cut')
    assert read_records(path, repair=True) == [{"problem": "a"}]
    assert path.read_text() == '{"problem": "a"}\n'


def test_problems_group_by_scene_in_one_or_one_per_problem():
    problem = Problem.from_dict(WALLS)
    named = [("a/0", problem), ("a/1", problem), ("b c/0", problem), ("loose", problem)]
    assert {k: [n for n, _ in v] for k, v in group_experiments(named, "scene", "set").items()} == {
        "a": ["a/0", "a/1"], "b_c": ["b c/0"], "set": ["loose"]}  # fmt: skip
    assert list(group_experiments(named, "one", "set")) == ["set"]
    assert len(group_experiments(named, "problem")) == 4


def test_limit_keeps_the_first_problems_of_each_scene_and_stop_at_first_ends_runs_early(
    bench, tmp_path
):
    problems, stored = bench
    extra = problems / "open" / "0001.json"
    extra.write_text(json.dumps(OPEN))
    try:
        out = tmp_path / "first"
        argv = command(problems, out, "--limit", "1", "--stop-at-first")
        argv[argv.index("--time-limit") + 1] = "10"
        argv[argv.index("--max-nodes") + 1] = "100000"
        assert main(argv) == 0
    finally:
        extra.unlink()
    records = read_records(out / "runs.jsonl")
    assert {r["problem"] for r in records} == {"open/0000", "walls/0000"}
    # Stopped at the first solution: the anytime planners end long before 10 s or the budget.
    solved = [r for r in records if r["solved"]]
    assert solved and all(r["nodes"] == r["first_nodes"] for r in solved)
    assert json.loads((out / "benchmark.json").read_text())["stop_at_first"] is True
    # A benchmark run without the flag keeps the manifest it always had.
    assert "stop_at_first" not in json.loads((stored / "benchmark.json").read_text())


def test_simplify_records_the_shorter_path_beside_the_planners_and_ompl_reads_it(bench, tmp_path):
    problems, stored = bench
    out = tmp_path / "simplified"
    argv = command(problems, out, "--stop-at-first", "--simplify")
    assert main(argv) == 0
    records = [r for r in read_records(out / "runs.jsonl") if r["solved"]]
    assert records
    for record in records:  # the planner's own figures stay the run's
        assert record["cost"] == pytest.approx(record["first_cost"])
        assert record["simplified_cost"] <= record["cost"] and record["simplification_time"] > 0
        assert 2 <= record["simplified_states"]
    assert any(r["simplified_cost"] < r["cost"] for r in records)
    manifest = json.loads((out / "benchmark.json").read_text())
    assert manifest["simplify"] is True
    assert "simplify" not in json.loads((stored / "benchmark.json").read_text())
    assert main(command(problems, out, "--stop-at-first")) == 2  # it would mix runs
    with sqlite3.connect(out / "benchmark.db") as connection:
        lengths = connection.execute(
            "SELECT simplified_solution_length, simplification_time FROM runs "
            "WHERE solved = 1 ORDER BY id"
        ).fetchall()
    assert sorted(length for length, _ in lengths) == sorted(r["simplified_cost"] for r in records)
    summary = (out / "summary.md").read_text()
    assert "median simplified cost" in summary
    tools = pytest.importorskip("ompl.tools")
    logs = sorted(str(path) for path in (out / "logs").glob("*.log"))
    tools.readBenchmarkLog(str(tmp_path / "ompl.db"), logs, False)
    with sqlite3.connect(tmp_path / "ompl.db") as theirs:
        query = "SELECT simplified_solution_length FROM runs WHERE solved = 1"
        assert sorted(theirs.execute(query).fetchall()) == sorted(
            (length,) for length, _ in lengths
        )


def test_the_outputs_are_written_under_the_folders_lock(bench, monkeypatch):
    """A second run of the same command may finish while the first writes its outputs: the
    writing holds the folder's lock (waiting for the other's), so the two never interleave."""
    import temp_gym.evaluation.benchmark_report as report
    from temp_gym.files import DirectoryLock

    problems, out = bench
    write, held = report.write_outputs, []

    def watched(*args, **kwargs):
        held.append(DirectoryLock(out, "test").is_held_elsewhere())
        return write(*args, **kwargs)

    monkeypatch.setattr(report, "write_outputs", watched)
    assert main(command(problems, out)) == 0
    assert held == [True]


def test_temp_plans_with_a_checkpoint_and_a_robot_without_a_policy_is_refused(
    tmp_path, capsys, monkeypatch
):
    # A robot of your own ships no policy: temp-benchmark had no way to give one, and recorded
    # every temp run as a crash (exit 0).
    from temp_gym.models import registry

    problems = tmp_path / "problems"
    (problems / "walls").mkdir(parents=True)
    (problems / "walls" / "0000.json").write_text(json.dumps(WALLS))
    shipped_2d, shipped_3d = (registry.shipped_checkpoint(r) for r in ("point2d", "point3d"))
    base = ["--problems", str(problems), "--planners", "temp", "--runs", "1", "--time-limit", "1",
            "--max-nodes", "300", "--stop-at-first", "--no-progress"]  # fmt: skip

    def refused(argv, message, out):
        assert main([*argv, "--out", str(out)]) == 2
        error = capsys.readouterr().err.strip()
        assert message in error and "\n" not in error, error
        assert not (out / "runs.jsonl").exists()

    out = tmp_path / "out"
    assert main([*base, "--out", str(out), "--checkpoint", str(shipped_2d)]) == 0
    records = read_records(out / "runs.jsonl")
    assert [r["status"] for r in records] == ["solved"]
    other = tmp_path / "other.pt"  # another policy: resuming would mix the two
    other.write_bytes(shipped_3d.read_bytes())
    assert main([*base, "--out", str(out), "--checkpoint", str(other)]) == 2
    assert "other settings (differs in: checkpoint)" in capsys.readouterr().err
    refused([*base, "--checkpoint", str(shipped_3d)],
            "--checkpoint: checkpoint", tmp_path / "o1")  # fmt: skip
    refused([*base[:3], "rrt_star", *base[4:], "--checkpoint", str(shipped_2d)],
            "--checkpoint: a policy for the temp planner", tmp_path / "o2")  # fmt: skip
    refused([*base, "--checkpoint", str(tmp_path / "missing.pt")],
            "--checkpoint: no such file", tmp_path / "o3")  # fmt: skip
    monkeypatch.setattr(registry, "CHECKPOINT_DIR", str(tmp_path / "none"))
    refused(base, "--planners temp: no pretrained policy ships for robot 'point2d'; give one "
            "with --checkpoint PATH", tmp_path / "o4")  # fmt: skip
