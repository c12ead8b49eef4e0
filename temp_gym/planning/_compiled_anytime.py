"""The anytime loop's extensions as one compiled loop: no Python round trip per node.

`temp_gym.planning.anytime.grow_anytime` runs RRT*, Informed RRT* and TEMP's classical phase.
With a checker that has a compiled path (`temp_gym.worlds.collision.compiled`) it hands the
extensions to `anytime_slice`, which runs them in numba and returns to Python only for what
Python does better, rarely:

* a new batch of samples (`NEED_BATCH`): the sampler draws it in Python, every 128 samples or
  fewer, exactly the batch the Python loop would draw;
* an improvement of the best cost (`IMPROVED`): the planner logs it, and Informed RRT*
  shrinks its informed set (which discards the batch, as in the Python loop);
* a full tree (`FULL`): the arrays are grown;
* the end of a slice (`RUNNING`): the caller looks at the clock.

Each iteration is one iteration of the Python loop: the goal-bias coin from the planner's
generator (`temp_gym.planning.samplers.GoalBiasedSampler`), else the next row of the batch,
then `temp_gym.planning._compiled_tree.extend`. The random numbers are drawn in the same order
from the same generator, so both loops grow the same tree, node for node (tested); only
``collision_checks`` counts fewer checks (`_compiled_tree`'s docstring says why).
"""

from __future__ import annotations

import numba

from temp_gym.planning._compiled_tree import BEST_NODE, NUM_NODES, SAMPLES, extend
from temp_gym.planning._generator import generator_at

STATE = ("coin_pending", "next_row", "rows")
"""The loop's int64 state, kept between calls: whether the goal-bias coin already chose the
batch for this iteration (and the batch was empty), the batch's next row and its valid rows."""
COIN_PENDING, NEXT_ROW, ROWS = range(len(STATE))
LIMITS = ("max_nodes", "sample_limit", "stop_at_first")
"""The int64 stop rules (``stop_at_first``: 1 or 0); the target cost is a float argument."""
MAX_NODES, SAMPLE_LIMIT, STOP_AT_FIRST = range(len(LIMITS))

RUNNING, DONE, NEED_BATCH, IMPROVED, FULL = range(5)
"""Statuses: the slice ended; a stop rule (other than the clock) fired; the batch is used up;
the best cost improved; the tree's arrays are full (grow them and call again)."""


@numba.njit(cache=True, nogil=True)
def anytime_slice(
    arrays, counters, best_cost, params, goal, bounds, context, rng_address, goal_bias, batch,
    state, limits, target_cost, max_iterations,
):  # fmt: skip
    """Run up to ``max_iterations`` anytime iterations; return a status.

    The arguments, in groups:

        arrays, counters, best_cost, params: the tree (`Tree.compiled_state`).
        goal, bounds: the problem's goal and ``(2, d)`` bounds.
        context: the checker's compiled context.
        rng_address, goal_bias: the planner's generator (its `_generator.address`) and the
            probability of sampling the goal.
        batch: float64 ``(rows, d)`` the sampler's current batch (valid rows: ``state``).
        state, limits, target_cost: the loop's state (`STATE`), its stop rules (`LIMITS`) and
            the cost at which it stops (``-inf``: none).
    """
    rng = generator_at(rng_address)
    capacity = arrays[0].shape[0]
    for _ in range(max_iterations):
        if counters[BEST_NODE] >= 0 and (limits[STOP_AT_FIRST] != 0 or best_cost[0] <= target_cost):
            return DONE
        if counters[NUM_NODES] >= limits[MAX_NODES] or counters[SAMPLES] >= limits[SAMPLE_LIMIT]:
            return DONE
        if counters[NUM_NODES] >= capacity:
            return FULL
        if state[COIN_PENDING] == 0 and goal_bias > 0.0 and rng.random() < goal_bias:
            sample = goal
        else:
            if state[NEXT_ROW] >= state[ROWS]:
                state[COIN_PENDING] = 1
                return NEED_BATCH
            state[COIN_PENDING] = 0
            sample = batch[state[NEXT_ROW]]
            state[NEXT_ROW] += 1
        before = best_cost[0]
        extend(arrays, counters, best_cost, params, goal, bounds, context, sample, False)
        if best_cost[0] < before:
            return IMPROVED
    return RUNNING


__all__ = ["DONE", "FULL", "IMPROVED", "NEED_BATCH", "RUNNING", "STATE", "anytime_slice"]
