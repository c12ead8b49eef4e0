import functools
import json

import numpy as np
import pytest

from temp_gym.evaluation.report import write_report
from temp_gym.evaluation.runner import (
    TEST_SET_VERSION,
    EvaluationSettings,
    ManifestMismatchError,
    attention_example,
    evaluate_task,
    evaluation_problem,
    run_evaluation,
    warm_up_problem,
)
from temp_gym.planning.plan import plan
from temp_gym.planning.temp_settings import OWN
from temp_gym.policies import UniformPolicy


def make_policy():
    return UniformPolicy(seed=0)


def settings(**changes):
    """Evaluation settings with ``changes``; TEMP's own settings among them go to ``temp``."""
    temp = {name: changes.pop(name) for name in list(changes) if name in OWN}
    base = dict(
        robot="point2d",
        groups={"2D easy": ("easy", 2), "2D challenging": ("challenging", 2)},
        max_nodes=3000,
        curve_tasks=1,
        curve_nodes=300,
        temp=temp,
    )
    base.update(changes)
    return EvaluationSettings(**base)


def test_test_tasks_are_deterministic_and_of_the_right_difficulty():
    a = evaluation_problem("point2d", "challenging", 3)
    assert a == evaluation_problem("point2d", "challenging", 3)
    assert a != evaluation_problem("point2d", "challenging", 4)


def test_each_timed_run_follows_a_warm_run_of_its_planner_that_changes_no_result(monkeypatch):
    from temp_gym.evaluation import runner
    from temp_gym.worlds.splits import SPLITS, split_workspace

    warm = warm_up_problem("point2d")
    tests = {split_workspace("point2d", "test", i) for i in range(SPLITS["test"])}
    assert warm.workspace not in tests  # warm runs fill no cache a timed run reads
    calls = []

    def recording(problem, planner="temp", settings=None, **kwargs):
        calls.append((planner, problem is warm))
        return plan(problem, planner, settings, **kwargs)

    monkeypatch.setattr(runner, "plan", recording)
    problem = evaluation_problem("point2d", "easy", 0)
    records = {}
    for warm_runs in (True, False):
        calls.clear()
        records[warm_runs] = evaluate_task(
            problem, make_policy(), settings(warm_runs=warm_runs), with_curves=False
        )
        names = ["temp", "rrt_star", "informed_rrt_star"]
        timed = [(name, False) for name in names]
        expected = [c for name in timed for c in ([(name[0], True)] if warm_runs else []) + [name]]
        assert calls == expected

    def without_times(record):
        return {
            name: {key: value for key, value in figures.items() if key != "time"}
            for name, figures in record["planners"].items()
        }

    assert without_times(records[True]) == without_times(records[False])


def test_each_timed_run_starts_on_a_workspace_nothing_remembers(monkeypatch):
    """With ``fresh_workspaces`` no timed run finds the task's workspace in a planner's cache:
    neither the tree's free volume nor TEMP's encoding; the records are the same either way."""
    from temp_gym.evaluation import runner
    from temp_gym.models.registry import load_policy
    from temp_gym.planning import tree as tree_module

    problem = evaluation_problem("point2d", "easy", 1)
    policy = load_policy("TEMP-2D-v0")
    seen = []

    def recording(planned, planner="temp", settings=None, **kwargs):
        if planned is problem:  # a timed run
            space = planned.workspace
            seen.append(
                (
                    planner,
                    space in tree_module._FREE_VOLUME_FLOOR_CACHE
                    or space in tree_module._FREE_VOLUME_CACHE,
                    space in policy.core._sei,
                )
            )
        return plan(planned, planner, settings, **kwargs)

    monkeypatch.setattr(runner, "plan", recording)
    records = {}
    for fresh in (True, False):
        for _ in range(2):  # the second pass meets the workspace again
            seen.clear()
            records[fresh] = evaluate_task(
                problem, policy, settings(fresh_workspaces=fresh), with_curves=False
            )
        # the policy's encoding matters to TEMP's run alone
        remembered = [tree or (sei and name == "temp") for name, tree, sei in seen]
        assert [name for name, *_ in seen] == ["temp", "rrt_star", "informed_rrt_star"]
        assert not any(remembered) if fresh else all(remembered)

    def without_times(record):
        return {
            name: {key: value for key, value in figures.items() if key != "time"}
            for name, figures in record["planners"].items()
        }

    assert without_times(records[True]) == without_times(records[False])


def test_evaluation_is_resumable_and_reports(tmp_path):
    records = run_evaluation(settings(), make_policy, tmp_path, workers=1, progress=False)
    assert len(records) == 4
    for record in records:
        assert record["planners"]["temp"]["success"]
        assert set(record["planners"]) == {"temp", "rrt_star", "informed_rrt_star"}
    # A rerun does nothing new: the files are not rewritten.
    files = sorted((tmp_path / "tasks").glob("*.json"))
    stamps = [f.stat().st_mtime_ns for f in files]
    (files[0]).unlink()  # as if killed before the first task was written
    again = run_evaluation(settings(), make_policy, tmp_path, workers=1, progress=False)
    assert [f.stat().st_mtime_ns for f in files[1:]] == stamps[1:]
    assert json.dumps(again[0]["problem"]) == json.dumps(records[0]["problem"])
    table = write_report(again, tmp_path / "report")
    assert "| 2D easy |" in table and "| 2D challenging |" in table
    for name in (
        "results.md",
        "results.json",
        "success_vs_time.png",
        "cost_vs_nodes.png",
        "sampling_failures.png",
    ):
        assert (tmp_path / "report" / name).exists()
    assert list((tmp_path / "report" / "tensorboard").glob("events.*"))


def test_a_rerun_with_other_settings_or_policy_refuses_to_mix_records(tmp_path):
    empty = settings(groups={"2D easy": ("easy", 0)})
    run_evaluation(empty, make_policy, tmp_path, progress=False, identity={"digest": "a"})
    manifest = json.loads((tmp_path / "run.json").read_text())
    assert manifest["test_set_version"] == TEST_SET_VERSION and manifest["digest"] == "a"
    # The same run resumes; another checkpoint, or other settings, stop with the key named.
    run_evaluation(empty, make_policy, tmp_path, progress=False, identity={"digest": "a"})
    with pytest.raises(ManifestMismatchError, match="differs in: digest"):
        run_evaluation(empty, make_policy, tmp_path, progress=False, identity={"digest": "b"})
    other = settings(groups={"2D easy": ("easy", 0)}, max_nodes=10)
    with pytest.raises(ManifestMismatchError, match="differs in: settings"):
        run_evaluation(other, make_policy, tmp_path, progress=False, identity={"digest": "a"})


def _without_times(record):
    planners = {
        name: {k: v for k, v in figures.items() if k != "time"}
        for name, figures in record["planners"].items()
    }
    return {**{k: v for k, v in record.items() if k != "task_time"}, "planners": planners}


def test_ray_backend_gives_the_same_records(tmp_path, monkeypatch):
    pytest.importorskip("ray")
    monkeypatch.setenv("RAY_ADDRESS", "")  # a local instance, whatever the shell says
    one = settings(groups={"2D challenging": ("challenging", 2)}, curve_tasks=0)
    # Ray workers import the policy factory by name: a partial of a package class.
    factory = functools.partial(UniformPolicy, seed=0)
    local = run_evaluation(one, factory, tmp_path / "local", workers=1, progress=False)
    ray = run_evaluation(one, factory, tmp_path / "ray", workers=2, progress=False, backend="ray")
    assert [_without_times(r) for r in ray] == [_without_times(r) for r in local]


def _untrained_temp_policy():
    import torch

    from temp_gym.models.policy import TEMPPolicy
    from temp_gym.models.temp import TEMPModel

    torch.manual_seed(0)
    model = TEMPModel.from_config(
        {"token_dim": 16, "num_heads": 2, "num_layers": 2, "ffn_dim": 32, "num_sei_tokens": 2,
         "eise_hidden": 32},
        "point2d", 8, 16,
    )  # fmt: skip
    return TEMPPolicy(model.eval())


def test_no_attention_example_when_the_policy_never_sampled(tmp_path):
    one_node = settings(groups={"2D easy": ("easy", 1)}, curve_tasks=0, max_nodes=1)
    assert attention_example(one_node, _untrained_temp_policy) is None
    records = run_evaluation(one_node, make_policy, tmp_path, workers=1, progress=False)
    write_report(records, tmp_path / "report", tensorboard=False, attention=None)
    assert (tmp_path / "report" / "results.md").exists()
    assert not (tmp_path / "report" / "attention.png").exists()


def test_attention_example_reads_one_plan_and_is_plotted(tmp_path):
    example = attention_example(settings(max_nodes=200), _untrained_temp_policy)
    steps = len(example["raw"]["SEI"])
    assert example["group"] == "2D easy" and example["index"] == 0
    # One attention map per model call: every AP iteration that did not sample the goal.
    assert steps == example["attention_phase"]["policy_samples"] >= 1
    for group in ("SEI", "Goal", "Start", "HPD"):
        normalized = example["normalized"][group]
        assert len(normalized) == steps and min(normalized) >= 0 and max(normalized) <= 1
    # The groups share the output query's head-averaged mass with the query's own token.
    totals = [sum(example["raw"][g][k] for g in ("SEI", "Goal", "Start", "HPD")) for k in range(3)]
    assert all(0.0 < total < 1.0 + 1e-6 for total in totals)
    records = run_evaluation(
        settings(groups={"2D easy": ("easy", 1)}, curve_tasks=0), make_policy, tmp_path,
        workers=1, progress=False,
    )  # fmt: skip
    write_report(records, tmp_path / "report", tensorboard=False, attention=example)
    assert (tmp_path / "report" / "attention.png").exists()
    stored = json.loads((tmp_path / "report" / "attention.json").read_text())
    assert stored["normalized"] == example["normalized"]


def test_damaged_records_and_manifest_are_named_and_a_rerun_says_what_is_done(tmp_path, capsys):
    from temp_gym.files import DirectoryLock, LockedError, StoredFileError

    one = settings(groups={"2D easy": ("easy", 2)}, curve_tasks=0)
    run_evaluation(one, make_policy, tmp_path, workers=1, progress=False)
    assert "starting: 2 tasks" in capsys.readouterr().err
    records = sorted((tmp_path / "tasks").glob("*.json"))
    records[1].write_text(records[1].read_text()[:40])  # truncated
    with pytest.raises(StoredFileError, match=r"2D_easy-0001\.json: damaged.*delete it and rerun"):
        run_evaluation(one, make_policy, tmp_path, workers=1, progress=False)
    records[1].unlink()  # what the message says to do
    run_evaluation(one, make_policy, tmp_path, workers=1, progress=False)
    assert "resuming: 1/2 tasks done" in capsys.readouterr().err
    (tmp_path / "run.json").write_text("")
    with pytest.raises(StoredFileError, match=r"run\.json: empty"):
        run_evaluation(one, make_policy, tmp_path, workers=1, progress=False)
    with DirectoryLock(tmp_path, "another evaluation"):
        with pytest.raises(LockedError, match="another evaluation"):
            run_evaluation(one, make_policy, tmp_path, workers=1, progress=False)


class Stuck:
    """A policy that cannot help: always the same corner, so the attention phase stalls."""

    def reset(self, problem, seed=None):
        pass

    def __call__(self, observation):
        return np.full(observation["goal"].shape, -1.0, np.float32)


def test_temp_is_timed_as_a_user_calls_it_when_its_attention_phase_stalls():
    # Record version 2: TEMP's figures are the whole planner's first solution; a task that
    # classical planning solved after the stall rule handed over counts as solved, and the
    # record says the attention phase did not solve it alone.
    problem = evaluation_problem("point2d", "easy", 0)
    stuck = settings(attention_patience=5, baselines=("rrt_star",))
    record = evaluate_task(problem, Stuck(), stuck, with_curves=False)
    temp = record["planners"]["temp"]
    reference = plan(
        problem, planner="temp", policy=Stuck(), seed=stuck.seed, max_nodes=stuck.max_nodes,
        attention_patience=5, stop_at_first=True,
    )  # fmt: skip
    assert temp["success"] and not temp["attention_solved"]
    assert temp["nodes"] == reference.nodes_to_first_solution
    assert temp["nodes"] > reference.attention["nodes"]
    assert temp["cost"] == pytest.approx(reference.cost)
    assert "rrt_star" in record["planners"] and record["target_cost"] > temp["cost"]


@pytest.mark.parametrize("goal_tree", [True, False])
def test_the_evaluation_plans_with_or_without_the_goal_tree_as_set(goal_tree):
    problem = evaluation_problem("point2d", "challenging", 1)
    chosen = settings(attention_patience=5, baselines=("rrt_star",), goal_tree=goal_tree)
    record = evaluate_task(problem, Stuck(), chosen, with_curves=False)
    runs = {
        flag: plan(
            problem,
            planner="temp",
            policy=Stuck(),
            seed=chosen.seed,
            max_nodes=chosen.max_nodes,
            attention_patience=5,
            stop_at_first=True,
            goal_tree=flag,
        )  # fmt: skip
        for flag in (True, False)
    }
    assert "goal_tree_nodes" in runs[True].attention
    assert "goal_tree_nodes" not in runs[False].attention
    assert record["planners"]["temp"]["nodes"] == runs[goal_tree].nodes_to_first_solution
    assert record["planners"]["temp"]["cost"] == runs[goal_tree].cost
    assert runs[True].cost != runs[False].cost  # different paths
    assert record["planners"]["temp"]["from_goal_solved"] == runs[goal_tree].attention.get(
        "from_goal_solved", False
    )


@pytest.mark.parametrize("rounds", [0, 2])
def test_the_evaluation_takes_the_rounds_it_is_set_to(rounds):
    problem = evaluation_problem("point2d", "challenging", 1)
    chosen = settings(attention_patience=5, baselines=("rrt_star",), attention_rounds=rounds)
    record = evaluate_task(problem, Stuck(), chosen, with_curves=False)
    run = plan(
        problem, planner="temp", policy=Stuck(), seed=chosen.seed, max_nodes=chosen.max_nodes,
        attention_patience=5, stop_at_first=True, attention_rounds=rounds,
    )  # fmt: skip
    stalled_both_ways = run.attention["from_goal_stop"] == "stalled"
    assert (run.attention["rounds"] > 0) == (stalled_both_ways and rounds > 0)
    assert run.attention["rounds"] <= rounds
    temp = record["planners"]["temp"]
    assert temp["nodes"] == run.nodes_to_first_solution and temp["cost"] == run.cost
    assert temp["rounds_solved"] == run.attention["rounds_solved"]
    # Without the goal tree there are no rounds: asking for some is refused, naming them.
    alone = settings(attention_patience=5, baselines=(), attention_rounds=rounds, goal_tree=False)
    if rounds:
        with pytest.raises(ValueError, match="^attention_rounds: .*goal_tree=False"):
            evaluate_task(problem, Stuck(), alone, with_curves=False)
    else:
        record = evaluate_task(problem, Stuck(), alone, with_curves=False)
        assert record["planners"]["temp"]["success"]


def test_attention_example_shows_the_phase_from_the_start_whatever_stalls():
    # A patience of 1 stalls at once: with the phase from the goal and its rounds, each reset
    # of the policy would start its record afresh; the example plans from the start only.
    example = attention_example(
        settings(max_nodes=300, attention_patience=1, attention_rounds=3), _untrained_temp_policy
    )
    assert example["attention_phase"]["stop"] == "stalled"
    assert "from_goal_stop" not in example["attention_phase"]
    assert all(len(values) > 0 for values in example["normalized"].values())


def test_test_tasks_come_from_the_family_asked_for():
    """Another family's test pool draws other workspaces; the default is the robot's own."""
    from temp_gym.worlds.splits import split_workspace

    own = evaluation_problem("point2d", "easy", 3)
    maze = evaluation_problem("point2d", "easy", 3, family="maze")
    assert own == evaluation_problem("point2d", "easy", 3, family="boxes")
    assert maze.workspace == split_workspace("point2d", "test", 3, "maze")
    assert maze.workspace != own.workspace


def test_the_manifest_names_a_family_other_than_the_default_and_refuses_to_mix_them(tmp_path):
    """A manifest written before the setting existed (no family: boxes) still resumes."""
    empty = settings(groups={"2D easy": ("easy", 0)})
    run_evaluation(empty, make_policy, tmp_path, progress=False)
    assert "workspace_family" not in json.loads((tmp_path / "run.json").read_text())["settings"]
    run_evaluation(empty, make_policy, tmp_path, progress=False)  # resumes
    maze = settings(groups={"2D easy": ("easy", 0)}, workspace_family="maze")
    with pytest.raises(ManifestMismatchError, match="differs in: settings"):
        run_evaluation(maze, make_policy, tmp_path, progress=False)
    run_evaluation(maze, make_policy, tmp_path / "maze", progress=False)
    stored = json.loads((tmp_path / "maze" / "run.json").read_text())["settings"]
    assert stored["workspace_family"] == "maze"
