"""Expert demonstrations: RRT* paths into torchrl replay buffers on disk.

* `generate_dataset` (``python trainers/generate.py --config configs/2d.yaml``) plans the
  train/val tasks in worker processes, resumably, and assembles the buffers.
* `load_split` gives a split's replay buffer and workspace table; `dataset_exists` tells
  whether a config's dataset is complete.

The on-disk format is `temp_gym.data.format`.
"""

from temp_gym.data.dataset import dataset_exists, load_split, load_tasks, load_workspaces
from temp_gym.data.generate import generate_dataset

__all__ = ["dataset_exists", "generate_dataset", "load_split", "load_tasks", "load_workspaces"]
