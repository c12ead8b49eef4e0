"""The documentation site: its API reference covers the public names, its snippets run.

``mkdocs build --strict`` (CI) fails on a broken link, anchor or reference; these tests cover
what it cannot see: a public name that no API page renders, a snippet that no longer runs, and
words about how the project was made rather than what it does.
"""

from __future__ import annotations

import importlib
import inspect
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PUBLIC_PACKAGES = (
    "temp_gym",
    "temp_gym.problem",
    "temp_gym.worlds.robots",
    "temp_gym.planning",
    "temp_gym.policies",
    "temp_gym.models",
    "temp_gym.envs",
    "temp_gym.wrappers",
    "temp_gym.data",
    "temp_gym.training",
    "temp_gym.evaluation",
    "temp_gym.benchmarks.motionbenchmaker",
    "temp_gym.config",
)
"""The package and its main subpackages: each name in their ``__all__`` must be documented."""

NOT_ABOUT_THE_LIBRARY = r"s[e]ssion|issue [0-9]|the [s]peed issue"
"""Words about how the project was made: the repository speaks to its users (the brackets keep
this line from matching itself)."""


def api_directives() -> dict[str, bool]:
    """Module -> whether its members are rendered, from the ``::: module`` lines of docs/api."""
    directives = {}
    for page in sorted((DOCS / "api").glob("*.md")):
        for match in re.finditer(r"^::: ([\w.]+)\n((?:    .*\n)*)", page.read_text(), re.M):
            directives[match[1]] = "members: false" not in match[2]
    return directives


def home_module(package: str, name: str) -> str:
    """The module that defines ``package.name`` (a class, function, module or constant)."""
    value = getattr(importlib.import_module(package), name)
    if inspect.ismodule(value):
        return value.__name__
    if inspect.isclass(value) or inspect.isfunction(value):
        return value.__module__
    for module in sorted(sys.modules):  # a constant: the module whose source assigns it
        if module == package or module.startswith(package + "."):
            source = getattr(sys.modules[module], "__file__", None)
            if source and re.search(rf"^{name}\b[^=\n]*=", Path(source).read_text(), re.M):
                return module
    return package


def public_names(module) -> list[str]:
    """The classes and functions a module without ``__all__`` defines, less the private ones."""
    return [
        name
        for name, value in vars(module).items()
        if not name.startswith("_")
        and (inspect.isclass(value) or inspect.isfunction(value))
        and value.__module__ == module.__name__
    ]


def undocumented(directives: dict[str, bool]) -> list[str]:
    missing = []
    for package in PUBLIC_PACKAGES:
        module = importlib.import_module(package)
        for name in getattr(module, "__all__", None) or public_names(module):
            home = home_module(package, name)
            # A rendered package shows the names of its __all__; a rendered module, its own.
            if not (directives.get(package) or directives.get(home)):
                missing.append(f"{package}.{name} (defined in {home})")
    return missing


def test_the_api_reference_covers_every_public_name():
    directives = api_directives()
    assert len(directives) >= 20
    assert not undocumented(directives)
    directives.pop("temp_gym.planning.plan")  # the check can fail: plan() is rendered there only
    assert "temp_gym.planning.plan (defined in temp_gym.planning.plan)" in undocumented(directives)


def test_every_api_directive_names_a_module_that_imports():
    for module in api_directives():
        importlib.import_module(module)


def snippets() -> list[tuple[str, str]]:
    """``(page, code)`` of every ``python`` block of the site; ``py`` blocks are sketches."""
    found = []
    for page in sorted(DOCS.rglob("*.md")):
        for code in re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S):
            found.append((str(page.relative_to(ROOT)), code))
    return found


RUN_EACH_ALONE = """
import sys, traceback
failures = []
for page, code in SNIPPETS:
    try:
        exec(compile(code, page, "exec"), {"__name__": "__main__"})
    except Exception:
        failures.append(page + ":\\n" + code + traceback.format_exc(limit=3))
print("\\n".join(failures), file=sys.stderr)
sys.exit(1 if failures else 0)
"""
"""Each snippet with a namespace of its own, in one interpreter (one start-up for them all)."""


def run_snippets(found: list[tuple[str, str]], cwd: Path) -> subprocess.CompletedProcess:
    script = f"SNIPPETS = {found!r}\n{RUN_EACH_ALONE}"
    return subprocess.run(
        [sys.executable, "-c", script], cwd=cwd, capture_output=True, text=True, timeout=900
    )


def test_every_python_snippet_of_the_site_runs_on_its_own(tmp_path):
    found = snippets()
    assert len(found) >= 8
    shutil.copytree(ROOT / "examples", tmp_path / "examples")  # they read examples/, write here
    done = run_snippets(found, tmp_path)
    assert done.returncode == 0, done.stderr[-4000:]


def test_every_problem_file_shown_in_the_docs_loads():
    """A ``json`` block holding a whole problem (it names a robot) is one a reader may copy."""
    import json

    from temp_gym.problem import Problem

    shown = []
    for page in sorted([*DOCS.rglob("*.md"), ROOT / "README.md"]):
        for block in re.findall(r"```json\n(.*?)```", page.read_text(), flags=re.S):
            data = json.loads(block)
            if isinstance(data, dict) and "robot" in data and "start" in data:
                shown.append(page.name)
                Problem.from_dict(data)  # raises, naming the field, if it does not load
    assert "problem-format.md" in shown


def test_a_snippet_that_leans_on_another_fails(tmp_path):
    found = [("a.md", "problem = 1\n"), ("b.md", "print(problem)\n")]
    assert "NameError" in run_snippets(found, tmp_path).stderr


def test_the_repository_speaks_to_its_users():
    if not (ROOT / ".git").exists() or shutil.which("git") is None:
        pytest.skip("not a git checkout")
    done = subprocess.run(
        ["git", "grep", "-n", "-i", "-E", NOT_ABOUT_THE_LIBRARY],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 1, done.stdout[:3000]  # 1: no match


USER_GUIDE = sorted(
    page
    for page in DOCS.rglob("*.md")
    if "research" not in page.parts and page.name not in ("results.md", "changelog.md")
)
"""Pages whose commands must work today (the research notes quote commands as they were run)."""


def guide_commands() -> list[tuple[str, list[str]]]:
    """``(page, words)`` of each command of ours in the user guide: inline or in a block."""
    commands = []
    for page in USER_GUIDE:
        text = page.read_text()
        quoted = re.findall(r"```bash\n(.*?)```", text, flags=re.S)
        quoted += re.findall(r"`([^`\n]+)`", re.sub(r"```.*?```", "", text, flags=re.S))
        for chunk in quoted:
            for line in chunk.replace("\\\n", " ").splitlines():
                line = re.sub(r"\s+#.*$", "", line).strip()
                for command in line.split("&&"):
                    words = [word.strip("[]") for word in command.split()]
                    words = [word for word in words if word not in ("--help", "-h")]
                    while words and re.match(r"^[A-Z_]+=", words[0]):  # VAR=value prefixes
                        words = words[1:]
                    if words[:1] == ["temp-plan"]:
                        commands.append((page.name, ["python", "temp_gym/cli.py", *words[1:]]))
                    elif words[:2] == ["python", "-m"] and words[2].startswith("temp_gym"):
                        script = str(Path(*words[2].split(".")).with_suffix(".py"))
                        commands.append((page.name, ["python", script, *words[3:]]))
                    elif words[:1] == ["python"] and words[1:2] and words[1].endswith(".py"):
                        commands.append((page.name, words))
    return commands


def test_commands_in_the_user_guide_name_existing_scripts_and_options():
    from test_readme import our_script_failure  # the README's check, on the site's pages

    commands = guide_commands()
    assert len(commands) >= 30
    failures = [f"{page}: {our_script_failure(words)}" for page, words in commands]
    assert not [failure for failure in failures if not failure.endswith(": ")]


def test_the_benchmark_and_example_indexes_list_every_file():
    benchmarks = (DOCS / "benchmarks.md").read_text()
    scripts = sorted((ROOT / "benchmarks").glob("*.py"))
    assert scripts and not [s.name for s in scripts if f"benchmarks/{s.name}" not in benchmarks]
    examples = (DOCS / "examples.md").read_text()
    problems = sorted((ROOT / "examples").rglob("*.json"))
    listed = [str(p.relative_to(ROOT / "examples" / "ood")) if "ood" in p.parts else
              f"examples/{p.name}" for p in problems]  # fmt: skip
    assert problems and not [name for name in listed if name not in examples]
