"""Every trainer and benchmark flag has help and shows its default; overrides go anywhere."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(list((ROOT / "trainers").glob("*.py")) + list((ROOT / "benchmarks").glob("*.py")))

# In a fresh process (the scripts set environment variables at import): load each script,
# capture the parser its main() builds, and describe it; then parse a command line with an
# override placed after an option that takes values.
INSPECT = textwrap.dedent(
    """
    import argparse, importlib.util, json, sys
    from pathlib import Path
    import temp_gym.config

    class Captured(Exception):
        pass

    def sample(action):
        if action.choices:
            return [str(next(iter(action.choices)))]
        kind = action.type or str
        value = {int: "1", float: "0.5", str: "x"}.get(kind, "1")  # a custom type: a count
        return [value, value] if action.nargs in ("+", "*") else [value]

    out = {}
    for path in map(Path, sys.argv[1:]):
        sys.path.insert(0, str(path.parent))
        spec = importlib.util.spec_from_file_location(f"script_{path.stem}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        captured = {}

        def capture(parser, argv=None):
            captured["parser"] = parser
            raise Captured

        # the script's own namespace, and the package module its main() comes from
        for owner in {module, sys.modules.get(module.main.__module__, module)}:
            if hasattr(owner, "parse_args"):
                owner.parse_args = capture
        try:
            module.main([])
        except Captured:
            pass
        parser = captured["parser"]
        actions = [a for a in parser._actions if not isinstance(a, argparse._HelpAction)]
        entry = {
            "formatter": issubclass(
                parser.formatter_class, argparse.ArgumentDefaultsHelpFormatter
            ),
            "no_help": [a.dest for a in actions if not a.help],
        }
        if any(a.dest == "overrides" for a in actions):
            argv = []
            for action in actions:
                if action.option_strings and action.nargs != 0:
                    argv += [action.option_strings[0], *sample(action)]
            argv.append("train.seed=1")
            entry["overrides"] = temp_gym.config.parse_args(parser, argv).overrides
        out[path.name] = entry
    print(json.dumps(out))
    """
)


@pytest.fixture(scope="module")
def described() -> dict:
    done = subprocess.run(
        [sys.executable, "-c", INSPECT, *map(str, SCRIPTS)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("script", [p.name for p in SCRIPTS])
def test_every_flag_has_help_and_shows_its_default(described, script):
    entry = described[script]
    assert entry["formatter"]  # argparse's formatter that shows defaults, or one derived
    assert entry["no_help"] == []


def test_overrides_are_accepted_after_any_option(described):
    with_overrides = {name: entry for name, entry in described.items() if "overrides" in entry}
    assert {"generate.py", "bc.py", "evaluate.py", "tune_planner.py", "ship.py"} <= set(
        with_overrides
    )
    for name, entry in with_overrides.items():
        assert entry["overrides"] == ["train.seed=1"], name


def test_config_parse_args_takes_overrides_out_of_multi_value_options():
    import argparse

    from temp_gym.config import parse_args

    parser = argparse.ArgumentParser()
    parser.add_argument("--noise-std", type=float, nargs="+")
    parser.add_argument("--out", default=None)
    parser.add_argument("overrides", nargs="*")
    args = parse_args(
        parser, ["a.b=1", "--noise-std", "0", "0.03", "train.seed=1", "--out=x=y", "+c.d=2"]
    )
    assert args.noise_std == [0.0, 0.03] and args.out == "x=y"
    assert args.overrides == ["a.b=1", "train.seed=1", "+c.d=2"]


def test_config_parse_args_leaves_a_single_value_options_value_alone():
    import argparse

    from temp_gym.config import parse_args

    parser = argparse.ArgumentParser()
    parser.add_argument("--policy", action="append")
    parser.add_argument("--noise-std", type=float, nargs="+")
    parser.add_argument("overrides", nargs="*")
    args = parse_args(
        parser, ["--policy", "shipped=a.pt", "--noise-std", "0", "b.c=1", "--policy=x=y", "d=2"]
    )
    assert args.policy == ["shipped=a.pt", "x=y"] and args.noise_std == [0.0]
    assert args.overrides == ["b.c=1", "d=2"]


def _benchmark(name: str):
    """The module of ``benchmarks/{name}.py``, imported with the benchmarks folder on the path."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))


def test_policy_speed_reads_planner_settings_after_an_at_sign():
    policy_speed = _benchmark("policy_speed")
    path, settings = policy_speed.parse_entry("runs/x/best.pt@noise_std=0.03,horizon=4")
    assert path == Path("runs/x/best.pt") and settings == {"noise_std": 0.03, "horizon": 4}
    assert policy_speed.parse_entry("runs/x/best.pt") == (Path("runs/x/best.pt"), {})
    for bad in ("a.pt@temperature=1", "a.pt@horizon=four", "a.pt@noise_std"):
        with pytest.raises(SystemExit, match="--checkpoints"):
            policy_speed.parse_entry(bad)


def test_policy_speed_draws_validation_tasks_as_tune_planner_does():
    policy_speed = _benchmark("policy_speed")
    from temp_gym import training
    from temp_gym.config import load_config

    rows = policy_speed.val_rows("2d", 3)
    config = load_config("configs/2d.yaml", [])
    expected = training.draw_problems(config, "val", 3, config.train_eval.seed + 20_000)
    assert list(rows) == ["val"] and rows["val"] == expected
    assert all(problem.robot == "point2d" for problem in rows["val"])


def test_directions_plans_each_ood_scene_from_both_ends():
    directions = _benchmark("directions")
    from temp_gym.evaluation.ood import load_ood_family

    medians = directions.main(["--worlds", "2d", "--seeds", "1", "--budget", "300"])
    assert set(medians["2d"]) == set(load_ood_family("point2d"))
    for forward, backward in medians["2d"].values():
        assert 0 < forward <= 300 and 0 < backward <= 300
    with pytest.raises(SystemExit):
        directions.main(["--seeds", "0"])


def test_end_to_end_runs_temp_without_its_goal_tree_side_by_side(capsys, tmp_path):
    end_to_end = _benchmark("end_to_end")
    out = tmp_path / "end_to_end.json"
    end_to_end.main(["--worlds", "2d", "--tasks", "2", "--seeds", "1", "--budget", "300",
                     "--reference-nodes", "300", "--complete-seeds", "1", "--variants",
                     "temp_no_goal_tree",
                     "--sections", "first", "anytime", "complete", "--out", str(out)])  # fmt: skip
    printed = capsys.readouterr().out
    assert "| temp_no_goal_tree |" in printed
    assert "| problem | temp | temp_no_goal_tree | informed_rrt_star |" in printed
    figures = json.loads(out.read_text())["2d"]
    assert len(figures["first_test"]["temp_no_goal_tree"]["time"]) == 2
    assert len(figures["anytime_ood"]["runs"]["temp_no_goal_tree"]) == len(figures["complete"])


def test_end_to_end_runs_another_checkpoint_side_by_side(capsys):
    end_to_end = _benchmark("end_to_end")
    shipped = str(ROOT / "temp_gym" / "checkpoints" / "2d.pt")
    end_to_end.main(["--worlds", "2d", "--tasks", "2", "--seeds", "1", "--budget", "300",
                     "--complete-seeds", "1", "--sections", "first", "complete",
                     "--checkpoints", f"{shipped}@attention_rounds=0"])  # fmt: skip
    printed = capsys.readouterr().out
    assert "| temp:checkpoints |" in printed
    assert "| problem | temp | temp:checkpoints | informed_rrt_star |" in printed
    assert end_to_end.POLICIES["temp:checkpoints"].attention_rounds == 0
    for bad in (["--worlds", "2d", "3d", "--checkpoints", shipped],
                ["--worlds", "3d", "--checkpoints", shipped],
                ["--worlds", "2d", "--checkpoints", f"{shipped}@rounds=1"]):  # fmt: skip
        with pytest.raises(SystemExit):
            end_to_end.main(bad)


def test_stall_sequence_times_both_sides_on_stalling_tasks(capsys):
    stall_sequence = _benchmark("stall_sequence")
    best = stall_sequence.main(["--worlds", "2d", "--tasks", "4", "--repeats", "1"])
    assert set(best) == {"2d"} and all(seconds > 0 for seconds in best["2d"])
    assert "| 2d |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        stall_sequence.main(["--tasks", "0"])


def test_checker_setup_times_each_build_per_arm(capsys):
    checker_setup = _benchmark("checker_setup")
    medians = checker_setup.main(["--robots", "franka_panda", "--problems", "2"])
    assert set(medians) == {"franka_panda, generated"}
    assert set(medians["franka_panda, generated"]) == {"fast checker", "exact checker", "tree"}
    assert all(seconds > 0 for seconds in medians["franka_panda, generated"].values())
    assert "| franka_panda, generated (2) |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        checker_setup.main(["--problems", "0"])


def _mbm_archive(folder: Path) -> Path:
    """A small MotionBenchMaker archive (`tests/benchmarks/test_motionbenchmaker.py` writes it)."""
    sys.path.insert(0, str(ROOT / "tests" / "benchmarks"))
    try:
        from test_motionbenchmaker import write_archive
    finally:
        sys.path.remove(str(ROOT / "tests" / "benchmarks"))
    return write_archive(folder)


def test_certification_times_the_paths_of_motionbenchmaker_problems(tmp_path, capsys):
    certification = _benchmark("certification")
    archive = _mbm_archive(tmp_path)
    paths = tmp_path / "paths.json"
    argv = ["--mbm", str(archive), "--per-scene", "1", "--planners", "rrt_connect",
            "--repeats", "1", "--paths", str(paths)]  # fmt: skip
    table = certification.main(argv)
    assert set(table) == {"rrt_connect"} and table["rrt_connect"]["paths"] == 2  # one a scene
    assert table["rrt_connect"]["median_ms"] > 0
    assert "| rrt_connect | 2 |" in capsys.readouterr().out
    again = certification.main(argv)  # the stored paths, certified again
    assert again["rrt_connect"]["paths"] == 2
    # Poses measured are deterministic: the same paths, the same count.
    assert again["rrt_connect"]["poses_per_edge"] == table["rrt_connect"]["poses_per_edge"] >= 1


def test_simplify_shortens_the_paths_of_motionbenchmaker_problems(tmp_path, capsys):
    simplify = _benchmark("simplify")
    archive = _mbm_archive(tmp_path)
    table = simplify.main(["--mbm", str(archive), "--per-scene", "1", "--planners", "rrt_connect"])
    row = table["rrt_connect"]
    assert row["paths"] == 2 and row["after"] <= row["before"] and 0 < row["ratio"] <= 1
    assert row["time"] > 0 and row["call"] >= row["time"]
    assert "| rrt_connect | 2 |" in capsys.readouterr().out


def test_plan_setup_times_every_planner_on_one_motion_problems(capsys):
    from temp_gym.worlds.checkers import make_checker

    plan_setup = _benchmark("plan_setup")
    medians = plan_setup.main(["--worlds", "2d", "--problems", "3", "--repeats", "1"])
    assert set(medians["2d"]) == {"temp", "rrt_star", "informed_rrt_star", "reset"}
    assert all(seconds > 0 for seconds in medians["2d"].values())
    problems = plan_setup.one_motion_problems("point2d", 3)
    for problem in problems:  # one straight free motion (a tree edge) solves each
        assert make_checker(problem).edge_free(problem.start, problem.goal)
    assert "| 2d | 3 | temp |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        plan_setup.main(["--problems", "0"])
