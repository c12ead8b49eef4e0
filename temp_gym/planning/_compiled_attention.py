"""TEMP's attention phase as one compiled loop: no Python round trip per node.

`temp_gym.planning.attention` runs the attention phase (the paper's Algorithm 1, with the
additions its docstring lists) either from Python, for any policy and checker, or here, when
the policy is a `TEMPPolicy` on its numba MPT (`TEMPPolicy.compiled_proposer`) and the checker
has a compiled path (`temp_gym.worlds.collision.compiled`). Each iteration of `attention_slice`
is one iteration of the Python loop, written against the same kernels and drawing the same
random numbers in the same order, so both grow the same tree (tested node for node):

1. goal bias: with probability ``goal_bias`` the goal is the sample (the chunk is dropped);
   else, with probability ``uniform``, a uniform sample (from the fallback's batch);
2. otherwise the next proposal of the current chunk, or, when none is left, a new MPT call
   on the path so far (`temp_gym.planning.mpt_kernel`), with the policy's output noise
   drawn here from the policy's own generator, value by value in the order of numpy's
   ``normal(0, std, (k, d))`` (numba's ``Generator.normal`` gives numpy's values), so the
   generator ends where the Python loop leaves it;
3. `temp_gym.planning._compiled_tree.extend_with_fallback`: nearest, steer, the random
   fallback while the edge collides, choose-parent, insert, rewire; a fallback or a failed
   extension drops the rest of the chunk (its proposals continued the path it predicted);
4. the node whose root path the next MPT call reads: the new node, unless it is a fallback
   node that brought the tree no closer to the goal, which it is with probability
   ``follow_fallback`` (`temp_gym.planning.attention.follows`);
5. progress: the tree's closest approach to the goal; ``patience`` nodes in a row without a
   closer one stall the phase (0: never), ``near_patience`` once that approach is within
   ``sqrt(near_sq)`` of the goal;
6. with a join check (the TEMP planner's goal tree, `temp_gym.planning.goal_tree`): every
   ``check_every`` nodes and once at a stop, the nodes of both trees not tried yet are tried
   against the other tree (`join_check`), where the Python loop calls its ``joined``, so that
   a goal tree grown by attention returns to Python only when its phase ends.

The loop runs at most ``max_iterations`` iterations per call and returns a status, so the
caller can check the wall clock, grow the tree's arrays, and call again.
"""

from __future__ import annotations

import numba
import numpy as np

from temp_gym.planning._compiled_tree import (
    BAD_ACTION,
    BEST_NODE,
    FALLBACK_BATCH,
    NEWEST,
    NUM_NODES,
    SAMPLES,
    extend_near_first,
    extend_with_fallback,
    fallback_sample,
    link_trees,
    normalized_root_path,
    squared_distance,
)
from temp_gym.planning._generator import generator_at
from temp_gym.planning._grid import scan_nearest
from temp_gym.planning.mpt_kernel import forward_kernel

STATE = ("pending", "next_row", "calls", "proposals", "stalled", "anchor")
"""The loop's int64 state, kept between calls: proposals left in the chunk and the next one,
MPT calls and proposals used so far, nodes since the closest approach improved, the node whose
root path the MPT reads."""
PENDING, NEXT_ROW, CALLS, PROPOSALS, STALLED, ANCHOR = range(len(STATE))
LIMITS = (
    "attention_nodes", "max_nodes", "max_samples", "patience", "max_fallback_tries",
    "near_patience", "local_tries", "next_check", "check_every", "other_count", "grown_side",
)  # fmt: skip
"""The int64 budgets of the phase (and the replacements of a proposal drawn near it), then
the join check's: the node count of the next check (`NO_CHECK`: none), the nodes between two,
the other tree's node count, and which tree grows (0: the planner's, 1: the goal tree)."""
(ATTENTION_NODES, MAX_NODES, MAX_SAMPLES, PATIENCE, MAX_TRIES, NEAR_PATIENCE,
 LOCAL_TRIES, NEXT_CHECK, CHECK_EVERY, OTHER_COUNT, GROWN_SIDE) = range(len(LIMITS))  # fmt: skip
NO_CHECK = np.iinfo(np.int64).max
"""``limits[NEXT_CHECK]`` of a phase without join checks."""

RUNNING, SOLVED, ATTENTION_BUDGET, BUDGET, STALLED_OUT, FULL, NOT_FINITE, JOINED = range(8)
"""Statuses: the slice ended; solved; the attention budget n or the node/sample budget is
used up; no progress for ``patience`` nodes; the tree's arrays are full (grow them and call
again); the policy proposed NaN or inf; a join check linked the two trees (the link is in
the join record, `temp_gym.planning._compiled_tree.LINK`)."""


@numba.njit(cache=True, nogil=True)
def attention_slice(
    arrays, counters, best_cost, params, goal, bounds, context, rng_address, buffer, cursor,
    goal_bias, uniform, follow_fallback, keep_chunk, weights, prefix_goal, prefix_z, prefix_qkv,
    noise_std,
    noise_address, proposals, chunk_out, path_rows, state, closest_sq, near_sq, limits,
    max_iterations, join,
):  # fmt: skip
    """Run up to ``max_iterations`` attention-phase iterations; return a status.

    The arguments, in groups:

        arrays, counters, best_cost, params: the tree (`Tree.compiled_state`).
        goal, bounds: the problem's goal (world units) and ``(2, d)`` bounds.
        context: the checker's compiled context.
        rng_address, buffer, cursor: the planner's generator (its `_generator.address`) and
            the uniform fallback's batch.
        goal_bias: probability of sampling the goal.
        uniform: probability of a uniform sample instead of the policy's.
        follow_fallback: probability that the MPT goes on from a fallback node that brought
            the tree no closer to the goal.
        keep_chunk: after a fallback node (a proposal collided), the chunk's next proposal
            comes next (True) or a new MPT call (False).
        weights, prefix_goal, prefix_z, prefix_qkv, noise_std: the policy
            (`TEMPPolicy.compiled_proposer`).
        noise_address: the policy's noise generator, by address (drawn from only when
            ``noise_std > 0``).
        proposals: float64 ``(k, d)`` the current chunk; ``chunk_out`` float32 ``(k, d)`` and
            ``path_rows`` float32 ``(L, d)`` are scratch.
        state, closest_sq, limits: the loop's state (`STATE`), the squared closest approach
            to the goal (an array of one) and budgets (`LIMITS`).
        near_sq: the squared distance to the goal within which ``near_patience`` applies.
        join: the join check's ``(other positions, other grid, other scratch, checked,
            record)`` (`join_check`); any arrays of those types when ``limits[NEXT_CHECK]``
            is `NO_CHECK`.
    """
    rng, noise_rng = generator_at(rng_address), generator_at(noise_address)
    positions, _, links = arrays[0], arrays[1], arrays[2]
    capacity = positions.shape[0]
    chunk, dim = proposals.shape
    local = np.empty(dim if limits[LOCAL_TRIES] > 0 else 0)  # scratch of `extend_near_first`
    for _ in range(max_iterations):
        if counters[BEST_NODE] >= 0:
            return stopped(SOLVED, arrays, counters, context, limits, join)
        if counters[NUM_NODES] >= limits[ATTENTION_NODES]:
            return stopped(ATTENTION_BUDGET, arrays, counters, context, limits, join)
        if counters[NUM_NODES] >= limits[MAX_NODES] or counters[SAMPLES] >= limits[MAX_SAMPLES]:
            return stopped(BUDGET, arrays, counters, context, limits, join)
        if counters[NUM_NODES] >= limits[NEXT_CHECK]:
            limits[NEXT_CHECK] = counters[NUM_NODES] + limits[CHECK_EVERY]
            if join_check(arrays, counters[NUM_NODES], context, limits, join):
                return JOINED
        if counters[NUM_NODES] >= capacity:
            return FULL
        if goal_bias > 0.0 and rng.random() < goal_bias:
            state[PENDING] = 0
            node, samples = extend_with_fallback(
                arrays, counters, best_cost, params, goal, bounds, context, goal, False, rng,
                buffer, cursor, limits[MAX_TRIES],
            )  # fmt: skip
        elif uniform > 0.0 and rng.random() < uniform:
            state[PENDING] = 0
            sample = fallback_sample(rng, bounds[0], bounds[1], buffer, cursor)
            node, samples = extend_with_fallback(
                arrays, counters, best_cost, params, goal, bounds, context, sample, False, rng,
                buffer, cursor, limits[MAX_TRIES],
            )  # fmt: skip
        else:
            if state[PENDING] == 0:
                length = normalized_root_path(links, positions, state[ANCHOR], bounds,
                                              path_rows)  # fmt: skip
                forward_kernel(path_rows, length, prefix_goal, prefix_z, prefix_qkv, *weights,
                               chunk_out)  # fmt: skip
                for row in range(chunk):
                    for k in range(dim):
                        value = np.float64(chunk_out[row, k])
                        if noise_std > 0.0:
                            value += noise_rng.normal(0.0, noise_std)
                        if value != value:  # NaN: the model is broken
                            return NOT_FINITE
                        proposals[row, k] = np.float64(np.float32(min(max(value, -1.0), 1.0)))
                state[PENDING] = chunk
                state[NEXT_ROW] = 0
                state[CALLS] += 1
            row = state[NEXT_ROW]
            state[NEXT_ROW] += 1
            state[PENDING] -= 1
            state[PROPOSALS] += 1
            if limits[LOCAL_TRIES] > 0:
                node, samples = extend_near_first(
                    arrays, counters, best_cost, params, goal, bounds, context, proposals[row],
                    rng, buffer, cursor, limits[MAX_TRIES], limits[LOCAL_TRIES], local,
                )  # fmt: skip
            else:
                node, samples = extend_with_fallback(
                    arrays, counters, best_cost, params, goal, bounds, context, proposals[row],
                    True, rng, buffer, cursor, limits[MAX_TRIES],
                )  # fmt: skip
            if node == BAD_ACTION:
                return NOT_FINITE
            if node < 0 or (samples > 1 and not keep_chunk):
                state[PENDING] = 0
        if node >= 0:
            distance_sq = squared_distance(positions[node], goal)
            closer = distance_sq < closest_sq[0]
            if samples == 1 or closer or follow_fallback >= 1.0:
                state[ANCHOR] = node
            elif follow_fallback > 0.0 and rng.random() < follow_fallback:
                state[ANCHOR] = node
            if closer:
                closest_sq[0] = distance_sq
                state[STALLED] = 0
            else:
                state[STALLED] += 1
                patience = limits[NEAR_PATIENCE] if closest_sq[0] <= near_sq else limits[PATIENCE]
                if limits[PATIENCE] > 0 and state[STALLED] >= patience:
                    return stopped(STALLED_OUT, arrays, counters, context, limits, join)
    return RUNNING


@numba.njit(cache=True, nogil=True)
def stopped(status, arrays, counters, context, limits, join) -> int:
    """``status``, a stop of the phase, after the join check the Python loop makes at a stop.

    With join checks (``limits[NEXT_CHECK]`` not `NO_CHECK`) the nodes since the last check
    are tried too (`join_check`), and a link makes the stop `JOINED`.
    """
    if limits[NEXT_CHECK] != NO_CHECK and join_check(
        arrays, counters[NUM_NODES], context, limits, join
    ):
        return JOINED
    return status


@numba.njit(cache=True, nogil=True)
def join_check(arrays, count, context, limits, join) -> bool:
    """`link_trees` between the grown tree and the other; True on the first free link.

    The grown tree is ``arrays`` with ``count`` nodes; the other is ``join``'s positions, grid
    and scratch with ``limits[OTHER_COUNT]`` nodes; ``limits[GROWN_SIDE]`` says which of them
    is the planner's tree. The link and the motion checks go into the join record.
    """
    other_positions, other_grid, other_scratch, checked, record = join
    grown = (arrays[0], arrays[9], arrays[4])
    other = (other_positions, other_grid, other_scratch)
    if limits[GROWN_SIDE] == 0:
        return link_trees(grown, count, other, limits[OTHER_COUNT], checked, context, record)
    return link_trees(other, limits[OTHER_COUNT], grown, count, checked, context, record)


SEQUENCE = ("phase", "started", "rounds", "from_goal_status", "last_status")
"""The int64 state of `attention_sequence`, kept between calls: the phase (0: the goal tree
from the goal; then, for round r, 2r - 1 the planner's tree and 2r the goal tree, both
resumed), whether it has begun, the rounds allowed, and the stop statuses of phase 0 and of
the last phase (-1 before they stop)."""
PHASE, STARTED, ROUNDS, FROM_GOAL_STATUS, LAST_STATUS = range(len(SEQUENCE))
DONE, FULL_PLANNER, FULL_GOAL = 100, 101, 102
"""`attention_sequence`'s statuses besides `RUNNING`, `JOINED` and `NOT_FINITE`: the sequence
ended (a stop other than a stall, a solution, or the rounds used up; `SEQUENCE` says which);
the planner's or the goal tree's arrays are full (grow that tree and call again)."""


@numba.njit(cache=True, nogil=True)
def attention_sequence(
    planner, goal_tree, goal, start, bounds, context, rng_address, buffer, cursor, goal_bias,
    uniform, follow_fallback, keep_chunk, weights, planner_prefix, goal_tree_prefix, noise_std,
    noise_address, proposals, chunk_out, path_rows, state, closest_sq, near_sq, base_limits,
    limits, sequence, checked, record, max_iterations,
):  # fmt: skip
    """The TEMP planner's attention phases after a stall, from the goal and in rounds.

    What `temp_gym.planning.goal_tree.GoalTree.grow_by_attention` and
    `GoalTree.grow_in_rounds` do from Python, one compiled call per slice instead of a return
    per phase: phase 0 grows the goal tree (its problem swapped: from ``goal`` towards
    ``start``); while phases stall and the planner's tree has no solution, round r grows the
    planner's tree (phase 2r - 1), then the goal tree (phase 2r), each resumed (progress
    counted from the tree's closest approach), up to ``sequence[ROUNDS]`` rounds. Each phase
    is `attention_slice` with the budgets of ``base_limits`` less the other tree's nodes and
    samples, and the join checks against the other tree (`join_check`: every
    ``limits[CHECK_EVERY]`` nodes and at the stop), exactly as each `run_attention_phase` of
    those methods sets them up.

    ``planner`` and ``goal_tree`` are ``(arrays, counters, best_cost, params)``
    (`Tree.compiled_state`); ``*_prefix`` are ``(goal, z, qkv)`` of the policy reset to each
    tree's problem (`TEMPPolicy.compiled_proposer`); ``limits`` is scratch for one phase's
    `LIMITS` (``limits[CHECK_EVERY]`` set); ``checked`` and ``record`` are the join check's.
    The rest is `attention_slice`'s. Returns `RUNNING` (a slice ran out: look at the clock
    and call again), `FULL_PLANNER` / `FULL_GOAL`, `NOT_FINITE`, `JOINED` (the link is in
    ``record``) or `DONE`.
    """
    while True:
        phase = sequence[PHASE]
        on_goal_tree = phase % 2 == 0
        if on_goal_tree:
            grown, other, prefix, grown_goal = goal_tree, planner, goal_tree_prefix, start
        else:
            grown, other, prefix, grown_goal = planner, goal_tree, planner_prefix, goal
        arrays, counters, best_cost, params = grown
        other_arrays, other_counters = other[0], other[1]
        if sequence[STARTED] == 0:  # run_attention_phase's set-up, through GoalTree._attend
            used_nodes, used_samples = other_counters[NUM_NODES], other_counters[SAMPLES]
            for k in range(base_limits.shape[0]):
                limits[k] = base_limits[k]
            limits[ATTENTION_NODES] = max(base_limits[ATTENTION_NODES] - used_nodes, 0)
            limits[MAX_NODES] = max(base_limits[MAX_NODES] - used_nodes, 0)
            limits[MAX_SAMPLES] = max(base_limits[MAX_SAMPLES] - used_samples, 0)
            limits[NEXT_CHECK] = counters[NUM_NODES] + limits[CHECK_EVERY]
            limits[OTHER_COUNT] = used_nodes
            limits[GROWN_SIDE] = 1 if on_goal_tree else 0
            state[:] = 0
            state[ANCHOR] = counters[NEWEST]
            cursor[0] = FALLBACK_BATCH  # a new phase draws a new fallback batch
            if phase == 0:  # not resumed: from the swapped problem's start
                closest_sq[0] = squared_distance(start, goal)
            else:
                closest_sq[0] = scan_nearest(arrays[0], counters[NUM_NODES], grown_goal)[1]
            sequence[STARTED] = 1
        status = attention_slice(
            arrays, counters, best_cost, params, grown_goal, bounds, context, rng_address,
            buffer, cursor, goal_bias, uniform, follow_fallback, keep_chunk, weights,
            prefix[0], prefix[1], prefix[2], noise_std, noise_address, proposals, chunk_out,
            path_rows, state, closest_sq, near_sq, limits, max_iterations,
            (other_arrays[0], other_arrays[9], other_arrays[4], checked, record),
        )  # fmt: skip
        if status == RUNNING:
            return RUNNING
        if status == FULL:
            return FULL_GOAL if on_goal_tree else FULL_PLANNER
        if status == NOT_FINITE:
            return NOT_FINITE
        sequence[LAST_STATUS] = status
        if phase == 0:
            sequence[FROM_GOAL_STATUS] = status
        if status == JOINED:
            return JOINED
        if status != STALLED_OUT or planner[1][BEST_NODE] >= 0:
            return DONE
        if phase >= 2 * sequence[ROUNDS]:  # the rounds are used up
            return DONE
        sequence[PHASE] = phase + 1
        sequence[STARTED] = 0
