"""The planner registry and `plan()`'s settings: a new planner plugs in with its own class."""

from __future__ import annotations

import dataclasses
import inspect
import json
from pathlib import Path

import numpy as np
import pytest

from temp_gym import Problem, load_policy
from temp_gym.planning import (
    PLANNERS,
    InformedRRTStarSettings,
    PlanSettings,
    RRTStarSettings,
    TEMPSettings,
    plan,
    register_planner,
)
from temp_gym.planning.planners import run_tree_planner
from temp_gym.planning.registry import settings_for
from temp_gym.planning.settings import field_names, positive
from temp_gym.planning.temp_settings import DECLARED

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def problem():
    return Problem.from_dict(json.loads((ROOT / "examples" / "point2d.json").read_text()))


def same_plan(a, b) -> bool:
    return (
        a.nodes == b.nodes
        and a.samples == b.samples
        and a.cost == b.cost
        and np.array_equal(a.path, b.path)
    )


def test_plan_takes_a_few_parameters():
    assert len(inspect.signature(plan).parameters) <= 8


def test_every_built_in_planner_registers_its_settings_class():
    classes = {name: entry.settings for name, entry in PLANNERS.items()}
    assert classes["temp"] is TEMPSettings and classes["rrt_star"] is RRTStarSettings
    assert classes["informed_rrt_star"] is InformedRRTStarSettings
    assert {"range", "k_nearest"} <= field_names(classes["ompl_rrt_star"])
    assert len(set(classes.values())) == len(classes)  # each planner its own class


def test_a_settings_object_a_common_one_and_shortcuts_plan_alike(problem):
    shortcuts = plan(problem, "rrt_star", seed=3, max_nodes=300)
    assert same_plan(shortcuts, plan(problem, settings=RRTStarSettings(seed=3, max_nodes=300)))
    assert same_plan(shortcuts, plan(problem, "rrt_star", PlanSettings(seed=3, max_nodes=300)))
    assert same_plan(shortcuts, plan(problem, "rrt_star", RRTStarSettings(seed=9), seed=3,
                                     max_nodes=300))  # fmt: skip
    temp = plan(problem, seed=2, max_nodes=300, attention_patience=40)  # temp: the default
    assert temp.planner == "temp"
    assert same_plan(
        temp, plan(problem, settings=TEMPSettings(seed=2, max_nodes=300, attention_patience=40))
    )


@pytest.mark.parametrize(
    ("call", "message"),
    [
        ({"planner": "rrt_star", "attention_patience": 30},
         "attention_patience: only the temp planner takes it, not rrt_star; use plan(problem, "
         "planner='temp', settings=TEMPSettings(attention_patience=...))"),
        ({"planner": "rrt_star", "policy": object()}, "policy: only the temp planner takes it"),
        ({"planner": "temp", "range": 0.5},
         "range: only the rrt_connect, ompl_rrt_star, ompl_informed_rrt_star and "
         "ompl_rrt_connect planners take it, not temp; use plan(problem, planner='rrt_connect', "
         "settings=RRTConnectSettings(range=...))"),
        ({"attention_patiense": 30}, "attention_patiense: not a setting of the temp planner "
         "(did you mean attention_patience?); TEMPSettings has "),
        ({"planner": "rrt_star", "settings": TEMPSettings()},
         "settings: the rrt_star planner takes RRTStarSettings, got TEMPSettings (the temp "
         "planner's); pass planner='temp' with it, or RRTStarSettings(...)"),
        ({"settings": {"seed": 1}}, "settings: the temp planner takes TEMPSettings, got dict"),
        ({"planner": "rrt_sharp"}, "planner: unknown planner 'rrt_sharp'; expected one of"),
    ],
)  # fmt: skip
def test_an_old_or_wrong_form_is_one_line_naming_the_form_to_use(problem, call, message):
    with pytest.raises(ValueError) as error:
        plan(problem, **call)
    assert str(error.value).startswith(message) and "\n" not in str(error.value)


def test_another_planners_setting_left_none_is_not_set(problem):
    # Older code passed TEMP's settings to every planner alike, None for the others.
    assert same_plan(
        plan(problem, "rrt_star", seed=1, max_nodes=200, policy=None, attention_nodes=None),
        plan(problem, "rrt_star", seed=1, max_nodes=200),
    )


@dataclasses.dataclass(frozen=True)
class StepsSettings(PlanSettings):
    """A planner of a user's: RRT* with OMPL's ``range`` as its steering step."""

    range: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.range is not None:
            self._normalize("range", positive(self.range, "range"))


def _steps(problem, settings: StepsSettings):
    step = settings.step_size if settings.range is None else settings.range
    return run_tree_planner(problem, dataclasses.replace(settings, step_size=step), "steps", False)


def test_a_planner_added_later_brings_its_settings_and_widens_no_shared_class(problem):
    before = {name: field_names(entry.settings) for name, entry in PLANNERS.items()}
    register_planner("steps", _steps, StepsSettings)
    try:
        assert {name: field_names(PLANNERS[name].settings) for name in before} == before
        ours = plan(problem, "steps", seed=1, max_nodes=200, range=0.5)
        assert same_plan(ours, plan(problem, settings=StepsSettings(seed=1, max_nodes=200,
                                                                    range=0.5)))  # fmt: skip
        assert same_plan(ours, plan(problem, "rrt_star", seed=1, max_nodes=200, step_size=0.5))
        with pytest.raises(ValueError, match="^range: expected a positive number"):
            plan(problem, "steps", range=-1.0)
        with pytest.raises(ValueError, match=r"^range: only the .*and steps planners take it"):
            plan(problem, "rrt_star", range=0.5)
        with pytest.raises(ValueError, match="already registered"):
            register_planner("steps", _steps, StepsSettings)
    finally:
        PLANNERS.pop("steps")
    with pytest.raises(ValueError, match="^settings: expected a dataclass extending PlanSettings"):
        register_planner("other", _steps, dict)
    assert "other" not in PLANNERS


def test_settings_for_keeps_the_common_fields_of_a_plain_settings_object():
    chosen = settings_for("temp", PlanSettings(seed=4, max_nodes=99), attention_rounds=2)
    assert chosen == TEMPSettings(seed=4, max_nodes=99, attention_rounds=2)


def test_plan_uses_the_settings_the_shipped_policy_carries_unless_told_otherwise(problem):
    shipped = load_policy("TEMP-2D-v0")
    carried = {name: value for name, value in shipped.planner_settings().items() if value}
    assert carried  # the 2D policy carries its tuned settings (its model card's)
    bare = shipped.fresh(**dict.fromkeys(DECLARED))  # the same model, carrying none
    default = plan(problem, seed=5, max_nodes=400, stop_at_first=True)
    assert same_plan(default, plan(problem, seed=5, max_nodes=400, stop_at_first=True,
                                   policy=bare, **carried))  # fmt: skip
    told = plan(problem, seed=5, max_nodes=400, stop_at_first=True, attention_local_fallback=0)
    assert same_plan(told, plan(problem, seed=5, max_nodes=400, stop_at_first=True, policy=bare,
                                **{**carried, "attention_local_fallback": 0}))  # fmt: skip


def test_a_planner_of_the_common_settings_alone_takes_no_one_elses(problem):
    register_planner("plain", lambda problem, settings: _steps(problem, StepsSettings(
        **vars(settings))), PlanSettings)  # fmt: skip
    try:
        common = PlanSettings(seed=1, max_nodes=100)
        assert plan(problem, settings=common).planner == "temp"  # every planner takes these
        assert plan(problem, "plain", common).nodes == 100
        with pytest.raises(ValueError, match="^settings: the plain planner takes PlanSettings, "
                           "got TEMPSettings \\(the temp planner's\\)"):  # fmt: skip
            plan(problem, "plain", TEMPSettings(max_nodes=100))
    finally:
        PLANNERS.pop("plain")


def test_a_shared_base_of_a_planners_settings_is_taken_with_its_fields():
    pytest.importorskip("ompl")
    from temp_gym.planning.ompl_planners import OMPLRRTStarSettings, OMPLSettings
    from temp_gym.planning.registry import settings_for

    settings = settings_for("ompl_rrt_star", OMPLSettings(range=0.5, max_nodes=77))
    assert type(settings) is OMPLRRTStarSettings
    assert settings.range == 0.5 and settings.max_nodes == 77
    with pytest.raises(ValueError, match="takes OMPLRRTStarSettings, got TEMPSettings"):
        from temp_gym.planning.temp_settings import TEMPSettings

        settings_for("ompl_rrt_star", TEMPSettings())
