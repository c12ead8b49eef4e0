"""YAML from users: numbers as YAML 1.2 reads them, and documents that cannot be walked refused."""

from __future__ import annotations

import pytest

from temp_gym.limits import MAX_YAML_DEPTH
from temp_gym.yaml_input import load_yaml


def test_exponents_without_a_dot_are_numbers_and_nothing_else_changes():
    text = "a: 6e-3\nb: 1E5\nc: -2e+3\nd: .5e3\ne: '6e-3'\nf: 1.5\ng: 12\nh: 6e\ni: e5\nj: 0x10\n"
    assert load_yaml(text, "f.yaml") == {"a": 0.006, "b": 1e5, "c": -2e3, "d": 500.0,
                                         "e": "6e-3", "f": 1.5, "g": 12, "h": "6e",
                                         "i": "e5", "j": 16}  # fmt: skip
    assert load_yaml(b"a: 1e-05\n", "f.yaml") == {"a": 1e-05}


def test_a_merge_may_override_the_keys_it_brings():
    text = "base: &b {x: 1, y: 2}\nc:\n  <<: *b\n  x: 5\n"
    assert load_yaml(text, "f.yaml")["c"] == {"x": 5, "y": 2}


def test_aliases_may_share_values():
    document = load_yaml("a: &a [[[1]]]\nb: [*a, *a]\nc: {x: *a}\n", "f.yaml")
    assert document == {"a": [[[1]]], "b": [[[[1]]], [[[1]]]], "c": {"x": [[[1]]]}}


@pytest.mark.parametrize(
    "text, message",
    [
        ("a: &a {k: *a}\n", "an alias makes a value contain itself"),
        ("a: &a [1, [2, *a]]\n", "an alias makes a value contain itself"),
        # Nine levels of eight aliases each: 8 ** 9 values when expanded, 80 lines of text.
        (
            "a0: &a0 [0, 0, 0, 0, 0, 0, 0, 0]\n"
            + "".join(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 8)}]\n" for i in range(1, 10)),
            "expands to more than 10,000,000 values",
        ),
        # Deep through an alias: the shared branch is walked where it is met shallow (y),
        # then met again deep inside x.
        (
            "x: " + "[" * 60 + "&a " + "[" * 60 + "1" + "]" * 120 + "\ny: *a\n",
            f"nested more than {MAX_YAML_DEPTH} levels deep",
        ),
        (
            "a: &a 1\nb: " + "[" * (MAX_YAML_DEPTH + 5) + "*a" + "]" * (MAX_YAML_DEPTH + 5) + "\n",
            f"nested more than {MAX_YAML_DEPTH} levels deep",
        ),
        ("a: [1, {b: 2}\n", "not valid YAML at line 2"),
        ("name: a\nurdf: b\nname: c\n", "line 3: found the key 'name' twice"),
    ],
)
def test_documents_that_never_end_or_do_not_parse_are_refused_in_one_line(text, message):
    with pytest.raises(ValueError, match=r"^f\.yaml: ") as error:
        load_yaml(text, "f.yaml")
    assert message in str(error.value) and "\n" not in str(error.value)


def test_bytes_that_are_no_text_are_named_by_their_position():
    # pyyaml's reader error has no "problem": the message said only "ReaderError".
    with pytest.raises(ValueError) as error:
        load_yaml(b"a: 1\n\xc3\x28\n", "f.yaml")
    assert str(error.value) == (
        "f.yaml: not valid YAML: not UTF-8 text at byte 6 (invalid trailing UTF-8 octet)"
    )
