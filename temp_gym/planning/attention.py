"""TEMP's attention-based planning phase (AP): the paper's Algorithm 1 on the shared tree.

Each iteration:

1. with probability ``goal_bias`` the goal is the sample (the baselines' goal bias: a learned
   sampler alone stops short of small goal regions, see `temp_gym.planning.temp_planner`);
   otherwise, with probability ``uniform``, a uniform sample (exploration the policy does not
   direct; 0 by default);
2. otherwise the policy proposes the sample from the path so far. A chunked policy
   (`temp_gym.models.mpt.MPT` with ``chunk = k``) proposes k samples per call, used in turn
   while each one extends the tree at its first try: a fallback, a failed extension or a
   goal-bias step drops the rest, since they continued a path the tree did not take;
3. `Tree.extend_with_fallback`: nearest and steer; while the edge collides, uniform random
   samples replace the proposal (Algorithm 1, lines 5-10; with ``local_tries`` of the limits,
   `AttentionLimits`, the first that many replacements of a policy's proposal are drawn from
   a small box around it instead); choose-parent, insert, rewire;
4. the path so far the policy reads next (Algorithm 1's UpdatePath) is the root path of the
   new node; but when that node is a fallback sample that brought the tree no closer to the
   goal, only with probability ``follow_fallback`` (1 by default, as in Algorithm 1; a draw
   of the planner's generator when strictly between 0 and 1): otherwise the policy goes on
   from the path it read before, instead of from wherever the uniform fallback landed;
5. stop at the first solution, at the attention budget n, or when the phase stalls: the
   tree's closest approach to the goal has not improved for ``patience`` nodes in a row, or
   ``near_patience`` once that approach is within ``sqrt(near_sq)`` of the goal
   (``patience = 0`` never stalls: Algorithm 1 as written).

Going on from a fallback node only sometimes (``follow_fallback`` below 1) is for policies
that a random anchor throws off: after a fallback, Algorithm 1 makes the policy read the path
to wherever the uniform sample landed, which often is not where it was heading. It pays in
nodes for some policies (with their output noise, a repeated path still gives new proposals)
and not for others (without noise the same path gives the same proposals again), so it is a
per-policy setting, chosen on validation tasks.

The stall rule is how TEMP degrades gracefully: a policy that keeps steering into a trap it
has not seen in training hands the rest of the budget to classical planning (Informed RRT*
on the same tree) instead of spending it all. `default_patience` sets it from the problem;
`near_goal_limits` can make it longer once the tree has come near the goal, where a stall is
more often the last stretch around an obstacle, which the policy finds given time, than a
wrong turn (a per-policy setting: it pays for some policies and not for others).

A stall need not end the policy's part: the ``temp`` planner (`temp_gym.planning.temp_planner`)
lets classical planning add `resume_nodes` nodes and then resumes the phase on the grown tree
(``resumed=True``): the policy reads the root path of the newest node, a classical one, so it
sets out from somewhere it has not been, and progress counts from the tree's closest approach.
A policy that stalls from one place often finds the way from another; classical planning
alone keeps the probabilistic completeness either way.

Two implementations grow the same tree from the same seed (tested node for node): the
compiled loop (`temp_gym.planning._compiled_attention`), used when the policy offers a
compiled proposer (`TEMPPolicy.compiled_proposer`: the numba MPT) and the checker a compiled
path (`temp_gym.worlds.collision.compiled`); and a Python loop for any other policy or
checker, which also serves as the reference.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from temp_gym.planning import _compiled_attention as compiled
from temp_gym.planning._compiled_tree import FALLBACK_BATCH, slice_length, squared_distance
from temp_gym.planning._generator import address
from temp_gym.planning.observation import TreeObserver
from temp_gym.planning.policy import SamplingPolicy, fast_path, observation_settings
from temp_gym.planning.samplers import UniformSampler
from temp_gym.planning.settings import MAX_COUNT
from temp_gym.planning.tree import Tree
from temp_gym.problem import Problem
from temp_gym.worlds.collision.compiled import compiled_context_of
from temp_gym.worlds.encoding import occupancy_grid
from temp_gym.worlds.robots import robot_spec

MAX_FALLBACK_TRIES = 1000
"""Most random replacements per proposal, so that a walled-in tree cannot loop forever."""
PATIENCE_PER_STEP = 10.0
"""`default_patience`: nodes without progress allowed per steering step of start-goal distance."""
MIN_PATIENCE = 200
"""`default_patience` never allows fewer nodes than this."""
RESUME_AFTER = 1.0
"""The ``temp`` planner's default ``attention_resume``: after a stall, classical planning adds
one stall patience of nodes before the attention phase resumes."""
NEAR_GOAL_SHARE = 0.4
"""`near_goal_limits`: the tree is near the goal once its closest approach is within this share
of the start-goal distance."""
STOPS = ("solved", "attention_budget", "budget", "stalled", "time", "joined")
"""Why the phase ended: a solution; the attention budget n; the planner's node or sample
budget; no progress for ``patience`` nodes; the time limit; the caller's ``joined`` check
(`run_attention_phase`: the phase grew a second tree that now meets the planner's)."""


def default_patience(problem: Problem, step_size: float) -> int:
    """The stall patience for ``problem``: proportional to its start-goal distance in steps.

    A policy on course reaches the goal in about ``distance / step_size`` nodes, and most of
    its nodes bring the tree closer; ``PATIENCE_PER_STEP`` times that many nodes in a row
    without a closer node means it has lost its way.
    """
    offset = problem.goal - problem.start
    steps = math.sqrt(float(offset.dot(offset))) / step_size  # np.linalg.norm's formula
    return max(MIN_PATIENCE, _ceil_count(PATIENCE_PER_STEP * steps))


def _ceil_count(nodes: float) -> int:
    """``ceil(nodes)`` held to the planner's largest node budget (`MAX_COUNT`).

    A patience no tree can reach (a step size far below the start-goal distance, a huge
    factor) then means "never stalls" instead of an overflow.
    """
    return MAX_COUNT if not nodes < MAX_COUNT else math.ceil(nodes)


def resume_nodes(patience: int, factor: float) -> int:
    """Classical nodes between a stall and the resumed attention phase: ``factor`` patiences.

    At least one node, held to the planner's largest node budget (`MAX_COUNT`).
    """
    return max(1, _ceil_count(factor * patience))


def near_goal_limits(problem: Problem, patience: int, factor: float) -> tuple[float, int]:
    """``(near_sq, near_patience)``: the stall patience is ``factor`` times longer near the goal.

    Near the goal means a closest approach within `NEAR_GOAL_SHARE` of the start-goal distance
    (``near_sq`` is that distance squared). Factor 1 leaves the patience as it is everywhere.
    """
    offset = problem.goal - problem.start
    near_sq = NEAR_GOAL_SHARE * NEAR_GOAL_SHARE * float(offset.dot(offset))
    return near_sq, _ceil_count(factor * patience)


@dataclass(frozen=True)
class AttentionLimits:
    """The budgets of one attention phase."""

    attention_nodes: int
    """n: the phase ends once the tree has this many nodes."""
    max_nodes: int
    """The planner's node budget."""
    max_samples: int
    """The planner's sample budget."""
    patience: int
    """Nodes in a row without a closer approach to the goal before the phase stalls (0: never)."""
    near_sq: float = -1.0
    """Squared distance to the goal within which the closest approach is near it (negative:
    never, the default)."""
    near_patience: int = 0
    """The patience once the closest approach is near the goal (with ``patience = 0`` the phase
    never stalls anywhere)."""
    deadline: float = math.inf
    """``time.perf_counter()`` value at which the phase stops."""
    local_tries: int = 0
    """Replacements of a colliding proposal drawn near it before uniform ones (0: Algorithm 1;
    `Tree.extend_with_fallback`)."""


@dataclass
class AttentionOutcome:
    """What one attention phase did (besides growing the tree)."""

    stop: str
    """One of `STOPS`."""
    policy_calls: int
    """Calls of the policy (a chunked policy proposes several samples per call)."""
    policy_samples: int
    """Proposals of the policy used as samples."""
    compiled: bool
    """Whether the compiled loop ran it."""


def observer_for(problem: Problem, policy: SamplingPolicy, max_nodes: int) -> TreeObserver:
    """The observer matching what the policy was trained on (its resolution and L)."""
    spec = robot_spec(problem.robot)
    resolution, max_path_length = observation_settings(
        policy, spec.encoding_resolution, spec.workspace_dim
    )
    occupancy = occupancy_grid(problem.workspace, resolution)
    return TreeObserver(problem, occupancy, max_path_length, max_nodes)


def run_attention_phase(
    tree: Tree,
    policy: SamplingPolicy,
    rng: np.random.Generator,
    goal_bias: float,
    limits: AttentionLimits,
    compiled_loop: bool | None = None,
    uniform: float = 0.0,
    follow_fallback: float = 1.0,
    resumed: bool = False,
    keep_chunk: bool = False,
    joined: Callable[[], bool] | None = None,
    check_every: int = 1,
) -> AttentionOutcome:
    """Grow ``tree`` by attention-based planning until a stop rule fires (module docstring).

    Args:
        tree: the planner's tree (its root is the problem's start).
        policy: a reset `temp_gym.planning.policy.SamplingPolicy`; its optional fast paths
            (``compiled_proposer``, ``propose_chunk``, ``propose``) are used when present.
        rng: the planner's generator (goal bias and fallback samples).
        goal_bias: probability of sampling the goal.
        limits: the budgets.
        compiled_loop: force the compiled loop (True; an error when it cannot run) or the
            Python loop (False); None picks the compiled one whenever it can run.
        uniform: probability of a uniform sample instead of the policy's (after goal bias).
        follow_fallback: probability that the policy goes on from a fallback node that brought
            the tree no closer to the goal (1: always, Algorithm 1's UpdatePath).
        resumed: the phase resumes on a tree that an earlier phase and classical planning
            grew: progress counts from the tree's closest approach to the goal instead of
            the start's. Either way the policy first reads the root path of the tree's
            newest node (the root itself on a new tree).
        keep_chunk: when a proposal of a chunk collided and a fallback node replaced it, the
            chunk's next proposal comes next (True); False drops the rest of the chunk and
            calls the policy again. A one-sample policy is the same either way.
        joined: called each time the tree has grown by ``check_every`` nodes, and once when
            a stop rule fires (except the time limit): True ends the phase with the stop
            ``"joined"``. The TEMP planner's goal tree grows by attention this way and checks
            whether it meets the planner's tree (`temp_gym.planning.goal_tree`). The checks
            come at the same node counts in both loops, so they grow the same trees. (The
            TEMP planner's phases after a stall run as one compiled sequence that makes these
            checks itself, `temp_gym.planning._compiled_attention.attention_sequence`.)
        check_every: nodes between two ``joined`` checks (at least 1).
    """
    if check_every < 1:
        raise ValueError(f"check_every: must be at least 1, got {check_every}")
    problem = tree.problem
    closest_sq = (
        closest_approach_sq(tree) if resumed else squared_distance(problem.start, problem.goal)
    )
    compiled_proposer = fast_path(policy, "compiled_proposer")
    proposer = compiled_proposer() if compiled_proposer is not None else None
    if proposer is not None and (not isinstance(proposer, tuple) or len(proposer) != 8):
        raise ValueError(
            "policy.compiled_proposer: expected None or the 8 entries "
            "`temp_gym.models.policy.TEMPPolicy.compiled_proposer` returns, got "
            f"{type(proposer).__name__} of {len(proposer) if isinstance(proposer, tuple) else 1}"
        )
    context = compiled_context_of(tree.checker)
    can_compile = proposer is not None and context is not None
    if compiled_loop and not can_compile:
        raise ValueError(
            "compiled_loop: needs a policy with a compiled proposer (a TEMPPolicy on its numba "
            "MPT) and a checker with a compiled path"
        )
    if can_compile and compiled_loop is not False:
        outcome = _run_compiled(
            tree, proposer, context, rng, goal_bias, uniform, follow_fallback, keep_chunk,
            limits, closest_sq, joined, check_every,
        )  # fmt: skip
    else:
        outcome = _run_python(
            tree, policy, rng, goal_bias, uniform, follow_fallback, keep_chunk, limits,
            closest_sq, joined, check_every,
        )  # fmt: skip
    if joined is not None and outcome.stop not in ("joined", "time") and joined():
        outcome.stop = "joined"  # the nodes since the last check met the other tree
    return outcome


def closest_approach_sq(tree: Tree) -> float:
    """The squared distance from the goal to the tree's node nearest to it."""
    offsets = tree.positions[: tree.num_nodes] - tree.problem.goal
    return float(np.min(np.einsum("ij,ij->i", offsets, offsets)))


def follows(samples: int, closer: bool, follow_fallback: float, rng: np.random.Generator) -> bool:
    """Whether the policy goes on from a new node that took ``samples`` samples to add.

    Always from a node added at the first sample or one that brought the tree ``closer`` to
    the goal; from any other (a fallback node) with probability ``follow_fallback``, drawn
    from ``rng`` only when that is strictly between 0 and 1.
    """
    if samples == 1 or closer or follow_fallback >= 1.0:
        return True
    return follow_fallback > 0.0 and rng.random() < follow_fallback


def _run_python(
    tree: Tree,
    policy: SamplingPolicy,
    rng: np.random.Generator,
    goal_bias: float,
    uniform: float,
    follow_fallback: float,
    keep_chunk: bool,
    limits: AttentionLimits,
    closest_sq: float,
    joined: Callable[[], bool] | None,
    check_every: int,
) -> AttentionOutcome:
    """The reference loop: any policy, any checker."""
    problem = tree.problem
    observer = observer_for(problem, policy, limits.max_nodes)
    fallback = UniformSampler(problem.bounds)
    goal = np.ascontiguousarray(problem.goal, dtype=np.float64)
    propose_chunk = fast_path(policy, "propose_chunk")
    propose_one = fast_path(policy, "propose")
    anchor = tree.newest  # the node whose root path the policy reads (sigma')
    if propose_chunk is not None:

        def propose() -> np.ndarray:
            proposals = np.asarray(propose_chunk(*observer.path_so_far(tree, anchor)))
            if proposals.ndim != 2 or len(proposals) == 0:
                raise ValueError(
                    f"policy.propose_chunk: expected (k, {problem.dim}) proposals with k >= 1, "
                    f"got shape {proposals.shape}"
                )
            return proposals

    elif propose_one is not None:

        def propose() -> np.ndarray:
            return np.asarray(propose_one(*observer.path_so_far(tree, anchor)))[None]

    else:

        def propose() -> np.ndarray:
            return np.asarray(policy(observer.observe(tree, anchor)))[None]

    stalled = calls = proposals_used = 0
    chunk: np.ndarray | None = None
    next_row = 0
    next_check = tree.num_nodes + check_every if joined is not None else MAX_COUNT
    while True:
        if tree.best_node >= 0:
            stop = "solved"
            break
        if tree.num_nodes >= limits.attention_nodes:
            stop = "attention_budget"
            break
        if _at_check(tree, limits, next_check):
            next_check = tree.num_nodes + check_every
            if joined():
                stop = "joined"
                break
        if tree.num_nodes >= limits.max_nodes or tree.samples >= limits.max_samples:
            stop = "budget"
            break
        if time.perf_counter() >= limits.deadline:
            stop = "time"
            break
        if goal_bias > 0 and rng.random() < goal_bias:
            chunk = None
            result = tree.extend_with_fallback(goal, fallback, rng, MAX_FALLBACK_TRIES)
        elif uniform > 0 and rng.random() < uniform:
            chunk = None
            result = tree.extend_with_fallback(
                fallback.sample(rng), fallback, rng, MAX_FALLBACK_TRIES
            )
        else:
            if chunk is None:
                chunk = np.asarray(propose())
                next_row = 0
                calls += 1
            action = chunk[next_row]
            next_row += 1
            proposals_used += 1
            if next_row == len(chunk):
                chunk = None
            result = tree.extend_with_fallback(
                action, fallback, rng, MAX_FALLBACK_TRIES, normalized=True,
                local_tries=limits.local_tries,
            )  # fmt: skip
            if result.node < 0 or (result.samples > 1 and not keep_chunk):
                chunk = None
        if result.node >= 0:
            distance_sq = squared_distance(tree.positions[result.node], goal)
            closer = distance_sq < closest_sq
            if follows(result.samples, closer, follow_fallback, rng):
                anchor = result.node
            if closer:
                closest_sq, stalled = distance_sq, 0
            else:
                stalled += 1
                patience = limits.near_patience if closest_sq <= limits.near_sq else limits.patience
                if limits.patience > 0 and stalled >= patience:
                    stop = "stalled"
                    break
    return AttentionOutcome(stop, calls, proposals_used, compiled=False)


def _at_check(tree: Tree, limits: AttentionLimits, next_check: int) -> bool:
    """Whether the tree stands at a ``joined`` check (its node count reached ``next_check``).

    Only with node and sample budget left: a compiled slice that stopped there stopped for it.
    """
    return (
        tree.num_nodes >= next_check
        and tree.num_nodes < limits.max_nodes
        and tree.samples < limits.max_samples
    )


_COMPILED_STOPS = {
    compiled.SOLVED: "solved",
    compiled.ATTENTION_BUDGET: "attention_budget",
    compiled.BUDGET: "budget",
    compiled.STALLED_OUT: "stalled",
}


def loop_arrays(
    limits: AttentionLimits, check_every: int, dim: int, chunk: int, max_path_length: int
) -> tuple[np.ndarray, ...]:
    """The compiled loop's budgets and scratch, new: what `_compiled_attention` takes.

    ``(budget, buffer, cursor, proposals, chunk_out, path_rows, state, closest)``: ``limits``
    as `_compiled_attention.LIMITS` (no join check), the uniform fallback's empty batch, the
    chunk, the path rows the MPT reads, the loop state (`STATE`, zeros) and the closest
    approach (0).
    """
    budget = np.array(
        [limits.attention_nodes, limits.max_nodes, limits.max_samples, limits.patience,
         MAX_FALLBACK_TRIES, limits.near_patience, limits.local_tries, compiled.NO_CHECK,
         check_every, 0, 0],
        dtype=np.int64,
    )  # fmt: skip
    return (
        budget,
        np.empty((FALLBACK_BATCH, dim)),
        np.array([FALLBACK_BATCH], dtype=np.int64),
        np.empty((chunk, dim)),
        np.empty((chunk, dim), np.float32),
        np.zeros((max_path_length, dim), np.float32),
        np.zeros(len(compiled.STATE), dtype=np.int64),
        np.zeros(1),
    )


def _run_compiled(
    tree: Tree,
    proposer: tuple,
    context: tuple,
    rng: np.random.Generator,
    goal_bias: float,
    uniform: float,
    follow_fallback: float,
    keep_chunk: bool,
    limits: AttentionLimits,
    closest_sq: float,
    joined: Callable[[], bool] | None,
    check_every: int,
) -> AttentionOutcome:
    """The compiled loop, in slices between looks at the clock (`slice_length`).

    With a ``joined`` check, a slice also ends at the next check's node count (its node
    budget held there), where the Python loop checks too.
    """
    weights, prefix_goal, prefix_z, prefix_qkv, policy_rng, noise_std, chunk, max_path_length = (
        proposer
    )
    problem = tree.problem
    dim = problem.dim
    noise_std = float(noise_std)
    noise_rng = policy_rng if noise_std > 0 else rng  # without noise, a placeholder never drawn
    # Both generators stay alive in this frame while the slices draw from them by address.
    rng_address, noise_address = address(rng), address(noise_rng)
    goal = np.ascontiguousarray(problem.goal, dtype=np.float64)
    bounds = np.ascontiguousarray(problem.bounds, dtype=np.float64)
    budget, buffer, cursor, proposals, chunk_out, path_rows, state, closest = loop_arrays(
        limits, check_every, dim, chunk, max_path_length
    )
    state[compiled.ANCHOR] = tree.newest
    closest[0] = closest_sq
    near_sq = float(limits.near_sq)
    next_check = tree.num_nodes + check_every if joined is not None else MAX_COUNT
    # The kernel's join check is off (NO_CHECK): ``joined`` is called from here. Placeholders
    # of its arrays' types, never read.
    own = tree.compiled_state()[0]
    join_arrays = (own[0], own[9], own[4], np.zeros(2, np.int64), np.zeros(3, np.int64))
    iterations = slice_length(limits.deadline, time.perf_counter(), 0.0)
    while True:
        began = time.perf_counter()
        if began >= limits.deadline:
            stop = "time"
            break
        budget[compiled.MAX_NODES] = min(limits.max_nodes, next_check)
        arrays, counters, best_cost, params = tree.compiled_state()
        status = compiled.attention_slice(
            arrays, counters, best_cost, params, goal, bounds, context, rng_address, buffer,
            cursor, float(goal_bias), float(uniform), float(follow_fallback), bool(keep_chunk),
            weights,
            prefix_goal, prefix_z, prefix_qkv, noise_std, noise_address, proposals, chunk_out,
            path_rows, state, closest, near_sq, budget, iterations, join_arrays,
        )  # fmt: skip
        tree.load_compiled_state(counters, best_cost)
        if status == compiled.RUNNING:  # a whole slice ran: its pace sizes the next one
            now = time.perf_counter()
            iterations = slice_length(limits.deadline, now, (now - began) / iterations)
        elif status == compiled.FULL:
            tree.grow()
        elif status == compiled.NOT_FINITE:
            raise ValueError("action: the policy proposed a sample that is not finite")
        elif status == compiled.BUDGET and _at_check(tree, limits, next_check):
            next_check = tree.num_nodes + check_every
            if joined():
                stop = "joined"
                break
        else:
            stop = _COMPILED_STOPS[status]
            break
    calls, used = int(state[compiled.CALLS]), int(state[compiled.PROPOSALS])
    return AttentionOutcome(stop, calls, used, compiled=True)


__all__ = [
    "AttentionLimits",
    "AttentionOutcome",
    "MAX_FALLBACK_TRIES",
    "RESUME_AFTER",
    "STOPS",
    "closest_approach_sq",
    "default_patience",
    "loop_arrays",
    "near_goal_limits",
    "observer_for",
    "resume_nodes",
    "run_attention_phase",
]
