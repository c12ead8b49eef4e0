"""Behaviour cloning of TEMP (EISE + MPT) on RRT* demonstrations, then TEMP vs. RRT*.

    python trainers/bc.py                                   # the main job: configs/quick.yaml
    python trainers/bc.py --config configs/7d.yaml train.max_epochs=300
    python trainers/bc.py --config configs/tiny.yaml logger.backend=""   # no TensorBoard
    torchrun --nproc_per_node=2 trainers/bc.py --config configs/2d.yaml  # data parallel (DDP)

Steps: (1) generate the dataset of ``data.dir`` if it is missing; (2) train with
L = λ·L_recons + η·L_semantic, Adam and ReduceLROnPlateau on the validation loss, until the
learning rate reaches ``optim.min_lr`` or ``train.max_epochs``; (3) plan ``train_eval.tasks``
held-out tasks (unseen ``test`` workspaces) up to the first solution with TEMP (the best
checkpoint in the ``temp`` planner: attention-based planning, Algorithm 1, for at most
``train_eval.temp.attention_nodes`` nodes, then classical planning) and with RRT*, each timed
as a user's warm, compiled ``plan`` call; (4) print the table.

Run directory: ``{logger.dir}/{env.id}__{train.exp_name}__{train.seed}`` with ``best.pt``
(lowest validation loss), its inference snapshot ``best.kernels.npz`` (written when training
ends, `temp_gym.models.snapshot`: ``temp-plan --checkpoint`` then needs no PyTorch),
``last.pt`` (model, optimizer, scheduler, RNG, config: a killed run restarted with the same
command resumes from it), ``results.yaml`` and the TensorBoard events.
A resume under a config that changes training (`RESUMABLE_CHANGES` lists what may change) is
refused, naming the keys. Reproducibility: with a fixed ``train.threads`` (the main job uses
1) a run, and a resumed run, give bit-identical weights; with ``null`` torch takes one thread
per core, so the weights depend on the machine (float sums are ordered by the thread count).

TensorBoard tags (step: epochs completed), each described on its chart
(``training.TAG_DESCRIPTIONS``): ``train/loss``, ``train/recons``, ``train/semantic`` (epoch
means), ``train/lr``, ``train/grad_norm``; ``val/loss``, ``val/recons``, ``val/semantic``;
``eval/success``, ``eval/nodes``, ``eval/cost`` (TEMP on ``train_eval.periodic_tasks`` test
tasks, every ``train_eval.every`` epochs), ``eval/plan`` (image) and ``eval/attention``
(figure: per-group attention along the plan, Eq. 7-8); ``eval/final/{temp,rrt_star}/...``
(the comparison, in the run folder's ``final/``, written whole again on a rerun);
``time/epoch``, ``time/samples_per_s``. The config is in the HParams
dashboard, and the custom-scalars dashboard puts each loss term's training and validation
curves on one chart (``val/recons`` rises on unseen workspaces: the charts say why that is not
divergence).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from temp_gym.config import (
    Config,
    ConfigError,
    differing_keys,
    flatten,
    load_config,
    parse_args,
    script_parser,
    upgrade_stored,
)
from temp_gym.config.checks import CHOICES, check_output_dir
from temp_gym.jobs import JobError, estimate_line, progress_line, report, run_script
from temp_gym.tensorboard_summaries import remove_events

if TYPE_CHECKING:
    import torch

# PyTorch, numba and the package's training code are imported where they are used, after the
# command line is read: ``--help`` and a bad value are answered without loading them.

MAIN_JOB = "configs/quick.yaml"
"""The config of ``python trainers/bc.py`` without ``--config``: the main job, 2D on a small
dataset and budget (the file says why each setting differs from ``configs/2d.yaml``)."""


def run_directory(config: Config) -> Path:
    """``{logger.dir}/{env.id}__{train.exp_name}__{train.seed}`` (no time: resumable)."""
    name = f"{config.env.id}__{config.train.exp_name}__{config.train.seed}"
    return Path(config.logger.dir) / name


def validate(model, loss_module, data, batch_size, device, dist=None) -> dict[str, float]:
    """Sample-weighted mean of each loss term over a whole split (batches split over ranks)."""
    import torch

    from temp_gym import training

    model.eval()
    rank, world = (dist.rank, dist.world) if dist is not None else (0, 1)
    keys = ("loss", "recons", "semantic")
    totals = torch.zeros(len(keys), dtype=torch.float64)
    for number, index in enumerate(training.iterate_batch_indices(data, batch_size)):
        if number % world != rank:
            continue
        with torch.no_grad():
            terms = training.model_step(model, loss_module, data.batch(index, device))
        totals += torch.tensor(
            [float(terms[key]) * len(index) for key in keys], dtype=torch.float64
        )
    if dist is not None:
        totals = dist.sum(totals)
    return {key: float(value) / max(len(data), 1) for key, value in zip(keys, totals)}


def evaluate_with_figures(config, model, problems, logger, step, tag="eval") -> dict[str, float]:
    """TEMP on ``problems``: log success/nodes/cost, one plan image and its attention figure."""
    from temp_gym import training
    from temp_gym.models.attention import attention_figure, normalized_group_attention
    from temp_gym.models.policy import TEMPPolicy
    from temp_gym.worlds.robots import robot_spec

    eval_config = config.train_eval
    policy = TEMPPolicy(model.cpu(), noise_std=eval_config.noise_std or 0.0, seed=eval_config.seed)
    env = training.make_env(config, fallback="random", split=eval_config.split, policy=policy)
    episodes = []
    for index, problem in enumerate(problems):
        policy.record_attention = index == 0
        episode, info = training.run_episode(env, policy, problem, eval_config.seed + index)
        episodes.append(episode)
        if index == 0 and logger.writer is not None:
            tree = env.unwrapped.tree
            renderer = robot_spec(problem.robot).make_renderer()
            try:
                image = renderer.draw_tree(
                    problem, tree.positions, tree.parents, tree.num_nodes, path=info.get("path")
                )
            finally:
                renderer.close()
            logger.image(f"{tag}/plan", image, step)
            weights = normalized_group_attention(policy.attentions, model.mpt.num_sei_tokens)
            logger.figure(f"{tag}/attention", attention_figure(weights), step)
    env.close()
    summary = training.summarize(episodes, env.unwrapped.max_nodes)
    logger.scalars(
        {f"{tag}/success": summary["success"], f"{tag}/nodes": summary["nodes_mean"]}
        | {f"{tag}/cost": summary["cost"]},
        step,
    )
    return summary


def _no_logging(config: Config) -> Config:
    """The config with logging off (ranks other than 0)."""
    return dataclasses.replace(config, logger=dataclasses.replace(config.logger, backend=""))


def train(
    config: Config,
    run_dir: Path,
    resume: bool,
    progress: bool = True,
    dist: Any = None,
) -> Path:
    """Train until the lr floor or ``train.max_epochs``; return the best checkpoint's path.

    The run folder is locked while this runs (`temp_gym.files.DirectoryLock`): a second run
    into it is refused with a one-line `temp_gym.files.LockedError` naming the first.

    Under ``torchrun`` (``dist.world > 1``) the model is wrapped in DistributedDataParallel,
    each rank reads its slice of every global batch (``train.batch_size`` stays the global
    size), and only rank 0 logs and writes checkpoints: the loss curve is the single-process
    one up to float rounding (tests/trainers/test_ddp.py). ``dist`` is a
    `temp_gym.training.Distributed` (None: this process alone).

    Raises:
        TrainingDivergedError: a loss, gradient or weight became NaN or inf; ``last.pt``
            keeps the last epoch that ended finite, and ``best.pt`` is never such a model.
    """
    from temp_gym.files import DirectoryLock

    lock = DirectoryLock(run_dir, "training")
    try:
        return _train(config, run_dir, resume, progress, dist, lock)
    finally:
        lock.release()


def _train(config: Config, run_dir: Path, resume: bool, progress: bool, dist: Any,
           lock: Any) -> Path:  # fmt: skip
    """`train`'s work; ``lock`` is taken once the folder exists."""
    import numpy as np
    import torch
    from tqdm import tqdm

    from temp_gym import training
    from temp_gym.models.temp import load_checkpoint
    from temp_gym.worlds.robots import robot_spec

    dist = dist or training.Distributed(config.train.device)
    train_config, eval_config = config.train, config.train_eval
    seed = train_config.seed
    device = dist.device
    torch.manual_seed(seed)
    np.random.seed(seed)
    train_data = training.make_replay_buffer(config, "train")  # checked: each column's range
    val_data = training.make_replay_buffer(config, "val")
    if dist.is_main:  # made once the data passed their checks: a refused run leaves no folder
        run_dir.mkdir(parents=True, exist_ok=True)
        lock.acquire()
    model = training.make_model(config).to(device)
    loss_module = training.make_loss(config)
    optimizer, scheduler = training.make_optimizer(config, model)
    last_path, best_path = run_dir / "last.pt", run_dir / "best.pt"
    max_epochs = train_config.max_epochs
    state = {"epoch": 0, "global_step": 0, "best_val": math.inf, "lr_floor": False, "history": []}
    resumed = resume and last_path.exists()
    if resumed:
        checkpoint = resume_checkpoint(last_path, config, model.robot)
        model.load_state_dict(checkpoint["state_dict"])
        optimizer.load_state_dict(checkpoint["optimizer"])
        scheduler.load_state_dict(checkpoint["scheduler"])
        torch.set_rng_state(checkpoint["rng"])
        state = {key: checkpoint.get(key, value) for key, value in state.items()}
        if dist.is_main:
            report(f"{run_dir}: {progress_line(state['epoch'], max_epochs, 'epochs')}")
            seconds = [entry["seconds"] for entry in state["history"] if "seconds" in entry]
            if seconds and state["epoch"] < max_epochs and not state["lr_floor"]:
                report(epoch_estimate(max_epochs - state["epoch"], seconds))
    elif train_config.init_from:  # fine-tuning (after a correction round, say): these weights
        source, _ = load_checkpoint(train_config.init_from, robot=model.robot)
        model.load_state_dict(source.state_dict())
    # A killed run may have logged part of the epoch it then lost: TensorBoard shows the
    # rerun's events from that epoch on, and a new run's only.
    logger = training.make_logger(config if dist.is_main else _no_logging(config), run_dir,
                                  purge_step=state["epoch"] + 1 if resumed else 0)  # fmt: skip
    if not resumed:
        logger.hparams(config)
    if dist.world > 1:
        from torch.nn.parallel import DistributedDataParallel

        trained = DistributedDataParallel(
            model, device_ids=[device] if device.type == "cuda" else None
        )
    else:
        trained = model
    if state["lr_floor"] or state["epoch"] >= max_epochs:
        print(f"{run_dir}: training already finished (epoch {state['epoch']})")
        logger.close()
        return best_path
    periodic = training.draw_problems(
        config, eval_config.split, eval_config.periodic_tasks, eval_config.seed
    )
    min_lr = config.optim.min_lr
    clip = config.optim.grad_clip or math.inf
    batch_size = train_config.batch_size
    monitor = train_config.monitor
    path_noise = train_config.path_noise
    augment = train_config.augment and robot_spec(model.robot).cube_symmetric
    history_shape = (model.max_path_length, model.dim)
    if monitor not in MONITORS:
        raise ValueError(f"train.monitor: expected one of {MONITORS}, got {monitor!r}")
    bar = tqdm(
        total=max_epochs,
        initial=state["epoch"],
        desc="train",
        disable=not (progress and dist.is_main),
    )
    while state["epoch"] < max_epochs and not state["lr_floor"]:
        epoch = state["epoch"]
        began = time.perf_counter()
        model.train()
        generator = torch.Generator().manual_seed(seed * 100_003 + epoch)
        keys = ("loss", "recons", "semantic", "grad_norm")
        sums = torch.zeros(len(keys), dtype=torch.float64)
        batches = 0
        for index in training.iterate_batch_indices(train_data, batch_size, generator):
            # Random draws are made for the global batch, so every rank (and a single
            # process) consumes the generator identically; then each rank keeps its slice.
            symmetry = training.draw_symmetry(model.dim, generator) if augment else None
            noise = (
                torch.randn((len(index), *history_shape), generator=generator)
                if path_noise > 0
                else None
            )
            positions, weight = dist.shard(len(index))
            batch = train_data.batch(index[positions], device)
            if symmetry is not None:
                batch = training.augment_symmetry(batch, symmetry=symmetry)
            if noise is not None:
                batch = training.perturb_path(batch, path_noise, noise=noise[positions])
            terms = training.model_step(trained, loss_module, batch)
            optimizer.zero_grad(set_to_none=True)
            (terms["loss"] * weight).backward()  # DDP averages: the global batch's gradient
            grad_norm = torch.nn.utils.clip_grad_norm_(model.parameters(), clip)
            check_finite(config, epoch, {"loss": terms["loss"], "gradient norm": grad_norm})
            optimizer.step()
            sums += torch.tensor(
                [float(terms[key].detach()) * weight / dist.world for key in keys[:3]]
                + [float(grad_norm) / dist.world],
                dtype=torch.float64,
            )
            batches += 1
            state["global_step"] += 1
        sums = dict(zip(keys, dist.sum(sums).tolist()))
        seconds = time.perf_counter() - began
        check_weights(config, epoch, model)
        val = validate(model, loss_module, val_data, batch_size, device, dist)
        check_finite(config, epoch, {f"validation {key}": value for key, value in val.items()})
        scheduler.step(val[monitor])
        lr = optimizer.param_groups[0]["lr"]
        state["epoch"] = epoch + 1
        state["history"].append(
            {"epoch": epoch + 1, "train_loss": sums["loss"] / batches, "val_loss": val["loss"],
             "val": dict(val), "lr": lr, "hardware": hardware(device, dist.world)}
        )  # fmt: skip
        step = state["epoch"]  # epochs completed: the periodic evaluation's step too
        logger.scalars({f"train/{key}": value / batches for key, value in sums.items()}, step)
        logger.scalars({f"val/{key}": value for key, value in val.items()}, step)
        logger.scalars(
            {
                "train/lr": lr,
                "time/epoch": seconds,
                "time/samples_per_s": len(train_data) / seconds,
            },
            step,
        )
        if val[monitor] < state["best_val"]:
            state["best_val"] = val[monitor]
            if dist.is_main:
                model.save(best_path, epoch=state["epoch"], val_loss=val[monitor])
        every = eval_config.every
        if every and state["epoch"] % every == 0 and periodic and dist.is_main:
            evaluate_with_figures(config, model, periodic, logger, state["epoch"])
            model.to(device)
        state["lr_floor"] = lr <= min_lr * (1 + 1e-6)
        state["history"][-1]["seconds"] = time.perf_counter() - began  # evaluation included
        if dist.is_main:
            model.save(
                last_path,
                optimizer=optimizer.state_dict(),
                scheduler=scheduler.state_dict(),
                rng=torch.get_rng_state(),
                config=config.to_dict(),
                finished=state["lr_floor"] or state["epoch"] >= max_epochs,
                **state,
            )
        if epoch == 0 and dist.is_main and max_epochs > 1 and not state["lr_floor"]:
            report(epoch_estimate(max_epochs - 1, [state["history"][-1]["seconds"]]))
        bar.update(1)
        bar.set_postfix(loss=f"{sums['loss'] / batches:.4f}", val=f"{val['loss']:.4f}", lr=lr)
    bar.close()
    logger.close()
    return best_path


class TrainingDivergedError(JobError, FloatingPointError):
    """A loss, gradient or weight became NaN or inf: training stops, nothing of it is kept."""


def check_finite(config: Config, epoch: int, values: dict[str, Any]) -> None:
    """Stop training, naming what and when, if any of ``values`` is NaN or inf.

    Raises:
        TrainingDivergedError: saying which setting to lower and how to start over.
    """
    for name, value in values.items():
        number = float(value.detach() if hasattr(value, "detach") else value)
        if not math.isfinite(number):
            raise TrainingDivergedError(
                f"training diverged in epoch {epoch + 1}: the {name} is {number} (optim.lr "
                f"{config.optim.lr:g}, optim.grad_clip {config.optim.grad_clip:g}); no checkpoint "
                "of it was written. Lower optim.lr and rerun with --no-resume"
            )


def check_weights(config: Config, epoch: int, model: Any) -> None:
    """`check_finite` for every weight of ``model`` (once an epoch, before it is saved)."""
    for name, parameter in model.named_parameters():
        if not bool(parameter.detach().isfinite().all()):
            check_finite(config, epoch, {f"weight {name}": float("nan")})


RESUMABLE_CHANGES = ("train.max_epochs", "train.threads", "train.device", "data.dir",
                     "data.workers", "train_eval", "evaluation", "logger")  # fmt: skip
"""Config keys that may differ when a run resumes: when to stop, where and how fast it runs,
and what is evaluated and logged. Every other key shapes the training itself (model, optim,
loss, data, env, train), so a run refuses to resume under a change to one of them. A config
stored by an older version is upgraded first (`temp_gym.config.upgrade_stored`: renamed
sections, keys added since at their defaults), so such a run resumes too.
``train.threads`` and ``train.device`` may change, but the result is then not bit-identical to
an uninterrupted run (floating-point sums are ordered by the thread count and device)."""


class ResumeMismatchError(JobError, ValueError):
    """``last.pt`` was written under a config that differs in a key training depends on."""


def resume_checkpoint(last_path: Path, config: Config, robot: str) -> dict[str, Any]:
    """``last.pt``, checked to be readable and written under the same training config.

    Raises:
        StoredFileError: it is damaged (named, with what to do).
        ResumeMismatchError: it was trained under another config (the keys are named).
    """
    from temp_gym.files import StoredFileError
    from temp_gym.models.temp import CheckpointError, load_checkpoint

    try:
        _, checkpoint = load_checkpoint(last_path, robot=robot)
    except CheckpointError as error:
        raise StoredFileError(
            last_path,
            f"cannot resume from it: {error.problem}",
            "delete it, or pass --no-resume, to train from the start",
        ) from None
    for key in ("optimizer", "scheduler", "rng", "epoch"):
        if key not in checkpoint:
            raise StoredFileError(
                last_path,
                f"cannot resume from it: no {key!r} (not a last.pt of trainers/bc.py)",
                "delete it, or pass --no-resume, to train from the start",
            )
    stored = checkpoint.get("config")
    if isinstance(stored, dict):
        stored, current = upgrade_stored(stored), config.to_dict()
        changed = differing_keys(stored, current, RESUMABLE_CHANGES)
        if changed:
            shown = ", ".join(
                f"{key}: {flatten(stored).get(key)!r} -> {flatten(current).get(key)!r}"
                for key in changed
            )
            raise ResumeMismatchError(
                f"{last_path} was trained with another config ({shown}); rerun with the "
                "original values to resume, or pass --no-resume (or another train.exp_name) "
                "to start a new run"
            )
    return checkpoint


def hardware(device: torch.device, world: int) -> str:
    """What an epoch ran on, for the model card: processes, device and CPU cores."""
    import torch

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    name = torch.cuda.get_device_name(device) if device.type == "cuda" else "CPU"
    return f"{world} x {name}, {cores} CPU cores, torch {torch.__version__}"


def epoch_estimate(remaining: int, seconds: list[float]) -> str:
    """The time the remaining epochs should take at the measured seconds per epoch."""
    import numpy as np

    line = estimate_line(remaining, float(np.median(seconds)), None, "epochs", "measured")
    return f"{line}, at most: training stops early at the lr floor"


FINAL_EVENTS = "final"
"""The run folder's subfolder of the final comparison's TensorBoard events."""


def compare_with_rrt_star(config: Config, checkpoint: Path, run_dir: Path) -> dict:
    """TEMP (best checkpoint) vs. RRT* on the same held-out tasks, up to the first solution.

    TEMP is the ``temp`` planner: attention-based planning (Algorithm 1) for at most
    ``train_eval.temp.attention_nodes`` nodes, then classical planning on the same tree; RRT*
    is ``rrt_star``. Both get the same tasks, seeds and ``train_eval.max_nodes`` budget, and
    both are timed as a user's ``plan`` call is, by the evaluation's protocol
    (`temp_gym.evaluation.runner.start_timed_run`): compiled and warm (an untimed short plan of
    the same planner elsewhere before each timed run), each timed run paying its set-up on the
    task's workspace (the tree's free volume, TEMP's encoding) as a first plan there does.
    """
    import numpy as np
    import torch

    from temp_gym import training
    from temp_gym.evaluation.runner import EvaluationSettings, start_timed_run
    from temp_gym.models.policy import TEMPPolicy
    from temp_gym.models.temp import load_checkpoint

    eval_config = config.train_eval
    torch.set_num_threads(1)  # the per-sample latency a planner sees
    model, _ = load_checkpoint(checkpoint, robot=config.env.robot)
    problems = training.draw_problems(
        config, eval_config.split, eval_config.tasks, eval_config.seed + 10_000
    )
    # A folder of its own, emptied first: a rerun (of a finished run, or one killed during the
    # comparison) writes the comparison again, and TensorBoard shows it once.
    remove_events(run_dir / FINAL_EVENTS)
    logger = training.make_logger(config, run_dir / FINAL_EVENTS)
    evaluate_with_figures(config, model, problems[:1], logger, 0, tag="eval/final/example")
    policy = TEMPPolicy(model.cpu(), noise_std=eval_config.noise_std or 0.0)
    timing = EvaluationSettings(robot=config.env.robot, groups={}, seed=eval_config.seed)
    temp_runs, rrt_runs = [], []
    for index, problem in enumerate(problems):
        seed = eval_config.seed + index
        start_timed_run("temp", problem, policy, timing)
        temp_runs.append(training.plan_episode(problem, "temp", seed, eval_config, policy))
        start_timed_run("rrt_star", problem, None, timing)
        rrt_runs.append(training.plan_episode(problem, "rrt_star", seed, eval_config))
    temp = training.summarize(temp_runs, eval_config.max_nodes)
    temp["attention_success"] = float(np.mean([run["attention_solved"] for run in temp_runs]))
    rrt_star = training.summarize(rrt_runs, eval_config.max_nodes)
    logger.scalars({f"eval/final/rrt_star/{key}": value for key, value in rrt_star.items()}, 0)
    logger.scalars({f"eval/final/temp/{key}": value for key, value in temp.items()}, 0)
    logger.close()
    return {
        "tasks": len(problems),
        "attention_nodes": eval_config.temp.attention_nodes,
        "temp": temp,
        "rrt_star": rrt_star,
    }


def results_table(results: dict[str, Any]) -> str:
    """A markdown table of the comparison."""
    rows = [
        "| planner | success | nodes to 1st solution (mean / median) | cost | samples | time (s) |",
        "|---|---|---|---|---|---|",
    ]
    budget = results.get("attention_nodes")
    temp_label = f"TEMP (AP <= {budget} nodes, then CP)" if budget else "TEMP (AP)"
    for name, label in (("temp", temp_label), ("rrt_star", "RRT*")):
        row = results[name]
        rows.append(
            f"| {label} | {row['success']:.2f} | {row['nodes_mean']:.1f} / "
            f"{row['nodes_median']:.0f} | {row['cost']:.2f} | {row['samples']:.1f} | "
            f"{row['time']:.3f} |"
        )
    return "\n".join(rows)


def read_command_line(argv: list[str] | None) -> tuple[Config, argparse.Namespace]:
    """The config (the file, the main job's by default, and the overrides) and the flags."""
    parser = script_parser(
        __doc__.split("\n")[0],
        epilog="Outputs: the dataset in data.dir (made if missing); the run in "
        "{logger.dir}/{env.id}__{train.exp_name}__{train.seed}/ (best.pt, its "
        "best.kernels.npz, last.pt, results.yaml, TensorBoard events).",
    )
    parser.add_argument("--config", default=MAIN_JOB, help="YAML config")
    parser.add_argument(
        "overrides", nargs="*", help="key.sub=value config overrides (train.max_epochs=3)"
    )
    parser.add_argument("--resume", action="store_true", help="require last.pt and resume")
    parser.add_argument("--no-resume", action="store_true", help="start over, ignore last.pt")
    parser.add_argument(
        "--skip-eval", action="store_true", help="no final comparison with RRT* after training"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    args = parse_args(parser, argv)
    return load_config(args.config, args.overrides), args


MONITORS = CHOICES["train.monitor"]
"""The validation losses ``train.monitor`` may choose the best checkpoint on."""


def check_job(config: Config, args: argparse.Namespace) -> None:
    """Refuse, naming the key, any setting the run would stumble on, before it writes anything.

    `load_config` has checked every value's bounds; here are the checks of the job itself,
    cheapest first: a final comparison without tasks, ``--resume`` without ``last.pt``,
    folders that cannot be made (``data.dir``, ``logger.dir``), correction rounds that are
    not there, then the data settings, the device, the model's sizes and ``train.init_from``
    (its robot and sizes), which load PyTorch.

    Raises:
        ConfigError: naming the key or flag and the reason.
    """
    if args.resume and args.no_resume:
        raise ConfigError("--resume and --no-resume: give one of them")
    if not args.skip_eval and config.train_eval.tasks < 1:
        raise ConfigError(
            f"train_eval.tasks: must be at least 1, got {config.train_eval.tasks} (pass "
            "--skip-eval for no final comparison)"
        )
    run_dir = run_directory(config)
    if args.resume and not (run_dir / "last.pt").is_file():
        raise ConfigError(f"--resume: no {run_dir / 'last.pt'} to resume from")
    check_output_dir(config.data.dir, "data.dir")
    check_output_dir(config.logger.dir, "logger.dir")
    if run_dir.exists() and not run_dir.is_dir():
        raise ConfigError(f"train.exp_name: {run_dir} is a file, not a run folder")
    for index, round_dir in enumerate(config.data.corrections):
        if not Path(round_dir).is_dir():
            raise ConfigError(f"data.corrections[{index}]: {round_dir} is not a folder")
    from temp_gym.data.dataset import data_settings  # the data section, as generation reads it

    workspaces = data_settings(config)["workspaces"]
    for split in ("train", "val"):  # training reads both; refused before data is generated
        if workspaces[split] < 1:
            raise ConfigError(
                f"data.workspaces.{split}: training needs at least one {split} workspace, got 0"
            )
    import torch

    from temp_gym.models.temp import load_checkpoint
    from temp_gym.training import make_model

    try:
        if config.train.device != "auto":  # auto: CUDA when there is one (`Distributed`)
            torch.device(config.train.device)
    except RuntimeError as error:
        raise ConfigError(f"train.device: {error}") from None
    try:  # the model section (widths, heads, prediction, dropout), as training builds it
        model = make_model(config)
    except ValueError as error:
        message = str(error)
        raise ConfigError(message if message.startswith("model") else f"model: {message}") from None
    if config.train.init_from:
        try:
            _, source = load_checkpoint(config.train.init_from, robot=config.env.robot)
        except (OSError, ValueError) as error:
            raise ConfigError(f"train.init_from: {error}") from None
        wanted = {name: tuple(t.shape) for name, t in model.state_dict().items()}
        stored = {name: tuple(t.shape) for name, t in source["state_dict"].items()}
        if wanted != stored:
            raise ConfigError(
                f"train.init_from: {config.train.init_from} holds a model of other sizes than "
                f"the model section makes (its model_config: {source['model_config']})"
            )


def main(argv: list[str] | None = None) -> dict[str, Any] | None:
    """Run the job; returns the comparison (None with ``--skip-eval`` or on ranks above 0).

    Raises:
        ConfigError: a bad value, before anything is written (`check_job`).
        TrainingDivergedError: a loss or weight became NaN or inf; no checkpoint of it is kept.
    """
    config, args = read_command_line(argv)
    check_job(config, args)
    import torch
    import yaml

    from temp_gym import training
    from temp_gym.models.snapshot import write_snapshot

    began = time.perf_counter()
    run_dir = run_directory(config)
    # Every rank makes sure of the dataset before the process group exists, so no rank waits
    # at a barrier (with its timeout) while another generates it; the directory lock lets
    # one process per node generate while the others wait for it.
    rank = training.launch_rank()
    training.ensure_dataset(config, progress=not args.no_progress and rank == 0, quiet=rank != 0)
    dist = training.Distributed(config.train.device)
    if config.train.threads:
        torch.set_num_threads(config.train.threads)
    best = train(
        config, run_dir, resume=not args.no_resume, progress=not args.no_progress, dist=dist
    )
    dist.barrier()
    dist.close()
    if not dist.is_main:
        return None
    if not best.exists():
        raise TrainingDivergedError(
            f"{best}: no epoch ended with a finite validation loss, so there is no best model; "
            "check the dataset and lower optim.lr"
        )
    print(f"best checkpoint: {best}")
    write_snapshot(best)  # temp-plan --checkpoint and policy_from_checkpoint need no PyTorch
    if args.skip_eval:
        return None
    results = compare_with_rrt_star(config, best, run_dir)
    results["wall_time_s"] = time.perf_counter() - began
    with open(run_dir / "results.yaml", "w") as handle:
        yaml.safe_dump(results, handle, sort_keys=False)
    print(
        f"\n{results['tasks']} held-out tasks ({config.train_eval.difficulty}, unseen "
        f"test workspaces), up to the first solution:\n"
    )
    print(results_table(results))
    print(f"\nwall time {results['wall_time_s']:.0f} s; results in {run_dir / 'results.yaml'}")
    if config.logger.backend:
        print(f"TensorBoard: tensorboard --logdir {run_dir.parent}")
    return results


if __name__ == "__main__":
    sys.exit(run_script("bc.py", main))
