"""Reading a problem's fields: real numbers that cannot overflow, vectors of a given length, JSON.

Every function raises a `ValueError` whose message starts with the field's name, so a user
learns which entry of a problem file is wrong and why.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

MAX_MAGNITUDE = 1e30
"""Largest magnitude of any coordinate or length. Planners square distances and multiply up
to 7 lengths (volumes): beyond this they would overflow to inf."""
MIN_LENGTH = 1e-30
"""Smallest goal radius and bound side: their squares and volumes must not underflow to 0
(a squared goal radius of 0 made a start outside the goal region count as inside)."""


def short(value: Any) -> str:
    """``value`` as text, cut short when it is long (a number of many digits, say)."""
    text = str(value)
    unit = "digits" if isinstance(value, int) and not isinstance(value, bool) else "characters"
    return text if len(text) <= 24 else f"{text[:10]}...({len(text)} {unit})"


def short_repr(value: Any, most: int = 40) -> str:
    """``repr(value)`` for an error message, cut after ``most`` characters."""
    text = repr(value)
    return text if len(text) <= most else f"{text[:most]}...({len(text)} characters)"


def as_float(value: Any, name: str) -> float:
    """``float(value)`` for a real number, or a `ValueError` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise ValueError(f"{name}: expected a number, got {short_repr(value)}")
    if isinstance(value, (complex, np.complexfloating)):
        raise ValueError(f"{name}: expected a real number, got {value!r}")
    try:
        number = float(value)
    except OverflowError:
        raise ValueError(
            f"{name}: {short(value)} is too large (at most {MAX_MAGNITUDE:g})"
        ) from None
    if math.isfinite(number) and abs(number) > MAX_MAGNITUDE:
        raise ValueError(f"{name}: {number:g} is too large (at most {MAX_MAGNITUDE:g})")
    return number


def finite_float(value: Any, name: str) -> float:
    """A finite real number (`as_float`, and neither NaN nor infinite), or a `ValueError`."""
    number = as_float(value, name)
    if not math.isfinite(number):
        raise ValueError(f"{name}: must be finite, got {number}")
    return number


def positive_length(value: Any, name: str) -> float:
    """A positive finite length, or a `ValueError` naming ``name``."""
    number = as_float(value, name)
    if not math.isfinite(number) or number <= 0:
        raise ValueError(f"{name}: must be positive and finite, got {value!r}")
    if number < MIN_LENGTH:
        raise ValueError(f"{name}: {number:g} is below {MIN_LENGTH:g}")
    return number


def float_vector(value: Any, name: str, length: int) -> np.ndarray:
    """Convert ``value`` to a finite float vector of ``length`` or raise a naming `ValueError`."""
    if isinstance(value, np.ndarray) and value.dtype.kind in "fiu":
        value = value.tolist()
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise ValueError(f"{name}: expected a list of {length} numbers, got {short(value)}")
    if len(value) != length:
        raise ValueError(f"{name}: expected {length} numbers, got {len(value)}")
    if any(isinstance(v, bool) or not isinstance(v, (int, float, np.number)) for v in value):
        raise ValueError(f"{name}: expected numbers, got {short(list(value))}")
    array = np.array([as_float(v, f"{name}[{i}]") for i, v in enumerate(value)])
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: contains NaN or inf: {array.tolist()}")
    return array


def float_array(value: Any, name: str, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """A float64 array of ``value`` (of ``shape``, if given), or a `ValueError` naming it."""
    if value is None:  # numpy reads None as NaN
        raise ValueError(f"{name}: expected numbers, got None")
    try:
        array = np.array(value, dtype=np.float64)
    except OverflowError:
        raise ValueError(f"{name}: a number is too large (at most {MAX_MAGNITUDE:g})") from None
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected numbers, got {short(value)}") from None
    if np.iscomplexobj(value) or np.asarray(value).dtype.kind == "b":
        raise ValueError(f"{name}: expected real numbers")
    if shape is not None and array.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: contains NaN or inf")
    if array.size and np.max(np.abs(array)) > MAX_MAGNITUDE:
        raise ValueError(f"{name}: a magnitude above {MAX_MAGNITUDE:g} (distances would overflow)")
    return array


def _reject_duplicate_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """``json`` hook: an object may not repeat a key (JSON would silently keep the last)."""
    data: dict[str, Any] = {}
    for key, value in pairs:
        if key in data:
            raise ValueError(f"{key}: duplicate key (a JSON object names each key once)")
        data[key] = value
    return data


def parse_problem_json(raw: bytes, source: str) -> Any:
    """Decode and parse a problem file's bytes: UTF-8 JSON, no duplicate keys.

    Raises:
        ValueError: naming ``source`` and the reason (encoding, syntax, nesting, duplicates).
    """
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        hint = " (it looks like UTF-16)" if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else ""
        raise ValueError(
            f"problem: {source} is not UTF-8 text{hint}: byte {error.start} cannot be decoded; "
            "save it as UTF-8"
        ) from None
    try:
        return json.loads(text, object_pairs_hook=_reject_duplicate_keys)
    except json.JSONDecodeError as error:
        raise ValueError(f"problem: malformed JSON in {source}: {error}") from None
    except RecursionError:
        raise ValueError(f"problem: {source} nests JSON too deeply to be a problem") from None
    except ValueError as error:  # a duplicate key, or an integer of too many digits
        raise ValueError(f"problem: {source}: {error}") from None
