"""`RobotSpec`: everything that differs between robots, in one place per robot.

A robot's file in this package builds one `RobotSpec`; the registry
(`temp_gym.worlds.robots`) maps its name to it. The env, the tree, the collision factory,
the encoding, the generators, the data, the trainers and the evaluation read the spec, so no
code outside this package asks which robot it is planning for.

The spec holds values (dimensions, budgets, the encoding) and factories (checkers,
generators, the renderer). The library calls the methods, which apply the spec's defaults.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from temp_gym.worlds.collision import SelfCollisionChecker

if TYPE_CHECKING:
    from temp_gym.problem import Problem, Workspace
    from temp_gym.worlds.collision import CollisionChecker
    from temp_gym.worlds.rendering.common import TreeRenderer

STEP_FRACTION = 0.05
"""Steering step of a robot without a fixed one: this fraction of the bounds' largest side."""


@dataclass(frozen=True)
class lazy:  # noqa: N801  (reads as a function in the specs)
    """``module.name``, imported on the first call.

    A spec's factories load no machinery (numba kernels, meshes, pybullet) until the robot is
    used; being a plain dataclass, a spec with them pickles (worker processes, Ray).
    """

    module: str
    name: str

    def __call__(self, *args, **kwargs):
        """Import ``module`` (once: Python caches it) and call its ``name``."""
        return getattr(importlib.import_module(self.module), self.name)(*args, **kwargs)


CheckerFactory = Callable[["Workspace", bool], "CollisionChecker"]
WorkspaceGenerator = Callable[[str, np.random.Generator], "Workspace"]
TaskGenerator = Callable[["Workspace", np.random.Generator, str, float], "Problem"]
StructuredGenerator = Callable[[str, np.random.Generator, str], "Workspace"]


@dataclass(frozen=True)
class RobotSpec:
    """One robot: its dimensions, defaults, checkers, generators and renderer.

    Examples:
        >>> spec = robot_spec("point2d")
        >>> spec.dim, spec.env_id, spec.encoding_resolution
        (2, 'TEMP-2D-v0', 32)
        >>> checker = spec.make_checker(problem.workspace)
    """

    name: str
    """The name problem files and configs use (``"robot": ...``)."""
    env_id: str
    """The Gymnasium id registered for it (``TEMP-2D-v0``)."""
    short_name: str
    """A short name for files and flags: its shipped checkpoint (``{short_name}.pt``), its
    out-of-distribution folder, benchmark options."""
    seed_code: int
    """Its entry in the seed sequence of the fixed workspace pools (`temp_gym.worlds.splits`);
    unique per robot, and never changed, or every pool changes."""
    dim: int
    """Configuration-space dimension."""
    workspace_dim: int
    """Dimension of the workspace the boxes live in (2 or 3)."""
    encoding_resolution: int
    """Default cells per workspace axis of the occupancy grid (env, planner, data)."""
    goal_radius: float
    """Goal radius of drawn tasks, in configuration units."""
    max_nodes: int
    """The env's default node budget (episode truncation)."""
    evaluation_rows: Mapping[str, str]
    """The rows of the evaluation table: row name -> task difficulty."""
    evaluation_tasks: int
    """Test tasks per evaluation row, by default."""
    checker_factory: CheckerFactory
    """``(workspace, exact) -> checker``: the fast checker planners call in their hot loop,
    or the exact one that certifies returned paths (`temp_gym.worlds.collision`)."""
    workspace_generator: WorkspaceGenerator
    """``(name, rng) -> Workspace``: a random workspace of the robot."""
    task_generator: TaskGenerator
    """``(workspace, rng, difficulty, goal_radius) -> Problem``: a random task in it."""
    renderer_factory: Callable[[], TreeRenderer]
    """A new renderer of the robot's episodes (`TreeRenderer`)."""
    step_size: float | None = None
    """Fixed steering step; None: `STEP_FRACTION` of the bounds' largest side."""
    encoding_region: np.ndarray | None = None
    """The ``(2, workspace_dim)`` box the occupancy grid covers; None: the bounds."""
    joint_limits: Callable[[], np.ndarray] | None = None
    """The robot's own ``(2, dim)`` limits: a problem's bounds default to them and lie within."""
    description: Path | None = None
    """The robot description file of an arm (`temp_gym.worlds.arm`): its URDF, chain and
    planning defaults, with its derived data beside it. None for other robots."""
    structured_generator: StructuredGenerator | None = None
    """``(name, rng, family) -> Workspace``: a workspace of a structured family (corridors,
    maze, traps, narrow, clutter: `temp_gym.worlds.structured` for point robots,
    `temp_gym.worlds.arm_structured` for arms); None: the robot has only its own
    generator."""
    cube_symmetric: bool = False
    """Its world is a cube whose occupancy grid shares the configuration axes (a point robot),
    so mirrored and axis-swapped samples are samples too: training may augment with them."""
    compile_minutes: float = 1.0
    """Roughly how long its planners' numba kernels take to compile on first use (an empty
    cache), for the one line that says so (`temp_gym.planning.warmup`)."""

    # ------------------------------------------------------------------ what the library calls
    def make_checker(self, workspace: Workspace, exact: bool = False) -> CollisionChecker:
        """The fast (default) or exact collision checker of ``workspace``."""
        return self.checker_factory(workspace, exact)

    def generate_workspace(self, rng: np.random.Generator) -> Workspace:
        """A random workspace, drawn from ``rng`` alone."""
        return self.workspace_generator(self.name, rng)

    def generate_structured_workspace(self, rng: np.random.Generator, family: str) -> Workspace:
        """A random workspace of a structured ``family``, drawn from ``rng`` alone.

        Raises:
            ValueError: the robot has no structured families.
        """
        if self.structured_generator is None:
            raise ValueError(f"family: {self.name} has only its own generator, not {family!r}")
        return self.structured_generator(self.name, rng, family)

    def generate_task(
        self,
        workspace: Workspace,
        rng: np.random.Generator,
        difficulty: str = "any",
        goal_radius: float | None = None,
    ) -> Problem:
        """A random task of ``difficulty`` in ``workspace`` (None ``goal_radius``: the robot's).

        Raises:
            RuntimeError: no task of that difficulty in the generator's tries.
        """
        radius = self.goal_radius if goal_radius is None else goal_radius
        return self.task_generator(workspace, rng, difficulty, radius)

    def make_renderer(self) -> TreeRenderer:
        """A new renderer of this robot's episodes; close it when done."""
        return self.renderer_factory()

    def default_step_size(self, bounds: np.ndarray) -> float:
        """The steering step for a problem of these ``bounds`` when none is given."""
        if self.step_size is not None:
            return self.step_size
        return STEP_FRACTION * float(np.max(bounds[1] - bounds[0]))

    def region(self, bounds: np.ndarray) -> np.ndarray:
        """The ``(2, workspace_dim)`` box the occupancy grid covers, a fresh array."""
        region = bounds if self.encoding_region is None else self.encoding_region
        return np.asarray(region, dtype=np.float64).copy()

    def collision_reasons(self, workspace: Workspace, states: np.ndarray) -> list[str | None]:
        """Per state: None when the state is free, else why not (for messages).

        A state the fast checker calls free is free. One it refuses is asked of the exact
        checker too, whose verdict stands: the fast checker is conservative, so a state a few
        millimetres from a surface may be refused by it and be free. A refused state's
        reason names the touching link and obstacle (its kind and index, "cylinder 3") with
        the penetration depth, or the colliding link pairs, and the checker.
        """
        checker = self.make_checker(workspace)
        fast_free = checker.states_free(states)
        reasons: list[str | None] = [None] * len(states)
        if fast_free.all():
            return reasons
        exact = self.make_checker(workspace, exact=True)
        for k in np.flatnonzero(~fast_free):
            state = states[k]
            if exact.states_free(state[None])[0]:
                continue
            reasons[k] = _refusal(exact, state)
        return reasons


def _refusal(checker: CollisionChecker, state: np.ndarray) -> str:
    """Why ``checker`` (an exact one) calls ``state`` in collision, in words."""
    pairs = checker.self_collisions(state) if isinstance(checker, SelfCollisionChecker) else []
    report = checker.obstacle_report(state) if hasattr(checker, "obstacle_report") else []
    if pairs:
        what = "self-collision between " + ", ".join(f"{a} and {b}" for a, b in pairs)
    elif report and report[0][2] <= 0:
        link, index, distance = report[0]
        depth = f", penetration {-distance * 1000:.1f} mm" if distance < 0 else ""
        named = hasattr(checker, "obstacle_name")
        obstacle = checker.obstacle_name(index) if named else f"obstacle {index}"
        what = f"collision: {link} touches {obstacle}{depth}"
    else:
        what = "collision"
    return f"{what} ({checker.description})"
