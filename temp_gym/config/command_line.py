"""Scripts' command lines: flags for argparse, ``key.sub=value`` tokens for the config.

Every command of the package parses its flags with a `CommandParser`: a bad flag or value is
one line on stderr and exit status 2 (argparse's own errors print the usage first), and the
help shows each flag's default except where the flag is required or a switch.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable, Sequence
from typing import NoReturn

from temp_gym.jobs import BAD_INPUT, brief, one_line
from temp_gym.limits import MAX_COUNT

OVERRIDE = re.compile(r"^\+?[A-Za-z_][\w-]*(\.[\w-]+)*=")
"""A ``key.sub=value`` (or ``+key.sub=value``) command-line override."""


class DefaultsHelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """argparse's formatter that shows defaults, except of required flags and switches.

    A required flag has no default to show ("default: None" beside "required" says two
    things at once), and a switch (``--no-progress``) is off unless given.
    """

    def _get_help_string(self, action: argparse.Action) -> str:
        if action.required or action.nargs == 0:
            return action.help or ""
        return super()._get_help_string(action)


class CommandParser(argparse.ArgumentParser):
    """An `argparse.ArgumentParser` whose every error is one line on stderr, exit status 2."""

    def error(self, message: str) -> NoReturn:
        """Print ``{prog}: error: {message}`` on one line and exit with `BAD_INPUT`."""
        self.exit(BAD_INPUT, one_line(f"{self.prog}: error: {message} (see --help)") + "\n")


def count(least: int = 0, most: int = MAX_COUNT) -> Callable[[str], int]:
    """An argparse ``type``: an integer in ``least..most``, else a one-line usage error.

    Example:
        >>> parser.add_argument("--tasks", type=count(1), default=60)
    """

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {brief(text)}") from None
        if value < least or value > most:
            bound = f"at least {least}" if most >= MAX_COUNT else f"in {least}..{most}"
            raise argparse.ArgumentTypeError(f"must be {bound}, got {value}")
        return value

    parse.__name__ = "count"
    return parse


def number(
    least: float = -math.inf, most: float = math.inf, above: bool = False
) -> Callable[[str], float]:
    """An argparse ``type``: a finite number in ``[least, most]``, else a one-line error.

    With ``above`` the number must exceed ``least`` (a time limit of 0 is no run).
    """

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {brief(text)}") from None
        low_ok = value > least if above else value >= least
        if not (math.isfinite(value) and low_ok and value <= most):
            if math.isinf(most):
                bound = f"a finite number {'above' if above else 'of at least'} {least:g}"
            else:
                bound = f"a number in {'(' if above else '['}{least:g}, {most:g}]"
            raise argparse.ArgumentTypeError(f"expected {bound}, got {value}")
        return value

    parse.__name__ = "number"
    return parse


def script_parser(
    description: str, epilog: str | None = None, prog: str | None = None
) -> CommandParser:
    """The parser of a command: one-line errors, and help that shows every flag's default."""
    return CommandParser(
        prog=prog, description=description, epilog=epilog, formatter_class=DefaultsHelpFormatter
    )


def parse_args(
    parser: argparse.ArgumentParser, argv: Sequence[str] | None = None
) -> argparse.Namespace:
    """Parse ``argv``, taking every ``key.sub=value`` token as an override, wherever it is.

    The overrides end up in ``args.overrides`` (the parser may declare that positional for
    its help text), so they may also follow an option that takes several values
    (``--noise-std 0 0.03 train.seed=1``). Tokens starting with ``-`` are never overrides,
    so ``--flag=value`` stays a flag, and neither is the value of an option that takes exactly
    one (``--policy shipped=3d.pt`` gives ``--policy`` its value).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    single_value = {
        option
        for action in parser._actions
        if action.nargs is None and action.option_strings
        for option in action.option_strings
    }
    overrides, rest = [], []
    for index, token in enumerate(argv):
        is_value = index > 0 and argv[index - 1] in single_value
        (overrides if OVERRIDE.match(token) and not is_value else rest).append(token)
    args = parser.parse_args(rest)
    args.overrides = list(getattr(args, "overrides", None) or []) + overrides
    return args


def add_robot_argument(parser: argparse.ArgumentParser) -> None:
    """The ``--robot DESCRIPTION`` flag (repeatable) of the commands that read problems."""
    parser.add_argument(
        "--robot",
        action="append",
        default=[],
        metavar="DESCRIPTION",
        help="a robot description (YAML) to register first, so that problems can name that "
        "arm; its derived data must be built (temp-robot build DESCRIPTION); repeatable",
    )


def register_robots(descriptions: Sequence[str], flag: str = "--robot") -> None:
    """Register the arms of robot description files (`temp_gym.register_robot_file`).

    Raises:
        ValueError: a bad description, stale derived data or a name clash, in one line that
            names ``flag``.
    """
    import temp_gym  # noqa: F401  (sets the loader)
    from temp_gym import hooks

    for description in descriptions:
        try:
            hooks.robot_file_loader(description)
        except (OSError, ValueError) as error:
            raise ValueError(f"{flag}: {error}") from None


def labelled_entry(entry: str, flag: str = "--policy") -> tuple[str, str]:
    """``LABEL=CHECKPOINT`` -> ``(label, checkpoint)``; the label may hold ``=``, the path not.

    Raises:
        ValueError: an entry without a label or a checkpoint, naming ``flag`` and the entry.
    """
    label, sep, path = entry.rpartition("=")
    if not sep or not label or not path:
        raise ValueError(f"{flag} {brief(entry)}: expected LABEL=CHECKPOINT")
    return label, path
