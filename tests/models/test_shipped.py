"""The pretrained policies shipped in the package: size, card, loading and planning."""

import json
import re
import subprocess
import sys

import numpy as np
import pytest

import temp_gym
from temp_gym.models.registry import checkpoint_path
from temp_gym.models.temp import load_checkpoint, weights_digest
from temp_gym.planning.plan import plan
from temp_gym.worlds.checkers import certify_path
from temp_gym.worlds.generators import generate_problem
from temp_gym.worlds.robots import spec_for_env

ROBOTS = {"TEMP-2D-v0": "point2d", "TEMP-3D-v0": "point3d", "TEMP-7D-v0": "kuka_iiwa14",
          "TEMP-Panda-v0": "franka_panda"}  # fmt: skip
SHIPPED = {"TEMP-2D-v0": "2d", "TEMP-3D-v0": "3d", "TEMP-7D-v0": "7d", "TEMP-Panda-v0": "panda"}
"""Env id -> checkpoint stem, as shipped (the specs must keep naming these files)."""


@pytest.mark.parametrize("env_id", list(SHIPPED))
def test_shipped_checkpoint_is_small_carded_and_consistent(env_id):
    path = checkpoint_path(spec_for_env(env_id))
    assert path.name == f"{SHIPPED[env_id]}.pt"
    assert path.stat().st_size <= 10 * 2**20
    model, checkpoint = load_checkpoint(path, robot=ROBOTS[env_id])  # weights_only=True
    assert checkpoint["provenance"]["digest"] == weights_digest(model.state_dict())
    # The attention phase gets the caller's whole budget, as every baseline does (the cards).
    assert checkpoint["planner"]["attention_nodes"] is None
    card = path.with_suffix(".md").read_text()
    assert env_id in card and checkpoint["provenance"]["digest"] in card


@pytest.mark.parametrize("env_id", list(SHIPPED))
def test_shipped_policy_plans_a_generated_problem(env_id):
    policy = temp_gym.load_policy(env_id, seed=0)
    problem = generate_problem(ROBOTS[env_id], np.random.default_rng(11), "easy")
    result = plan(problem, seed=0, max_nodes=3000, policy=policy, stop_at_first=True)
    assert result.planner == "temp" and result.success
    assert certify_path(problem, result.path)
    # The default planner is TEMP with this very policy: the same seed gives the same plan.
    default = plan(problem, seed=0, max_nodes=3000, stop_at_first=True)
    assert default.planner == "temp" and default.nodes == result.nodes
    np.testing.assert_allclose(default.path, result.path)


def test_temp_plan_default_solves_a_file_end_to_end(tmp_path):
    problem = generate_problem("point2d", np.random.default_rng(5), "challenging")
    path = tmp_path / "problem.json"
    problem.save(path)
    out = tmp_path / "result.json"
    done = subprocess.run(
        [sys.executable, "-m", "temp_gym.cli", str(path), "--out", str(out)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("temp ")
    # The summary reports the attention phase: its solution, or why it handed over.
    assert re.search(
        r"attention phase: (cost [\d.]+|stalled, no solution) at \d+ nodes", done.stdout
    )
    result = json.loads(out.read_text())
    assert result["planner"] == "temp" and result["success"]
    assert certify_path(problem, np.asarray(result["path"]))
