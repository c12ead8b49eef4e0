"""Scripts' command lines: flags for argparse, ``key.sub=value`` tokens for the config."""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence

OVERRIDE = re.compile(r"^\+?[A-Za-z_][\w-]*(\.[\w-]+)*=")
"""A ``key.sub=value`` (or ``+key.sub=value``) command-line override."""


def script_parser(description: str) -> argparse.ArgumentParser:
    """An `argparse.ArgumentParser` whose help shows every flag's default."""
    return argparse.ArgumentParser(
        description=description, formatter_class=argparse.ArgumentDefaultsHelpFormatter
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


def labelled_entry(entry: str, flag: str = "--policy") -> tuple[str, str]:
    """``LABEL=CHECKPOINT`` -> ``(label, checkpoint)``; the label may hold ``=``, the path not.

    Raises:
        ValueError: an entry without a label or a checkpoint, naming ``flag`` and the entry.
    """
    label, sep, path = entry.rpartition("=")
    if not sep or not label or not path:
        raise ValueError(f"{flag} {entry!r}: expected LABEL=CHECKPOINT")
    return label, path
