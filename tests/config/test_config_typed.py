"""temp_gym.config.typed: dataclasses from mappings, every key and type checked."""

from __future__ import annotations

import dataclasses
import doctest

import pytest

import temp_gym.config.typed
from temp_gym.config import ConfigError
from temp_gym.config.typed import build, convert, fill_defaults, replace_key, to_dict


@dataclasses.dataclass(frozen=True)
class Inner:
    count: int | None = None
    names: list[str] = dataclasses.field(default_factory=list)


@dataclasses.dataclass(frozen=True)
class Outer:
    path: str
    rate: float = 0.5
    steps: int = 3
    on: bool = True
    inner: Inner = dataclasses.field(default_factory=Inner)


def test_absent_keys_take_defaults_and_values_keep_their_meaning():
    built = build(Outer, {"path": "x", "rate": 2, "steps": 4.0, "inner": {"names": ("a", "b")}})
    assert built == Outer("x", 2.0, 4, True, Inner(None, ["a", "b"]))
    assert isinstance(built.rate, float) and isinstance(built.steps, int)
    assert build(Outer, {"path": "x", "rate": "1e-3"}).rate == 1e-3  # YAML 1.1 reads it as text
    assert build(Outer, {"path": "x", "inner": None}).inner == Inner()  # an empty YAML heading
    assert to_dict(built) == {"path": "x", "rate": 2.0, "steps": 4, "on": True,
                              "inner": {"count": None, "names": ["a", "b"]}}  # fmt: skip


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"path": "x", "step": 1}, "unknown key step (did you mean steps?)"),
        (
            {"path": "x", "inner": {"cuont": 1}},
            "unknown key inner.cuont (did you mean inner.count?)",
        ),
        ({"path": "x", "zzz": 1}, "unknown key zzz"),
        ({}, "path: missing (it has no default)"),
        ({"path": 3}, "path: expected a string, got 3"),
        ({"path": "x", "steps": 2.5}, "steps: expected an integer, got 2.5"),
        ({"path": "x", "steps": True}, "steps: expected an integer, got True"),
        ({"path": "x", "steps": "3"}, "steps: expected an integer, got '3'"),
        ({"path": "x", "rate": "fast"}, "rate: expected a number, got 'fast'"),
        ({"path": "x", "rate": "nan"}, "rate: expected a number, got 'nan'"),
        ({"path": "x", "on": "yes please"}, "on: expected true or false, got 'yes please'"),
        ({"path": "x", "on": 1}, "on: expected true or false, got 1"),
        (
            {"path": "x", "inner": {"count": 1.5}},
            "inner.count: expected an integer or null, got 1.5",
        ),
        (
            {"path": "x", "inner": {"names": "ab"}},
            "inner.names: expected a list of strings, got 'ab'",
        ),
        ({"path": "x", "inner": {"names": ["a", 2]}}, "inner.names[1]: expected a string, got 2"),
        ({"path": "x", "inner": [1]}, "inner: expected a mapping of keys, got [1]"),
    ],
)
def test_bad_values_are_refused_naming_the_key(values, message):
    with pytest.raises(ConfigError) as error:
        build(Outer, values)
    assert str(error.value) == message


def test_replace_key_sets_one_dotted_key_with_the_same_checks():
    base = build(Outer, {"path": "x", "inner": {"count": 1, "names": ["a"]}})
    assert replace_key(base, "inner.count", 5).inner == Inner(5, ["a"])
    assert replace_key(base, "inner.count", None).inner.count is None
    assert replace_key(base, "rate", 1).rate == 1.0
    # A mapping is merged into the section, key by key: its absent keys keep their values.
    assert replace_key(base, "inner", {"count": 2}).inner == Inner(2, ["a"])
    assert replace_key(base, "inner", {}).inner == Inner(1, ["a"])
    with pytest.raises(ConfigError, match=r"unknown key inner.cont \(did you mean inner.count"):
        replace_key(base, "inner", {"cont": 2})
    with pytest.raises(ConfigError, match="inner.count: expected an integer or null, got 'a'"):
        replace_key(base, "inner", {"count": "a"})
    assert base.inner == Inner(1, ["a"])  # frozen: the original is unchanged
    with pytest.raises(ConfigError, match=r"unknown key inner.cont \(did you mean inner.count"):
        replace_key(base, "inner.cont", 1)
    with pytest.raises(ConfigError, match=r"unknown key rate.x \(rate is a value, not a section\)"):
        replace_key(base, "rate.x", 1)
    with pytest.raises(ConfigError, match="inner.count: expected an integer or null, got 'a'"):
        replace_key(base, "inner.count", "a")


def test_fill_defaults_completes_an_older_dict_and_keeps_what_is_gone():
    older = {"path": "x", "steps": 7, "removed": 1, "inner": {"count": 2}}
    filled = fill_defaults(Outer, older)
    assert filled == {"path": "x", "steps": 7, "removed": 1, "rate": 0.5, "on": True,
                      "inner": {"count": 2, "names": []}}  # fmt: skip
    assert fill_defaults(Outer, {"steps": "7"})["steps"] == "7"  # stored values are not converted
    assert older == {"path": "x", "steps": 7, "removed": 1, "inner": {"count": 2}}


def test_convert_of_an_instance_keeps_it():
    inner = Inner(3)
    assert convert(inner, Inner, "inner") is inner


def test_the_module_docstring_example_runs():
    outcome = doctest.testmod(temp_gym.config.typed)
    assert outcome.attempted >= 3 and outcome.failed == 0
