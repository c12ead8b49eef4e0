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
        3,
    )
    assert "rrt_star seed=1" in capsys.readouterr().out


def test_simplify_writes_the_shorter_path_and_the_planners_cost(tmp_path, capsys):
    from temp_gym.cli import main

    problem = tmp_path / "problem.json"
    problem.write_text(json.dumps(PROBLEM))
    out = tmp_path / "result.json"
    flags = ["--planner", "rrt_star", "--max-nodes", "800", "--stop-at-first", "--out", str(out)]
    assert main([str(problem), *flags, "--simplify"]) == 0
    assert "simplified from cost" in capsys.readouterr().out
    result = json.loads(out.read_text())
    assert result["cost"] < result["simplification"]["cost"]
    assert result["path"][0] == [2.0, 2.0] and len(result["path"]) >= 2


# ---------------------------------------------------------------------- hostile input
HUGE = "1" + "0" * 400  # an integer beyond float range


def raw_problem(**changes) -> str:
    return json.dumps({**PROBLEM, **changes})


BAD_FILES = {
    "huge integer": raw_problem(start=[2, 2]).replace("[2, 2]", f"[{HUGE}, 2]"),
    "deep nesting": "[" * 200_000 + "]" * 200_000,
    "goal radius whose square overflows": raw_problem(goal_radius=1e308),
    "bounds of 1e308": raw_problem(bounds=[[-1e308, -1e308], [1e308, 1e308]]),
    "duplicate key": raw_problem().replace(
        '"robot": "point2d"', '"robot": "x", "robot": "point2d"'
    ),
    "empty file": "",
}


def assert_one_line_error(code, stderr, *fragments):
    assert code == 2
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("temp-plan: error:"), stderr
    for fragment in fragments:
        assert fragment in lines[0]


@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_bad_problem_files_give_one_line_and_exit_2(tmp_path, capsys, name):
    from temp_gym.cli import main

    problem = tmp_path / "problem.json"
    problem.write_text(BAD_FILES[name])
    code = main([str(problem), "--planner", "rrt_star", "--max-nodes", "50"])
    assert_one_line_error(code, capsys.readouterr().err)


def test_a_utf16_file_names_the_file(tmp_path, capsys):
    from temp_gym.cli import main

    problem = tmp_path / "problem.json"
    problem.write_bytes(raw_problem().encode("utf-16"))
    code = main([str(problem), "--planner", "rrt_star"])
    assert_one_line_error(code, capsys.readouterr().err, "problem.json", "UTF-8")


class Payload:
    """Unpickling this creates ``marker``."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def broken_checkpoints(tmp_path):
    import torch

    from temp_gym.models.registry import shipped_checkpoint

    good = torch.load(shipped_checkpoint("point2d"), weights_only=True)
    data = shipped_checkpoint("point2d").read_bytes()
    files = {
        "truncated": data[: len(data) // 2],
        "empty": b"",
        "random bytes": bytes(range(256)) * 8,
    }
    paths = {}
    for name, content in files.items():
        paths[name] = tmp_path / f"{name}.pt"
        paths[name].write_bytes(content)
    missing_robot = {key: value for key, value in good.items() if key != "robot"}
    wrong_shape = {**good, "state_dict": dict(good["state_dict"])}
    first = next(iter(wrong_shape["state_dict"]))
    wrong_shape["state_dict"][first] = torch.zeros(3, 1)
    nan = {**good, "state_dict": dict(good["state_dict"])}
    nan["state_dict"][first] = torch.full_like(good["state_dict"][first], float("nan"))
    malicious = {**good, "extra": Payload(tmp_path / "ran")}
    for name, content in (
        ("missing robot", missing_robot),
        ("wrong shapes", wrong_shape),
        ("nan weights", nan),
        ("malicious", malicious),
    ):
        paths[name] = tmp_path / f"{name}.pt"
        torch.save(content, paths[name])
    return paths


def test_every_broken_checkpoint_gives_one_line_and_exit_2(tmp_path, capsys):
    from temp_gym.cli import main

    problem = tmp_path / "problem.json"
    problem.write_text(raw_problem())
    for name, path in broken_checkpoints(tmp_path).items():
        code = main([str(problem), "--checkpoint", str(path), "--max-nodes", "50"])
        err = capsys.readouterr().err
        assert_one_line_error(code, err, str(path))
        if name == "nan weights":
            assert "NaN" in err
    assert not (tmp_path / "ran").exists()  # the malicious checkpoint ran nothing


def test_no_path_has_its_own_exit_code(tmp_path):
    problem = tmp_path / "problem.json"
    problem.write_text(raw_problem())
    done = run_cli(problem, "--planner", "rrt_star", "--max-nodes", 3)
    assert done.returncode == 3, done.stderr
    assert "no solution" in done.stdout and done.stderr == ""


def test_batch_mode_writes_one_result_per_problem_and_reports_bad_files(tmp_path):
    for name, goal in (("a", [18, 18]), ("b", [18, 2])):
        (tmp_path / f"{name}.json").write_text(raw_problem(goal=goal))
    (tmp_path / "c.json").write_text("{broken")
    out = tmp_path / "results"
    files = [tmp_path / f"{name}.json" for name in "abc"]
    done = run_cli(*files, "--planner", "rrt_star", "--max-nodes", 400, "--out-dir", out)
    assert done.returncode == 2  # one bad file
    assert done.stderr.count("temp-plan: error:") == 1 and "c.json" in done.stderr
    lines = done.stdout.strip().splitlines()
    assert [line.split(":")[0] for line in lines] == [str(files[0]), str(files[1])]
    for name, goal in (("a", [18, 18]), ("b", [18, 2])):
        result = json.loads((out / f"{name}.json").read_text())
        assert result["success"] and result["path"][-1] == pytest.approx(goal, abs=0.5)
    assert not (out / "c.json").exists()


def test_help_shows_every_default():
    done = run_cli("--help")
    assert "(default: 5000)" in done.stdout and "exit status" in done.stdout


def test_the_help_texts_copies_of_the_registry_are_the_registry():
    from temp_gym.cli import BUILT_IN_PLANNERS, DEFAULT_MAX_NODES, own_settings
    from temp_gym.planning import PLANNERS, PlanSettings
    from temp_gym.planning.settings import field_names

    assert set(BUILT_IN_PLANNERS) <= set(PLANNERS)
    assert DEFAULT_MAX_NODES == PlanSettings.max_nodes
    common = field_names(PlanSettings)
    registered = {
        name: sorted(field_names(PLANNERS[name].settings) - common - {"policy"})
        for name in BUILT_IN_PLANNERS
    }
    assert own_settings() == {name: own for name, own in registered.items() if own}


def test_help_lists_the_settings_of_set():
    text = " ".join(run_cli("--help").stdout.split())
    assert "settings of --set: every planner takes goal_bias, max_nodes" in text
    assert (
        "temp also attention_follow_fallback" in text
        and "ompl_rrt_star also k_nearest, range" in text
    )


def test_the_shipped_checkpoint_named_plans_as_the_default(tmp_path):
    from temp_gym.models.registry import shipped_checkpoint

    paths = {}
    for name, extra in (
        ("default", []),
        ("named", ["--checkpoint", str(shipped_checkpoint("point2d"))]),
    ):
        out = tmp_path / f"{name}.json"
        done = run_cli(
            "examples/point2d.json", "--stop-at-first", "--seed", 4, "--out", out, *extra
        )
        assert done.returncode == 0, done.stderr
        paths[name] = json.loads(out.read_text())["path"]
    assert paths["named"] == paths["default"]


def test_output_flags_are_checked_before_planning(tmp_path, capsys):
    from temp_gym.cli import main

    problem = tmp_path / "problem.json"
    problem.write_text(json.dumps(PROBLEM))
    a_file = tmp_path / "file.txt"
    a_file.write_text("")
    for flags, words in [
        (["--out", str(tmp_path / "r.json"), "--out-dir", str(tmp_path / "d")], ("--out-dir",)),
        (["--out", str(tmp_path)], ("--out", "directory")),  # found only after planning before
        (["--out-dir", str(a_file)], ("--out-dir", "not a directory")),
    ]:
        code = main([str(problem), "--planner", "rrt_star", "--max-nodes", "50", *flags])
        assert_one_line_error(code, capsys.readouterr().err, *words)
    assert not (tmp_path / "d").exists() and not (tmp_path / "r.json").exists()


def test_an_output_folder_that_cannot_be_made_is_refused_before_planning(tmp_path, capsys):
    from temp_gym.cli import main

    problem = tmp_path / "problem.json"
    problem.write_text(json.dumps(PROBLEM))
    blocker = tmp_path / "blocker"
    blocker.write_text("")  # a file where the output's directory would have to be
    code = main([str(problem), "--planner", "rrt_star", "--max-nodes", "50",
                 "--out", str(blocker / "r.json")])  # fmt: skip
    captured = capsys.readouterr()
    assert captured.out == ""  # nothing planned
    assert_one_line_error(code, captured.err, "--out", "is a file", str(blocker))


def test_a_write_that_fails_is_named_after_the_summary(tmp_path, capsys, monkeypatch):
    from temp_gym import files
    from temp_gym.cli import main

    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(files, "write_json_atomic", full_disk)
    problem = tmp_path / "problem.json"
    problem.write_text(json.dumps(PROBLEM))
    code = main([str(problem), "--planner", "rrt_star", "--max-nodes", "50",
                 "--out", str(tmp_path / "r.json")])  # fmt: skip
    captured = capsys.readouterr()
    assert "rrt_star seed=0" in captured.out  # the plan's figures are not lost
    assert_one_line_error(code, captured.err, "--out", "cannot write", "No space left")


def test_an_output_that_is_an_input_is_refused_and_the_input_kept(tmp_path, capsys):
    from temp_gym.cli import main

    problem = tmp_path / "problem.json"
    problem.write_text(raw_problem())
    for flags in (["--out", str(problem)], ["--out-dir", str(tmp_path)]):
        code = main([str(problem), "--planner", "rrt_star", "--max-nodes", "50", *flags])
        assert_one_line_error(code, capsys.readouterr().err, "is the problem file")
    (tmp_path / "link.json").symlink_to(problem)  # the same file by another name
    code = main([str(problem), "--planner", "rrt_star", "--out", str(tmp_path / "link.json")])
    assert_one_line_error(code, capsys.readouterr().err, "is the problem file")
    assert problem.read_text() == raw_problem()


def test_an_out_dir_holding_other_problems_is_refused_file_by_file(tmp_path, capsys):
    from temp_gym.cli import main

    inputs, results = tmp_path / "in", tmp_path / "results"
    inputs.mkdir()
    results.mkdir()
    (inputs / "a.json").write_text(raw_problem())
    (results / "a.json").write_text(raw_problem(goal=[18, 2]))  # a problem, not a result
    code = main([str(inputs / "a.json"), "--planner", "rrt_star", "--out-dir", str(results)])
    assert_one_line_error(code, capsys.readouterr().err, "not a temp-plan result")
    assert json.loads((results / "a.json").read_text())["goal"] == [18, 2]


def test_a_result_of_temp_plan_is_replaced(tmp_path, capsys):
    from temp_gym.cli import RESULT_FORMAT, main

    problem, out = tmp_path / "problem.json", tmp_path / "result.json"
    problem.write_text(raw_problem())
    for seed in ("1", "2"):  # the second run replaces the first run's result
        code = main([str(problem), "--planner", "rrt_star", "--max-nodes", "300",
                     "--seed", seed, "--out", str(out)])  # fmt: skip
        assert code in (0, 3), capsys.readouterr().err
        result = json.loads(out.read_text())
        assert result["format"] == RESULT_FORMAT and result["seed"] == int(seed)


def test_a_batch_with_a_file_name_that_is_not_utf8_goes_on(tmp_path):
    import os

    folder = os.fsencode(tmp_path)
    odd = os.path.join(folder, b"caf\xe9.json")  # Latin-1, not UTF-8
    with open(odd, "w") as handle:
        handle.write(raw_problem())
    (tmp_path / "plain.json").write_text(raw_problem(goal=[18, 2]))
    done = subprocess.run(
        [sys.executable, "-m", "temp_gym.cli", odd, os.path.join(folder, b"plain.json"),
         "--planner", "rrt_star", "--max-nodes", "300", "--out-dir", os.path.join(folder, b"r")],
        capture_output=True, timeout=120, env={**os.environ, "PYTHONIOENCODING": "utf-8:strict"},
    )  # fmt: skip
    assert done.returncode in (0, 3), done.stderr.decode()
    lines = done.stdout.decode("utf-8").splitlines()  # strict UTF-8 throughout
    assert len(lines) == 2 and lines[0].startswith(str(tmp_path) + "/caf\\xe9.json: ")
    assert os.path.exists(os.path.join(folder, b"r", b"caf\xe9.json"))
    assert (tmp_path / "r" / "plain.json").exists()


def test_any_setting_of_the_planner_is_set_and_checked_before_planning(tmp_path, capsys):
    from temp_gym.cli import main

    problem = tmp_path / "problem.json"
    problem.write_text(json.dumps(PROBLEM))
    out = tmp_path / "r.json"
    base = [str(problem), "--stop-at-first", "--seed", "2", "--max-nodes", "2000"]
    assert main([*base, "--set", "goal_bias=0.2", "--planner", "rrt_star", "--out", str(out)]) == 0
    capsys.readouterr()
    set_once = json.loads(out.read_text())
    from temp_gym import plan
    from temp_gym.problem import Problem

    same = plan(Problem.from_dict(PROBLEM), "rrt_star", seed=2, max_nodes=2000,
                stop_at_first=True, goal_bias=0.2)  # fmt: skip
    assert set_once["nodes"] == same.nodes and set_once["cost"] == pytest.approx(same.cost)
    for flags, words in [
        (["--set", "attention_patience=30", "--planner", "rrt_star"],
         ("attention_patience: only the temp planner takes it",
          "use --planner temp --set attention_patience=...")),
        # A flag's value given twice, as a flag and by --set: refused, not one silently kept.
        (["--set", "max_nodes=300", "--max-nodes", "400"],
         ("--set max_nodes: max_nodes has its own flag; give it as --max-nodes",)),
        (["--set", "seed=1"], ("--set seed:", "--seed")),
        (["--set", "attention_patience=-1"], ("attention_patience: expected an integer",)),
        (["--set", "patience=3"], ("patience: not a setting of the temp planner",)),
        (["--set", "goal_bias"], ("--set 'goal_bias': expected KEY=VALUE",)),
        (["--set", "policy=a.pt"], ("--set policy", "--checkpoint")),
    ]:  # fmt: skip
        code = main([*base, *flags, "--out", str(tmp_path / "bad.json")])
        assert_one_line_error(code, capsys.readouterr().err, *words)
    assert not (tmp_path / "bad.json").exists()


def test_rrt_connect_plans_from_the_command_line_with_its_own_setting(tmp_path, capsys):
    from temp_gym import plan
    from temp_gym.cli import main
    from temp_gym.problem import Problem

    problem = tmp_path / "problem.json"
    problem.write_text(json.dumps(PROBLEM))
    out = tmp_path / "r.json"
    flags = ["--planner", "rrt_connect", "--seed", "1", "--set", "range=0.5", "--out", str(out)]
    assert main([str(problem), *flags]) == 0
    assert "rrt_connect seed=1" in capsys.readouterr().out
    written = json.loads(out.read_text())
    same = plan(Problem.from_dict(PROBLEM), "rrt_connect", seed=1, range=0.5)
    assert written["path"] == same.path.tolist() and written["nodes"] == same.nodes
    code = main([str(problem), "--planner", "rrt_connect", "--set", "range=0", "--out", str(out)])
    assert_one_line_error(code, capsys.readouterr().err, "range: expected a positive number")


def test_temp_plan_uses_the_settings_the_shipped_policy_carries(tmp_path, capsys):
    """With no setting flag, the shipped policy's settings; the card's values set by hand
    give the same plan, and a value told otherwise another."""
    from temp_gym import load_policy
    from temp_gym.cli import main

    carried = {k: v for k, v in load_policy("point2d").planner_settings().items() if v}
    as_set = [item for key, value in carried.items() for item in ("--set", f"{key}={value}")]
    base = ["examples/point2d.json", "--stop-at-first", "--seed", "4", "--max-nodes", "3000"]
    results = {}
    for name, flags in (("default", []), ("card", as_set),
                        ("other", ["--set", "attention_local_fallback=0"])):  # fmt: skip
        out = tmp_path / f"{name}.json"
        assert main([*base, *flags, "--out", str(out)]) in (0, 3)
        results[name] = json.loads(out.read_text())
    capsys.readouterr()
    assert carried["attention_local_fallback"] > 0

    def plan_of(result):
        return [result[key] for key in ("path", "nodes", "samples", "cost", "attention_solved")]

    for result in results.values():
        result["attention_solved"] = result["attention"]["solved"]
    assert plan_of(results["card"]) == plan_of(results["default"])
    assert plan_of(results["other"]) != plan_of(results["default"])


def test_an_infinite_time_limit_is_no_limit_as_in_plan_and_nan_is_refused(tmp_path, capsys):
    from temp_gym.cli import main

    problem = tmp_path / "problem.json"
    problem.write_text(json.dumps(PROBLEM))
    base = [str(problem), "--planner", "rrt_star", "--max-nodes", "300"]
    assert main([*base, "--time-limit", "inf"]) in (0, 3)
    assert "300 nodes" in capsys.readouterr().out
    code = main([*base, "--time-limit", "nan"])
    assert_one_line_error(code, capsys.readouterr().err, "--time-limit: expected a number")
