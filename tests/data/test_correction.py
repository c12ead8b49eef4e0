"""On-policy correction: the lattice expert's labels, rounds on disk, and training on them."""

from pathlib import Path

import numpy as np
import pytest
import torch

from temp_gym import Problem
from temp_gym.data.correction import (
    CARD_NAME,
    collect_corrections,
    correction_samples,
    correction_settings,
    correction_unit,
    expert_next_nodes,
    load_corrections,
)
from temp_gym.files import StoredFileError
from temp_gym.models.policy import TEMPPolicy
from temp_gym.models.temp import TEMPModel
from temp_gym.problem import Workspace
from temp_gym.worlds.checkers import certify_path, make_checker
from temp_gym.worlds.normalization import denormalize
from temp_gym.worlds.reference import GoalField, ReferencePlanner

ROOT = Path(__file__).resolve().parents[2]
SMALL = {"token_dim": 16, "num_heads": 2, "num_layers": 1, "ffn_dim": 32, "num_sei_tokens": 4}


def _field(problem: Problem) -> GoalField:
    return GoalField(ReferencePlanner(problem.workspace), problem.goal)


def test_the_expert_walks_the_shortest_path_a_step_at_a_time(wall):
    problem = Problem.from_dict(wall)
    field = _field(problem)
    path = field.path(problem.start)
    assert certify_path(problem, path)
    reference = ReferencePlanner(problem.workspace).solve(problem.start, problem.goal)
    cost = np.linalg.norm(np.diff(path, axis=0), axis=1).sum()
    assert cost == pytest.approx(reference.cost, rel=0.02)
    nodes, mask = expert_next_nodes(field, problem.start, 1.0, 3)
    assert mask.all()
    steps = np.linalg.norm(np.diff(np.vstack([problem.start, nodes]), axis=0), axis=1)
    assert np.all(steps <= 1.0 + 1e-9) and np.all(steps > 0.5)
    # Next to the goal the expert's path ends sooner: the rest is masked.
    near_goal = problem.goal - np.array([1.5, 0.0])
    nodes, mask = expert_next_nodes(field, near_goal, 1.0, 4)
    assert mask.tolist() == [True, True, False, False]
    np.testing.assert_array_equal(nodes[1], problem.goal)
    np.testing.assert_array_equal(nodes[2:], nodes[1:2].repeat(2, 0))


def test_samples_hold_the_policys_own_inputs_and_the_experts_targets(wall):
    problem = Problem.from_dict(wall)
    torch.manual_seed(0)
    policy = TEMPPolicy(TEMPModel("point2d", 8, 16, eise_hidden=16, chunk=2, **SMALL))
    samples = correction_samples(policy, problem, _field(problem), seed=0, max_nodes=200,
                                 max_samples=30, chunk=2)  # fmt: skip
    count = len(samples["step"])
    assert 0 < count <= 30
    assert samples["targets"].shape == (count, 2, 2) and samples["target_mask"][:, 0].all()
    np.testing.assert_array_equal(samples["target"], samples["targets"][:, 0])
    for path, length, target in zip(samples["path"], samples["path_length"][:, 0],
                                    samples["targets"]):  # fmt: skip
        state = denormalize(path[length - 1], problem.bounds)
        step = np.linalg.norm(denormalize(target[0], problem.bounds) - state)
        assert 0 < step <= 1.0 + 1e-4  # the expert's next node, one step on
        assert np.all(path[length:] == 0)  # padding as the planner hands it over


@pytest.fixture
def tiny_round(tmp_path):
    """A tiny config, a small random chunked checkpoint and a round's settings."""
    from temp_gym.config import load_config

    config = load_config(
        ROOT / "configs" / "tiny.yaml", [f"data.dir={tmp_path / 'data'}", "data.workspaces.train=2"]
    )
    torch.manual_seed(0)
    env = config.env
    model = TEMPModel("point2d", env.encoding_resolution, env.max_path_length,
                      eise_hidden=16, chunk=2, **SMALL)  # fmt: skip
    checkpoint = tmp_path / "policy.pt"
    model.save(checkpoint)
    settings = correction_settings(config, checkpoint, 1, tasks_per_workspace=2,
                                   samples_per_task=20, max_nodes=150)  # fmt: skip
    return config, settings, tmp_path / "round1"


def test_a_round_resumes_and_is_verified_on_load(tiny_round):
    _, settings, out = tiny_round
    collect_corrections(settings, out, progress=False)
    columns = load_corrections(out)
    assert columns["targets"].shape[1:] == (2, 2) and len(columns["step"]) > 0
    assert set(np.unique(columns["workspace_id"])) <= {0, 1}
    # A killed round: the card and one unit gone; the rerun redoes that unit alone, the same.
    first = dict(columns)
    (out / CARD_NAME).unlink()
    (out / "units" / "001.npz").unlink()
    collect_corrections(settings, out, progress=False)
    again = load_corrections(out)
    for key, value in first.items():
        np.testing.assert_array_equal(again[key], value)
    # Other settings never mix into a round; a damaged column is refused by name.
    with pytest.raises(ValueError, match="other settings"):
        collect_corrections({**settings, "max_nodes": 99}, out, progress=False)
    target = out / "samples" / "targets.npy"
    data = bytearray(target.read_bytes())
    data[-1] ^= 0xFF
    target.write_bytes(bytes(data))
    with pytest.raises(StoredFileError, match="targets.npy"):
        load_corrections(out)


def test_a_round_plans_in_the_datasets_workspace_family(tiny_round, monkeypatch):
    import temp_gym.worlds.splits as splits
    from temp_gym.config import apply_overrides

    config, settings, _ = tiny_round
    assert "workspace_family" not in settings  # the default: rounds made before keep theirs
    assert "expert" not in settings  # the lattice: point rounds made before keep theirs too
    maze = correction_settings(apply_overrides(config, ["data.workspace_family=maze"]),
                               settings["checkpoint"], 1, tasks_per_workspace=1,
                               samples_per_task=5, max_nodes=50)  # fmt: skip
    assert maze["workspace_family"] == "maze"
    asked = []
    real = splits.split_workspace
    monkeypatch.setattr(splits, "split_workspace", lambda *key: asked.append(key) or real(*key))
    correction_unit(maze, 0)
    assert asked == [("point2d", "train", 0, "maze")]


def test_training_batches_mix_demonstrations_and_corrections(tiny_round):
    config, settings, out = tiny_round
    from temp_gym.config import apply_overrides
    from temp_gym.data import generate_dataset, load_split
    from temp_gym.training import SplitData

    config = apply_overrides(config, ["model.chunk=2"])
    generate_dataset(config, workers=1, progress=False)
    collect_corrections(settings, out, progress=False)
    buffer, workspaces = load_split(config.data.dir, "train")
    corrections = load_corrections(out)
    data = SplitData(buffer, workspaces, 2, [corrections])
    demonstrations = len(buffer)
    assert len(data) == demonstrations + len(corrections["step"])
    index = torch.arange(demonstrations, len(data))
    batch = data.batch(index, torch.device("cpu"))
    np.testing.assert_array_equal(batch["targets"].numpy(), corrections["targets"])
    np.testing.assert_array_equal(batch["path"].numpy(), corrections["path"])
    np.testing.assert_array_equal(batch["target"].numpy(), corrections["targets"][:, 0])
    with pytest.raises(ValueError, match="labelled with 2 targets"):
        SplitData(buffer, workspaces, 3, [corrections])


def test_a_task_solved_without_asking_the_policy_gives_no_samples(wall):
    problem = Problem.from_dict({**wall, "obstacles": [], "goal": [2.3, 10.2]})
    torch.manual_seed(0)
    policy = TEMPPolicy(TEMPModel("point2d", 8, 16, eise_hidden=16, chunk=2, **SMALL))
    samples = correction_samples(policy, problem, _field(problem), 0, 100, 10, chunk=2)
    assert samples["path"].shape == (0, 16, 2) and samples["targets"].shape == (0, 2, 2)


def test_the_clear_expert_keeps_its_distance_where_it_can(wall):
    from temp_gym.data.correction import ClearField

    problem = Problem.from_dict(wall)
    workspace = problem.workspace
    path = ClearField(workspace, problem.goal, 0.5).path(problem.start)
    tight = _field(problem).path(problem.start)
    grown = Workspace(workspace.robot, workspace.bounds, workspace.obstacle_centers,
                      workspace.obstacle_half_extents + 0.5)  # fmt: skip
    checker = make_checker(grown)
    assert checker.path_free(path) and not checker.path_free(tight)  # clear vs corner-hugging
    # From a state the grown boxes close off, the real boxes' shortest path serves.
    hugging = np.array([9.3, 18.3])  # 0.2 beside the wall, 0.3 below its top: in the grown wall
    assert np.allclose(ClearField(workspace, problem.goal, 0.5).path(hugging),
                       _field(problem).path(hugging))  # fmt: skip


# ---- the arm: no lattice, so the demonstrations' planner labels ------------------------------
def _arm_task(index: int = 0) -> Problem:
    from temp_gym.worlds.generators import generate_task
    from temp_gym.worlds.splits import split_workspace

    workspace = split_workspace("kuka_iiwa14", "train", 3)
    return generate_task(workspace, np.random.default_rng([4, index]), "challenging")


def test_the_arms_expert_plans_a_certified_path_from_the_state_reproducibly():
    from temp_gym.data.correction import PlannerExpert

    problem = _arm_task()
    paths = [
        PlannerExpert(problem, "informed_rrt_star", 1500, 0.05, seed=3).path(problem.start)
        for _ in range(2)
    ]
    np.testing.assert_array_equal(paths[0], paths[1])  # the same seed, the same labels
    path = paths[0]
    np.testing.assert_array_equal(path[0], problem.start)
    assert np.linalg.norm(path[-1] - problem.goal) <= problem.goal_radius + 1e-9
    assert certify_path(problem, path)
    expert = PlannerExpert(problem, "informed_rrt_star", 1500, 0.05, seed=3)
    first, second = expert.path(problem.start), expert.path(problem.start)
    assert not np.array_equal(first, second)  # each call plans with the next seed


def test_the_arms_samples_are_labelled_one_free_step_on():
    from temp_gym.data.correction import PlannerExpert
    from temp_gym.worlds.robots import KUKA_IIWA14

    policy = TEMPPolicy.from_checkpoint(ROOT / "temp_gym" / "checkpoints" / "7d.pt",
                                        robot="kuka_iiwa14", noise_std=0.0)  # fmt: skip
    problem = _arm_task(1)
    expert = PlannerExpert(problem, "informed_rrt_star", 1500, 0.05, seed=1)
    samples = correction_samples(policy, problem, expert, seed=1, max_nodes=300, max_samples=6,
                                 chunk=1)  # fmt: skip
    count = len(samples["step"])
    assert 0 < count <= 6 and samples["targets"].shape == (count, 1, 7)
    lengths = samples["path_length"][:, 0]
    ends = denormalize(samples["path"][np.arange(count), lengths - 1], problem.bounds)
    targets = denormalize(samples["target"], problem.bounds)
    steps = np.linalg.norm(targets - ends, axis=1)
    assert np.all((steps > 0) & (steps <= 0.5 + 1e-4))  # the robot's steering step
    assert KUKA_IIWA14.make_checker(problem.workspace).edges_free(ends, targets).all()


def test_an_arm_round_names_its_expert_and_refuses_a_clearance(tmp_path):
    from temp_gym.config import ConfigError, load_config

    checkpoint = ROOT / "temp_gym" / "checkpoints" / "7d.pt"
    config = load_config(ROOT / "configs" / "7d.yaml", [f"data.dir={tmp_path}"])
    settings = correction_settings(config, checkpoint, 1, tasks_per_workspace=1,
                                   samples_per_task=4, max_nodes=100)  # fmt: skip
    data = config.data
    named = ("expert", "expert_nodes", "expert_goal_bias", "expert_step_size")
    expected = (data.planner, data.max_nodes, data.goal_bias, data.planner_step_size)
    assert tuple(settings[key] for key in named) == expected
    with pytest.raises(ConfigError, match="labelled by a planner"):
        correction_settings(config, checkpoint, 1, 1, 4, 100, clearance=0.5)
    unit = correction_unit({**settings, "workspaces": 1}, 0)
    assert len(unit["step"]) > 0 and unit["targets"].shape[1:] == (1, 7)
