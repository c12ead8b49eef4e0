"""The README, run as written: its Python snippets, its shell lines and its JSON example.

Everything is read from README.md itself, so the front page and the code cannot drift apart:

* Every ``python`` block runs on its own, in a fresh interpreter, as a reader would paste it
  alone: a snippet that leans on an earlier one's names fails.
* The shell lines that plan (``temp-plan ...``) and the main job (``python trainers/bc.py``)
  run in a scratch copy of the repository's scripts, configs and examples, the main job
  smoke-sized through ``TEMP_GYM_OVERRIDES`` (config overrides taken from the environment,
  `temp_gym.config`).
* The other shell lines are checked, not run: the options they give a third-party program
  (pip, pytest, mkdocs) must be in its ``--help``, and those they give a script of ours must be
  defined in its source (the trainers' own tests run them: ``tests/data``, ``tests/trainers``,
  ``tests/evaluation``).
* The ``json`` block is ``examples/point2d.json``, and the README stays a front page.
"""

from __future__ import annotations

import concurrent.futures
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
COPIED = ("trainers", "configs", "examples")
"""What the README's lines read, copied so that they write nothing into the checkout."""
MAX_LINES = 300
"""The README is a front door: what, install, a first plan, results, links."""

SMOKE = " ".join(
    [
        "data.workspaces.train=2",
        "data.workspaces.val=1",
        "data.tasks_per_workspace=3",
        "data.max_nodes=600",
        "data.workers=1",
        "train.max_epochs=1",
        "train_eval.tasks=2",
        "train_eval.periodic_tasks=1",
        "train_eval.max_nodes=300",
    ]
)
"""Config overrides that make the main job a smoke test (``TEMP_GYM_OVERRIDES``)."""

RUN = (r"^temp-plan ", r"^python trainers/bc\.py$")
"""Shell commands that run in the test: the plans, and the main job at smoke size."""

THIRD_PARTY = {
    "pip": [sys.executable, "-m", "pip", "install", "--help"],
    "pytest": [sys.executable, "-m", "pytest", "--help"],
    "mkdocs": [str(Path(sys.executable).with_name("mkdocs")), "build", "--help"],
}
"""Programs of other projects the README names, and the help that must list its options."""


# ---------------------------------------------------------------------- reading the README
def fenced(language: str) -> list[str]:
    """The bodies of the README's fenced blocks in ``language``, in order."""
    return re.findall(rf"```{language}\n(.*?)```", README, flags=re.S)


def shell_commands() -> list[str]:
    """Every command of the ``bash`` blocks: continuations joined, comments dropped."""
    commands = []
    for block in fenced("bash"):
        for line in block.replace("\\\n", " ").splitlines():
            line = re.sub(r"\s+#.*$", "", line).strip()
            if line and not line.startswith("#"):
                commands += [" ".join(part.split()) for part in line.split("&&")]
    return commands


def runs(command: str) -> bool:
    return any(re.search(pattern, command) for pattern in RUN)


def _environment(**extra: str) -> dict[str, str]:
    path = f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"
    return dict(os.environ, PATH=path, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", **extra)


# ---------------------------------------------------------------------- checking a command
def options_of(words: list[str]) -> list[str]:
    """The options a command uses (``--name`` or ``-x``)."""
    return [word.split("=", 1)[0] for word in words if re.match(r"^--?[A-Za-z]", word)]


def check_pip_requirements(arguments: list[str]) -> None:
    """Extras exist in pyproject.toml; the torch pin is the one CI installs."""
    pyproject = (ROOT / "pyproject.toml").read_text()
    for argument in arguments:
        for extras in re.findall(r"\.\[([^\]]+)\]", argument):
            for extra in extras.split(","):
                assert re.search(rf"^{extra} = \[", pyproject, flags=re.M), extra
        if argument.startswith("torch"):
            assert argument == "torch==2.13.0", argument
            assert "torch==2.13.0" in (ROOT / ".ci" / "run").read_text()


def our_script_failure(words: list[str]) -> str:
    """A failure message, or "": ``python SCRIPT`` exists and its source defines the options."""
    source = ROOT / words[1]
    if not source.is_file():
        return f"{' '.join(words)}: no {words[1]}"
    text = source.read_text()
    pending = re.findall(r"^from (temp_gym[\w.]*) import", text, flags=re.M)
    seen: set[str] = set()
    while pending:  # the package modules it imports, and theirs: shared flags live there
        module = pending.pop()
        helper = ROOT / Path(*module.split(".")).with_suffix(".py")
        if module in seen or not helper.is_file():
            continue
        seen.add(module)
        helper_text = helper.read_text()
        text += helper_text
        pending += re.findall(r"^from (temp_gym[\w.]*) import", helper_text, flags=re.M)
    missing = [option for option in options_of(words[2:]) if f'"{option}"' not in text]
    return f"{' '.join(words)}: {words[1]} defines no {missing}" if missing else ""


def help_check(command: str) -> tuple[list[str], list[str]] | None:
    """``(help command, options it must list)`` for a command that is checked, not run."""
    words = shlex.split(command)
    program, rest = words[0], words[1:]
    if program in ("python3", ".") or (program == "python" and rest[:2] == ["-m", "venv"]):
        return None  # creating and entering the environment the tests already run in
    if program == "pip":
        check_pip_requirements(rest[1:])
        return THIRD_PARTY["pip"], options_of(rest[1:])
    if program == "python" and rest[:2] == ["-m", "pytest"]:
        return THIRD_PARTY["pytest"], options_of(rest[2:])
    if program == "mkdocs":
        return THIRD_PARTY["mkdocs"], options_of(rest[1:])
    if program == "temp-robot":  # builds take minutes: its help must list the subcommand
        return [str(Path(sys.executable).with_name(program)), rest[0], "--help"], options_of(rest)
    assert program == "python" and rest[0].endswith(".py"), f"{command}: no check for it"
    failure = our_script_failure(words)
    assert not failure, failure
    return None


def help_failure(help_command: list[str], options: list[str]) -> str:
    """Run one help command; a failure message, or "" when it lists every option."""
    done = subprocess.run(
        help_command, capture_output=True, text=True, timeout=120, cwd=ROOT, env=_environment()
    )
    if done.returncode != 0:
        return f"{' '.join(help_command)}: exit {done.returncode}: {done.stderr[-500:]}"
    missing = [option for option in options if option not in done.stdout]
    return f"{' '.join(help_command)}: no {missing}" if missing else ""


# ---------------------------------------------------------------------- the tests
def test_readme_is_a_front_page_with_what_these_tests_read():
    assert len(README.splitlines()) <= MAX_LINES
    assert len(fenced("python")) >= 4
    assert "python trainers/bc.py" in shell_commands()  # the main job
    assert "python -m pytest -q -n 2" in shell_commands()  # the command .ci/run runs
    assert "python -m pytest -q -n 2" in (ROOT / ".ci" / "run").read_text()
    assert sum(command.startswith("temp-plan ") for command in shell_commands()) >= 3


def test_commands_that_are_not_run_match_their_help_or_source():
    checks: dict[tuple[str, ...], set[str]] = {}
    for command in shell_commands():
        if not runs(command) and (check := help_check(command)) is not None:
            checks.setdefault(tuple(check[0]), set()).update(check[1])
    assert checks, "no third-party command checked"
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        failures = list(pool.map(lambda item: help_failure(list(item[0]), sorted(item[1])),
                                 checks.items()))  # fmt: skip
    assert not [failure for failure in failures if failure]
    assert our_script_failure(["python", "trainers/bc.py", "--no-such-flag"])  # it can fail


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    """A directory with copies of the scripts, configs and examples the README names."""
    root = tmp_path_factory.mktemp("readme")
    for name in COPIED:
        shutil.copytree(ROOT / name, root / name, ignore=shutil.ignore_patterns("__pycache__"))
    return root


def test_shell_lines_that_plan_run_as_written(scratch):
    ran = []
    for command in shell_commands():
        if not runs(command):
            continue
        done = subprocess.run(
            command,
            shell=True,
            cwd=scratch,
            env=_environment(TEMP_GYM_OVERRIDES=SMOKE),
            capture_output=True,
            text=True,
            timeout=900,
        )
        assert done.returncode == 0, f"{command}\n{done.stdout[-2000:]}\n{done.stderr[-3000:]}"
        ran.append(command)
    assert "python trainers/bc.py" in ran
    assert (scratch / "runs" / "TEMP-2D-v0__quick__0" / "best.pt").is_file()
    assert json.loads((scratch / "result.json").read_text())["success"]  # the arm's --out


def _run_alone(snippet: str, cwd: Path) -> str:
    """Run ``snippet`` in a fresh interpreter; a failure message, or ""."""
    done = subprocess.run(
        [sys.executable, "-c", snippet],
        cwd=cwd,
        env=_environment(),
        capture_output=True,
        text=True,
        timeout=900,
    )
    return "" if done.returncode == 0 else f"{snippet}\n{done.stderr[-3000:]}"


def test_every_python_snippet_runs_on_its_own(scratch):
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        failures = list(pool.map(lambda snippet: _run_alone(snippet, scratch), fenced("python")))
    assert not [failure for failure in failures if failure]


def test_a_snippet_that_leans_on_another_fails_alone(tmp_path):
    assert _run_alone("problem.start", tmp_path)  # what the test above catches


def test_json_block_is_the_shipped_example():
    (block,) = fenced("json")
    assert json.loads(block) == json.loads((ROOT / "examples" / "point2d.json").read_text())
