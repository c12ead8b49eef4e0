"""Same seeds, same results: what the library computes matches the fingerprints stored from
the code before the package was reorganized into its layers (see ``golden.py``).

Each section is recomputed in a child process with OpenBLAS's kernel pinned (`PINNED_ENV`),
so that the fingerprints do not depend on the CPU the suite runs on.
"""

import pytest
from golden import SECTIONS, pinned_kernel_supported, run_pinned

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
