"""temp_gym.limits is the one home of the supported sizes; docs/security.md lists every one."""

from __future__ import annotations

from pathlib import Path

import temp_gym.limits as limits

PAGE = Path(__file__).resolve().parents[1] / "docs" / "security.md"


def test_every_limit_is_on_the_security_page():
    names = [name for name in dir(limits) if name.isupper()]
    text = PAGE.read_text()
    assert names and all(f"`{name}`" in text for name in names), [
        name for name in names if f"`{name}`" not in text
    ]


def test_the_page_states_the_limits_values():
    text = PAGE.read_text()
    assert f"| {limits.MAX_OBSTACLES:,} |" in text
    assert f"| {limits.MAX_PROBLEM_BYTES // 2**20} MiB |" in text
    assert f"{limits.MAX_MODEL_PARAMETERS:,}" in text
    assert f"| {limits.MAX_CHECKPOINT_BYTES // 2**20} MiB |" in text
    assert f"({limits.MAX_ENCODING_CELLS:,} cells)" in text
