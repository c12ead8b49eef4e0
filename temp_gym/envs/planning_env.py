"""`PlanningEnv`: RRT* tree growth as a Gymnasium environment, one tree extension per step."""

from __future__ import annotations

import math
import numbers
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from temp_gym.limits import MAX_COUNT
from temp_gym.planning.observation import (
    DEFAULT_MAX_PATH_LENGTH,
    TreeObserver,
    check_path_length,
)
from temp_gym.planning.samplers import UniformSampler
from temp_gym.planning.temp_settings import local_fallback_count
from temp_gym.planning.tree import Tree, default_step_size
from temp_gym.problem import Problem, Workspace
from temp_gym.problem.parsing import positive_length
from temp_gym.worlds.encoding import check_resolution, occupancy_grid
from temp_gym.worlds.normalization import MAX_RATIO
from temp_gym.worlds.robots import robot_spec
from temp_gym.worlds.splits import SPLITS, split_workspace
from temp_gym.worlds.structured import BOXES, check_family

DIFFICULTIES = ("any", "easy", "challenging", "mixed")
FALLBACKS = ("random", "none")


def _is_integer(value: object) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _is_positive(value: object) -> bool:
    """A finite number above 0 (not a bool, not complex)."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(value) and value > 0
    except OverflowError:  # an integer beyond float range
        return False


def _check_target_cost(value: object, name: str) -> None:
    """None or a real number that is not NaN."""
    if value is None:
        return
    try:
        bad = not isinstance(value, numbers.Real) or isinstance(value, bool) or math.isnan(value)
    except OverflowError:  # an integer beyond float range
        bad = True
    if bad:
        raise ValueError(f"{name}: expected a number (not NaN) or None, got {value!r}")


class PlanningEnv(gym.Env):
    """Grow an RRT* tree towards a goal region; the action is where to sample next.

    ## Description
    A sampling-based motion-planning query (a `temp_gym.Problem`: a point robot in 2D/3D or
    a 7-DOF Kuka iiwa 14 among axis-aligned boxes) is solved by growing an RRT* tree from the
    start. Each step is **one tree extension** on the shared core `temp_gym.planning.Tree`:
    the action is the next sample; the env steers from the nearest node by the step size,
    checks the edge for collisions, chooses the cheapest collision-free parent among the near
    nodes, inserts the node and rewires. "RRT*" is this env stepped with
    `temp_gym.policies.UniformPolicy`; TEMP is this env stepped with the learned policy.

    ## Action Space
    `Box(-1, 1, (d,), float32)`: the sample, normalized so that -1 and 1 are the lower and
    upper configuration bounds (d = 2, 3 or 7). A finite action outside [-1, 1] is clipped
    to it; a NaN or inf action, or one of the wrong shape, raises `ValueError` and leaves the
    tree untouched.

    With ``fallback="random"`` (the paper's Algorithm 1, lines 7-10) a sample whose steered
    edge collides is replaced by uniform random samples until an extension succeeds (at most
    ``max_fallback_tries``); each failure is counted. With ``attention_local_fallback`` N > 0
    the first N replacements are drawn near the action, as the ``temp`` planner draws them
    (`temp_gym.planning.TEMPSettings.attention_local_fallback`; a shipped policy carries its
    N, ``policy.attention_local_fallback``). With ``fallback="none"`` a colliding action adds
    no node and ``info["added"]`` is False.

    ## Observation Space
    A `Dict` of fresh arrays (normalized coordinates are in [-1, 1]). ``path`` holds the
    normalized root path of the newest node, the last L nodes when it is longer.

    | key | shape | meaning | range |
    |---|---|---|---|
    | ``occupancy`` | (R,)*w | occupancy grid of the workspace (w = 2 or 3), 1 = occupied | {0, 1} |
    | ``start`` | (d,) | start configuration, normalized | [-1, 1] |
    | ``goal`` | (d,) | goal configuration, normalized | [-1, 1] |
    | ``goal_radius`` | (1,) | goal radius over the mean half-range of the bounds | (0, 100] |
    | ``path`` | (L, d) | root path of the newest node ("path so far"), zero-padded | [-1, 1] |
    | ``path_length`` | (1,) | number of valid rows of ``path`` | [1, L] |
    | ``best_cost`` | (1,) | best cost / start-goal distance; 0 before a solution | [0, 100] |
    | ``solved`` | (1,) | 1 once a solution exists | {0, 1} |
    | ``progress`` | (1,) | nodes over ``max_nodes`` | [0, 1] |

    ## Rewards
    ``-step_penalty`` every step; ``+success_reward`` on the step that first reaches the goal
    region; afterwards, every cost improvement ``(J_before - J_after) / |goal - start|``. The
    sum rewards reaching the goal in few steps and then shortening the path.

    ## Starting State
    ``reset(options={"problem": problem})`` plans the given `Problem`. Without it, a workspace
    is drawn from the env's split (a fixed, seeded pool: `temp_gym.worlds.splits`) and a task
    of the requested difficulty in it, all from the env's own ``np_random``.

    ## Episode End
    * Termination: the goal region is first reached; or, when a target cost is set
      (``target_cost`` argument or ``options["target_cost"]``), when the best cost is at most it.
    * Truncation: the tree has ``max_nodes`` nodes, or it has drawn ``max_samples`` samples
      (fallback ones included; default ``100 * max_nodes``, the planners' sample budget), so
      that an episode of colliding actions ends too (with ``fallback="none"`` a colliding
      action adds no node).
    * A start already in the goal region is solved at reset (``solved`` is 1); the first step
      then terminates the episode, without the success reward, which reaching the goal earns.

    ``info`` carries ``nodes``, ``samples``, ``sampling_failures``, ``collision_checks``,
    ``best_cost`` (world units, inf before a solution), ``success``, ``added``, ``collided``;
    at the end of an episode also ``path``, the best path (K, d) in world units, or None.

    ## Arguments
    ```python
    gymnasium.make("TEMP-2D-v0", difficulty="challenging", max_nodes=2000, split="test")
    ```
    * ``robot``: a registered robot's name (set by the registered id; `temp_gym.worlds.robots`).
    * ``difficulty``: ``any``, ``easy``, ``challenging`` or ``mixed`` (easy or challenging with
      equal chance) for drawn tasks.
    * ``max_nodes``: truncation budget (default: the robot's, 3000 in 2D/3D and 5000 in 7D);
      ``max_samples``: the sample budget (default ``100 * max_nodes``).
      ``step_size``: steering step (world units; default
      `temp_gym.planning.tree.default_step_size`). ``goal_radius``: goal radius of drawn tasks
      (default: the robot's).
    * ``fallback``: ``random`` or ``none``; ``max_fallback_tries``; ``attention_local_fallback``
      (default 0, Algorithm 1).
    * ``encoding_resolution``: cells per axis of the occupancy grid (32 in 2D, 16 in 3D/7D).
    * ``split``: ``train``, ``val``, ``test`` or ``tune`` workspace pool for drawn tasks.
    * ``workspace_family``: the family of those workspaces (`temp_gym.worlds.structured`;
      default ``boxes``, the robot's own generator; 2D and 3D point worlds also draw
      ``corridors``, ``maze``, ``traps``, ``narrow``, ``clutter`` or ``mixed``).
    * ``max_path_length``: L, rows of the ``path`` observation.
    * ``step_penalty``, ``success_reward``, ``target_cost``: see Rewards and Episode End.
    * ``render_mode``: ``rgb_array`` or ``human``.

    ## Version History
    * v0: initial release.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 4}

    def __init__(
        self,
        robot: str,
        *,
        difficulty: str = "any",
        max_nodes: int | None = None,
        max_samples: int | None = None,
        step_size: float | None = None,
        goal_radius: float | None = None,
        fallback: str = "random",
        max_fallback_tries: int = 1000,
        attention_local_fallback: int = 0,
        encoding_resolution: int | None = None,
        split: str = "train",
        workspace_family: str = BOXES,
        max_path_length: int = DEFAULT_MAX_PATH_LENGTH,
        step_penalty: float = 0.01,
        success_reward: float = 1.0,
        target_cost: float | None = None,
        render_mode: str | None = None,
    ) -> None:
        spec = robot_spec(robot)
        if difficulty not in DIFFICULTIES:
            raise ValueError(f"difficulty: expected one of {DIFFICULTIES}, got {difficulty!r}")
        if fallback not in FALLBACKS:
            raise ValueError(f"fallback: expected one of {FALLBACKS}, got {fallback!r}")
        if split not in SPLITS:
            raise ValueError(f"split: expected one of {list(SPLITS)}, got {split!r}")
        check_family(robot, workspace_family, "workspace_family")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode: expected one of {self.metadata['render_modes']}")
        max_nodes = spec.max_nodes if max_nodes is None else max_nodes
        if not _is_integer(max_nodes) or max_nodes < 2:
            raise ValueError(f"max_nodes: expected an integer of at least 2, got {max_nodes!r}")
        if max_samples is not None and (not _is_integer(max_samples) or max_samples < 1):
            raise ValueError(f"max_samples: expected a positive integer, got {max_samples!r}")
        check_path_length(max_path_length)
        if step_size is not None and not _is_positive(step_size):
            raise ValueError(f"step_size: must be positive and finite, got {step_size!r}")
        if goal_radius is not None:
            positive_length(goal_radius, "goal_radius")  # as `Problem` checks it
        if encoding_resolution is not None:
            check_resolution(encoding_resolution, spec.workspace_dim, "encoding_resolution")
        for name, value, most in (
            ("max_nodes", max_nodes, MAX_COUNT),
            ("max_samples", max_samples, MAX_COUNT),
            ("max_fallback_tries", max_fallback_tries, MAX_COUNT),
        ):
            if value is not None and _is_integer(value) and value > most:
                raise ValueError(f"{name}: at most {most} is supported, got {value}")
        _check_target_cost(target_cost, "target_cost")
        if not _is_integer(max_fallback_tries) or max_fallback_tries < 0:
            raise ValueError(
                f"max_fallback_tries: expected a non-negative integer, got {max_fallback_tries!r}"
            )
        for name, value in (("step_penalty", step_penalty), ("success_reward", success_reward)):
            if (
                not isinstance(value, numbers.Real)
                or isinstance(value, bool)
                or not (math.isfinite(value))
            ):
                raise ValueError(f"{name}: expected a finite number, got {value!r}")
        self.robot = robot
        self.robot_spec = spec
        self.difficulty = difficulty
        self.max_nodes = int(max_nodes)
        self.max_samples = 100 * self.max_nodes if max_samples is None else int(max_samples)
        self.step_size = step_size
        self.goal_radius = goal_radius
        self.fallback = fallback
        self.max_fallback_tries = int(max_fallback_tries)
        self.local_fallback = local_fallback_count(attention_local_fallback)
        self.resolution = (
            spec.encoding_resolution if encoding_resolution is None else int(encoding_resolution)
        )
        self.split = split
        self.workspace_family = workspace_family
        self.max_path_length = int(max_path_length)
        self.step_penalty = float(step_penalty)
        self.success_reward = float(success_reward)
        self.default_target_cost = target_cost
        self.render_mode = render_mode

        dim, wdim = spec.dim, spec.workspace_dim
        self.dim = dim
        unit = spaces.Box(-1.0, 1.0, (dim,), np.float32)
        ratio = spaces.Box(0.0, MAX_RATIO, (1,), np.float32)
        fraction = spaces.Box(0.0, 1.0, (1,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (dim,), np.float32)
        self.observation_space = spaces.Dict(
            {
                "occupancy": spaces.Box(0.0, 1.0, (self.resolution,) * wdim, np.float32),
                "start": unit,
                "goal": unit,
                "goal_radius": ratio,
                "path": spaces.Box(-1.0, 1.0, (self.max_path_length, dim), np.float32),
                "path_length": spaces.Box(1, self.max_path_length, (1,), np.int64),
                "best_cost": ratio,
                "solved": fraction,
                "progress": fraction,
            }
        )
        self.problem: Problem | None = None
        self.tree: Tree | None = None
        self._occupancy: np.ndarray | None = None
        self._occupancy_key: Workspace | None = None
        self._renderer = None
        self._figure = None

    # ------------------------------------------------------------------ tasks
    def _draw_problem(self) -> Problem:
        rng = self.np_random
        difficulty = self.difficulty
        if difficulty == "mixed":
            difficulty = "easy" if rng.random() < 0.5 else "challenging"
        last_error: RuntimeError | None = None
        for _ in range(20):
            index = int(rng.integers(SPLITS[self.split]))
            workspace = split_workspace(self.robot, self.split, index, self.workspace_family)
            try:
                return self.robot_spec.generate_task(workspace, rng, difficulty, self.goal_radius)
            except RuntimeError as error:  # no task of that difficulty here: next workspace
                last_error = error
        raise RuntimeError(f"no {difficulty} task found in 20 {self.split} workspaces") from (
            last_error
        )

    def _encoding(self, problem: Problem) -> np.ndarray:
        if problem.workspace != self._occupancy_key:
            self._occupancy = occupancy_grid(problem.workspace, self.resolution)
            self._occupancy_key = problem.workspace
        return self._occupancy

    # ------------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start a new planning query (see Starting State)."""
        if isinstance(seed, np.integer):  # as plan() takes them; gymnasium wants an int
            seed = int(seed)
        super().reset(seed=seed)
        if options is not None and not isinstance(options, dict):
            raise ValueError(
                f"options: expected a dict such as {{'problem': problem}}, got "
                f"{type(options).__name__}"
            )
        options = options or {}
        unknown = set(options) - {"problem", "target_cost"}
        if unknown:
            raise ValueError(f"options: unknown keys {sorted(unknown)}")
        problem = options.get("problem")
        if problem is None:
            problem = self._draw_problem()
        elif not isinstance(problem, Problem):
            raise ValueError(f"options['problem']: expected a temp_gym.Problem, got {problem!r}")
        elif problem.robot != self.robot:
            raise ValueError(f"options['problem']: robot {problem.robot} in a {self.robot} env")
        target = options.get("target_cost", self.default_target_cost)
        _check_target_cost(target, "options['target_cost']")
        self.target_cost = -math.inf if target is None else float(target)
        self.problem = problem
        step = self.step_size if self.step_size is not None else default_step_size(problem)
        self.tree = Tree(problem, step_size=step)
        self._fallback_sampler = UniformSampler(problem.bounds)
        self._observer = TreeObserver(
            problem, self._encoding(problem), self.max_path_length, self.max_nodes
        )
        self._solved_before = self.tree.best_node >= 0
        if self.render_mode == "human":  # as after every step: Gymnasium's convention
            self.render()
        return self._observation(), self._info(added=False, collided=False, final=False)

    def step(self, action: np.ndarray):
        """Extend the tree once towards the (denormalized) action; see the class docstring."""
        tree = self.tree
        if tree is None:
            raise RuntimeError("step() called before reset()")
        best_before = tree.best_cost
        # The tree clips and denormalizes the action; a bad one raises ValueError untouched.
        if self.fallback == "random":
            result = tree.extend_with_fallback(
                action,
                self._fallback_sampler,
                self.np_random,
                self.max_fallback_tries,
                normalized=True,
                local_tries=self.local_fallback,
            )
        else:
            result = tree.extend(action, normalized=True)
        reward = -self.step_penalty
        solved = tree.best_node >= 0
        if solved and not self._solved_before:
            reward += self.success_reward
        elif solved and tree.best_cost < best_before:
            reward += (best_before - tree.best_cost) / self._observer.distance
        self._solved_before = solved
        if self.target_cost > -math.inf:  # anytime refinement down to a target cost
            terminated = solved and tree.best_cost <= self.target_cost
        else:
            terminated = solved
        truncated = not terminated and (
            tree.num_nodes >= self.max_nodes or tree.samples >= self.max_samples
        )
        observation = self._observer.observe(tree)
        info = self._info(result.node >= 0, result.collided, terminated or truncated)
        if self.render_mode == "human":
            self.render()
        return observation, float(reward), bool(terminated), bool(truncated), info

    def _observation(self) -> dict[str, np.ndarray]:
        return self._observer.observe(self.tree)

    def _info(self, added: bool, collided: bool, final: bool) -> dict[str, Any]:
        tree = self.tree
        info = {
            "nodes": tree.num_nodes,
            "samples": tree.samples,
            "sampling_failures": tree.sampling_failures,
            "collision_checks": tree.collision_checks,
            "best_cost": tree.best_cost,
            "success": tree.best_node >= 0,
            "added": added,
            "collided": collided,
        }
        if final:
            info["path"] = tree.best_path()
        return info

    # ------------------------------------------------------------------ rendering
    def render(self) -> np.ndarray | None:
        """Draw the tree, path, start and goal (2D/3D), or the arm along its path (7D)."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; nothing drawn")
            return None
        if self.tree is None:
            raise RuntimeError("render() called before reset()")
        image = self._render_image()
        if self.render_mode == "rgb_array":
            return image
        self._show(image)
        return None

    def _render_image(self) -> np.ndarray:
        tree = self.tree
        if self._renderer is None:
            self._renderer = self.robot_spec.make_renderer()
        # A solution, or else the path so far (drawn and titled as such).
        solution = tree.best_path()
        return self._renderer.draw_tree(
            self.problem,
            tree.positions[: tree.num_nodes],
            tree.parents,
            tree.num_nodes,
            path=solution,
            path_so_far=None if solution is not None else tree.path_so_far(),
        )

    def _show(self, image: np.ndarray) -> None:
        import matplotlib.pyplot as plt

        if self._figure is None:
            self._figure, axes = plt.subplots()
            axes.set_axis_off()
            self._artist = axes.imshow(image)
        else:
            self._artist.set_data(image)
        plt.pause(1.0 / self.metadata["render_fps"])

    def __getstate__(self) -> dict[str, Any]:
        """The env for `copy.deepcopy` and pickle, without its renderer and figure.

        A renderer holds a connection (the iiwa's pybullet client) that a copy cannot share:
        closing the copy would close the original's, and an unpickled id names no server. A
        copy makes its own on its first `render`.
        """
        state = self.__dict__.copy()
        state["_renderer"] = None
        state["_figure"] = None
        return state

    def close(self) -> None:
        """Release the renderer's pybullet client and any window; safe to call twice."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._figure is not None:
            import matplotlib.pyplot as plt

            plt.close(self._figure)
            self._figure = None
        super().close()
