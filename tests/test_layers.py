"""The layers of docs/architecture.md: a module imports only from its own layer or below.

Every import counts, a deferred one inside a function too: a lower layer that needs something
from a higher one gets it handed in (e.g. `temp_gym.planning.temp_planner.set_default_policy`).
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "temp_gym"
LAYERS = {
    "problem": 0,
    "worlds": 1,
    "planning": 2,
    "models": 3,
    "policies": 3,
    "envs": 4,
    "wrappers": 4,
    "evaluation": 4,
    "benchmarks": 4,
    "viewer": 4,
    "data": 5,
    "training": 6,
}
"""``temp_gym.<name>`` -> its layer, lowest first."""
SUPPORT = {
    "files",
    "jobs",
    "config",
    "distributed",
    "quiet",
    "tensorboard_summaries",
    "limits",
    "hooks",
    "yaml_input",
}
"""Job-support modules: they import no layer, and any layer may import them."""
TOP = {"__init__", "cli"}
"""The package's face (``import temp_gym``, the ``temp-plan`` command): may import anything."""


def _part(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if parts[0] == "temp_gym" and len(parts) > 1 else None


def _imports(path: Path) -> list[str]:
    names = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.append(node.module)
    return [name for name in names if _part(name) is not None]


MODULES = sorted(PACKAGE.rglob("*.py"))


def test_every_module_has_a_layer():
    for path in MODULES:
        part = path.relative_to(PACKAGE).with_suffix("").parts[0]
        assert part in LAYERS or part in SUPPORT or part in TOP, path


@pytest.mark.parametrize("path", MODULES, ids=lambda path: str(path.relative_to(PACKAGE)))
def test_no_import_reaches_up(path):
    part = path.relative_to(PACKAGE).with_suffix("").parts[0]
    if part in TOP:
        return
    for name in _imports(path):
        other = _part(name)
        if other in SUPPORT:
            continue
        assert part not in SUPPORT, f"{path.name}: a job-support module imports {name}"
        assert LAYERS[other] <= LAYERS[part], f"{path.relative_to(PACKAGE)} imports {name}"
