"""Each planner's settings class: the common fields shared, its own beside them, all checked."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from temp_gym.planning import (
    PLANNERS,
    InformedRRTStarSettings,
    OMPLSettings,
    PlanSettings,
    RRTStarSettings,
    TEMPSettings,
)
from temp_gym.planning.policy import POLICY_SETTINGS, PolicySettings
from temp_gym.planning.settings import field_names
from temp_gym.planning.temp_settings import DECLARED, OWN, check, resolve

COMMON = {"seed", "max_nodes", "time_limit", "stop_at_first", "step_size", "goal_bias",
          "target_cost", "max_samples"}  # fmt: skip


def test_the_shared_settings_hold_the_common_fields_and_nothing_of_one_planner():
    assert field_names(PlanSettings) == COMMON
    for entry in PLANNERS.values():
        assert issubclass(entry.settings, PlanSettings)
        assert field_names(entry.settings) >= COMMON
    assert not set(OWN) & COMMON and "attention_local_fallback" in OWN and "policy" in OWN


@pytest.mark.parametrize(
    ("cls", "changes", "message"),
    [
        (PlanSettings, {"max_nodes": 0}, "max_nodes: expected an integer in [1, 2**53], got 0"),
        (PlanSettings, {"seed": -1}, "seed: expected a non-negative integer, got -1"),
        (PlanSettings, {"goal_bias": 1.5}, "goal_bias: expected a number in [0, 1], got 1.5"),
        (PlanSettings, {"step_size": 0}, "step_size: expected a positive number or None, got 0"),
        (PlanSettings, {"stop_at_first": "no"}, "stop_at_first: expected True or False"),
        (RRTStarSettings, {"time_limit": -1}, "time_limit: expected a non-negative number"),
        (InformedRRTStarSettings, {"target_cost": math.nan}, "target_cost: expected a number"),
        (TEMPSettings, {"attention_nodes": 0}, "attention_nodes: expected an integer in [1,"),
        (TEMPSettings, {"attention_patience": -1}, "attention_patience: expected an integer"),
        (TEMPSettings, {"attention_uniform": 2.0}, "attention_uniform: expected a number in"),
        (TEMPSettings, {"attention_near_goal_factor": 0.5}, "attention_near_goal_factor: "),
        (TEMPSettings, {"attention_follow_fallback": -0.1}, "attention_follow_fallback: "),
        (TEMPSettings, {"attention_keep_chunk": 1}, "attention_keep_chunk: expected True or"),
        (TEMPSettings, {"attention_resume": -1.0}, "attention_resume: expected a finite number"),
        (TEMPSettings, {"attention_resume_growth": 0.5}, "attention_resume_growth: expected"),
        (TEMPSettings, {"goal_tree": "yes"}, "goal_tree: expected True or False"),
        (TEMPSettings, {"attention_rounds": 1.5}, "attention_rounds: expected an integer"),
        (TEMPSettings, {"attention_local_fallback": -2}, "attention_local_fallback: expected"),
        (TEMPSettings, {"policy": object()}, "policy: expected a SamplingPolicy"),
        (TEMPSettings, {"goal_tree": False, "attention_from_goal": True}, "attention_from_goal:"),
        (TEMPSettings, {"goal_tree": False, "attention_rounds": 2}, "attention_rounds: the"),
        (OMPLSettings, {"range": 0.0}, "range: expected a positive number or None, got 0.0"),
        (OMPLSettings, {"k_nearest": None}, "k_nearest: expected True or False, got None"),
    ],
)
def test_a_bad_value_is_one_line_naming_the_field(cls, changes, message):
    with pytest.raises(ValueError) as error:
        cls(**changes)
    text = str(error.value)
    assert text.startswith(message) and "\n" not in text


def test_values_are_normalized_to_plain_numbers():
    settings = TEMPSettings(seed=np.int64(3), attention_patience=np.int32(30),
                            attention_resume_growth=2, goal_tree=np.bool_(False))  # fmt: skip
    assert type(settings.seed) is int and type(settings.attention_patience) is int
    assert type(settings.attention_resume_growth) is float and settings.goal_tree is False
    assert OMPLSettings(range=1).range == 1.0 and OMPLSettings().k_nearest is False


def test_a_field_of_another_class_names_the_class_that_has_it():
    with pytest.raises(TypeError) as error:
        PlanSettings(attention_patience=30)
    assert str(error.value) == (
        "PlanSettings has no field attention_patience: it is a setting of the temp planner; "
        "use TEMPSettings(attention_patience=...)"
    )
    with pytest.raises(TypeError, match="^RRTStarSettings has no field range: it is a setting"):
        RRTStarSettings(range=1.0)
    with pytest.raises(TypeError, match="^TEMPSettings has no field nodes$"):
        TEMPSettings(nodes=3)


def test_copies_keep_their_class_and_checks():
    settings = TEMPSettings(max_nodes=100, attention_patience=5)
    assert type(dataclasses.replace(settings, seed=2)) is TEMPSettings
    assert type(settings.derived(max_nodes=50)) is TEMPSettings
    assert settings.derived(max_nodes=50).attention_patience == 5
    assert settings.common() == PlanSettings(max_nodes=100)
    with pytest.raises(ValueError, match="^attention_patience"):
        dataclasses.replace(settings, attention_patience=-1)


def test_one_check_per_field_for_every_entry_point():
    assert check("attention_rounds", 2) == 2
    with pytest.raises(ValueError, match="^--rounds: expected an integer"):
        check("attention_rounds", -1, "--rounds")


def test_the_policy_declares_exactly_the_planner_settings_marked_so():
    assert POLICY_SETTINGS == ("encoding_resolution", "max_path_length", *DECLARED)
    assert set(DECLARED) <= set(OWN)
    assert {"policy", "goal_tree", "attention_keep_chunk"}.isdisjoint(DECLARED)
    assert [field.name for field in dataclasses.fields(PolicySettings)] == list(POLICY_SETTINGS)


class Carrying:
    attention_patience = 30
    attention_rounds = -3  # a bad declared value is refused when used, naming the policy


def test_a_setting_left_none_takes_the_policys_own_then_the_default():
    policy = Carrying()
    assert resolve(TEMPSettings(), policy, "attention_patience", None) == 30
    assert resolve(TEMPSettings(attention_patience=7), policy, "attention_patience", None) == 7
    assert resolve(TEMPSettings(), policy, "attention_uniform", 0.0) == 0.0
    assert resolve(TEMPSettings(), policy, "goal_tree", True) is True  # not declarable
    with pytest.raises(ValueError, match="^policy.attention_rounds: "):
        resolve(TEMPSettings(), policy, "attention_rounds", 1)


def test_a_config_section_maps_onto_the_planners_settings():
    from temp_gym.config import TEMPConfig
    from temp_gym.config.typed import field_types

    own = {name: kind for name, kind in field_types(TEMPSettings).items() if name in OWN}
    own.pop("policy")
    assert field_types(TEMPConfig) == own  # the same keys, in order, with the same types
    with pytest.raises(ValueError, match="^train_eval.temp.attention_rounds: expected"):
        TEMPSettings.at("train_eval.temp", attention_rounds=-1)
