import json
import subprocess
import sys

import pytest

PROBLEM = {
    "robot": "point2d",
    "bounds": [[0, 0], [20, 20]],
    "obstacles": [{"center": [10, 10], "half_extents": [1, 6]}],
    "start": [2, 2],
    "goal": [18, 18],
    "goal_radius": 0.5,
}


def run_cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "temp_gym.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_cli_solves_and_writes_the_result(tmp_path):
    problem = tmp_path / "problem.json"
    problem.write_text(json.dumps(PROBLEM))
    out = tmp_path / "result.json"
    done = run_cli(
        problem, "--planner", "informed_rrt_star", "--seed", 3, "--max-nodes", 600, "--out", out
    )
    assert done.returncode == 0, done.stderr
    assert len(done.stdout.strip().splitlines()) == 1
    assert "informed_rrt_star" in done.stdout
    result = json.loads(out.read_text())
    assert result["success"] and result["nodes"] == 600 and result["seed"] == 3
    assert result["path"][0] == [2.0, 2.0]


@pytest.mark.parametrize(
    "content", ["{not json", "[1, 2]", json.dumps({**PROBLEM, "goal": [10, 10]}), None]
)
def test_cli_rejects_bad_problem_files(tmp_path, content):
    problem = tmp_path / "problem.json"
    if content is not None:
        problem.write_text(content)
    done = run_cli(problem, "--max-nodes", 50)
    assert done.returncode == 2
    assert done.stderr.startswith("temp-plan: error:")
    assert len(done.stderr.strip().splitlines()) == 1
    assert "Traceback" not in done.stderr


def test_cli_main_in_process(tmp_path, capsys):
    from temp_gym.cli import main

    problem = tmp_path / "problem.json"
    problem.write_text(json.dumps(PROBLEM))
    assert main([str(problem), "--planner", "rrt_star", "--max-nodes", "300", "--seed", "1"]) in (
        0,
        1,
    )
    assert "rrt_star seed=1" in capsys.readouterr().out
