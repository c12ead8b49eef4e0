"""`TEMPSettings`: the ``temp`` planner's settings, the common ones and its own.

Every field of its own is None by default, which means "the policy's own, else the planner's
default": a shipped policy carries the settings it was tuned with (its checkpoint's
``planner`` entry, applied by `temp_gym.load_policy`), and the planner reads them from the
policy where the caller set nothing (`resolve`). The fields a policy may declare are marked
(`DECLARED`); `temp_gym.planning.policy` reads exactly those.

    >>> settings = TEMPSettings(max_nodes=3000, attention_patience=30)
    >>> plan(problem, settings=settings)                        # the same as
    >>> plan(problem, planner="temp", max_nodes=3000, attention_patience=30)

Each field's check is declared with it (`check`), so that a policy's declared value, a
config key or a script's flag is refused as the planner would refuse it, naming its own
field (``policy.attention_rounds``, ``train_eval.temp.attention_rounds``, ``--rounds``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import Any

from temp_gym.planning.settings import PlanSettings, count, finite_at_least, flag, share

Check = Callable[[object, str], Any]


def near_goal_factor(value: object, name: str = "attention_near_goal_factor") -> float:
    """A stall-patience factor near the goal: a finite real number of at least 1."""
    return finite_at_least(value, name, 1.0)


def resume_factor(value: object, name: str = "attention_resume") -> float:
    """A resume factor: a finite real number of at least 0 (0: never resume).

    It counts the classical nodes between a stall and the resumed attention phase in stall
    patiences (`TEMPSettings.attention_resume`).
    """
    return finite_at_least(value, name, 0.0)


def resume_growth(value: object, name: str = "attention_resume_growth") -> float:
    """A growth factor of the classical turns between resumed phases: finite, at least 1."""
    return finite_at_least(value, name, 1.0)


def local_fallback_count(value: object, name: str = "attention_local_fallback") -> int:
    """A count of replacements drawn near a colliding proposal (0: none, Algorithm 1)."""
    return count(value, name, 0)


def rounds_count(value: object, name: str = "attention_rounds") -> int:
    """A number of rounds of the attention phase after it stalled both ways: an integer >= 0."""
    return count(value, name, 0)


def _budget(value: object, name: str) -> int:
    return count(value, name, 1)


def _patience(value: object, name: str) -> int:
    return count(value, name, 0)


def _policy(value: object, name: str) -> Any:
    from temp_gym.planning.policy import as_sampling_policy  # the contract imports this module

    return as_sampling_policy(value)  # a ValueError naming the policy for anything else


def _own(check: Check, declared: bool = True, **options: Any) -> Any:
    """A field of the planner's own: None by default, checked by ``check`` when given."""
    return field(default=None, metadata={"check": check, "declared": declared}, **options)


@dataclass(frozen=True)
class TEMPSettings(PlanSettings):
    """The ``temp`` planner's settings: `PlanSettings` plus the attention phase's.

    None, for each field below, means the policy's own setting when it declares one (a
    shipped policy does), else the planner's default, which the field says.

    Raises:
        ValueError: naming the first invalid field and what it expected, or a pair of fields
            that contradict each other.
    """

    policy: Any = _own(_policy, declared=False, compare=False, repr=False)
    """The sampling policy (`temp_gym.planning.policy.SamplingPolicy`); None: the policy
    shipped for the robot (`temp_gym.load_policy`)."""
    attention_nodes: int | None = _own(_budget)
    """Most tree nodes for attention-based planning, the n of Algorithm 1 (default: all of
    ``max_nodes``)."""
    attention_patience: int | None = _own(_patience)
    """Attention-phase nodes in a row without a closer approach to the goal before classical
    planning takes over (default: `temp_gym.planning.attention.default_patience`, in
    proportion to the start-goal distance; 0: never, Algorithm 1 as written)."""
    attention_uniform: float | None = _own(share)
    """Probability of a uniform sample instead of the policy's in the attention phase
    (default 0)."""
    attention_near_goal_factor: float | None = _own(near_goal_factor)
    """How many times ``attention_patience`` the attention phase waits once the tree's closest
    approach to the goal is within `temp_gym.planning.attention.NEAR_GOAL_SHARE` of the
    start-goal distance (at least 1; default 1, the same patience everywhere)."""
    attention_follow_fallback: float | None = _own(share)
    """Probability that the policy goes on from a fallback node (a uniform sample that
    replaced a colliding proposal) which brought the tree no closer to the goal; otherwise
    the path so far it reads stays the one it read before (default 1: always, Algorithm 1's
    UpdatePath)."""
    attention_keep_chunk: bool | None = _own(flag, declared=False)
    """For a policy that proposes several samples per call (a chunk): when a proposal collided
    and a uniform fallback sample replaced it, go on with the chunk's next proposal (True:
    fewer nodes to a first solution, costlier paths) or call the policy again (default
    False)."""
    attention_resume: float | None = _own(resume_factor)
    """After the attention phase stalls, classical planning adds this many stall patiences of
    nodes, then the attention phase resumes from the newest node, in turns until the first
    solution (default `temp_gym.planning.attention.RESUME_AFTER`; 0: never)."""
    attention_resume_growth: float | None = _own(resume_growth)
    """Each classical turn between resumed attention phases is this many times longer than
    the one before (at least 1; default 1, equal turns). Above 1, a policy that keeps stalling
    hands the search over to Informed RRT* by degrees."""
    goal_tree: bool | None = _own(flag, declared=False)
    """When the attention phase ends without a solution, grow a second tree from the goal
    beside the planner's until the two meet (`temp_gym.planning.goal_tree`; its nodes count
    against ``max_nodes``; default True; False: Informed RRT* alone)."""
    attention_from_goal: bool | None = _own(flag, declared=False)
    """When the attention phase stalls, the policy first grows the goal tree (its attention
    phase on the swapped problem) until the two trees meet or it stalls too (default True
    with the goal tree; False: the goal tree grows by Informed RRT*'s samples alone). Needs
    the goal tree."""
    attention_rounds: int | None = _own(rounds_count)
    """After the attention phases from the start and from the goal both stalled, up to this
    many more rounds of the two, a resumed phase on each tree in turn (default
    `temp_gym.planning.goal_tree.ATTENTION_ROUNDS`; 0: none). Needs the phase from the goal."""
    attention_local_fallback: int | None = _own(local_fallback_count)
    """When a policy's proposal collides, this many of its replacements are drawn near it
    before uniform ones (`temp_gym.planning.tree.Tree.extend_with_fallback`; default 0,
    Algorithm 1's uniform replacements)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        for name in OWN:
            value = getattr(self, name)
            if value is not None:
                self._normalize(name, check(name, value))
        if self.attention_from_goal and self.goal_tree is False:
            raise ValueError(
                "attention_from_goal: the policy grows the goal tree, which goal_tree=False "
                "turns off; pass attention_from_goal=False or None with it"
            )
        if self.attention_rounds and (self.attention_from_goal is False or self.goal_tree is False):
            raise ValueError(
                "attention_rounds: the rounds follow the attention phase from the goal, which "
                "attention_from_goal=False or goal_tree=False turns off; pass 0 or None with them"
            )

    @classmethod
    def at(cls, where: str, **values: Any) -> TEMPSettings:
        """``TEMPSettings(**values)``, a bad value's error naming it ``{where}.{field}``.

        For settings read from a config section (``train_eval.temp``) or a file.
        """
        try:
            return cls(**values)
        except (TypeError, ValueError) as error:
            raise ValueError(f"{where}.{error}") from None


OWN = tuple(f.name for f in fields(TEMPSettings) if "check" in f.metadata)
"""The fields `TEMPSettings` adds to `PlanSettings`."""

DECLARED = tuple(f.name for f in fields(TEMPSettings) if f.metadata.get("declared"))
"""The fields a policy may declare as attributes (`temp_gym.planning.policy`), which the
planner reads from it when the caller set none."""

_CHECKS: dict[str, Check] = {
    f.name: f.metadata["check"] for f in fields(TEMPSettings) if f.name in OWN
}


def check(name: str, value: object, label: str | None = None) -> Any:
    """``value`` checked and normalized as field ``name`` of `TEMPSettings` takes it.

    ``label`` names the value in the error (default ``name``): ``policy.attention_rounds``
    for a policy's declared value, ``--rounds`` for a script's flag.

    Raises:
        ValueError: one line naming ``label``.
        KeyError: ``name`` is not a field of the planner's own.
    """
    return _CHECKS[name](value, name if label is None else label)


def resolve(settings: TEMPSettings, policy: Any, name: str, default: Any) -> Any:
    """Field ``name``: the caller's (checked already), else the policy's, else ``default``.

    A policy's declared value is checked as the field is, naming it ``policy.<name>``.
    """
    given = getattr(settings, name)
    if given is not None:
        return given
    declared = getattr(policy, name, None) if name in DECLARED else None
    return default if declared is None else check(name, declared, f"policy.{name}")


__all__ = [
    "DECLARED",
    "OWN",
    "TEMPSettings",
    "check",
    "local_fallback_count",
    "near_goal_factor",
    "resolve",
    "resume_factor",
    "resume_growth",
    "rounds_count",
]
