import sqlite3

import pytest

from temp_gym.evaluation.ompl_database import LogFormatError, logs_to_database
from temp_gym.evaluation.ompl_log import (
    EXACT_SOLUTION,
    TIMEOUT,
    LogExperiment,
    LogPlanner,
    boolean,
    format_log,
    real,
    write_log,
)


def experiment() -> LogExperiment:
    solved = {"time REAL": real(0.25), "solved BOOLEAN": boolean(True),
              "status ENUM": str(EXACT_SOLUTION), "best cost REAL": real(12.5)}  # fmt: skip
    failed = {"time REAL": real(1.0), "solved BOOLEAN": boolean(False),
              "status ENUM": str(TIMEOUT), "best cost REAL": real(float("inf"))}  # fmt: skip
    planner = LogPlanner(
        "rrt_star",
        {"goal_bias": "0.05", "range": "None"},
        [solved, failed],
        [[{"time REAL": "0.1", "best cost REAL": "13.0"},
          {"time REAL": "0.2", "best cost REAL": "12.5"}], []],
    )  # fmt: skip
    return LogExperiment("walls", [planner], {"robot STRING": "point2d"}, "temp-gym 1.2.3",
                         host="bench", setup="one problem\n", cpu_info="a cpu", seed=7,
                         time_limit=1.0, run_count=2, total_time=1.25)  # fmt: skip


def test_the_log_is_written_as_ompls_benchmark_writes_it():
    lines = format_log(experiment()).splitlines()
    assert lines[:5] == ["temp-gym version 1.2.3", "Experiment walls", "1 experiment properties",
                         "robot STRING = point2d", "Running on bench"]  # fmt: skip
    assert lines[5].startswith("Starting at ")
    assert lines[6:12] == ["<<<|", "one problem", "|>>>", "<<<|", "a cpu", "|>>>"]
    assert lines[12:19] == [
        "7 is the random seed", "1 seconds per run", "0 MB per run", "2 runs per planner",
        "1.25 seconds spent to collect the data", "1 enum type",
        "status|Unknown status|Invalid start|Invalid goal|Unrecognized goal type|Timeout|"
        "Approximate solution|Exact solution|Crash|Abort|Infeasible",
    ]  # fmt: skip
    planner = lines[19:]
    assert planner[:5] == ["1 planners", "rrt_star", "2 common properties", "goal_bias = 0.05",
                           "range = None"]  # fmt: skip
    assert planner[5:13] == ["4 properties for each run", "best cost REAL", "solved BOOLEAN",
                             "status ENUM", "time REAL", "2 runs", "12.5; 1; 6; 0.25; ",
                             "inf; 0; 4; 1.0; "]  # fmt: skip
    assert planner[13:] == ["2 progress properties for each run", "best cost REAL", "time REAL",
                            "2 runs", "13.0,0.1,;12.5,0.2,;", "", "."]  # fmt: skip


def test_the_database_holds_what_the_log_says(tmp_path):
    log = write_log(experiment(), tmp_path / "walls.log")
    database = logs_to_database([log], tmp_path / "b.db")
    with sqlite3.connect(database) as connection:
        rows = connection.execute(
            "SELECT plannerConfigs.name, settings, time, solved, status, best_cost FROM runs "
            "JOIN plannerConfigs ON plannerConfigs.id = runs.plannerid ORDER BY runs.id"
        ).fetchall()
        progress = connection.execute("SELECT runid, time, best_cost FROM progress").fetchall()
        header = connection.execute("SELECT name, seed, runcount, version, robot FROM experiments")
        assert header.fetchall() == [("walls", "7", 2, "temp-gym 1.2.3", "point2d")]
    settings = "goal_bias = 0.05\n;range = None\n;"
    assert rows == [("rrt_star", settings, 0.25, 1, 6, 12.5),
                    ("rrt_star", settings, 1.0, 0, 4, None)]  # fmt: skip
    assert sorted(progress) == [(1, 0.1, 13.0), (1, 0.2, 12.5)]


@pytest.mark.parametrize(
    "change, field",
    [
        ({"name": "two words"}, "experiment name"),
        ({"properties": {"robot": "point2d"}}, "experiment property"),
        ({"setup": "|>>> ends early"}, "setup"),
    ],
)
def test_a_log_that_readers_would_misread_is_refused(change, field):
    bad = experiment()
    for key, value in change.items():
        setattr(bad, key, value)
    with pytest.raises(ValueError, match=f"^{field}") as error:
        format_log(bad)
    assert "\n" not in str(error.value)


def test_a_value_holding_a_separator_is_refused():
    bad = experiment()
    bad.planners[0].runs[0]["best cost REAL"] = "1; 2"
    with pytest.raises(ValueError, match="separator"):
        format_log(bad)


def test_a_damaged_log_is_one_line_naming_the_file(tmp_path):
    path = tmp_path / "cut.log"
    path.write_text("\n".join(format_log(experiment()).splitlines()[:14]))
    with pytest.raises(LogFormatError, match="cut.log") as error:
        logs_to_database([path], tmp_path / "b.db")
    assert "\n" not in str(error.value)
