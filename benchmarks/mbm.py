"""MotionBenchMaker problems through ``temp-benchmark``: OMPL logs, database, summary, plots.

    python benchmarks/mbm.py path/to/mbm --planners temp rrt_star informed_rrt_star \
        --time-limit 10 --runs 10 --out results/mbm

The archive or folder is read by `temp_gym.benchmarks.motionbenchmaker.load`, which names
each problem ``<scene>/<NNNN>``: ``--group scene`` (the default) makes one experiment per
scene. Everything else (flags, outputs, resuming) is `temp_gym.evaluation.benchmark_command`'s.
"""

import sys

from temp_gym.config import parse_args
from temp_gym.evaluation.benchmark_command import ProblemSource, build_parser, run_checked


def load(path: str):
    """All problems of the set, less those whose start or goal the exact checker refuses."""
    from temp_gym.benchmarks.motionbenchmaker import invalid
    from temp_gym.benchmarks.motionbenchmaker import load as load_motionbenchmaker

    problems = load_motionbenchmaker(path)
    refused = invalid(problems)
    kept = [(name, problem) for name, problem in problems if name not in refused]
    return kept, sorted(refused.items())


SOURCE = ProblemSource(
    metavar="MBM", help="a MotionBenchMaker archive or folder of problems", load=load
)


def main(argv=None) -> int:
    args = parse_args(build_parser(SOURCE, prog="mbm.py"), argv)
    return run_checked(args, SOURCE)


if __name__ == "__main__":
    sys.exit(main())
