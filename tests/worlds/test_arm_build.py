"""``temp-robot build``: the derived data is written once, checked on load, and rebuilt only
when its sources change."""

from __future__ import annotations

import subprocess
import sys

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
