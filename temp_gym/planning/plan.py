"""`plan()`: run a registered planner on a `Problem`.

Example:
    >>> result = plan(problem, planner="informed_rrt_star", seed=1, max_nodes=2000)
    >>> result.success, result.path[0].tolist() == problem.start.tolist()
    (True, True)
"""

from __future__ import annotations

from collections.abc import Callable

from temp_gym.planning.planners import informed_rrt_star, rrt_star
from temp_gym.planning.result import PlanResult, PlanSettings
from temp_gym.planning.temp_planner import temp
from temp_gym.planning.warmup import warm_up
from temp_gym.problem import Problem

PlannerFunction = Callable[[Problem, PlanSettings], PlanResult]

PLANNERS: dict[str, PlannerFunction] = {}
"""Planner name -> function; `plan` dispatches through it."""


def register_planner(name: str, function: PlannerFunction, overwrite: bool = False) -> None:
    """Make ``function`` available as ``plan(..., planner=name)``."""
    if not overwrite and name in PLANNERS:
        raise ValueError(f"planner: {name!r} is already registered")
    PLANNERS[name] = function


def _ompl_planner(name: str) -> PlannerFunction:
    def run(problem: Problem, settings: PlanSettings) -> PlanResult:
        from temp_gym.planning.ompl_planners import solve_with_ompl

        return solve_with_ompl(problem, settings, name)

    run.__name__ = name
    run.__doc__ = f"OMPL's {name.removeprefix('ompl_')} (needs `pip install temp-gym[ompl]`)."
    return run


register_planner("rrt_star", rrt_star)
register_planner("informed_rrt_star", informed_rrt_star)
register_planner("temp", temp)
# OMPL is imported only when one of these runs; without it they raise a clear ImportError.
register_planner("ompl_rrt_star", _ompl_planner("ompl_rrt_star"))
register_planner("ompl_informed_rrt_star", _ompl_planner("ompl_informed_rrt_star"))


def plan(
    problem: Problem,
    planner: str = "temp",
    seed: int = 0,
    max_nodes: int = 5000,
    time_limit: float | None = None,
    stop_at_first: bool = False,
    step_size: float | None = None,
    goal_bias: float = 0.05,
    target_cost: float | None = None,
    max_samples: int | None = None,
    policy: object = None,
    attention_nodes: int | None = None,
    attention_patience: int | None = None,
    attention_uniform: float | None = None,
    attention_near_goal_factor: float | None = None,
    attention_follow_fallback: float | None = None,
    attention_resume: float | None = None,
    attention_resume_growth: float | None = None,
    attention_keep_chunk: bool | None = None,
    goal_tree: bool | None = None,
    attention_from_goal: bool | None = None,
    attention_rounds: int | None = None,
    attention_local_fallback: int | None = None,
) -> PlanResult:
    """Solve ``problem`` with a registered planner and return a certified `PlanResult`.

    The run stops at the first of: ``max_nodes`` tree nodes, ``max_samples`` samples,
    ``time_limit`` seconds, the first solution (``stop_at_first``), a solution costing at
    most ``target_cost``. A returned path is certified by the exact collision checker, starts
    at ``problem.start`` and ends inside the goal region. The same seed gives the same result
    (wall times aside) unless the time limit is what stopped the run; OMPL's planners are the
    exception: OMPL takes one seed per process, at its first run, and later runs continue its
    stream (`temp_gym.planning.ompl_planners`), so only the same sequence of OMPL runs in a
    fresh process repeats them.

    What the time limit and the reported times cover: the planner's run, from building its
    tree (collision checker, per-workspace set-up, TEMP's workspace encoding) to the end of
    the search. Not covered: the first call in a process for each robot and planner first
    plans the same problem briefly, untimed, to compile the numba kernels
    (`temp_gym.planning.warmup`; seconds with an empty numba cache, milliseconds otherwise);
    loading a shipped policy; and certifying the returned path, which ``wall_time`` includes
    but the limit does not stop.

    Args:
        problem: The query.
        planner: A key of `PLANNERS`: ``temp`` (the default: TEMP, with the policy shipped
            for the robot unless ``policy`` is given), ``rrt_star``, ``informed_rrt_star``,
            ``ompl_rrt_star``, ``ompl_informed_rrt_star``.
        seed: Seed of the planner's random generator.
        max_nodes: Tree-size budget, root included (1 to 2**53).
        time_limit: Seconds of wall time for the search, or None for no limit (see above).
        stop_at_first: Stop at the first solution.
        step_size: Steering step; None picks 5% of the largest bound side for point robots
            (1.0 in ``[0, 20]^d``) and 0.5 rad for the iiwa.
        goal_bias: Probability of sampling the goal, in ``[0, 1]``.
        target_cost: Stop once a solution costs at most this.
        max_samples: Sample budget; None means ``100 * max_nodes``.
        policy: ``temp`` only: a `temp_gym.planning.policy.SamplingPolicy` (for instance
            `temp_gym.load_policy("TEMP-2D-v0")`); None loads the shipped policy for the robot.
        attention_nodes: ``temp`` only: tree-node budget of attention-based planning before
            classical planning takes over, the n of Algorithm 1 (None: the policy's own
            ``attention_nodes``, which shipped policies carry; else all of ``max_nodes``).
        attention_patience: ``temp`` only: attention-phase nodes in a row without getting
            closer to the goal before classical planning takes over (None: proportional to
            the start-goal distance, `temp_gym.planning.attention.default_patience`; 0: never,
            the paper's Algorithm 1).
        attention_uniform: ``temp`` only: probability, in the attention phase, of a uniform
            sample instead of the policy's (None: the policy's own setting, else 0).
        attention_near_goal_factor: ``temp`` only: how many times ``attention_patience`` the
            attention phase waits once the tree has come within 40% of the start-goal
            distance of the goal (None: the policy's own setting, else 1; the shipped 3D
            policy waits 5 times longer there).
        attention_follow_fallback: ``temp`` only: probability, in ``[0, 1]``, that the policy
            goes on from a node the uniform fallback added (its proposal collided) when that
            node brought the tree no closer to the goal; otherwise it goes on from the path
            it read before (None: the policy's own setting, else 1, Algorithm 1's rule).
        attention_resume: ``temp`` only: after the attention phase stalls, classical planning
            adds this many stall patiences of nodes, then the attention phase resumes from
            the newest node, in turns until the first solution (None: the policy's own
            setting, else 1; 0: never, classical planning keeps the rest of the budget).
        attention_resume_growth: ``temp`` only: each classical turn between resumed attention
            phases is this many times longer than the one before, at least 1 (None: the
            policy's own setting, else 1: equal turns). Above 1, a policy that keeps stalling
            hands the search over to Informed RRT* by degrees.
        attention_keep_chunk: ``temp`` only, for a policy that proposes a chunk of samples per
            call: after a proposal collided and a uniform fallback sample replaced it, go on
            with the chunk's next proposal (True: fewer nodes to a first solution, costlier
            paths) or call the policy again (False; None means False).
        goal_tree: ``temp`` only: when the attention phase ends without a solution, a second
            tree grows from the goal beside the planner's until the two meet
            (`temp_gym.planning.goal_tree`; its nodes count against ``max_nodes``). None
            means True; False leaves classical planning to Informed RRT* alone.
        attention_from_goal: ``temp`` only: when the attention phase stalls, the policy
            grows the goal tree first (the attention phase from the goal, until the trees
            meet or it stalls too). None means True unless ``goal_tree`` is False.
        attention_rounds: ``temp`` only: when the phases from the start and from the goal
            both stalled, up to this many more rounds of the two, a resumed attention phase
            on each tree in turn, before Informed RRT*'s samples grow them (None:
            `temp_gym.planning.goal_tree.ATTENTION_ROUNDS`, 1; 0: none). Needs
            ``attention_from_goal``.
        attention_local_fallback: ``temp`` only: when a policy's proposal collides, this
            many replacements are drawn near it (a small box around it) before uniform ones
            (None: the policy's own setting, else 0, Algorithm 1).

    Raises:
        ValueError: For an unknown planner or an invalid argument (`PlanSettings` checks
            the arguments).
    """
    if not isinstance(problem, Problem):
        raise ValueError(f"problem: expected a Problem, got {type(problem).__name__}")
    if not isinstance(planner, str) or planner not in PLANNERS:
        raise ValueError(
            f"planner: unknown planner {planner!r}; expected one of {sorted(PLANNERS)}"
        )
    settings = PlanSettings(
        seed=seed, max_nodes=max_nodes, time_limit=time_limit, stop_at_first=stop_at_first,
        step_size=step_size, goal_bias=goal_bias, target_cost=target_cost,
        max_samples=max_samples, policy=policy, attention_nodes=attention_nodes,
        attention_patience=attention_patience, attention_uniform=attention_uniform,
        attention_near_goal_factor=attention_near_goal_factor,
        attention_follow_fallback=attention_follow_fallback,
        attention_resume=attention_resume, attention_resume_growth=attention_resume_growth,
        attention_keep_chunk=attention_keep_chunk,
        goal_tree=goal_tree, attention_from_goal=attention_from_goal,
        attention_rounds=attention_rounds, attention_local_fallback=attention_local_fallback,
    )  # fmt: skip
    if settings.policy is not None and planner != "temp":
        raise ValueError(f"policy: only the temp planner takes a policy, not {planner!r}")
    warm_up(problem, planner, settings, PLANNERS)  # compile before the clock starts
    return PLANNERS[planner](problem, settings)
