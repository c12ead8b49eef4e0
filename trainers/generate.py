"""Generate the expert-demonstration dataset of a config (RRT* paths in replay buffers).

    python trainers/generate.py --config configs/2d.yaml
    python trainers/generate.py --config configs/tiny.yaml --workers 2 data.dir=/tmp/tiny
    python trainers/generate.py --config configs/7d.yaml --backend ray --ray-address auto

Resumable: rerun the same command after an interruption. See `temp_gym.data.generate`.
"""

from __future__ import annotations

import json
import sys

from temp_gym.config import load_config, parse_args, script_parser
from temp_gym.config.checks import check_output_dir
from temp_gym.distributed import add_backend_arguments
from temp_gym.jobs import run_script


def main(argv: list[str] | None = None) -> None:
    """Parse the command line, generate, print the card's totals and timing."""
    parser = script_parser(
        __doc__.splitlines()[0],
        epilog="Output: data.dir (the replay buffers, workspace and task tables, "
        "dataset_card.json), made if missing; rerunning resumes.",
    )
    parser.add_argument("--config", default="configs/2d.yaml", help="YAML config")
    add_backend_arguments(parser, "data.workers", "units")
    parser.add_argument("overrides", nargs="*", help="key.sub=value config overrides")
    args = parse_args(parser, argv)
    config = load_config(args.config, args.overrides)
    check_output_dir(config.data.dir, "data.dir")
    from temp_gym.data import generate_dataset  # after the command line: numba loads here
    from temp_gym.data.dataset import read_card

    root = generate_dataset(
        config,
        workers=args.workers,
        progress=not args.no_progress,
        backend=args.backend,
        address=args.ray_address,
    )
    card = read_card(root)
    summary = {"dir": str(root), "totals": card["totals"], "timing": card["timing"]}
    print(json.dumps(summary, indent=2))
    for line in empty_split_warnings(card):
        print(f"generate.py: warning: {line}", file=sys.stderr)


def empty_split_warnings(card: dict) -> list[str]:
    """A line for each split of the dataset card that stored no expert plan (bc.py refuses it)."""
    lines = []
    for split, figures in card["splits"].items():
        if figures.get("plans_stored") == 0:
            attempted, failed = figures.get("plans_attempted", 0), figures.get("plans_failed", 0)
            count = figures.get("workspaces", 0)
            lines.append(
                f"the {split} split stored no expert plan ({failed} of {attempted} failed, in "
                f"{count} workspace{'' if count == 1 else 's'}): bc.py cannot train on it; "
                "give the expert more nodes (data.max_nodes) or the split more workspaces "
                "(data.workspaces)"
            )
    return lines


if __name__ == "__main__":
    sys.exit(run_script("generate.py", main))
