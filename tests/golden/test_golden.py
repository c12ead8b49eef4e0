"""Same seeds, same results: what the library computes matches the fingerprints stored from
the code before the package was reorganized into its layers (see ``golden.py``).

Each section is recomputed in a child process with OpenBLAS's kernel pinned (`PINNED_ENV`),
so that the fingerprints do not depend on the CPU the suite runs on.
"""

import json

import pytest
from golden import SECTIONS, STORED, VARIANTS, differences, pinned_kernel_supported, run_pinned

pytestmark = pytest.mark.skipif(
    not pinned_kernel_supported(),
    reason="the fingerprints are stored for OpenBLAS's Haswell kernel (x86-64, AVX2 and FMA)",
)


@pytest.mark.parametrize("section", SECTIONS)
def test_the_section_matches_its_stored_fingerprints(section):
    """Problems drawn, every planner's plans, env episodes, the tiny dataset column for column
    and the evaluation records: each as stored."""
    child = run_pinned(["--check", "--section", section])
    assert child.returncode == 0, child.stdout + child.stderr[-4000:]
    assert child.stdout.strip() == "identical"


def test_a_variant_is_accepted_only_for_its_own_entry():
    stored = {"plans": {"a": "1", "b": "2"}}
    variants = {"plans": {"a": ["9"]}}
    assert differences({"plans": {"a": "9", "b": "2"}}, stored, variants) == []
    assert differences({"plans": {"a": "1", "b": "9"}}, stored, variants) == ["plans/b: 9 != 2"]
    assert differences({"plans": {"a": "8"}}, stored, variants) == ["plans/a: 8 != 1"]


def test_every_variant_belongs_to_a_stored_entry_and_differs_from_it():
    stored, variants = json.loads(STORED.read_text()), json.loads(VARIANTS.read_text())
    for section, entries in variants.items():
        for key, values in entries.items():
            assert key in stored[section] and stored[section][key] not in values, (section, key)
