r"""Ship a trained policy inside the package: a slim checkpoint plus its model card.

    python trainers/ship.py --config configs/2d.yaml --checkpoint runs/.../best.pt \\
        [--attention-nodes N] --noise-std 0.03 [--horizon K] [--attention-patience P] \\
        [key=value overrides used in training]

Writes ``temp_gym/checkpoints/{2d,3d,7d}.pt`` (the model weights and sizes, the planner
settings `temp_gym.load_policy` applies, and where the weights came from; no optimizer state,
so it stays well under 10 MB), its inference snapshot ``{2d,3d,7d}.kernels.npz`` (the numba
kernels' arrays, so a default ``plan`` needs no PyTorch: `temp_gym.models.snapshot`) and the
model card ``{2d,3d,7d}.md`` beside it: the data (the
dataset card), the config, the training figures and, once ``trainers/evaluate.py`` has written
``results/{env id}/results.json`` for this checkpoint, the evaluation table. Run it again after
the evaluation to put the figures in the card; the weights are unchanged by that.

    python trainers/ship.py --refresh-evaluation TEMP-3D-v0

rewrites only the Evaluation section of a shipped card from ``results/{env id}`` (after a
re-evaluation of the shipped weights, when their training run is not at hand); it refuses
results made with other weights, as the card itself would say.

    python trainers/ship.py --update-planner TEMP-2D-v0 attention_follow_fallback=0.25 \
        "chosen_by=..."

changes planner settings of a shipped checkpoint (`PLANNER_KEYS`; values in YAML) without its
training run: the weights and their provenance stay, the checkpoint, its snapshot and the
card's planner section are rewritten. The settings are checked as `load_policy` checks them
before anything is written.
"""

from __future__ import annotations

import io
import json
import sys
from pathlib import Path
from typing import Any

import yaml

from temp_gym.config import (
    Config,
    ConfigError,
    count,
    load_config,
    number,
    parse_args,
    script_parser,
)
from temp_gym.config.checks import check_output_dir
from temp_gym.files import atomic_write, read_json
from temp_gym.jobs import run_script
from temp_gym.models.checkpoint_settings import CARRIED_KEYS
from temp_gym.models.registry import CHECKPOINT_DIR, policy_from_checkpoint
from temp_gym.models.snapshot import write_snapshot
from temp_gym.worlds.robots import robot_specs

# PyTorch and the planners are imported where they are used, after the command line is read:
# ``--help`` and a bad value are answered without loading them.

MAX_BYTES = 10 * 2**20
"""The most a shipped checkpoint may weigh: the package ships three of them."""


def slim_checkpoint(
    source: dict[str, Any], planner: dict[str, Any], provenance: dict[str, Any]
) -> dict[str, Any]:
    """The shipped dict: model entries of ``source`` plus planner settings and provenance."""
    keep = ("version", "state_dict", "model_config", "robot", "dim", "encoding_resolution")
    slim = {key: source[key] for key in keep + ("max_path_length",)}
    slim["planner"] = planner
    slim["provenance"] = provenance
    return slim


def _checkpoint_stems() -> dict[str, str]:
    """Env id -> the stem of its shipped checkpoint (the robot's short name)."""
    return {spec.env_id: spec.short_name for spec in robot_specs()}


def _evaluation_section(env_id: str, digest: str) -> str:
    results = Path("results") / env_id / "results.json"
    table = Path("results") / env_id / "results.md"
    if not results.is_file() or not table.is_file():
        return (
            "Not evaluated yet: run `python trainers/evaluate.py --config ...` and then this "
            "script again.\n"
        )
    evaluated = json.loads(results.read_text()).get("checkpoint_digest")
    if evaluated != digest:
        return (
            f"`{results}` was made with other weights (digest {evaluated}); rerun "
            "`trainers/evaluate.py` for this checkpoint.\n"
        )
    return (
        f"The paper's protocol on unseen test workspaces (`{table}`, made by "
        "`python trainers/evaluate.py` with these weights; times on a 2-core CPU):\n\n"
        + table.read_text()
    )


def _shipped_path(env_id: str, out_dir: str | Path, flag: str) -> Path:
    """The shipped checkpoint of ``env_id`` in ``out_dir``; an unknown id exits naming ``flag``."""
    stems = _checkpoint_stems()
    if env_id not in stems:
        raise ConfigError(f"{flag}: expected one of {list(stems)}, got {env_id!r}")
    return Path(out_dir) / f"{stems[env_id]}.pt"


def refresh_evaluation(env_id: str, out_dir: str | Path = CHECKPOINT_DIR) -> Path:
    """Rewrite the Evaluation section of ``env_id``'s shipped card from ``results/{env id}``.

    Raises:
        ConfigError: if the card or checkpoint is missing, or the results are of other weights.
    """
    path = _shipped_path(env_id, out_dir, "--refresh-evaluation")
    card_path = path.with_suffix(".md")
    marker = "\n## Evaluation\n"
    if not (path.is_file() and card_path.is_file() and marker in card_path.read_text()):
        raise ConfigError(f"{card_path}: no shipped card with an Evaluation section to refresh")
    import torch

    digest = torch.load(path, weights_only=True)["provenance"]["digest"]
    section = _evaluation_section(env_id, digest)
    if not section.startswith("The paper's protocol"):
        raise ConfigError(section.strip())
    head = card_path.read_text().split(marker)[0]
    card_path.write_text(head + marker + section)
    return card_path


def update_planner(env_id: str, settings: list[str], out_dir: str | Path = CHECKPOINT_DIR) -> Path:
    """Change planner settings (``key=value``, `PLANNER_KEYS`) of ``env_id``'s shipped policy.

    The weights and provenance stay; the checkpoint, its snapshot and the card's planner
    section are rewritten, after the new settings pass the checks `load_policy` applies.

    Raises:
        ConfigError: an unknown env id or key, a malformed or invalid value, no shipped card.
    """
    path = _shipped_path(env_id, out_dir, "--update-planner")
    changes = {}
    for setting in settings:
        key, equals, value = setting.partition("=")
        if not equals or key not in PLANNER_KEYS:
            raise ConfigError(f"--update-planner: expected key=value with a key of {PLANNER_KEYS}, "
                             f"got {setting!r}")  # fmt: skip
        changes[key] = value if key == "chosen_by" else yaml.safe_load(value)
    if not changes:
        raise ConfigError("--update-planner: give at least one key=value")
    card_path = path.with_suffix(".md")
    heading, next_heading = "## Planner settings applied by `load_policy`\n", "\n## Data\n"
    card = card_path.read_text() if card_path.is_file() else ""
    if heading not in card or next_heading not in card:
        raise ConfigError(f"{card_path}: no shipped card with a planner section to update")
    import torch

    from temp_gym.models.temp import model_config_of

    checkpoint = torch.load(path, weights_only=True, map_location="cpu")
    checkpoint["planner"] = {**checkpoint["planner"], **changes}
    buffer = io.BytesIO()
    torch.save(checkpoint, buffer)
    trial = path.with_name(f".{path.name}.trial")
    try:  # the checks load_policy applies, on a copy, before anything is replaced
        trial.write_bytes(buffer.getvalue())
        policy_from_checkpoint(trial)
    except ValueError as error:
        raise ConfigError(f"--update-planner: {error}") from None
    finally:
        trial.unlink(missing_ok=True)
    with atomic_write(path) as handle:
        handle.write(buffer.getvalue())
    write_snapshot(path)
    chunk = model_config_of(checkpoint["model_config"]).chunk
    head, rest = card.split(heading, 1)
    tail = rest.split(next_heading, 1)[1]
    lines = "\n".join(planner_lines(checkpoint["planner"], chunk))
    card_path.write_text(head + heading + lines + "\n" + next_heading + tail)
    return path


def _logged_scalar(run_dir: Path, tag: str) -> dict[int, float]:
    """``tag``'s values by step from the run's TensorBoard files (the last write of a step wins)."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    values: dict[int, float] = {}
    for events in sorted(run_dir.glob("events.out.tfevents.*")):
        accumulator = EventAccumulator(str(events), size_guidance={"scalars": 0})
        accumulator.Reload()
        if tag in accumulator.Tags().get("scalars", []):
            values.update({event.step: event.value for event in accumulator.Scalars(tag)})
    return values


MAY_DIFFER = ("train.threads", "train.device", "data.dir", "data.workers", "train_eval",
              "evaluation", "logger")  # fmt: skip
"""Config keys that may differ from the run's: where and how fast it ran, what was evaluated
and logged. The card shows the config given, so every other key must be the run's."""


def check_trained_with(config: Config, source: dict[str, Any], checkpoint: Path) -> None:
    """Refuse a ``--config`` and overrides other than those the checkpoint was trained with.

    The model's sizes are in the checkpoint; the whole config, where the run's ``last.pt``
    beside it stores one. The card would otherwise describe a training that never happened.

    Raises:
        ConfigError: naming each key that differs, with both values.
    """
    import dataclasses

    import torch

    from temp_gym.config import differing_keys, flatten, upgrade_stored
    from temp_gym.models.temp import model_config_of

    pairs = [({"model": dataclasses.asdict(model_config_of(source["model_config"]))},
              {"model": dataclasses.asdict(config.model)}, checkpoint.name)]  # fmt: skip
    last = checkpoint.with_name("last.pt")
    if last.is_file():
        try:
            stored = torch.load(last, weights_only=True, map_location="cpu").get("config")
        except (OSError, RuntimeError, AttributeError, EOFError):
            stored = None
        if isinstance(stored, dict):
            pairs.append((upgrade_stored(stored), config.to_dict(), last.name))
    for trained, given, where in pairs:
        changed = differing_keys(trained, given, MAY_DIFFER)
        if changed:
            shown = ", ".join(f"{key}: {flatten(trained).get(key)!r} in {where}, "
                              f"{flatten(given).get(key)!r} given" for key in changed)  # fmt: skip
            raise ConfigError(f"--config: not the config the checkpoint was trained with "
                              f"({shown}); give that config and its overrides")  # fmt: skip


def training_figures(checkpoint: str | Path, hardware: str | None = None) -> list[str]:
    """Card lines from the run's ``last.pt`` history: the validation curve, time and hardware.

    ``hardware`` describes the training machine for runs that predate the history's own record
    of it; the history's record wins where it exists.
    """
    import torch

    last = Path(checkpoint).with_name("last.pt")
    try:
        history = torch.load(last, weights_only=True, map_location="cpu").get("history") or []
    except (OSError, RuntimeError, AttributeError) as error:
        return [f"- Training history unavailable ({last}: {error})."]
    if not history:
        return [f"- Training history unavailable ({last} records no epochs)."]
    seconds = [entry["seconds"] for entry in history if "seconds" in entry]
    recorded = {entry["hardware"] for entry in history if "hardware" in entry}
    machine = ", ".join(sorted(recorded)) or hardware or "not recorded"
    timing = (
        f"{sum(seconds) / 60:.1f} min over {len(seconds)} timed epochs"
        if seconds
        else "not recorded by this run"
    )
    lines = [
        f"- Epochs: {len(history)}; training time: {timing}; hardware: {machine}.",
        "",
        "Validation curve (the trainer's `history`; `val semantic` is the next-node term the "
        "best checkpoint is chosen on, where recorded):",
        "",
        "| epoch | train loss | val loss | val semantic | lr |",
        "|---:|---:|---:|---:|---:|",
    ]
    logged = _logged_scalar(last.parent, "val/semantic")
    for entry in history:
        semantic = entry.get("val", {}).get("semantic", logged.get(entry["epoch"]))
        lines.append(
            f"| {entry['epoch']} | {entry['train_loss']:.5f} | {entry['val_loss']:.5f} | "
            + (f"{semantic:.5f}" if semantic is not None else "-")
            + f" | {entry['lr']:.0e} |"
        )
    return lines


PLANNER_KEYS = CARRIED_KEYS
"""The planner settings a shipped checkpoint carries (`temp_gym.models.registry` applies them):
the settings any checkpoint entry may give, and the text saying how they were chosen
(`temp_gym.models.checkpoint_settings.CARRIED_KEYS`, which loading checks)."""


def planner_lines(planner: dict[str, Any], chunk: int) -> list[str]:
    """The card's lines on the planner settings ``load_policy`` applies."""
    from temp_gym.planning.attention import RESUME_AFTER
    from temp_gym.planning.goal_tree import ATTENTION_ROUNDS

    follow = planner.get("attention_follow_fallback")
    resume = planner.get("attention_resume")
    growth = planner.get("attention_resume_growth")
    return [
        "- Attention-phase budget n (Algorithm 1): "
        + (
            "all of the planner's `max_nodes`, the budget every baseline gets"
            if planner["attention_nodes"] is None
            else f"{planner['attention_nodes']} nodes"
        )
        + "; then classical planning (Informed RRT*).",
        f"- Output noise: {planner['noise_std']} (normalized units).",
        f"- Proposals per MPT call (horizon): "
        f"{planner.get('horizon') or chunk} of the model's chunk of {chunk}.",
        "- Path so far read per MPT call: "
        + (
            "the whole path the model was trained on (its L)"
            if planner.get("path_window") is None
            else f"the newest {planner['path_window']} nodes (`path_window`)"
        )
        + ".",
        "- Stall patience of the attention phase: "
        + (
            "the planner's default rule (`temp_gym.planning.attention.default_patience`)"
            if planner.get("attention_patience") is None
            else f"{planner['attention_patience']} nodes"
        )
        + (
            ""
            if planner.get("attention_near_goal_factor") in (None, 1.0)
            else f", {planner['attention_near_goal_factor']:g} times longer once the tree's "
            "closest approach is within `temp_gym.planning.attention.NEAR_GOAL_SHARE` of the "
            "start-goal distance from the goal"
        )
        + ".",
        "- After a fallback node (a uniform sample replacing a colliding proposal) that brought "
        "the tree no closer to the goal, the policy goes on from it "
        + (
            "always (Algorithm 1's UpdatePath)."
            if follow in (None, 1.0)
            else f"with probability {follow:g}, else from the path it read before "
            "(`temp_gym.planning.attention`)."
        ),
        "- After a stall, classical planning adds "
        + (
            f"{RESUME_AFTER:g} x the stall patience in nodes (the planner's default, "
            "`temp_gym.planning.attention.RESUME_AFTER`)"
            if resume is None
            else f"{resume:g} x the stall patience in nodes"
        )
        + ", then the attention phase resumes from the newest node, in turns until the first "
        "solution"
        + (
            "."
            if growth in (None, 1.0)
            else f"; each later classical turn is {growth:g} x the one before "
            "(`attention_resume_growth`)."
        )
        if resume != 0
        else "- After a stall, classical planning keeps the rest of the budget.",
        "- After stalls from the start and from the goal (the attention phase from the goal), "
        + (
            f"{ATTENTION_ROUNDS} more round(s) of the two (the planner's default, "
            "`temp_gym.planning.goal_tree.ATTENTION_ROUNDS`)"
            if planner.get("attention_rounds") is None
            else f"{planner['attention_rounds']} more round(s) of the two"
        )
        + ", a resumed attention phase on each tree in turn.",
        *(
            []
            if not planner.get("attention_uniform")
            else [
                f"- A share of {planner['attention_uniform']:g} of the attention phase's samples "
                "is uniform, not the policy's (`attention_uniform`)."
            ]
        ),
        *(
            []
            if not planner.get("attention_local_fallback")
            else [
                f"- When a proposal collides, its first {planner['attention_local_fallback']} "
                "replacements are drawn near it, then uniform ones (`attention_local_fallback`; "
                "Algorithm 1 draws them all uniform)."
            ]
        ),
        f"- How they were chosen: {planner['chosen_by']}.",
    ]


def model_card(
    env_id: str,
    config: Config,
    checkpoint: dict[str, Any],
    planner: dict[str, Any],
    provenance: dict[str, Any],
    parameters: int,
    size: int,
) -> str:
    """The markdown model card of a shipped checkpoint."""
    from temp_gym.data.dataset import CARD
    from temp_gym.models.temp import model_config_of

    try:
        card = read_json(Path(config.data.dir) / CARD, "the model card is written without it")
        splits = card.get("splits", {})
        counts = ", ".join(
            f"{split}: {figures.get('plans_stored', '?')} plans, "
            f"{figures.get('samples', '?')} samples ({figures.get('plans_failed', '?')} failed "
            "plans not stored)"
            for split, figures in splits.items()
        )
        data_lines = [
            f"- Expert: `{card['planner']['name']}`, {card['planner']['budget']}, step "
            f"{card['planner']['step_size']}; every stored path certified by the exact checker.",
            f"- Workspaces: {card['settings']['workspaces']} from the fixed train/val pools "
            f"(`temp_gym.worlds.splits`), {card['settings']['tasks_per_workspace']} tasks each, "
            f"difficulty `{card['settings']['difficulty']}`.",
            f"- Stored: {counts}.",
        ]
    except (FileNotFoundError, KeyError, ValueError) as error:
        data_lines = [f"- Dataset card unavailable ({error})."]
    everything = config.to_dict()
    sections = {key: everything[key] for key in ("env", "data", "model", "optim", "loss", "train")}
    chunk = model_config_of(checkpoint["model_config"]).chunk
    return "\n".join(
        [
            f"# Model card: `{env_id}` TEMP policy",
            "",
            f'`temp_gym.load_policy("{env_id}")` loads it; `plan(problem)` and `temp-plan` use '
            "it by default for this robot.",
            "",
            "## Model",
            f"- EISE + MPT (`temp_gym.models.TEMPModel`), robot `{checkpoint['robot']}` "
            f"(d = {checkpoint['dim']}), occupancy grid {checkpoint['encoding_resolution']} "
            f"cells per axis, path so far up to {checkpoint['max_path_length']} nodes.",
            f"- Sizes: {json.dumps(checkpoint['model_config'])}; {parameters:,} parameters; "
            f"file {size / 2**20:.2f} MB.",
            f"- Weights digest (SHA-256): `{provenance['digest']}`.",
            "",
            "## Planner settings applied by `load_policy`",
            *planner_lines(planner, chunk),
            "",
            "## Data",
            *data_lines,
            "",
            "## Training",
            f"- `python trainers/bc.py --config {provenance['config']}"
            + "".join(f" {o}" for o in provenance["overrides"])
            + "`",
            f"- Checkpoint: {provenance['source']} (epoch {provenance.get('epoch')}, validation "
            f"loss {provenance.get('val_loss')}).",
            *training_figures(provenance["source"], provenance.get("hardware")),
            "",
            "```yaml",
            yaml.safe_dump(sections, sort_keys=False).strip(),
            "```",
            *(["", f"Notes: {provenance['notes']}"] if provenance.get("notes") else []),
            "",
            "## Evaluation",
            _evaluation_section(env_id, provenance["digest"]),
        ]
    )


def main(argv: list[str] | None = None) -> Path:
    """Write the shipped checkpoint and its card; return the checkpoint path."""
    parser = script_parser(
        __doc__.splitlines()[0],
        epilog="Output: {out-dir}/{2d,3d,7d}.pt, its .kernels.npz snapshot and .md card.",
    )
    parser.add_argument("--config", help="the config the policy was trained with")
    parser.add_argument("--checkpoint", help="a trainers/bc.py best.pt")
    parser.add_argument(
        "--refresh-evaluation", metavar="ENV_ID", help="only rewrite that card's evaluation"
    )
    parser.add_argument(
        "--attention-nodes",
        type=count(1),
        default=None,
        help="AP budget n, in tree nodes (None: all of the caller's max_nodes, the budget "
        "baselines get)",
    )
    parser.add_argument(
        "--noise-std",
        type=number(0.0),
        default=0.0,
        help="output noise load_policy applies (a standard deviation, normalized units)",
    )
    parser.add_argument(
        "--horizon", type=count(1), default=None, help="proposals per MPT call (None: the chunk)"
    )
    parser.add_argument(
        "--attention-patience",
        type=count(0),
        default=None,
        help="stall patience of the attention phase, in tree nodes (None: the planner's rule)",
    )
    parser.add_argument(
        "--attention-near-goal-factor",
        type=number(1.0),
        default=None,
        help="how many times that patience the attention phase waits near the goal (None: 1)",
    )
    parser.add_argument(
        "--attention-follow-fallback",
        type=number(0.0, 1.0),
        default=None,
        help="probability of going on from a fallback node that got no closer to the goal "
        "(None: 1, Algorithm 1)",
    )
    parser.add_argument(
        "--update-planner",
        metavar="ENV_ID",
        help="only change planner settings of that shipped policy: key=value arguments",
    )
    parser.add_argument(
        "--chosen-by", default="tuned on the validation workspaces", help="for the card"
    )
    parser.add_argument("--notes", default="", help="for the card: how training went")
    parser.add_argument(
        "--hardware",
        default=None,
        help="for the card: the training machine, for runs whose history does not record it",
    )
    parser.add_argument(
        "--out-dir", default=str(CHECKPOINT_DIR), help="where checkpoint and card go"
    )
    parser.add_argument(
        "overrides",
        nargs="*",
        help="the key=value overrides used in training (with --update-planner: the settings)",
    )
    args = parse_args(parser, argv)
    if args.update_planner:
        path = update_planner(args.update_planner, args.overrides, args.out_dir)
        print(f"updated the planner settings of {path}, its snapshot and card")
        return path
    if args.refresh_evaluation:
        card = refresh_evaluation(args.refresh_evaluation, args.out_dir)
        print(f"refreshed the evaluation section of {card}")
        return card.with_suffix(".pt")
    if args.config is None or args.checkpoint is None:
        parser.error("--config and --checkpoint are required (or --refresh-evaluation)")
    config = load_config(args.config, args.overrides)
    env_id = config.env.id
    out_dir = check_output_dir(args.out_dir, "--out-dir")
    from temp_gym.models.temp import load_checkpoint, weights_digest

    try:
        model, source = load_checkpoint(args.checkpoint, robot=config.env.robot)
    except (OSError, ValueError) as error:
        raise ConfigError(f"--checkpoint: {error}") from None
    check_trained_with(config, source, Path(args.checkpoint))
    if args.horizon is not None and args.horizon > model.mpt.chunk:
        raise ConfigError(
            f"--horizon {args.horizon}: the model predicts {model.mpt.chunk} per call"
        )
    factor, follow = args.attention_near_goal_factor, args.attention_follow_fallback
    planner = {
        "attention_nodes": args.attention_nodes,
        "noise_std": args.noise_std,
        "horizon": args.horizon,
        "attention_patience": args.attention_patience,
        "attention_near_goal_factor": factor,
        "attention_follow_fallback": follow,
        "chosen_by": args.chosen_by,
    }
    provenance = {
        "source": str(args.checkpoint),
        "config": args.config,
        "overrides": list(args.overrides),
        "epoch": source.get("epoch"),
        "val_loss": source.get("val_loss"),
        "digest": weights_digest(source["state_dict"]),
        "notes": args.notes,
        "hardware": args.hardware,
    }
    import torch

    path = out_dir / f"{_checkpoint_stems()[env_id]}.pt"
    buffer = io.BytesIO()
    torch.save(slim_checkpoint(source, planner, provenance), buffer)
    size = buffer.getbuffer().nbytes
    if size > MAX_BYTES:
        raise ConfigError(f"{path}: {size / 2**20:.1f} MB exceeds the 10 MB limit")
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_write(path) as handle:
        handle.write(buffer.getvalue())
    snapshot = write_snapshot(path)  # what a CPU policy runs on, without PyTorch
    card = model_card(env_id, config, source, planner, provenance, model.num_parameters(), size)
    path.with_suffix(".md").write_text(card)
    print(f"shipped {path} ({size / 2**20:.2f} MB), {snapshot} and {path.with_suffix('.md')}")
    return path


if __name__ == "__main__":
    sys.exit(run_script("ship.py", main))
