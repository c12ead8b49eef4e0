"""``temp-robot build``: the derived data is written once, checked on load, and rebuilt only
when its sources change."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from arm_fixtures import write_test_arm

from temp_gym.worlds.arm.build import build
from temp_gym.worlds.arm.model import ArmDataError, load_arm


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    path = write_test_arm(tmp_path_factory.mktemp("built"))
    build(path, log=lambda line: None)
    return path


def test_the_data_lands_beside_the_description_and_loads(built):
    arm = load_arm(built)
    data = arm.derived_data()
    assert built.with_name("test_arm.derived.json").is_file()
    assert [b["body"] for b in data["spheres"]["bodies"]] == list(arm.body_names)
    assert len(arm.enabled_pairs()) > 0
    reasons = {tuple(entry["bodies"]): entry["reason"] for entry in data["acm"]["pairs"]}
    assert all(reasons[(a, a + 1)] == "adjacent" for a in range(arm.dim))


def test_building_again_changes_nothing(built):
    target = built.with_name("test_arm.derived.json")
    before = (target.read_bytes(), target.stat().st_mtime_ns)
    lines = []
    build(built, log=lines.append)
    assert (target.read_bytes(), target.stat().st_mtime_ns) == before
    assert any("up to date" in line for line in lines)


def test_a_body_of_very_many_spheres_gets_a_hint_to_raise_the_tolerance(built, monkeypatch):
    from temp_gym.worlds.arm import build as build_module

    arm = load_arm(built)
    counts = [len(body["radii"]) for body in arm.derived_data()["spheres"]["bodies"]]
    quiet = []
    build_module.fit_spheres(arm, log=quiet.append)
    assert not any("builds and checks faster" in line for line in quiet)  # none is that large
    monkeypatch.setattr(build_module, "MANY_SPHERES", sorted(counts)[-2])
    hinted = []
    build_module.fit_spheres(arm, log=hinted.append)
    hints = [line for line in hinted if "spheres: {tolerance: 0.006}" in line]
    assert len(hints) == 1 and arm.body_names[counts.index(max(counts))] in hints[0]


def test_data_of_other_sources_is_refused_with_the_command_that_rebuilds_it(built, tmp_path):
    copy = tmp_path / "test_arm.yaml"
    copy.write_text(built.read_text().replace("tolerance: 0.006", "tolerance: 0.007")
                    .replace("urdf: test_arm/", f"urdf: {built.parent}/test_arm/"))  # fmt: skip
    (tmp_path / "test_arm.derived.json").write_bytes(
        built.with_name("test_arm.derived.json").read_bytes()
    )
    with pytest.raises(ArmDataError, match="temp-robot build"):
        load_arm(copy)
    (tmp_path / "test_arm.derived.json").unlink()
    with pytest.raises(ArmDataError, match="no derived data"):
        load_arm(copy)


def _run(*args):
    return subprocess.run([sys.executable, "-m", "temp_gym.worlds.arm.build", *args],
                          capture_output=True, text=True, timeout=300)  # fmt: skip


def test_the_command_checks_and_refuses_in_one_line(built, tmp_path):
    ok = _run("check", str(built))
    assert ok.returncode == 0 and "up to date" in ok.stdout
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nurdf: nowhere.urdf\nbase_link: a\ntip_link: b\n")
    for command in ("check", "build"):
        refused = _run(command, str(bad))
        assert refused.returncode == 2
        assert refused.stderr.count("\n") == 1 and "urdf" in refused.stderr


def test_the_data_stays_valid_where_the_folder_is_moved(built, tmp_path):
    """The digest names files relative to the description (and pybullet_data's as
    ``pybullet_data://``), so an installed copy of a robot's folder needs no rebuild."""
    import shutil

    moved = tmp_path / "elsewhere"
    shutil.copytree(built.parent, moved)
    arm = load_arm(moved / built.name)  # require_derived: refused if the digest moved with it
    assert arm.derived is not None and arm.description.path.parent == moved.resolve()


def test_a_built_in_arm_names_its_urdf_in_pybullet_data_portably():
    from temp_gym.worlds.arm.description import load_description, portable_name
    from temp_gym.worlds.robots import robot_spec

    description = load_description(robot_spec("franka_panda").description)
    assert portable_name(description.urdf, description.path.parent) == (
        "pybullet_data://franka_panda/panda.urdf"
    )


def test_a_dataset_of_a_described_arm_records_the_arms_digest(built, tmp_path):
    from temp_gym.config import load_config
    from temp_gym.data.dataset import data_settings
    from temp_gym.worlds.arm.spec import robot_digest
    from temp_gym.worlds.robots import forget_robot

    root = Path(__file__).resolve().parents[2]
    try:
        config = load_config(root / "configs" / "tiny.yaml",
                             [f"env.robot={built}", f"data.dir={tmp_path}"])  # fmt: skip
        settings = data_settings(config)
    finally:
        forget_robot("test_arm")
    assert settings["robot_description"] == str(built.resolve())
    assert settings["robot_digest"] == robot_digest(built)


def joint_count(robot: str) -> int:
    """The dimension of ``robot`` as a worker process knows it."""
    from temp_gym.worlds.robots import robot_spec

    return robot_spec(robot).dim


def test_worker_processes_know_the_arms_this_process_registered(built):
    import temp_gym
    from temp_gym.distributed import map_units
    from temp_gym.worlds.robots import forget_robot

    spec = temp_gym.register_robot_file(built)
    try:
        results = dict(map_units(joint_count, ["test_arm", "kuka_iiwa14"], "local", 2))
    finally:
        forget_robot(spec.name)
    assert results == {0: spec.dim, 1: 7}


def test_the_benchmark_command_registers_a_described_arm_for_itself_and_its_workers(
    built, tmp_path
):
    import json

    from temp_gym.evaluation.benchmark_command import main
    from temp_gym.worlds.robots import forget_robot

    argv = ["--robot", str(built), "--split", "test_arm:easy:2", "--planners", "rrt_connect",
            "--runs", "1", "--time-limit", "5", "--stop-at-first", "--workers", "2",
            "--out", str(tmp_path / "out"), "--no-progress"]  # fmt: skip
    try:
        assert main(argv) == 0
    finally:
        forget_robot("test_arm")
    records = [json.loads(line) for line in (tmp_path / "out" / "runs.jsonl").open()]
    assert len(records) == 2
    assert all(record["status"] != "crash" for record in records), records


def test_the_viewer_command_registers_a_described_arm(built, tmp_path, monkeypatch):
    pytest.importorskip("viser")
    import numpy as np

    import temp_gym
    from temp_gym.viewer import plan_viewer
    from temp_gym.viewer.command import main
    from temp_gym.worlds.generators import generate_task, generate_workspace
    from temp_gym.worlds.robots import forget_robot

    spec = temp_gym.register_robot_file(built)
    try:
        rng = np.random.default_rng(0)
        generate_task(generate_workspace(spec.name, rng), rng, "easy").save(tmp_path / "p.json")
    finally:
        forget_robot(spec.name)
    served = []
    monkeypatch.setattr(plan_viewer, "serve_plan", lambda problem, **_: served.append(problem))
    assert main([str(tmp_path / "p.json"), "--port", "0"]) == 2  # no such robot here yet
    try:
        assert main([str(tmp_path / "p.json"), "--robot", str(built), "--port", "0"]) == 0
    finally:
        forget_robot(spec.name)
    assert [problem.robot for problem in served] == ["test_arm"]


@pytest.mark.parametrize("argv", [[], ["build"], ["check", "a.yaml", "b.yaml"]])
def test_a_bad_command_line_is_one_line(argv, capsys):
    from temp_gym.worlds.arm.build import main

    with pytest.raises(SystemExit) as exit:
        main(argv)
    assert exit.value.code == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("temp-robot") and "error:" in error and "\n" not in error
