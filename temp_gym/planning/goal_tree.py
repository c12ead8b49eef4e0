"""A second tree, rooted at the goal, that grows beside the planner's until the two meet.

A goal inside a pocket (a bin, a cubby, a window, a bug trap) is hard to enter for a tree
grown from the start and easy to leave for a tree grown from the goal: on the arm's
out-of-distribution scenes Informed RRT* from the goal needs a few hundred nodes where from
the start it fails at 10,000, and the 2D generator's tasks on which TEMP's attention phase
stalls are solved by it from the goal with half the nodes (docs/research/planner.md). TEMP's
classical phase uses this tree until the first solution, RRT-Connect's idea (Kuffner and
LaValle 2000) on RRT* trees:

* the goal tree is an RRT* tree of the swapped problem (root: the goal; its goal-biased
  samples: the start), grown in turns with the planner's tree;
* every node either tree gains is tried against its nearest node in the other: one straight
  motion check;
* the first free link joins them: the goal tree's branch from the linked node to the goal is
  appended to the planner's tree as a chain of nodes, which gives the planner's tree a
  solution. The goal tree is then dropped, and the planner's tree goes on as before (Informed
  RRT* improves the path, rewiring the chain like any other nodes).

After a stall of the attention phase the policy grows the goal tree first
(`GoalTree.grow_by_attention`: the attention phase on the swapped problem, its new nodes tried
against the planner's tree every `CHECK_EVERY` nodes), until the trees meet or it stalls too.
A policy that stalled walking into a pocket mostly walks out of it. If it stalls too, the
policy takes up to ``attention_rounds`` more rounds (`GoalTree.grow_in_rounds`, default
`ATTENTION_ROUNDS`): a resumed attention phase on the planner's tree, then one on the goal
tree, each with the same stall patience and its new nodes tried against the other tree. Then
RRT*'s samples grow both trees as above. With a compiled policy and checker the phase from the
goal and the rounds run as one compiled sequence (`GoalTree.grow_from_goal_and_in_rounds`).

Every node either tree grew counts against the node budget (`GoalTree.extra_nodes`: the goal
tree's nodes that the chain did not copy), so nodes to a first solution compare with a
one-tree planner's honestly. The joined path is certified by the exact checker like any other
(`temp_gym.planning.result.tree_plan_result`).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from temp_gym.planning import _compiled_attention as compiled
from temp_gym.planning._compiled_tree import (
    GOAL_NODE,
    LINK_CHECKS,
    PLANNER_NODE,
    graft_branch,
    link_trees,
    slice_length,
)
from temp_gym.planning._generator import address
from temp_gym.planning._kernels import nearest
from temp_gym.planning.anytime import grow_anytime
from temp_gym.planning.attention import (
    AttentionLimits,
    AttentionOutcome,
    loop_arrays,
    run_attention_phase,
)
from temp_gym.planning.policy import SamplingPolicy, fast_path
from temp_gym.planning.result import AnytimeLog
from temp_gym.planning.settings import PlanSettings
from temp_gym.planning.tree import Tree
from temp_gym.worlds.collision.compiled import compiled_context_of

TURN_NODES = 32
"""Nodes each tree adds per turn before the new ones are tried against the other tree."""
CHECK_EVERY = 8
"""While the policy grows the goal tree (`GoalTree.grow_by_attention`): nodes between two tries
of its new nodes against the planner's tree. Checking after every node saved a node more on 2D
validation when each check cost a return from the compiled loop; the compiled sequence after a
stall now makes the checks itself (`_compiled_attention.join_check`), and this has not been
chosen again since."""
ATTENTION_ROUNDS = 1
"""The ``temp`` planner's default ``attention_rounds`` (`GoalTree.grow_in_rounds`): after the
attention phases from the start and from the goal both stalled, one more round of the two
before Informed RRT*'s samples take over."""


class GoalTree:
    """The goal-rooted tree beside ``tree`` (module docstring), until they are joined.

    Args:
        tree: the planner's tree; its checker and step size are shared.
    """

    def __init__(self, tree: Tree) -> None:
        self.tree = Tree(tree.problem.swapped(), step_size=tree.step_size, checker_of=tree)
        self._context = compiled_context_of(tree.checker)
        self._checked = np.array([tree.num_nodes, 0], dtype=np.int64)
        """Nodes of the planner's tree and of this one tried against the other so far: the
        planner's older nodes are reached through this tree's nearest queries. The compiled
        sequence after a stall moves them on too (`_compiled_sequence`)."""
        self._grafted = 0
        """Nodes of this tree copied into the planner's (its branch, once joined)."""

    @property
    def joined(self) -> bool:
        """Whether the trees are joined (the planner's tree then has the grafted branch)."""
        return self._grafted > 0

    @property
    def extra_nodes(self) -> int:
        """Nodes this tree adds to the planner's count: all of them but the grafted branch."""
        return self.tree.num_nodes - self._grafted

    def grow_by_attention(
        self,
        tree: Tree,
        policy: SamplingPolicy,
        rng: np.random.Generator,
        log: AnytimeLog,
        goal_bias: float,
        limits: AttentionLimits,
        **options,
    ) -> AttentionOutcome:
        """Grow this tree by the policy's attention phase (from the goal) until it meets ``tree``.

        The policy plans the swapped problem (it is reset to it, then back to ``tree``'s
        problem): the way out of a pocket is the way in, read backwards, and a policy that
        stalled entering the goal's pocket usually leaves it. Every `CHECK_EVERY` new nodes
        are tried against the planner's tree (`_join`); the phase ends joined, or by the stop
        rules of ``limits`` (its stall patience among them), which count the nodes and samples
        of both trees. ``options`` are `run_attention_phase`'s.
        """
        policy.reset(self.tree.problem)
        try:
            outcome = self._attend(self.tree, tree, policy, rng, log, goal_bias, limits, **options)
        finally:
            policy.reset(tree.problem)
        return outcome

    def grow_from_goal_and_in_rounds(
        self,
        tree: Tree,
        policy: SamplingPolicy,
        rng: np.random.Generator,
        log: AnytimeLog,
        goal_bias: float,
        limits: AttentionLimits,
        rounds: int,
        **options,
    ) -> tuple[str, int]:
        """`grow_by_attention`, then, if it stalled, `grow_in_rounds`: the phases after a stall.

        Returns the stop of the phase from the goal and the rounds begun (0 when it did not
        stall, or ``tree`` has a solution, or ``rounds`` is 0). For a policy with a compiled
        proposer and a checker with a compiled path, the whole sequence runs in
        `temp_gym.planning._compiled_attention.attention_sequence`, which returns to Python
        only to grow a tree, to look at the clock and when the sequence ends; it grows the
        same trees as the two methods (tested). ``options`` are `run_attention_phase`'s.
        """
        if set(options) <= _SEQUENCE_OPTIONS:
            compiled_run = self._compiled_sequence(
                tree, policy, rng, log, goal_bias, limits, rounds, **options
            )
            if compiled_run is not None:
                return compiled_run
        from_goal = self.grow_by_attention(tree, policy, rng, log, goal_bias, limits, **options)
        begun = 0
        if from_goal.stop == "stalled" and rounds > 0 and tree.best_node < 0:
            begun = self.grow_in_rounds(
                tree, policy, rng, log, goal_bias, limits, rounds, **options
            )
        return from_goal.stop, begun

    def _compiled_sequence(
        self,
        tree: Tree,
        policy: SamplingPolicy,
        rng: np.random.Generator,
        log: AnytimeLog,
        goal_bias: float,
        limits: AttentionLimits,
        rounds: int,
        uniform: float = 0.0,
        follow_fallback: float = 1.0,
        keep_chunk: bool = False,
    ) -> tuple[str, int] | None:
        """`grow_from_goal_and_in_rounds` in compiled code, or None when it cannot run there."""
        proposer_of = fast_path(policy, "compiled_proposer")
        if proposer_of is None or self._context is None or not SEQUENCE_COMPILED:
            return None
        planner_proposer = proposer_of()
        policy.reset(self.tree.problem)
        try:
            goal_tree_proposer = proposer_of()
        finally:
            policy.reset(tree.problem)
        if planner_proposer is None or goal_tree_proposer is None:
            return None
        weights, _, _, _, policy_rng, noise_std, chunk, max_path_length = planner_proposer
        dim = tree.dim
        noise_std = float(noise_std)
        noise_rng = policy_rng if noise_std > 0 else rng  # without noise, never drawn
        # Both generators stay alive in this frame while the slices draw from them by address.
        rng_address, noise_address = address(rng), address(noise_rng)
        goal = np.ascontiguousarray(tree.problem.goal, dtype=np.float64)
        start = np.ascontiguousarray(tree.problem.start, dtype=np.float64)
        bounds = np.ascontiguousarray(tree.problem.bounds, dtype=np.float64)
        base_limits, buffer, cursor, proposals, chunk_out, path_rows, state, closest = loop_arrays(
            limits, CHECK_EVERY, dim, chunk, max_path_length
        )
        phase_limits = base_limits.copy()
        sequence = np.zeros(len(compiled.SEQUENCE), dtype=np.int64)
        sequence[compiled.ROUNDS] = rounds
        sequence[compiled.FROM_GOAL_STATUS] = sequence[compiled.LAST_STATUS] = -1
        record = np.array([-1, -1, 0], dtype=np.int64)
        prefixes = (planner_proposer[1:4], goal_tree_proposer[1:4])
        iterations = slice_length(limits.deadline, time.perf_counter(), 0.0)
        timed_out, status = False, compiled.RUNNING
        while True:
            began = time.perf_counter()
            if began >= limits.deadline:
                timed_out = True
                break
            planner = tree.compiled_state()
            goal_tree = self.tree.compiled_state()
            status = compiled.attention_sequence(
                planner, goal_tree, goal, start, bounds, self._context, rng_address, buffer,
                cursor, float(goal_bias), float(uniform), float(follow_fallback),
                bool(keep_chunk), weights, prefixes[0], prefixes[1], noise_std, noise_address,
                proposals, chunk_out, path_rows, state, closest, float(limits.near_sq),
                base_limits, phase_limits, sequence, self._checked, record, iterations,
            )  # fmt: skip
            tree.load_compiled_state(planner[1], planner[2])
            self.tree.load_compiled_state(goal_tree[1], goal_tree[2])
            tree.collision_checks += int(record[LINK_CHECKS])
            record[LINK_CHECKS] = 0
            if status == compiled.RUNNING:  # a whole slice ran: its pace sizes the next one
                now = time.perf_counter()
                iterations = slice_length(limits.deadline, now, (now - began) / iterations)
            elif status == compiled.FULL_PLANNER:
                tree.grow()
            elif status == compiled.FULL_GOAL:
                self.tree.grow()
            elif status == compiled.NOT_FINITE:
                raise ValueError("action: the policy proposed a sample that is not finite")
            else:
                break
        phase = int(sequence[compiled.PHASE])
        if status == compiled.JOINED and not timed_out:
            self._graft(tree, int(record[PLANNER_NODE]),
                        int(record[GOAL_NODE]), log)  # fmt: skip
        elif phase % 2 == 1 and tree.best_node >= 0 and not self.joined:
            log.extra_nodes = self.extra_nodes
            log.record_tree(tree)  # a round's phase on the planner's tree reached the goal
        log.extra_nodes = self.extra_nodes
        if timed_out:
            last = "time"
        else:
            last = _SEQUENCE_STOPS[int(sequence[compiled.LAST_STATUS])]
        if phase > 0:
            return _SEQUENCE_STOPS[int(sequence[compiled.FROM_GOAL_STATUS])], (phase + 1) // 2
        return last, 0

    def grow_in_rounds(
        self,
        tree: Tree,
        policy: SamplingPolicy,
        rng: np.random.Generator,
        log: AnytimeLog,
        goal_bias: float,
        limits: AttentionLimits,
        rounds: int,
        **options,
    ) -> int:
        """After both attention phases stalled: up to ``rounds`` more rounds of the two.

        A round is the attention phase resumed on the planner's tree (from its newest node,
        progress counted from its closest approach to the goal), then, if that stalls too, on
        this tree (`grow_by_attention`, resumed alike). Each phase keeps the stop rules of
        ``limits`` and tries its new nodes against the other tree every `CHECK_EVERY` nodes.
        The rounds end when a phase joins the trees or solves the problem, or stops for any
        reason but a stall. Returns the rounds begun.
        """
        for begun in range(1, rounds + 1):
            outcome = self._attend(
                tree, tree, policy, rng, log, goal_bias, limits, resumed=True, **options
            )
            if tree.best_node >= 0 and not self.joined:  # it reached the goal region itself
                log.record_tree(tree)
            if outcome.stop != "stalled" or tree.best_node >= 0:
                return begun
            outcome = self.grow_by_attention(
                tree, policy, rng, log, goal_bias, limits, resumed=True, **options
            )
            if outcome.stop != "stalled" or tree.best_node >= 0:
                return begun
        return rounds

    def _attend(
        self,
        grown: Tree,
        tree: Tree,
        policy: SamplingPolicy,
        rng: np.random.Generator,
        log: AnytimeLog,
        goal_bias: float,
        limits: AttentionLimits,
        **options,
    ) -> AttentionOutcome:
        """The attention phase on ``grown`` (``tree``, the planner's, or this one), checking joins.

        ``policy`` must be reset to ``grown``'s problem (the callers do). The budgets of
        ``limits`` count the nodes and samples of both trees.
        """
        other = self.tree if grown is tree else tree
        used_nodes, used_samples = other.num_nodes, other.samples
        budget = dataclasses.replace(
            limits,
            attention_nodes=max(limits.attention_nodes - used_nodes, 0),
            max_nodes=max(limits.max_nodes - used_nodes, 0),
            max_samples=max(limits.max_samples - used_samples, 0),
        )
        outcome = run_attention_phase(
            grown, policy, rng, goal_bias, budget,
            joined=lambda: self._join(tree, log), check_every=CHECK_EVERY, **options,
        )  # fmt: skip
        log.extra_nodes = self.extra_nodes
        return outcome

    def grow_until_joined(
        self, tree: Tree, settings: PlanSettings, rng: np.random.Generator, log: AnytimeLog,
        max_nodes: int,
    ) -> bool:  # fmt: skip
        """Grow both trees in turns until they are joined; return whether there is a solution.

        The turns also end when the planner's tree solves the problem by itself, or both
        trees together reach ``max_nodes``, or a sample or time limit of ``settings``.

        ``log`` records the first solution with both trees' nodes.
        """
        deadline = settings.deadline(log.started)
        goal_log = AnytimeLog(started=log.started)
        while True:
            if self._join(tree, log):
                return True
            total = tree.num_nodes + self.tree.num_nodes
            samples = tree.samples + self.tree.samples
            if total >= max_nodes or samples >= settings.sample_limit:
                return False
            if time.perf_counter() >= deadline:
                return False
            forward = settings.derived(
                max_nodes=int(tree.num_nodes + min(TURN_NODES, (max_nodes - total + 1) // 2)),
                max_samples=int(max(settings.sample_limit - self.tree.samples, 1)),
                stop_at_first=True,
            )
            log.extra_nodes = self.extra_nodes
            grow_anytime(tree, forward, rng, log, informed=True)
            if tree.best_node >= 0:
                return True
            turn = min(TURN_NODES, max_nodes - tree.num_nodes - self.tree.num_nodes)
            if turn <= 0:
                continue
            backward = settings.derived(
                max_nodes=int(self.tree.num_nodes + turn),
                max_samples=int(max(settings.sample_limit - tree.samples, 1)),
                stop_at_first=False,
                target_cost=None,
            )
            grow_anytime(self.tree, backward, rng, goal_log, informed=False)
            log.extra_nodes = self.extra_nodes  # what the planner's next record adds

    def _join(self, tree: Tree, log: AnytimeLog) -> bool:
        """Try the new nodes of both trees against the other; graft on the first free link.

        Compiled for a checker with a compiled path (`_compiled_tree.link_trees`, which the
        compiled sequence after a stall calls too), else the same tries from Python.
        """
        if self._context is not None:
            ours, theirs = tree.compiled_state()[0], self.tree.compiled_state()[0]
            record = np.array([-1, -1, 0], dtype=np.int64)
            linked = link_trees(
                (ours[0], ours[9], ours[4]), tree.num_nodes, (theirs[0], theirs[9], theirs[4]),
                self.tree.num_nodes, self._checked, self._context, record,
            )  # fmt: skip
            tree.collision_checks += int(record[LINK_CHECKS])
            link = (int(record[PLANNER_NODE]), int(record[GOAL_NODE])) if linked else None
        else:
            link = self._first_link(tree, self.tree, 0, towards_other=True)
            if link is None:
                found = self._first_link(self.tree, tree, 1, towards_other=False)
                link = None if found is None else (found[1], found[0])
        if link is None:
            return False
        self._graft(tree, link[0], link[1], log)
        return True

    def _first_link(
        self, tree: Tree, other: Tree, side: int, towards_other: bool
    ) -> tuple[int, int] | None:
        """The first unchecked node of ``tree`` with a free motion to its nearest in ``other``.

        Returns ``(i, j)``, the nodes of ``tree`` and ``other``, the motion checked from ``i``
        to ``j`` when ``towards_other`` (else back), or None. The tries from Python over the
        checker's ``edge_free`` (`_compiled_tree.first_link` is the compiled loop); the checks
        count in the planner's tree.
        """
        planner_tree = tree if side == 0 else other
        first, count = self._checked[side], tree.num_nodes
        theirs = other.compiled_state()[0]
        node = partner = -1
        for i in range(first, count):
            j, _ = nearest(other.positions, other.num_nodes, tree.positions[i], theirs[9],
                           theirs[4])  # fmt: skip
            planner_tree.collision_checks += 1
            ends = (tree.positions[i], other.positions[j])
            if self.tree.checker.edge_free(*(ends if towards_other else ends[::-1])):
                node, partner = i, int(j)
                break
        self._checked[side] = count if node < 0 else node + 1
        return None if node < 0 else (int(node), int(partner))

    def _graft(self, tree: Tree, forward_node: int, goal_node: int, log: AnytimeLog) -> None:
        """Append the goal tree's branch from ``goal_node`` to the goal under ``forward_node``."""
        branch = self.tree.path_to(goal_node)[::-1].copy()  # goal_node first, the goal last
        while tree.capacity < tree.num_nodes + len(branch):
            tree.grow()
        arrays, counters, best_cost, params = tree.compiled_state()
        goal = np.ascontiguousarray(tree.problem.goal, dtype=np.float64)
        self._grafted = graft_branch(
            arrays, counters, best_cost, params, goal, forward_node, branch
        )
        tree.load_compiled_state(counters, best_cost)
        tree.samples += self.tree.samples
        tree.sampling_failures += self.tree.sampling_failures
        tree.collision_checks += self.tree.collision_checks
        log.extra_nodes = self.extra_nodes
        log.record_tree(tree)


SEQUENCE_COMPILED = True
"""Whether `GoalTree.grow_from_goal_and_in_rounds` runs its phases in compiled code when it
can (tests turn it off to compare with the phases driven from Python)."""
_SEQUENCE_OPTIONS = {"uniform", "follow_fallback", "keep_chunk"}
"""The `run_attention_phase` options the compiled sequence takes (others: the Python phases)."""
_SEQUENCE_STOPS = {
    compiled.SOLVED: "solved",
    compiled.ATTENTION_BUDGET: "attention_budget",
    compiled.BUDGET: "budget",
    compiled.STALLED_OUT: "stalled",
    compiled.JOINED: "joined",
}


__all__ = ["ATTENTION_ROUNDS", "CHECK_EVERY", "TURN_NODES", "GoalTree"]
