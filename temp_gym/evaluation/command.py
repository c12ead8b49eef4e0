"""The paper's evaluation: TEMP vs RRT*, Informed RRT* (and OMPL's) on unseen test tasks.

    python trainers/evaluate.py --config configs/2d.yaml                 # shipped policy
    python trainers/evaluate.py --config configs/7d.yaml --checkpoint runs/.../best.pt
    python trainers/evaluate.py --config configs/2d.yaml evaluation.tasks=20 --workers 2
    python trainers/evaluate.py --config configs/7d.yaml --backend ray --ray-address auto

Protocol (`temp_gym.evaluation`): TEMP's first solution gives t, N, J; each baseline runs until
its cost is at most (1 + tau) J. Test sets: 100 easy + 100 challenging tasks in 2D and 3D, 200
tasks in 7D (``evaluation.tasks`` per group), from the unseen ``test`` workspaces.

Outputs in ``evaluation.out`` (default ``results/{env id}``): ``results.md`` (Table 1 layout and
the TEMP/baseline ratios), ``results.json`` (raw records), ``success_vs_time.png``,
``cost_vs_nodes.png``, ``sampling_failures.png``, ``attention.png`` (normalized attention per
token group along the plan of the first row's task 0), ``tensorboard/`` (custom-scalars layout with
TEMP and the baselines on shared charts) and ``tasks/`` (one record per task: rerunning the
same command resumes).

``trainers/evaluate.py`` runs `main`; ``docs/make_results.py`` calls it for each world.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

from temp_gym.config import (
    Config,
    EvaluationConfig,
    TEMPConfig,
    load_config,
    parse_args,
    script_parser,
)
from temp_gym.config.checks import check_output_dir
from temp_gym.config.errors import ConfigError
from temp_gym.config.typed import to_dict
from temp_gym.distributed import add_backend_arguments

if TYPE_CHECKING:
    from temp_gym.evaluation.runner import EvaluationSettings

# The planners, the models and PyTorch are imported where they are used, after the command
# line is read: ``--help`` and a bad value are answered without loading them.

POLICY_FALLBACKS = {"noise_std": 0.0, "horizon": None}
"""What a null policy setting of the ``evaluation`` section takes when the checkpoint names
none: no noise, the model's whole chunk."""


def temp_fallbacks() -> dict[str, Any]:
    """What a null setting of ``evaluation.temp`` records when the checkpoint names none.

    Where the planner's default is a number: the default resume after a stall and equal
    classical turns between resumed phases (recorded as numbers, so that records made with
    another default do not mix). Every other null one records the checkpoint's value, else
    null: the planner's default.
    """
    from temp_gym.planning.attention import RESUME_AFTER

    return {"attention_resume": RESUME_AFTER, "attention_resume_growth": 1.0}


UNRECORDED = ("tasks", "workers", "out")
"""Keys of the ``evaluation`` section that the report's metadata leaves out: the tasks are in
the records, and where and how fast a run went does not change them."""


def settings_from(
    config: Config, planner_defaults: Mapping[str, Any] | None = None
) -> tuple[EvaluationSettings, EvaluationConfig]:
    """The evaluation settings of a config's ``evaluation`` section, its nulls resolved.

    ``noise_std``, ``horizon`` and every key of ``evaluation.temp`` a policy may carry
    (`temp_gym.planning.temp_settings.DECLARED`) left null take the checkpoint's own
    (``planner_defaults``, what `temp_gym.load_policy` applies to a shipped policy), else
    `POLICY_FALLBACKS` and `temp_fallbacks`; a null ``tasks`` is the robot's (its spec's
    ``evaluation_tasks``).

    Raises:
        ConfigError: a key the planners would refuse, named.
    """
    from temp_gym.evaluation.runner import EvaluationSettings
    from temp_gym.planning.temp_settings import DECLARED
    from temp_gym.worlds.robots import robot_spec

    fallbacks = temp_fallbacks()
    robot = config.env.robot
    carried = {key: value for key, value in (planner_defaults or {}).items() if value is not None}
    section = config.evaluation
    temp = {
        key: carried.get(key, fallbacks.get(key)) if value is None and key in DECLARED else value
        for key, value in asdict(section.temp).items()
    }
    policy = {key: carried.get(key, fallback) for key, fallback in POLICY_FALLBACKS.items()
              if getattr(section, key) is None}  # fmt: skip
    section = dataclasses.replace(section, temp=TEMPConfig(**temp), **policy)
    spec = robot_spec(robot)
    _check_section(section, robot)
    tasks = section.tasks or spec.evaluation_tasks
    groups = {name: (difficulty, tasks) for name, difficulty in spec.evaluation_rows.items()}
    settings = EvaluationSettings(
        robot=robot,
        groups=groups,
        baselines=tuple(section.baselines),
        max_nodes=section.max_nodes,
        time_limit=section.time_limit,
        temp={key: value for key, value in temp.items() if value is not None},
        curve_tasks=section.curve_tasks,
        curve_nodes=section.curve_nodes,
        seed=section.seed,
        warm_runs=section.warm_runs,
        fresh_workspaces=section.fresh_workspaces,
        workspace_family=section.workspace_family,
    )
    return settings, section


def _check_section(section: EvaluationConfig, robot: str) -> None:
    """Refuse, naming the key, what the planners would refuse task by task in the workers."""
    from temp_gym.planning.plan import PLANNERS
    from temp_gym.planning.settings import PlanSettings
    from temp_gym.planning.temp_settings import TEMPSettings
    from temp_gym.worlds.structured import check_family

    try:
        check_family(robot, section.workspace_family, "evaluation.workspace_family")
    except ValueError as error:
        raise ConfigError(str(error)) from None

    if section.tasks is not None and section.tasks < 1:
        raise ConfigError(f"evaluation.tasks: expected at least 1 or null, got {section.tasks}")
    for key, least in (("curve_tasks", 0), ("curve_nodes", 1)):
        if getattr(section, key) < least:
            raise ConfigError(f"evaluation.{key}: expected at least {least}, got "
                              f"{getattr(section, key)}")  # fmt: skip
    unknown = [name for name in section.baselines if name not in PLANNERS or name == "temp"]
    if unknown:
        baselines = sorted(set(PLANNERS) - {"temp"})
        raise ConfigError(
            f"evaluation.baselines: unknown planner {unknown[0]!r}; expected some of {baselines}"
        )
    repeated = [name for k, name in enumerate(section.baselines) if name in section.baselines[:k]]
    if repeated:
        raise ConfigError(f"evaluation.baselines: {repeated[0]!r} is listed twice")
    try:  # plan()'s own checks of the budgets and TEMP's settings
        PlanSettings(max_nodes=section.max_nodes, time_limit=section.time_limit)
    except ValueError as error:
        raise ConfigError(f"evaluation.{error}") from None
    try:
        TEMPSettings.at("evaluation.temp", **asdict(section.temp))
    except ValueError as error:
        raise ConfigError(str(error)) from None


def main(argv: list[str] | None = None) -> str:
    """Evaluate (resuming), write the report, print the table.

    Every value (the config's, the flags', the checkpoint) is checked before the output
    folder is made; a bad one is a one-line `ConfigError`.
    """
    parser = script_parser(
        __doc__.splitlines()[0],
        epilog="Output: evaluation.out (default results/{env.id}): results.md, results.json, "
        "the figures, tensorboard/ and tasks/ (one record per task; rerunning resumes).",
    )
    parser.add_argument(
        "--config", required=True, help="YAML config of the world (configs/2d.yaml, 3d, 7d)"
    )
    parser.add_argument(
        "--checkpoint", default=None, help="policy to evaluate (None: the shipped one)"
    )
    add_backend_arguments(parser, "evaluation.workers", "tasks")
    parser.add_argument("overrides", nargs="*", help="key.sub=value overrides")
    args = parse_args(parser, argv)
    config = load_config(args.config, args.overrides)
    out = Path(config.evaluation.out or Path("results") / config.env.id)
    check_output_dir(out, "evaluation.out")
    if args.checkpoint:  # a file that cannot be a checkpoint is refused before PyTorch loads
        from temp_gym.models.checkpoint_file import read_checkpoint_bytes

        try:
            read_checkpoint_bytes(args.checkpoint)
        except (OSError, ValueError) as error:
            raise ConfigError(f"--checkpoint: {error}") from None
    from temp_gym.evaluation.report import write_report
    from temp_gym.evaluation.runner import (
        ManifestMismatchError,
        attention_example,
        run_evaluation,
    )
    from temp_gym.models.registry import policy_from_checkpoint, shipped_checkpoint
    from temp_gym.models.temp import load_checkpoint, weights_digest

    robot = config.env.robot
    flag = "--checkpoint" if args.checkpoint else "the shipped policy"
    try:  # fail fast, with one line, on a missing, damaged or other robot's checkpoint
        checkpoint = Path(args.checkpoint) if args.checkpoint else shipped_checkpoint(robot)
        _, stored = load_checkpoint(checkpoint, robot=robot)
    except (OSError, ValueError) as error:
        raise ConfigError(f"{flag}: {error}") from None
    settings, section = settings_from(config, stored.get("planner"))
    make_policy = functools.partial(
        policy_from_checkpoint,
        str(checkpoint),
        robot=settings.robot,
        noise_std=float(section.noise_std),
        seed=settings.seed,
        horizon=section.horizon,
    )
    try:  # the policy's own checks (noise, horizon against the chunk), before any worker runs
        make_policy()
    except ValueError as error:
        raise ConfigError(f"evaluation.{error}") from None
    digest = weights_digest(stored["state_dict"])
    path_window = stored.get("planner", {}).get("path_window")
    window = {} if path_window is None else {"path_window": path_window}  # the checkpoint's own
    try:
        records = run_evaluation(
            settings,
            make_policy,
            out,
            workers=int(args.workers or section.workers),
            progress=not args.no_progress,
            backend=args.backend,
            address=args.ray_address,
            identity={
                "checkpoint_digest": digest,
                "noise_std": float(section.noise_std),
                "horizon": section.horizon,
                **window,
            },
        )
    except ManifestMismatchError:  # another checkpoint's or settings' records: one line
        raise
    metadata = {
        "checkpoint": str(checkpoint),
        "checkpoint_digest": digest,
        "settings": {
            **{key: value for key, value in to_dict(section).items() if key not in UNRECORDED},
            **window,
        },
    }
    example = attention_example(settings, make_policy)
    table = write_report(records, out, attention=example, metadata=metadata)
    print(table)
    print(
        f"\nreport: {out / 'results.md'}; TensorBoard: tensorboard --logdir {out / 'tensorboard'}"
    )
    return table
