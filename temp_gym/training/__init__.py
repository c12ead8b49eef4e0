"""What the trainers (``trainers/*.py``) share.

* `temp_gym.training.batches`: `SplitData`, chunk targets, augmentation, batch order,
  `ensure_dataset`;
* `temp_gym.training.parallel`: `Distributed`, this process's place in a ``torchrun`` job;
* `temp_gym.training.optimization`: `make_model`, `make_loss`, `make_optimizer`, `model_step`;
* `temp_gym.training.logs`: `Logger` (TensorBoard or none), tag descriptions, chart layout;
* `temp_gym.training.episodes`: `make_env`, `draw_problems`, `plan_episode`, `summarize`,
  `paired_nodes`.

The top layer of the package (docs/architecture.md): it may import every other; nothing in
the package imports it.
"""

from temp_gym.training.batches import (
    BATCH_KEYS,
    COORDINATE_KEYS,
    SplitData,
    augment_symmetry,
    chunk_rows,
    draw_symmetry,
    ensure_dataset,
    iterate_batch_indices,
    iterate_batches,
    make_replay_buffer,
    perturb_path,
)
from temp_gym.training.episodes import (
    draw_problems,
    evaluate_planner,
    make_env,
    nodes_or_budget,
    paired_nodes,
    plan_episode,
    run_episode,
    summarize,
    temp_settings,
)
from temp_gym.training.logs import (
    FINAL_DESCRIPTION,
    HPARAM_METRICS,
    LAYOUT,
    TAG_DESCRIPTIONS,
    Logger,
    check_logger_backend,
    describe_tag,
    make_logger,
)
from temp_gym.training.optimization import make_loss, make_model, make_optimizer, model_step
from temp_gym.training.parallel import Distributed, launch_rank

__all__ = [
    "BATCH_KEYS",
    "COORDINATE_KEYS",
    "FINAL_DESCRIPTION",
    "HPARAM_METRICS",
    "LAYOUT",
    "TAG_DESCRIPTIONS",
    "Distributed",
    "Logger",
    "SplitData",
    "augment_symmetry",
    "check_logger_backend",
    "chunk_rows",
    "describe_tag",
    "draw_problems",
    "draw_symmetry",
    "ensure_dataset",
    "evaluate_planner",
    "iterate_batch_indices",
    "iterate_batches",
    "launch_rank",
    "make_env",
    "make_logger",
    "make_loss",
    "make_model",
    "make_optimizer",
    "make_replay_buffer",
    "model_step",
    "nodes_or_budget",
    "paired_nodes",
    "perturb_path",
    "plan_episode",
    "run_episode",
    "summarize",
    "temp_settings",
]
