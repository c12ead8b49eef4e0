"""The on-disk demonstration format, shared by the generator, the trainer and the tests.

A dataset directory (``data.dir`` in the config) holds, per split (``train``, ``val``):

* ``{split}/buffer/``: the samples, one entry per (expert path prefix, next node), loaded as
  a torchrl `ReplayBuffer` (`temp_gym.data.load_split`).
* ``{split}/workspaces/``: the workspace table, one row per workspace: ``workspace_id``
  (int64) and ``occupancy`` (float32, ``(R,)*w``). Samples refer to it by ``workspace_id``,
  so the encoding is stored once per workspace, not per sample.
* ``{split}/tasks/``: one row per attempted task (`TASK_KEYS`); ``{split}/units/``: the
  generator's resumable per-workspace results (``.npz``, read without pickle).

Each table is a directory of ``{key}.npy`` columns (`temp_gym.data.tables`): memory-mapped,
never unpickled. ``dataset_card.json`` (format version, counts, planner, budget, seeds, cost
and node statistics, and the size and SHA-256 of every table file) is written last;
``settings.json`` holds the settings that made the dataset.

Sample keys use the names of the env's observation (`temp_gym.envs.PlanningEnv`), so a
policy reads a training sample and a live observation the same way. All coordinates are
normalized to [-1, 1]^d.
"""

from __future__ import annotations

SPLITS = ("train", "val")

SAMPLE_KEYS: dict[str, str] = {
    "workspace_id": "int64 (): row of the workspace table (the split's workspace index)",
    "task_id": "int64 (): task index within the split (workspace * tasks_per_workspace + task)",
    "step": "int64 (): k, the index of the last node of the prefix",
    "start": "float32 (d,): start, normalized",
    "goal": "float32 (d,): goal, normalized",
    "goal_radius": "float32 (1,): goal radius over the mean half-range of the bounds",
    "path": "float32 (L, d): prefix x0..xk (its last L nodes), normalized, zero-padded",
    "path_length": "int64 (1,): valid rows of path",
    "target": "float32 (d,): x(k+1), the next node of the expert path, normalized",
}
"""Every key of a stored sample, with dtype, shape and meaning."""


def sample_shapes(dim: int, max_path_length: int) -> dict[str, tuple[str, tuple[int, ...]]]:
    """Dtype and per-sample shape of every `SAMPLE_KEYS` entry, for ``d = dim``, ``L``."""
    shapes = {"()": (), "(d,)": (dim,), "(1,)": (1,), "(L, d)": (max_path_length, dim)}
    out = {}
    for key, doc in SAMPLE_KEYS.items():
        dtype, shape = doc.split(":")[0].split(" ", 1)
        out[key] = (dtype, shapes[shape])
    return out


WORKSPACE_KEYS: dict[str, str] = {
    "workspace_id": "int64 (): the split's workspace index",
    "occupancy": "float32 (R,)*w: occupancy grid (temp_gym.worlds.encoding.occupancy_grid)",
}

TASK_KEYS: dict[str, str] = {
    "task_id": "int64 (): task index within the split, as in samples",
    "workspace_id": "int64 (): row of the workspace table",
    "status": "int64 (): 0 solved and stored, 1 no certified solution, 2 no task drawn",
    "success": "bool (): status == 0 (only these tasks have samples)",
    "start": "float64 (d,): start, world units",
    "goal": "float64 (d,): goal, world units",
    "goal_radius": "float64 (): goal radius, world units",
    "cost": "float64 (): expert path cost, world units (inf when not solved)",
    "nodes": "int64 (): tree nodes of the expert run",
    "nodes_to_first_solution": "int64 (): tree size at the first solution (-1: none)",
    "plan_time": "float64 (): seconds the expert planner ran",
    "plan_seed": "int64 (): seed passed to temp_gym.plan",
    "waypoints": "int64 (): vertices of the expert path before resampling (0: not solved)",
    "samples": "int64 (): samples of the task in the buffer (resampled nodes - 1)",
}
"""Added for the generator: ``{split}/tasks/``, a memory-mapped `TensorDict` with one row per
attempted task (failed ones included), for auditing and evaluation; not needed for training."""
