"""``temp-view`` and ``temp-plan --view``: bad input gets one line and exit 2; Ctrl-C stops."""

import json
import signal
import subprocess
import sys
import tempfile
import urllib.request

import numpy as np
import pytest
from viewer_cases import POINT2D

from temp_gym.viewer.command import main, path_outside_bounds

pytest.importorskip("viser", reason="the viewer needs temp-gym[view]")


@pytest.fixture
def problem_file(tmp_path):
    path = tmp_path / "problem.json"
    path.write_text(json.dumps(POINT2D))
    return path


@pytest.mark.parametrize(
    "content, message",
    [
        ("{oops", "not JSON"),
        (json.dumps({"cost": 3}), "expected a result with a 'path'"),
        (json.dumps([[2, 2], [3]]), "path: expected a list of 2-number states"),
        (json.dumps([[2, 2, 2]]), "path: expected a non-empty list of 2-number states"),
        (json.dumps({"path": [[2, 2], [None, 3]]}), "path: expected finite numbers"),
    ],
)
def test_bad_path_files_get_one_line_and_exit_2(tmp_path, problem_file, capsys, content, message):
    path_file = tmp_path / "path.json"
    path_file.write_text(content)
    assert main([str(problem_file), str(path_file), "--port", "0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("temp-view: error:") and message in err
    assert len(err.strip().splitlines()) == 1


def test_bad_problems_and_addresses_get_one_line_and_exit_2(tmp_path, problem_file, capsys):
    for argv, message in [
        (
            [str(tmp_path / "missing.json")],
            "missing.json: cannot read the problem file (no such file",
        ),
        ([str(problem_file), "--port", "70000"], "port: expected an integer in 0..65535"),
        (
            [str(problem_file), str(tmp_path / "none.json")],
            "none.json: cannot read the path file (no such file",
        ),
        ([str(problem_file), "--host", "no.such.host.invalid"], "host: cannot listen"),
    ]:
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith("temp-view: error:") and message in err, err
        assert len(err.strip().splitlines()) == 1


def test_temp_plan_view_takes_one_problem(problem_file, capsys):
    from temp_gym.cli import main as temp_plan

    assert temp_plan([str(problem_file), str(problem_file), "--view"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == "temp-plan: error: --view takes one problem"


def _default_interrupts() -> None:
    """In the child: Ctrl-C's default disposition, as in a terminal.

    An ignored SIGINT is inherited across exec, and Python then leaves it ignored, so a test
    process that ignores it (a test runner's worker may) would hand that on to the server.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _serve_until_interrupted(command: list[str]) -> tuple[str, int]:
    """Run ``command``, read its announced address, load the page, press Ctrl-C.

    The command's stderr goes to a file, not a pipe nobody reads while it runs (a full pipe
    would block it), and a command still running 30 s after Ctrl-C fails with what it wrote.
    """
    with tempfile.TemporaryFile("w+") as errors:
        process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=errors, text=True,
            preexec_fn=_default_interrupts,
        )  # fmt: skip
        try:
            lines = []
            while not any("viewer: http" in line for line in lines):
                line = process.stdout.readline()
                if not line:
                    process.wait(timeout=30)
                    errors.seek(0)
                    pytest.fail(f"no address announced: {lines} {errors.read()}")
                lines.append(line)
            url = lines[-1].split("viewer: ")[1].split()[0]
            with urllib.request.urlopen(url, timeout=10) as page:
                assert page.status == 200
            process.send_signal(signal.SIGINT)
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                errors.seek(0)
                pytest.fail(f"still running 30 s after Ctrl-C; its stderr: {errors.read()!r}")
        finally:
            process.kill()
            process.wait()
    return "".join(lines), process.returncode


def test_temp_view_serves_a_stored_path_until_ctrl_c(tmp_path, problem_file):
    path_file = tmp_path / "path.json"
    path_file.write_text(json.dumps({"path": [[2, 2], [2, 18], [18, 18]]}))
    command = [sys.executable, "-m", "temp_gym.viewer.command", str(problem_file), str(path_file)]
    out, status = _serve_until_interrupted([*command, "--port", "0"])
    assert status == 0 and out.startswith("temp-view: viewer: http://127.0.0.1:")


def test_temp_plan_view_plans_then_serves_until_ctrl_c(problem_file):
    command = [sys.executable, "-m", "temp_gym.cli", str(problem_file), "--planner", "rrt_star"]
    out, status = _serve_until_interrupted([*command, "--max-nodes", "300", "--view"])
    summary, announced = out.strip().splitlines()
    assert status == 0 and summary.startswith("rrt_star seed=0: cost")
    assert announced.startswith("temp-plan: viewer: http://127.0.0.1:")


def test_a_path_that_leaves_the_bounds_is_named():
    from temp_gym.problem import Problem

    problem = Problem.from_dict(POINT2D)
    low, high = problem.bounds
    inside = np.array([low, (low + high) / 2, high])
    assert path_outside_bounds(inside, problem) is None
    outside = np.array([low, high + [500.0, 0.0], low - 1.0])
    assert path_outside_bounds(outside, problem) == (
        "states outside the problem's bounds: 2 of 3; the first, state 1: outside the bounds: "
        f"[0] = {high[0] + 500:g} is above the bound {high[0]:g}"
    )


def test_a_path_that_is_no_solution_of_the_problem_is_named():
    from temp_gym.problem import Problem
    from temp_gym.viewer.command import path_warning

    problem = Problem.from_dict(POINT2D)
    start, goal = np.asarray(problem.start), np.asarray(problem.goal)
    around = np.array([start, [2.0, 18.0], goal])  # beside the box
    assert path_warning(around, problem) is None
    assert path_warning(np.array([start, goal]), problem) == (  # through the box
        "the exact collision checker refuses it (a state or motion in collision)"
    )
    low, high = problem.bounds
    assert path_warning(np.array([start, high + 1.0]), problem).startswith("states outside")
    assert "not at the problem's start" in path_warning(np.array([goal, goal]), problem)
    assert path_warning(np.array([start, start]), problem) == (
        "its last state is outside the goal region"
    )
