"""The arms' manipulation scenes (`temp_gym.worlds.arm_manipulation`)."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from temp_gym.planning.plan import plan
from temp_gym.problem import Problem, Workspace
from temp_gym.problem.obstacles import BOX, CYLINDER, rotation_matrices
from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.arm_manipulation import (
    BUILDERS,
    FLOOR_SHARE,
    PEDESTAL_FLOOR,
    SEPARATION,
    STRUCTURES,
    _lid,
    manipulation_scene,
)
from temp_gym.worlds.arm_pieces import (
    OBJECT_HALF,
    OBJECT_HALF_HEIGHT,
    OBJECT_RADIUS,
    bounding_boxes,
    objects_on,
)
from temp_gym.worlds.arm_structured import MIN_FREE_FRACTION
from temp_gym.worlds.arm_world import (
    FLOOR_TOP,
    arm_scale,
    base_free,
    generate_arm_task,
    near_surface,
)
from temp_gym.worlds.checkers import make_checker
from temp_gym.worlds.generators import generate_workspace
from temp_gym.worlds.robots import robot_spec
from temp_gym.worlds.splits import split_workspace
from temp_gym.worlds.structured import FAMILY_MIX, MANIPULATION, check_family, draw_family

ROBOTS = ["franka_panda", "kuka_iiwa14"]


@cache
def sample(robot: str, count: int, seed: int = 0) -> tuple[Workspace, ...]:
    """``count`` manipulation workspaces, workspace i from generator ``[seed, i]``."""
    return tuple(
        generate_workspace(robot, np.random.default_rng([seed, i]), MANIPULATION)
        for i in range(count)
    )


@cache
def scenes(robot: str, count: int) -> tuple:
    """``count`` candidate scenes (ground pieces, structures), scene i from generator ``[1, i]``."""
    return tuple(manipulation_scene(robot, np.random.default_rng([1, i])) for i in range(count))


def _yaws(workspace: Workspace) -> np.ndarray:
    """The turn about z of every obstacle turned about z alone (quaternions ``[0, 0, z, w]``)."""
    q = workspace.obstacle_orientations
    about_z = np.all(q[:, :2] == 0.0, axis=1) & ~workspace.unrotated
    return 2 * np.arctan2(q[about_z, 2], q[about_z, 3])


# ---- the family and its registration ----------------------------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
def test_same_seed_same_workspace_other_seed_other_workspace(robot):
    def draw(seed: int) -> list[Workspace]:
        rng = np.random.default_rng(seed)
        return [generate_workspace(robot, rng, MANIPULATION) for _ in range(3)]

    assert draw(3) == draw(3)
    assert draw(3) != draw(4)


def test_the_family_is_for_arms_and_mixed_never_draws_it():
    check_family("franka_panda", MANIPULATION)
    with pytest.raises(ValueError, match="family: 'manipulation' is drawn for arms only"):
        check_family("point3d", MANIPULATION)
    assert MANIPULATION not in FAMILY_MIX
    rng = np.random.default_rng(0)
    assert MANIPULATION not in {draw_family(rng) for _ in range(200)}


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_family_has_pools_of_its_own(robot):
    pool = split_workspace(robot, "train", 0, MANIPULATION)
    assert pool == split_workspace(robot, "train", 0, MANIPULATION)
    assert pool != split_workspace(robot, "train", 1, MANIPULATION)
    assert pool != split_workspace(robot, "train", 0)
    assert not pool.axis_aligned


# ---- geometry ---------------------------------------------------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
def test_scenes_have_one_to_three_separate_structures_clear_of_the_base(robot):
    arm = load_arm(robot_spec(robot).description)
    scale = arm_scale(arm)
    counts = []
    for ground, structures in scenes(robot, 30):
        counts.append(len(structures))
        footprints = []
        for structure in structures:
            lower, upper = bounding_boxes(structure)
            assert base_free(arm, list(zip((lower + upper) / 2, (upper - lower) / 2)))
            footprints.append((lower.min(axis=0)[:2], upper.max(axis=0)[:2]))
        for k, (low, high) in enumerate(footprints):
            for other_low, other_high in footprints[k + 1 :]:
                apart = np.any(high + SEPARATION * scale <= other_low) or np.any(
                    other_high + SEPARATION * scale <= low
                )
                assert apart
        assert len(ground) in (0, 1, 2)  # none, a floor, or a floor and a pedestal
    assert min(counts) >= STRUCTURES[0] and max(counts) <= STRUCTURES[1]
    assert len(set(counts)) == 3, counts


@pytest.mark.parametrize("robot", ROBOTS)
def test_sizes_stay_within_the_arms_reach_and_the_drawn_ranges(robot):
    arm = load_arm(robot_spec(robot).description)
    scale = arm_scale(arm)
    for workspace in sample(robot, 20):
        halves = workspace.obstacle_half_extents
        assert np.all(halves >= 0.005 * scale - 1e-12)
        assert np.all(halves <= 1.5 * scale + 1e-12)
        lower, upper = workspace.obstacle_lower, workspace.obstacle_upper
        structure = halves.max(axis=1) < 1.5 * scale - 1e-9  # every piece but the floor
        assert np.all(np.abs(lower[structure, :2]) < 2.5 * scale)
        assert np.all(lower[structure, 2] >= (PEDESTAL_FLOOR[0] - 0.85) * scale)
        assert np.all(upper[structure, 2] <= 1.8 * scale)  # top boards to 1.35 m, objects 40 cm
        cylinders = workspace.obstacle_kinds == CYLINDER
        assert np.all(halves[cylinders, 0] == halves[cylinders, 1])


def test_objects_stand_on_their_surface_apart_and_in_the_ranges():
    rng = np.random.default_rng(2)
    rect = (0.4, 1.0, -0.5, 0.5)
    drawn = 0
    for _ in range(50):
        room = rng.uniform(0.1, 0.6)
        pieces = objects_on(rng, 6, rect, 0.3, room)
        drawn += len(pieces)
        assert len(pieces) <= 6
        lower, upper = bounding_boxes(pieces)
        assert np.all(lower[:, 0] >= rect[0] - 1e-12) and np.all(upper[:, 0] <= rect[1] + 1e-12)
        assert np.all(lower[:, 1] >= rect[2] - 1e-12) and np.all(upper[:, 1] <= rect[3] + 1e-12)
        np.testing.assert_allclose(lower[:, 2], 0.3)
        assert np.all(upper[:, 2] - 0.3 <= 0.8 * room + 1e-12)
        for piece in pieces:
            assert OBJECT_HALF_HEIGHT[0] <= piece.half[2] <= OBJECT_HALF_HEIGHT[1]
            if piece.kind == CYLINDER:
                assert OBJECT_RADIUS[0] <= piece.half[0] <= OBJECT_RADIUS[1]
            else:
                assert np.all(
                    (OBJECT_HALF[0] <= piece.half[:2]) & (piece.half[:2] <= OBJECT_HALF[1])
                )
        footprints = [(p.center[:2], np.hypot(*p.half[:2]) if p.kind == BOX else p.half[0])
                      for p in pieces]  # fmt: skip
        for k, (a, ra) in enumerate(footprints):
            for b, rb in footprints[k + 1 :]:
                assert np.linalg.norm(a - b) >= ra + rb
    assert drawn > 100
    assert objects_on(rng, 5, rect, 0.3, 0.05) == []  # no room for the smallest object


def test_a_tilted_lid_rests_on_its_hinge_edge():
    """The lid's lower face meets the box's top along one of the box's four top edges."""
    halves, top, thickness, x = (0.3, 0.2), 0.5, 0.02, 0.8
    tilted = 0
    for seed in range(60):
        lids = _lid(np.random.default_rng(seed), x, halves, top, thickness)
        if not lids or np.all(lids[0].orientation[:2] == 0):
            continue  # no lid, or one lying flat (its turn is about z alone)
        (lid,) = lids
        rotation = rotation_matrices(lid.orientation[None])[0]
        a, b, t = lid.half
        hinge = [lid.center + rotation @ np.array([a, s * b, -t]) for s in (-1.0, 1.0)]
        for point in hinge:
            assert point[2] == pytest.approx(top)
            offset = np.abs(point[:2] - [x, 0.0])
            assert np.isclose(offset[0], halves[0]) or np.isclose(offset[1], halves[1]), point
        assert lid.center[2] > top + thickness  # opened upwards
        tilted += 1
    assert tilted >= 15


@pytest.mark.parametrize("robot", ROBOTS)
def test_structures_turn_at_any_angle_and_cylinders_stand_and_lie(robot):
    yaws, kinds, lying, tilted = [], [], 0, 0
    for workspace in sample(robot, 30):
        yaws.extend(_yaws(workspace))
        kinds.extend(workspace.obstacle_kinds)
        axes = workspace.obstacle_rotations[:, :, 2]
        cylinders = workspace.obstacle_kinds == CYLINDER
        lying += int(np.sum(cylinders & (np.abs(axes[:, 2]) < 1e-9)))
        tilted += int(np.sum(~cylinders & (np.abs(axes[:, 2]) < 1 - 1e-9)))
    quarter = np.sort(np.mod(yaws, np.pi / 2))  # the four sides fold onto one point
    gaps = np.diff(np.concatenate([quarter, [quarter[0] + np.pi / 2]]))
    assert gaps.max() < 0.2, "structures should turn at any angle, not to four sides"
    assert np.mean(np.array(kinds) == CYLINDER) > 0.1
    assert lying > 0 and tilted > 0  # bars and legs lying along x or y; tilted lids


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_ground_is_a_floor_a_pedestal_or_none(robot):
    scale = arm_scale(load_arm(robot_spec(robot).description))
    kinds = []
    for ground, _ in scenes(robot, 30):
        if not ground:
            kinds.append("none")
            continue
        floor_top = ground[0].center[2] + ground[0].half[2]
        if len(ground) == 1:
            assert floor_top == pytest.approx(FLOOR_TOP * scale)
            kinds.append("floor")
        else:
            low, high = np.array(PEDESTAL_FLOOR) * scale
            assert low <= floor_top <= high
            pedestal = ground[1]
            assert pedestal.center[2] + pedestal.half[2] == pytest.approx(FLOOR_TOP * scale)
            assert pedestal.center[2] - pedestal.half[2] == pytest.approx(floor_top)
            kinds.append("pedestal")
    assert set(kinds) == {"none", "floor", "pedestal"}
    assert abs(kinds.count("floor") / len(kinds) - FLOOR_SHARE) < 0.3


@pytest.mark.parametrize("robot", ROBOTS)
def test_workspaces_keep_the_base_and_enough_configurations_free(robot):
    limits = robot_spec(robot).joint_limits()
    states = np.random.default_rng(7).uniform(*limits, size=(1000, 7))
    fractions = []
    for workspace in sample(robot, 8):
        np.testing.assert_array_equal(workspace.bounds, limits)
        assert make_checker(workspace, exact=True).base_free
        fractions.append(float(make_checker(workspace).states_free(states).mean()))
    print(robot, "free share of random configurations:", np.round(fractions, 2))
    assert min(fractions) >= MIN_FREE_FRACTION / 2  # probes differ from the generator's
    assert np.median(fractions) <= 0.85  # the structures are in the arm's way


PIECE_COUNTS = {
    "bookshelf": (4, 6 + 4 + 1 + 1 + 6 * 2 * 3),  # boards, legs, divider, back, objects
    "open_box": (5, 5 + 1 + 3 + 1),  # bottom and walls, lid, objects, stand
    "cage": (4, 1 + 3 * 4 + 4 + 4 + 1 + 4),  # base, sides' bars, front, cap, object, legs
    "table": (5, 5 + 8 + 1 + 3),  # top and legs, objects on it, lower board, objects under
}
"""Each structure's fewest and most pieces, from the counts its builder draws."""


@pytest.mark.parametrize("name", list(BUILDERS))
def test_each_structure_has_as_many_pieces_as_its_builder_draws(name):
    low, high = PIECE_COUNTS[name]
    counts = []
    for seed in range(60):
        ground = (None, FLOOR_TOP, -0.5)[seed % 3]
        pieces, anchor = BUILDERS[name](np.random.default_rng(seed), ground)
        counts.append(len(pieces))
        assert anchor[0] > 0 and anchor[1] == 0  # in front of the robot, along +x
        if ground is not None:  # nothing below the ground
            assert bounding_boxes(pieces)[0][:, 2].min() >= ground - 1e-12
    assert low <= min(counts) and max(counts) <= high, (min(counts), max(counts))
    assert max(counts) - min(counts) >= 3  # counts are drawn, not fixed


# ---- tasks ------------------------------------------------------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
def test_tasks_are_free_for_the_exact_checker_and_goals_reach_near_surfaces(robot):
    """`generate_arm_task` draws in these scenes: start and goal free by the exact checker, a
    goal near a surface within `NEAR_SURFACE` of one, and both difficulties found."""
    rng = np.random.default_rng(5)
    for workspace in sample(robot, 3, seed=11):
        exact = make_checker(workspace, exact=True)
        for difficulty, near in (("easy", "none"), ("challenging", "none"), ("any", "goal")):
            problem = generate_arm_task(workspace, rng, difficulty, 0.1, near=near)
            assert exact.states_free(np.stack([problem.start, problem.goal])).all()
            if near == "goal":
                assert near_surface(exact, problem.goal[None])[0]


def test_the_expert_solves_tasks_of_both_difficulties():
    """Informed RRT* solves every task at 3000 nodes with the demonstrations' retries (other
    seeds, `data.attempts`, each also planned from the goal, `data.expert_reverse`), and its
    paths are certified by the exact checker (`plan` certifies what it returns)."""
    rng = np.random.default_rng(5)
    unsolved = []
    for workspace in sample("franka_panda", 2, seed=11):
        for difficulty in ("easy", "challenging"):
            problem = generate_arm_task(workspace, rng, difficulty, 0.1)
            reverse = Problem(workspace, problem.goal, problem.start, problem.goal_radius)
            results = [
                plan(task, planner="informed_rrt_star", seed=seed, max_nodes=3000,
                     stop_at_first=True)
                for seed in range(3) for task in (problem, reverse)
            ]  # fmt: skip
            solved = [result for result in results if result.success]
            if not solved:
                unsolved.append(difficulty)
            exact = make_checker(workspace, exact=True)
            for result in solved:
                path = np.asarray(result.path)
                assert exact.states_free(path).all()
    assert not unsolved, f"Informed RRT* missed {unsolved} at 3000 nodes"
