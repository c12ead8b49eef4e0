"""The config: one dataclass per YAML section, the only home of every default.

Each field says what it is and why it matters, in the docstring under it (CleanRL's style).
A YAML file (``configs/*.yaml``) may restate a default; a key it leaves out takes the value
here. The dataclasses are frozen: a changed config is a new one (`dataclasses.replace`, or
`temp_gym.config.apply_overrides`).

| section | read by |
|---|---|
| `EnvConfig` ``env`` | every script: the world, the observation sizes |
| `DataConfig` ``data`` | ``trainers/generate.py``, ``bc.py``, ``correct.py``: the demonstrations |
| `ModelConfig` ``model`` | `temp_gym.models.TEMPModel` (and checkpoints, as a dict) |
| `OptimConfig` ``optim``, `LossConfig` ``loss``, `TrainConfig` ``train`` | ``trainers/bc.py`` |
| `TrainEvalConfig` ``train_eval`` | ``bc.py``'s planning on held-out tasks, ``tune_planner.py`` |
| `EvaluationConfig` ``evaluation`` | ``trainers/evaluate.py``: the paper's protocol |
| `LoggerConfig` ``logger`` | ``trainers/bc.py``: TensorBoard |

Fields with no default (``env.id``, ``env.robot``, ``data.dir``) name a robot or a place,
which every config file chooses for itself.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from temp_gym.config.typed import to_dict


@dataclass(frozen=True)
class EnvConfig:
    """``env``: the planning world and the sizes of what the policy observes."""

    id: str
    """Gymnasium env id (``TEMP-2D-v0``, ...): the world; it also names the run directory."""
    robot: str
    """The env's robot, a name `temp_gym.worlds.robots` registers: the model's dimension. A
    robot description file (``my_arm.yaml``) registers that arm and stands for its name
    (`temp_gym.config.loading.load_config`); ``env.id`` then defaults to the arm's env."""
    description: str | None = None
    """The robot description of an arm given as ``env.robot`` (set when the config is loaded,
    so that worker processes register the same arm); null for a built-in robot."""
    encoding_resolution: int | None = None
    """Occupancy-grid cells per workspace axis, the EISE's input; null: the robot spec's."""
    max_path_length: int = 64
    """L: rows of the path-so-far (HPD) tokens the MPT reads (the env's default too)."""
    step_size: float | None = None
    """The tree's steering step (world units), to which demonstrations are resampled;
    null: `temp_gym.planning.tree.default_step_size`."""


@dataclass(frozen=True)
class Workspaces:
    """``data.workspaces``: how many workspaces of each fixed pool (`temp_gym.worlds.splits`)."""

    train: int | None = None
    """The first N workspaces of the training pool; null: the whole pool."""
    val: int | None = None
    """The first N workspaces of the validation pool; null: the whole pool."""


@dataclass(frozen=True)
class DataConfig:
    """``data``: the expert demonstrations (`temp_gym.data.generate`)."""

    dir: str
    """Where the replay buffers, workspace tables and dataset card go."""
    seed: int = 0
    """With split, workspace and task, the SeedSequence of each task: same seed, same data."""
    workers: int = 2
    """Planning processes (``--workers`` of ``trainers/generate.py`` overrides it)."""
    workspaces: Workspaces = field(default_factory=Workspaces)
    """Workspaces per split, the first of fixed pools, so that datasets of any size nest."""
    tasks_per_workspace: int = 200
    """Start-goal pairs planned in each workspace (the paper's 200)."""
    difficulty: str = "any"
    """Task difficulty: any, easy or challenging (`temp_gym.worlds.generators`)."""
    workspace_family: str = "boxes"
    """Which workspaces the train and val pools hold (`temp_gym.worlds.structured`): boxes (the
    robot's own generator, as every dataset before the key), corridors, maze, traps, narrow,
    clutter (the point worlds' and the arms' own versions), manipulation (arms only: shelves,
    open boxes, cages and tables at any angle, `temp_gym.worlds.arm_manipulation`), or mixed
    (one of the first six drawn per workspace)."""
    planner: str = "informed_rrt_star"
    """The expert, a planner of `temp_gym.plan`: Informed RRT* refines in fewer nodes."""
    max_nodes: int = 2000
    """The expert's budget: tree nodes per task, refining the path until then."""
    planner_step_size: float | None = None
    """The expert's steering step (world units); null: the env's. Longer steps refine faster;
    the paths are resampled at the env's step either way."""
    goal_bias: float = 0.05
    """Probability that the expert samples the goal."""
    attempts: int = 1
    """Seeds the expert tries on a task (each retry with a larger budget) before the task
    counts as failed."""
    expert_reverse: bool = False
    """After each failed attempt, plan the same attempt from the goal to the start and store
    the reversed path (`temp_gym.data.generate.expert_plan`): a forward tree rarely enters a
    goal in a pocket (a bin, a compartment, a trap), so without it the data lose those tasks."""
    corrections: list[str] = field(default_factory=list)
    """On-policy correction rounds (``trainers/correct.py`` directories) added to training."""


@dataclass(frozen=True)
class ModelConfig:
    """``model``: the sizes of `temp_gym.models.TEMPModel` (EISE + MPT).

    Checkpoints store it as a dict (``model_config``); `dataclasses.asdict` gives that dict,
    in this field order.
    """

    token_dim: int = 64
    """Width of every token (SEI, goal, start, HPD, output)."""
    num_heads: int = 4
    """Attention heads per transformer layer."""
    num_layers: int = 3
    """M, the MPT's transformer layers."""
    ffn_dim: int = 128
    """Hidden width of each layer's feed-forward network."""
    num_sei_tokens: int = 8
    """SEI tokens the EISE makes of a workspace."""
    eise_hidden: int = 256
    """Hidden width of the EISE's encoder and decoder."""
    dropout: float = 0.0
    """Dropout in the MPT while training (a regularizer for small datasets)."""
    prediction: str = "offset"
    """offset: x^ = x_current + offset_scale * tanh(.); absolute: x^ = tanh(.)."""
    offset_scale: float = 0.5
    """Largest offset per coordinate (normalized units) of an ``offset`` prediction."""
    chunk: int = 1
    """Nodes the MPT predicts per call (1: the paper's MPT; more: fewer calls per plan)."""


@dataclass(frozen=True)
class OptimConfig:
    """``optim``: Adam and ReduceLROnPlateau on the validation loss (the paper's schedule)."""

    lr: float = 1e-3
    """Adam's initial learning rate."""
    betas: list[float] = field(default_factory=lambda: [0.9, 0.999])
    """Adam's decay rates of the gradient's first and second moments."""
    eps: float = 1e-8
    """Adam's denominator guard."""
    weight_decay: float = 0.0
    """Adam's L2 penalty."""
    grad_clip: float = 1.0
    """Largest gradient norm; 0 disables clipping."""
    lr_factor: float = 0.1
    """The lr is multiplied by this when the monitored validation loss plateaus."""
    lr_patience: int = 10
    """Epochs without a relative improvement of ``lr_threshold`` before the lr is cut."""
    lr_threshold: float = 0.1
    """Relative improvement of the monitored loss that counts (threshold mode ``rel``)."""
    min_lr: float = 1e-6
    """The lr floor: training stops once the lr reaches it."""


@dataclass(frozen=True)
class LossConfig:
    """``loss``: L = recons_weight * L_recons + semantic_weight * L_semantic."""

    recons_weight: float = 0.01
    """λ: weight of the EISE's reconstruction term (BCE of the occupancy grid)."""
    semantic_weight: float = 1.0
    """η: weight of the MPT's next-node term (MSE to the expert's next node)."""


@dataclass(frozen=True)
class TrainConfig:
    """``train``: the behaviour-cloning run of ``trainers/bc.py``."""

    exp_name: str = "bc"
    """Run name: the run directory is ``{logger.dir}/{env.id}__{exp_name}__{seed}``."""
    seed: int = 0
    """Seeds the weights, the batch order, augmentation and path noise."""
    device: str = "auto"
    """A torch device; auto: cuda when present, else cpu."""
    threads: int | None = None
    """torch CPU threads; null: one per core, and the weights then depend on the machine
    (float sums are ordered by the thread count) and need not repeat to the last digit."""
    batch_size: int = 256
    """Samples per optimizer step (the global batch, split over the ranks of torchrun)."""
    augment: bool = True
    """Mirror the worlds of cube-symmetric robots (flips, axis swaps) per batch."""
    path_noise: float = 0.03
    """Std of Gaussian noise on the training paths (normalized units): the policy learns to
    steer back to the expert from where its own tree went (as in DART)."""
    monitor: str = "loss"
    """The validation term that drives the lr schedule and picks best.pt: loss, semantic or
    recons."""
    max_epochs: int = 300
    """Most epochs; training stops earlier at ``optim.min_lr``."""
    init_from: str | None = None
    """A checkpoint whose weights start the run (fine-tuning); null: fresh weights."""


@dataclass(frozen=True)
class TEMPConfig:
    """``train_eval.temp``, ``evaluation.temp``: the ``temp`` planner's own settings.

    One key per field of `temp_gym.planning.TEMPSettings` beyond the common ones (its
    ``policy`` aside), which say what each means; the planner checks them. Null, the default
    of each: the policy's own setting (a shipped policy carries those it was tuned with),
    else the planner's default.
    """

    attention_nodes: int | None = None
    """The attention-phase budget n of Algorithm 1; the planner's default: all of the nodes."""
    attention_patience: int | None = None
    """Attention-phase nodes without progress before classical planning takes over (0:
    never)."""
    attention_uniform: float | None = None
    """Probability of a uniform sample in the attention phase."""
    attention_near_goal_factor: float | None = None
    """How many times its patience the attention phase waits once the tree is near the goal
    (at least 1)."""
    attention_follow_fallback: float | None = None
    """Probability that the policy goes on from a fallback node that got no closer to the
    goal."""
    attention_keep_chunk: bool | None = None
    """After a chunk's proposal collided and a fallback node replaced it, go on with the chunk
    (true) or call the policy again (false, the planner's default)."""
    attention_resume: float | None = None
    """Classical nodes, in stall patiences, before the attention phase resumes after a stall
    (0: never)."""
    attention_resume_growth: float | None = None
    """How many times longer each classical turn between resumed attention phases is than the
    one before (at least 1)."""
    goal_tree: bool | None = None
    """Whether TEMP grows a tree from the goal when its attention phase ends unsolved (the
    planner's default: true)."""
    attention_from_goal: bool | None = None
    """Whether, after a stall, the policy grows that tree first (the attention phase from the
    goal; needs ``goal_tree``; the planner's default: true)."""
    attention_rounds: int | None = None
    """After the attention phases from the start and from the goal both stalled, at most this
    many more rounds of the two (0: none; needs ``attention_from_goal``)."""
    attention_local_fallback: int | None = None
    """Replacements of a colliding proposal drawn near it before uniform ones (0: none,
    Algorithm 1)."""


@dataclass(frozen=True)
class TrainEvalConfig:
    """``train_eval``: ``trainers/bc.py``'s planning on held-out tasks.

    Every ``every`` epochs TEMP plans ``periodic_tasks`` tasks in the env (TensorBoard's
    ``eval/*`` charts); after training, TEMP and RRT* plan ``tasks`` tasks up to their first
    solution (the printed table). ``trainers/tune_planner.py`` plans with these settings too.
    The paper's protocol is the ``evaluation`` section's.
    """

    split: str = "test"
    """Workspace split the tasks are drawn from (test: workspaces no training saw)."""
    difficulty: str = "mixed"
    """Task difficulty: mixed (easy and challenging, half each), any, easy or challenging."""
    tasks: int = 100
    """Tasks of the final TEMP vs. RRT* comparison."""
    periodic_tasks: int = 10
    """Tasks of each evaluation during training."""
    every: int = 10
    """Epochs between evaluations during training; 0: none."""
    max_nodes: int = 3000
    """Node budget per episode; a failure counts as all of it."""
    noise_std: float | None = 0.03
    """Gaussian noise on TEMP's samples (normalized units); null: the checkpoint's own setting
    (a shipped policy's, for ``trainers/correct.py`` and ``trainers/tune_planner.py``), else
    none."""
    temp: TEMPConfig = field(default_factory=TEMPConfig)
    """TEMP's planner settings (`TEMPConfig`); null ones: the policy's own, else the
    planner's defaults."""
    seed: int = 1000
    """Seed of the periodic tasks (task i: seed + i); the final comparison's are drawn from
    seed + 10000 and ``tune_planner.py``'s from seed + 20000, so the sets differ."""


@dataclass(frozen=True)
class EvaluationConfig:
    """``evaluation``: the paper's protocol (``trainers/evaluate.py``) on unseen test tasks."""

    tasks: int | None = None
    """Tasks per row (2D/3D: an easy and a challenging row; 7D: one); null: the robot's."""
    baselines: list[str] = field(default_factory=lambda: ["rrt_star", "informed_rrt_star"])
    """Planners TEMP is compared with (the OMPL ones need the ``ompl`` extra)."""
    max_nodes: int = 10000
    """Node budget of every run."""
    time_limit: float = 60.0
    """Seconds per run."""
    curve_tasks: int = 10
    """Per row, tasks that also get fixed-budget runs (the cost-vs-nodes curves)."""
    curve_nodes: int = 3000
    """Node budget of those fixed-budget runs."""
    noise_std: float | None = None
    """TEMP's output noise; null: the checkpoint's setting, else none."""
    horizon: int | None = None
    """Proposals used per MPT call; null: the checkpoint's, else the model's whole chunk."""
    temp: TEMPConfig = field(default_factory=TEMPConfig)
    """TEMP's planner settings (`TEMPConfig`); null ones: the checkpoint's, else the
    planner's defaults."""
    seed: int = 0
    """Seeds the test tasks drawn and every planner's runs on them."""
    warm_runs: bool = True
    """Before each timed run, an untimed short run of the same planner on another problem,
    so that the order of the planners does not bias their times."""
    fresh_workspaces: bool = True
    """Before each timed run, the planners forget the task's workspace (the tree's free
    volume, TEMP's encoding), so that every planner pays that set-up as a first plan on a new
    workspace does."""
    workspace_family: str = "boxes"
    """Workspace family of the test workspaces (`temp_gym.worlds.structured`): the family
    the policy was trained on (``data.workspace_family``) measures it in distribution."""
    workers: int = 2
    """Processes (``--workers`` overrides it)."""
    out: str | None = None
    """Output directory; null: ``results/{env.id}``."""


@dataclass(frozen=True)
class LoggerConfig:
    """``logger``: where and how ``trainers/bc.py`` logs."""

    backend: str = "tensorboard"
    """tensorboard, or "" to log nothing."""
    dir: str = "runs"
    """The directory that holds the run directories."""


@dataclass(frozen=True)
class Config:
    """A whole config: its sections, in the order of the YAML files."""

    env: EnvConfig
    """The planning world."""
    data: DataConfig
    """The demonstrations."""
    model: ModelConfig = field(default_factory=ModelConfig)
    """The model's sizes."""
    optim: OptimConfig = field(default_factory=OptimConfig)
    """The optimizer and lr schedule."""
    loss: LossConfig = field(default_factory=LossConfig)
    """The loss weights."""
    train: TrainConfig = field(default_factory=TrainConfig)
    """The training run."""
    train_eval: TrainEvalConfig = field(default_factory=TrainEvalConfig)
    """Planning on held-out tasks during and after training."""
    evaluation: EvaluationConfig = field(default_factory=EvaluationConfig)
    """The paper's evaluation protocol."""
    logger: LoggerConfig = field(default_factory=LoggerConfig)
    """Logging."""

    def to_dict(self) -> dict[str, Any]:
        """The plain nested dict (what ``last.pt`` stores and TensorBoard's HParams show)."""
        return to_dict(self)
