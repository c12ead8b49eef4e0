r"""On-policy correction (DAgger): label the states a trained policy reaches, for more training.

    python trainers/correct.py --config configs/2d.yaml --checkpoint runs/.../best.pt --round 1
    python trainers/bc.py --config configs/2d.yaml \\
        data.corrections=[datasets/2d/corrections/round1] train.exp_name=dagger1

Plans new tasks in the config's training workspaces with the policy (attention phase only,
its shipped noise and horizon), asks the expert where to go from the end of every path the
policy was handed (`temp_gym.data.correction`: lattice paths in the point worlds, the config's
expert planner from that state for the iiwa), and stores the samples as a round in
``{data.dir}/corrections/round{N}`` (``--out`` to choose). The trainer adds the rounds listed
in ``data.corrections`` to the demonstrations. Resumable: rerun the same command after an
interruption.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from temp_gym.config import ConfigError, count, load_config, number, parse_args, script_parser
from temp_gym.config.checks import check_output_dir
from temp_gym.jobs import run_script
from temp_gym.limits import MAX_TASKS_PER_WORKSPACE, MAX_WORKERS


def main(argv: list[str] | None = None) -> Path:
    """Parse the command line, run the round, print its card's totals."""
    parser = script_parser(
        __doc__.splitlines()[0],
        epilog="Output: the round folder (--out), made if missing; rerunning resumes.",
    )
    parser.add_argument("--config", required=True, help="the config the policy was trained with")
    parser.add_argument("--checkpoint", required=True, help="the policy to correct")
    parser.add_argument(
        "--round", type=count(0), required=True, help="round number (seeds its tasks)"
    )
    parser.add_argument(
        "--tasks-per-workspace",
        type=count(1, MAX_TASKS_PER_WORKSPACE),
        default=10,
        help="tasks per training workspace",
    )
    parser.add_argument(
        "--samples-per-task", type=count(1), default=100, help="most samples per task"
    )
    parser.add_argument(
        "--max-nodes", type=count(1), default=2000, help="attention-phase budget, in tree nodes"
    )
    parser.add_argument(
        "--clearance",
        type=number(0.0),
        default=0.0,
        help="the expert keeps this far from boxes (world units; point robots only)",
    )
    parser.add_argument(
        "--workers", type=count(1, MAX_WORKERS), default=None, help="processes (None: data.workers)"
    )
    parser.add_argument(
        "--out", default=None, help="round folder (None: {data.dir}/corrections/round{N})"
    )
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    parser.add_argument("overrides", nargs="*", help="key.sub=value config overrides")
    args = parse_args(parser, argv)
    config = load_config(args.config, args.overrides)
    out = Path(args.out or Path(config.data.dir) / "corrections" / f"round{args.round}")
    check_output_dir(out, "--out" if args.out else "data.dir")
    from temp_gym.data.correction import CARD_NAME, collect_corrections, correction_settings
    from temp_gym.files import read_json

    try:
        settings = correction_settings(
            config, args.checkpoint, args.round, args.tasks_per_workspace,
            args.samples_per_task, args.max_nodes, args.clearance,
        )  # fmt: skip
    except (OSError, ValueError) as error:
        if isinstance(error, ConfigError):
            raise
        raise ConfigError(f"--checkpoint: {error}") from None
    workers = int(args.workers or config.data.workers or 1)
    root = collect_corrections(settings, out, workers, progress=not args.no_progress)
    card = read_json(root / CARD_NAME, "rerun the same command")
    print(json.dumps({"dir": str(root), "samples": card["samples"],
                      "unit_time_s": card["unit_time_s"]}, indent=2))  # fmt: skip
    return root


if __name__ == "__main__":
    sys.exit(run_script("correct.py", main))
