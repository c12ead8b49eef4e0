"""The TEMP planner: attention-based planning (the paper's Algorithm 1), then classical planning.

**Attention-based planning (AP)**, for at most ``attention_nodes`` nodes
(`temp_gym.planning.attention`):

1. the policy (the MPT) proposes ``x_sample`` from the observation of the tree: environment,
   start, goal and the path so far (`temp_gym.planning.observation.TreeObserver`); with
   probability ``goal_bias`` (default 0.05, the goal bias RRT* and Informed RRT* get too) the
   goal is the sample instead;
2. nearest node and steer by the step size;
3. while that edge collides, a uniform random sample replaces it (each failure is counted);
4. find-near and choose-parent;
5. append and rewire (`Tree.extend_with_fallback` does 2-5 on the shared core);
6. the path so far becomes the root path of the new node (with ``attention_follow_fallback``
   below 1, a fallback node that got no closer to the goal only sometimes becomes it);
7. stop as soon as a node lies in the goal region.

Our additions to Algorithm 1, each with a setting that turns it off: the goal bias
(``goal_bias=0``); chunked proposals, when the policy's MPT predicts several nodes per call
(used in turn until one collides and a fallback node replaces it; then the MPT is called
again, unless ``attention_keep_chunk=True``, which goes on with the chunk: faster to a first
solution, costlier paths); and the stall rule
(``attention_patience=0``): when the tree's closest approach to the goal has not improved for
``attention_patience`` nodes, the policy has lost its way and classical planning takes over
with the budget left, so TEMP degrades towards Informed RRT* instead of spending a whole
budget in a trap. A policy may wait longer once the tree is near the goal
(``attention_near_goal_factor``; the shipped 3D policy does). A policy may also go on from
its own last node instead of from a random fallback node that got no closer to the goal
(``attention_follow_fallback`` below 1, `temp_gym.planning.attention`; no shipped policy
does). After a stall, classical planning and the attention phase take turns until the first
solution (``attention_resume``, default `temp_gym.planning.attention.RESUME_AFTER`; 0: classical
planning keeps the rest of the budget): Informed RRT* adds ``attention_resume`` stall patiences
of nodes, then the phase resumes from the newest node with the same stop rules; with
``attention_resume_growth`` above 1 each later classical turn is that many times longer, so a
policy that keeps stalling hands the search over to Informed RRT* by degrees. The phase runs
compiled (no Python per node) for a `TEMPPolicy` on the CPU and the built-in checkers.

On the goal bias: A learned sampler imitates expert paths
whose last node lies anywhere in the goal region, and its predictions near the goal average
out short of a small region: on 30 validation tasks the 3D policy ended 0.8 world units from
a goal of radius 0.5 and its AP solved 40% of them within 1000 nodes; sampling the goal 5% of
the time, exactly as the baselines do, made it 100% (2D: the median AP nodes fell from 56 to
37). ``goal_bias=0`` gives Algorithm 1 unchanged.

The AP phase's time, nodes and cost are what the paper reports for TEMP; `PlanResult` keeps
them in ``attention`` (``solved``, ``nodes``, ``time``, ``cost``, ``samples``,
``policy_samples``, ``sampling_failures``): the first phase's, before any stall, plus
``resumes``, the number of resumed phases.

**Classical planning (CP)** then continues the same tree with informed sampling (Informed
RRT*) until ``max_nodes``, ``time_limit`` or ``target_cost``, for asymptotic optimality; with
``stop_at_first`` it is skipped. If AP used up ``attention_nodes`` without reaching the goal, CP
carries on from the tree AP built: so TEMP stays probabilistically complete whatever the
policy proposes.

**The goal tree** (our addition; ``goal_tree=False`` turns it off): when AP ends without a
solution, CP also grows a tree rooted at the goal, in turns with the planner's, until a free
straight motion links the two; the goal tree's branch is then grafted onto the planner's tree
and Informed RRT* improves the joined path (`temp_gym.planning.goal_tree`). The tasks on which
a policy stalls are mostly those whose goal lies in a pocket that a tree from the start enters
rarely and a tree from the goal leaves easily. Its nodes count against ``max_nodes``.

**The attention phase from the goal** (our addition; ``attention_from_goal=False`` turns it
off): after a stall, the policy grows the goal tree first, planning the swapped problem with
the same stop rules, its new nodes tried against the planner's tree every few nodes
(`temp_gym.planning.goal_tree.GoalTree.grow_by_attention`); a policy that stalled walking into
a pocket mostly walks out of it. If that stalls too, the policy takes up to
``attention_rounds`` more rounds, a resumed phase on each tree in turn (default
`temp_gym.planning.goal_tree.ATTENTION_ROUNDS`; 0: none), before RRT*'s samples grow the two
trees. ``result.attention`` then has ``from_goal_stop``, ``from_goal_solved`` (the phase from
the goal joined the trees), ``rounds`` (the rounds begun), ``rounds_solved`` (a round solved
the problem) and ``from_goal_nodes`` (the goal tree's nodes when the policy stopped growing
it). `attention_solved_both_ways` reads them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator

import numpy as np

from temp_gym import hooks
from temp_gym.planning.anytime import finished, grow_anytime
from temp_gym.planning.attention import (
    RESUME_AFTER,
    AttentionLimits,
    default_patience,
    near_goal_limits,
    resume_nodes,
    run_attention_phase,
)
from temp_gym.planning.goal_tree import ATTENTION_ROUNDS, GoalTree
from temp_gym.planning.policy import SamplingPolicy
from temp_gym.planning.result import AnytimeLog, PlanResult, tree_plan_result
from temp_gym.planning.temp_settings import TEMPSettings, resolve
from temp_gym.planning.tree import Tree
from temp_gym.problem import Problem

DEFAULTS = {
    "attention_near_goal_factor": 1.0,
    "attention_local_fallback": 0,
    "attention_uniform": 0.0,
    "attention_follow_fallback": 1.0,
    "attention_resume": RESUME_AFTER,
    "attention_resume_growth": 1.0,
    "attention_rounds": ATTENTION_ROUNDS,
}
"""The planner's value of each setting that neither its caller nor the policy gives
(`temp_gym.planning.temp_settings.resolve`); the budget n and the patience follow the problem."""


def set_default_policy(loader: Callable[[str], SamplingPolicy] | None) -> None:
    """Set what the ``temp`` planner uses when ``plan`` is given no policy.

    ``loader(robot)`` returns a `temp_gym.planning.policy.SamplingPolicy` for a robot name.
    Importing `temp_gym` sets the shipped policies (`temp_gym.load_policy`, loaded on first
    use): the planning layer imports no model code, so the loader is handed in from above
    (kept in `temp_gym.hooks`, which importing `temp_gym` can set without this module).
    """
    hooks.default_policy_loader = loader


def default_policy(robot: str) -> SamplingPolicy:
    """The policy the ``temp`` planner uses for ``robot`` when given none."""
    loader = hooks.default_policy_loader
    if loader is None:
        raise ValueError(
            "policy: the temp planner has no default policy (set_default_policy(None) was "
            "called); pass policy=..."
        )
    return loader(robot)


def temp(problem: Problem, settings: TEMPSettings) -> PlanResult:
    """Plan with a sampling policy (AP, Algorithm 1), then Informed RRT* (CP).

    Each setting left None takes the policy's own, else the planner's default
    (`temp_gym.planning.temp_settings.resolve`).
    """
    if not isinstance(settings, TEMPSettings):  # common settings alone: TEMP's defaults
        settings = TEMPSettings(**vars(settings.common()))
    policy = settings.policy
    if policy is None:
        policy = default_policy(problem.robot)
    log = AnytimeLog()
    rng = np.random.default_rng(settings.seed)
    tree = Tree(problem, step_size=settings.step_size)
    policy.reset(problem, seed=settings.seed)

    def setting(name: str):  # the caller's, else the policy's, else the planner's `DEFAULTS`
        return resolve(settings, policy, name, DEFAULTS[name])

    # The budget n (all of max_nodes by default) and the patience (its default follows the
    # start-goal distance) are resolved like every other setting.
    attention_nodes = resolve(settings, policy, "attention_nodes", settings.max_nodes)
    patience = resolve(settings, policy, "attention_patience", None)
    if patience is None:
        patience = default_patience(problem, tree.step_size)
    factor = setting("attention_near_goal_factor")
    near_sq, near_patience = (
        near_goal_limits(problem, patience, factor) if factor > 1 else (-1.0, 0)
    )

    # ---- attention-based planning (Algorithm 1)
    local_tries = setting("attention_local_fallback")
    limits = AttentionLimits(
        attention_nodes=attention_nodes,
        max_nodes=settings.max_nodes,
        max_samples=settings.sample_limit,
        patience=patience,
        near_sq=near_sq,
        near_patience=near_patience,
        deadline=settings.deadline(log.started),
        local_tries=local_tries,
    )
    uniform = setting("attention_uniform")
    follow = setting("attention_follow_fallback")
    resume = setting("attention_resume")
    growth = setting("attention_resume_growth")
    rounds = setting("attention_rounds")
    keep_chunk = bool(settings.attention_keep_chunk)  # None: False, the rule shipped policies use
    outcome = run_attention_phase(
        tree, policy, rng, settings.goal_bias, limits, uniform=uniform, follow_fallback=follow,
        keep_chunk=keep_chunk,
    )  # fmt: skip
    attention = {
        "solved": tree.best_node >= 0,
        "nodes": tree.num_nodes,
        "time": log.elapsed(),
        "cost": tree.best_cost,
        "samples": tree.samples,
        "policy_samples": outcome.policy_samples,
        "policy_calls": outcome.policy_calls,
        "sampling_failures": tree.sampling_failures,
        "stop": outcome.stop,
        "compiled": outcome.compiled,
        "resumes": 0,
    }
    if attention["solved"]:
        log.record(tree.num_nodes, attention["time"], tree.best_cost)

    # ---- unsolved: a tree from the goal grows beside the planner's until they join
    goal_tree = None
    if (
        settings.goal_tree is not False
        and tree.best_node < 0
        and not finished(tree, settings, limits.deadline)
    ):
        goal_tree = GoalTree(tree)

    # ---- after a stall: the policy grows the goal tree, from the goal towards the start
    if (
        goal_tree is not None
        and outcome.stop == "stalled"
        and settings.attention_from_goal is not False
    ):
        from_goal_stop, attention["rounds"] = goal_tree.grow_from_goal_and_in_rounds(
            tree, policy, rng, log, settings.goal_bias, limits, rounds, uniform=uniform,
            follow_fallback=follow, keep_chunk=keep_chunk,
        )  # fmt: skip
        attention["from_goal_stop"] = from_goal_stop
        attention["from_goal_solved"] = from_goal_stop == "joined"
        attention["from_goal_nodes"] = goal_tree.tree.num_nodes
        attention["rounds_solved"] = attention["rounds"] > 0 and tree.best_node >= 0

    # ---- after a stall: classical planning and the resumed attention phase in turns
    if outcome.stop == "stalled" and resume > 0 and tree.best_node < 0:
        attention["resumes"] = _resume_until_solved(
            tree, policy, rng, log, settings, limits, resume_nodes(patience, resume), growth,
            uniform, follow, keep_chunk, goal_tree,
        )  # fmt: skip

    # ---- classical planning: Informed RRT* on the same tree
    if goal_tree is not None and tree.best_node < 0:
        goal_tree.grow_until_joined(tree, settings, rng, log, settings.max_nodes)
    if goal_tree is not None:
        attention["goal_tree_nodes"] = goal_tree.tree.num_nodes
        attention["goal_tree_joined"] = goal_tree.joined
    grow_anytime(tree, _less_budget(settings, log.extra_nodes), rng, log, informed=True)
    return tree_plan_result(problem, tree, "temp", settings, log, attention=attention)


def attention_solved_both_ways(attention: dict) -> bool:
    """Whether the attention phase solved the problem before any of Informed RRT*'s nodes.

    From the start, or after a stall from the goal (`GoalTree.grow_by_attention`) or in a
    later round of the two (`GoalTree.grow_in_rounds`); ``attention`` is a TEMP result's.
    """
    return bool(
        attention["solved"]
        or attention.get("from_goal_solved", False)
        or attention.get("rounds_solved", False)
    )


def _less_budget(settings: TEMPSettings, nodes: int) -> TEMPSettings:
    """``settings`` with ``nodes`` fewer tree nodes (grown elsewhere: the goal tree's)."""
    if nodes == 0:
        return settings
    return settings.derived(max_nodes=int(max(settings.max_nodes - nodes, 1)))


def _resume_until_solved(
    tree: Tree,
    policy: SamplingPolicy,
    rng: np.random.Generator,
    log: AnytimeLog,
    settings: TEMPSettings,
    limits: AttentionLimits,
    classical_nodes: int,
    growth: float,
    uniform: float,
    follow: float,
    keep_chunk: bool,
    goal_tree: GoalTree | None = None,
) -> int:
    """After a stall: ``classical_nodes`` of Informed RRT*, then the attention phase again.

    The resumed phase starts from the newest node, a classical one (so the policy reads a
    path it has not read before) and counts progress from the tree's closest approach; it
    ends by the same stop rules. Turns go on while a phase stalls, until the first solution
    or the node, sample or time budget; each classical turn is ``growth`` times the one
    before (`resume_turns`). Returns the number of resumed phases.
    """
    resumes = 0
    turns = resume_turns(classical_nodes, growth, settings.max_nodes)
    while True:
        extra = 0 if goal_tree is None else goal_tree.extra_nodes
        turn_end = min(settings.max_nodes, tree.num_nodes + extra + next(turns))
        if goal_tree is None:
            classical = settings.derived(max_nodes=int(turn_end), stop_at_first=True)
            grow_anytime(tree, classical, rng, log, informed=True)
        else:
            goal_tree.grow_until_joined(tree, settings, rng, log, turn_end)
            extra = goal_tree.extra_nodes
        if tree.best_node >= 0 or tree.num_nodes + extra >= settings.max_nodes:
            return resumes
        goal_samples = 0 if goal_tree is None else goal_tree.tree.samples
        if tree.samples + goal_samples >= settings.sample_limit:
            return resumes
        resumed_limits = dataclasses.replace(
            limits,
            max_nodes=limits.max_nodes - extra,
            max_samples=limits.max_samples - goal_samples,
        )
        outcome = run_attention_phase(
            tree, policy, rng, settings.goal_bias, resumed_limits, uniform=uniform,
            follow_fallback=follow, resumed=True, keep_chunk=keep_chunk,
        )  # fmt: skip
        resumes += 1
        if tree.best_node >= 0:
            log.record_tree(tree)
        if outcome.stop != "stalled":
            return resumes


def resume_turns(first: int, growth: float, largest: int) -> Iterator[int]:
    """Classical nodes of each turn between resumed phases: ``first``, then ``growth`` times more.

    Each turn is ``first * growth ** k`` rounded, at least 1 and at most ``largest`` (the
    planner's node budget, which ends the turns anyway); with ``growth`` 1 they are all
    ``first``.
    """
    size = float(first)
    while True:
        yield int(min(max(round(size), 1), largest))
        size = min(size * growth, float(largest))
