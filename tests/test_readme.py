"""The README, run as written: its shell lines, its Python snippets in order, its JSON example.

Lines are read from README.md itself, so the docs and the code cannot drift apart:

* Every line of a fenced ``bash`` block runs in a scratch copy of the repository's scripts,
  in README order (a later line may use what an earlier one made, such as the main job's
  checkpoint), with ``TEMP_GYM_OVERRIDES`` (`temp_gym.config`) shrinking the long jobs to a
  smoke test. Only these are not run (`CHECK_ONLY`): lines that install packages or create
  the environment, the test suite itself, a server that runs until stopped, and lines that
  need a Ray cluster or several processes. They are checked instead: the options they give a
  third-party program (pip, pytest, torchrun, tensorboard) must be in its ``--help``, and
  those they give a script of ours must be defined in its source.
* Commands quoted inline in the text (benchmarks, tuning, shipping: minutes each) name a
  script or module that exists and options that its source defines (read, not run: some have
  no ``--help``, and starting each would cost seconds).
* The ``python`` blocks run one after another in one interpreter, as a reader would paste
  them, and the ``json`` block is ``examples/point2d.json``.
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
COPIED = ("trainers", "benchmarks", "configs", "examples", "docs")
"""What the README's lines read, copied so that they write nothing into the checkout."""

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
        "evaluation.tasks=1",
        "evaluation.max_nodes=300",
        "evaluation.curve_tasks=1",
        "evaluation.curve_nodes=100",
        "evaluation.baselines=[rrt_star]",
        "evaluation.workers=1",
    ]
)
"""Config overrides that make every README job a smoke test (``TEMP_GYM_OVERRIDES``)."""

CHECK_ONLY = (
    (r"^(python3? -m venv|\. )", "creates the environment the tests already run in"),
    (r"^pip ", "installs packages"),
    (r"^python -m pytest", "the test suite itself"),
    (r"^tensorboard ", "a server that runs until stopped"),
    (r"^torchrun ", "needs several processes, or several nodes"),
    (r"--backend ray|RAY_ADDRESS=", "needs a Ray cluster"),
    (r"^bash \.ci/run", "CI's whole install and test run"),
)
"""Shell commands that are checked against their ``--help`` instead of run, and why."""


# ---------------------------------------------------------------------- reading the README
def fenced(language: str) -> list[str]:
    """The bodies of the README's fenced blocks in ``language``, in order."""
    return re.findall(rf"```{language}\n(.*?)```", README, flags=re.S)


def shell_lines() -> list[str]:
    """Every logical line of the ``bash`` blocks: continuations joined, comments dropped."""
    lines = []
    for block in fenced("bash"):
        for line in block.replace("\\\n", " ").splitlines():
            line = re.sub(r"\s+#.*$", "", line).strip()
            if line and not line.startswith("#"):
                lines.append(" ".join(line.split()))
    return lines


def inline_commands() -> list[str]:
    """Commands quoted inline in the README's text (outside fenced blocks)."""
    text = re.sub(r"```.*?```", "", README, flags=re.S)
    commands = []
    for quoted in re.findall(r"`([^`]+)`", text):
        command = " ".join(quoted.split())
        if re.match(r"^([A-Z_]+=\S+ )*(python3? |pip |torchrun |temp-plan |bash )", command):
            commands.append(command)
    return commands


def commands_of(line: str) -> list[str]:
    return [part.strip() for part in line.split("&&")]


def check_only_reason(command: str) -> str | None:
    for pattern, reason in CHECK_ONLY:
        if re.search(pattern, command):
            return reason
    return None


# ---------------------------------------------------------------------- checking a command
def flags_of(words: list[str]) -> list[str]:
    """The options a command uses (``--name`` or ``-x``), optional ``[...]`` parts included."""
    words = [word.strip("[]") for word in words]
    return [word.split("=", 1)[0] for word in words if re.match(r"^--?[A-Za-z]", word)]


def help_checks(command: str) -> list[tuple[list[str], list[str]]]:
    """``(help command, flags it must list)`` for the third-party programs of ``command``.

    The repository's own scripts in it are checked by `static_check` (the run test starts
    them anyway).
    """
    words = shlex.split(command)
    while words and re.match(r"^[A-Z_]+=", words[0]):  # VAR=value prefixes
        words = words[1:]
    program, rest = words[0], words[1:]
    python = [sys.executable]
    if program in ("python", "python3") and rest[0] == "-m" and rest[1] in ("pytest", "venv"):
        return [([*python, "-m", rest[1], "--help"], flags_of(rest[2:]))]
    if program == "pip":
        check_pip_requirements(rest[1:])
        return [([*python, "-m", "pip", rest[0], "--help"], flags_of(rest[1:]))]
    if program == "torchrun":
        script = next(index for index, word in enumerate(rest) if word.endswith(".py"))
        assert not static_check(" ".join(["python", *rest[script:]])), command
        return [([*python, "-m", "torch.distributed.run", "--help"], flags_of(rest[:script]))]
    if program == "tensorboard":
        return [([str(Path(sys.executable).with_name("tensorboard")), "--help"], flags_of(rest))]
    if program == ".":
        return []  # sourcing the environment `python3 -m venv` made on the same line
    failure = static_check(command)
    assert not failure, failure
    return []


def check_pip_requirements(arguments: list[str]) -> None:
    """Extras exist in pyproject.toml; the torch pin is the one the README and CI use."""
    pyproject = (ROOT / "pyproject.toml").read_text()
    for argument in arguments:
        for extras in re.findall(r"\.\[([^\]]+)\]", argument):
            for extra in extras.split(","):
                assert re.search(rf"^{extra} = \[", pyproject, flags=re.M), extra
        if argument.startswith("torch"):
            assert argument == "torch==2.13.0", argument
            assert "torch==2.13.0" in (ROOT / ".ci" / "run").read_text()


def verify(help_command: list[str], flags: list[str]) -> str:
    """Run one help command; return a failure message, or "" when every flag is listed."""
    done = subprocess.run(
        help_command, capture_output=True, text=True, timeout=120, cwd=ROOT, env=_environment()
    )
    if done.returncode != 0:
        return f"{' '.join(help_command)}: exit {done.returncode}: {done.stderr[-500:]}"
    missing = [flag for flag in flags if flag not in done.stdout]
    return f"{' '.join(help_command)}: no {missing}" if missing else ""


def _environment(**extra: str) -> dict[str, str]:
    path = f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"
    return dict(os.environ, PATH=path, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", **extra)


# ---------------------------------------------------------------------- the tests
def test_readme_has_what_these_tests_read():
    assert len(shell_lines()) >= 10 and len(fenced("python")) >= 4 and len(inline_commands()) >= 5
    for line in shell_lines():
        for command in commands_of(line):
            if check_only_reason(command) is None:
                assert command.split()[0] in ("python", "temp-plan"), command


def static_check(command: str) -> str:
    """A failure message, or "": the script or module of an inline command and its options."""
    words = shlex.split(command)
    while words and re.match(r"^[A-Z_]+=", words[0]):
        words = words[1:]
    program, rest = words[0], words[1:]
    if program == "pip":
        check_pip_requirements(rest[1:])
        return ""
    if program == "bash":
        return "" if (ROOT / rest[0]).is_file() else f"{rest[0]}: no such file"
    if program not in ("python", "python3"):
        return f"{command}: expected a python, pip or bash command"
    if rest[0] == "-m":
        source, options = ROOT / Path(*rest[1].split(".")).with_suffix(".py"), rest[2:]
    else:
        source, options = ROOT / rest[0], rest[1:]
    if not source.is_file():
        return f"{command}: no {source.relative_to(ROOT)}"
    text = source.read_text()
    seen: set[str] = set()
    pending = re.findall(r"^from (temp_gym[\w.]*) import", text, flags=re.M)
    while pending:  # the package modules it imports, and theirs: shared flags live there
        module = pending.pop()
        helper = ROOT / Path(*module.split(".")).with_suffix(".py")
        if module in seen or not helper.is_file():
            continue
        seen.add(module)
        helper_text = helper.read_text()
        text += helper_text
        pending += re.findall(r"^from (temp_gym[\w.]*) import", helper_text, flags=re.M)
    missing = [flag for flag in flags_of(options) if f'"{flag}"' not in text]
    return f"{command}: {source.name} defines no {missing}" if missing else ""


def test_inline_commands_name_existing_scripts_and_options():
    failures = [static_check(command) for command in inline_commands()]
    assert not [failure for failure in failures if failure]
    assert static_check("python benchmarks/planners.py --no-such-flag")  # the check can fail


def test_check_only_lines_match_their_help():
    # Install, server and cluster lines of the code blocks.
    commands = [
        command
        for line in shell_lines()
        for command in commands_of(line)
        if check_only_reason(command) is not None
    ]
    checks: dict[tuple[str, ...], set[str]] = {}
    for command in commands:
        for help_command, flags in help_checks(command):
            checks.setdefault(tuple(help_command), set()).update(flags)
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        failures = list(
            pool.map(lambda item: verify(list(item[0]), sorted(item[1])), checks.items())
        )
    assert not [failure for failure in failures if failure]


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    """A directory with copies of the scripts, configs and examples the README names."""
    root = tmp_path_factory.mktemp("readme")
    for name in COPIED:
        shutil.copytree(
            ROOT / name,
            root / name,
            ignore=shutil.ignore_patterns("__pycache__", "images", "results", "results.md"),
        )
    return root


def test_shell_lines_run_as_written(scratch):
    ran: list[str] = []
    for line in shell_lines():
        commands = [command for command in commands_of(line) if check_only_reason(command) is None]
        for command in commands:
            if command in ran:  # a line the README repeats says nothing new
                continue
            done = subprocess.run(
                command,
                shell=True,
                cwd=scratch,
                env=_environment(TEMP_GYM_OVERRIDES=SMOKE),
                capture_output=True,
                text=True,
                timeout=600,
            )
            assert done.returncode == 0, f"{command}\n{done.stdout[-2000:]}\n{done.stderr[-3000:]}"
            ran.append(command)
    assert any(command == "python trainers/bc.py" for command in ran)  # the main job
    assert (scratch / "runs" / "TEMP-2D-v0__quick__0" / "best.pt").is_file()
    assert (scratch / "docs" / "results.md").is_file()  # make_results, on the smoke results


def test_python_snippets_run_in_order(scratch):
    script = "\n".join(fenced("python"))
    done = subprocess.run(
        [sys.executable, "-c", script],
        cwd=scratch,
        env=_environment(),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]


def test_json_block_is_the_shipped_example():
    (block,) = fenced("json")
    assert json.loads(block) == json.loads((ROOT / "examples" / "point2d.json").read_text())
