"""The pretrained policies shipped inside the package, `load_policy`, and the loaded-policy cache.

Checkpoints live in ``temp_gym/checkpoints/{short name}.pt`` (``2d``, ``3d``, ``7d``: the
robot spec's ``short_name``) with a model card beside each (``.md``: data, config, metrics).
They are ordinary `TEMPModel` checkpoints, read with
``torch.load(..., weights_only=True)``.

**Loaded once per process.** `load_policy` and `policy_from_checkpoint` keep what they loaded
(the model in eval mode, its numba MPT, the SEI of each workspace seen: a `PolicyCore`) keyed
by the checkpoint file's SHA-256 digest and its snapshot's (so a snapshot beside one copy of a
checkpoint never serves another copy). A later call finds the file unchanged by its size,
modification time and inode (one ``stat``, no read) and builds a new `TEMPPolicy` on the same
core; a file that changed is read and hashed again, and only a new digest loads new weights.
Each call still returns its own policy (its own noise generator and problem), so concurrent
plans do not share state beyond the read-only core.

**The planner's default policy** (`shipped_policy`, what ``plan(problem)`` uses when given no
policy) goes one step further: one `TEMPPolicy` per robot and thread, kept while the
checkpoint's digest stays the same. The planner resets it (problem and seed) before every
run, so keeping it changes no result, and a default ``plan(problem)`` after the first on a
robot builds no policy and reads nothing from disk.

**Without PyTorch when it can.** Beside a checkpoint may lie its inference snapshot
(``{stem}.kernels.npz``, `temp_gym.models.snapshot`; ``trainers/ship.py`` writes one for each
shipped policy). When its stored digest is the checkpoint file's, the cached core is built
from it: the numba kernels' arrays, with no PyTorch import, which is most of a first
``plan(problem)``'s time. The PyTorch model is loaded from the same bytes when something
needs it (``policy.model``, ``backend="torch"``, recorded attention); a checkpoint file
changed in between is refused, not silently mixed.

The cached models are shared: do not train them in place (their parameters have
``requires_grad`` off to make that fail loudly). To fine-tune, load a private copy with
`temp_gym.models.temp.load_checkpoint`.
"""

from __future__ import annotations

import hashlib
import os
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from temp_gym.models.checkpoint_file import read_checkpoint_bytes
from temp_gym.models.snapshot import snapshot_path
from temp_gym.worlds.robots import RobotSpec, robot_specs

CHECKPOINT_DIR = Path(__file__).resolve().parent.parent / "checkpoints"


def robot_of(name: str) -> RobotSpec:
    """The spec of an env id (``TEMP-7D-v0``) or a robot name (``point2d``).

    Raises:
        ValueError: for an unknown name (the message lists the known ones).
    """
    specs = robot_specs()
    for spec in specs:
        if name in (spec.env_id, spec.name):
            return spec
    known = [spec.env_id for spec in specs] + [spec.name for spec in specs]
    raise ValueError(f"policy: unknown name {name!r}; expected one of {known}")


def checkpoint_path(spec: RobotSpec) -> Path:
    """Where the policy shipped for ``spec``'s robot is (or would be) stored."""
    return Path(_checkpoint_file(spec))


def _checkpoint_file(spec: RobotSpec) -> str:
    # A string: `load_policy` runs on every default plan(), and pathlib costs microseconds.
    return os.path.join(CHECKPOINT_DIR, f"{spec.short_name}.pt")


def shipped_checkpoint(name: str) -> Path:
    """Path of the shipped checkpoint for an env id (``TEMP-7D-v0``) or a robot (``point2d``).

    Raises:
        ValueError: for an unknown name.
        FileNotFoundError: when this build ships no checkpoint for it.
    """
    spec = robot_of(name)
    path = checkpoint_path(spec)
    if not path.is_file():
        raise _not_shipped(spec, path)
    return path


def _not_shipped(spec: RobotSpec, path: Path) -> FileNotFoundError:
    return FileNotFoundError(
        f"no pretrained policy for {spec.env_id} ships with this build ({path} is missing); "
        "train one with trainers/bc.py and pass it (policy=TEMPPolicy.from_checkpoint(PATH) in "
        "Python, --checkpoint PATH to temp-plan), or plan without one "
        "(planner='informed_rrt_star', or 'rrt_connect')"
    )


@dataclass
class LoadedCheckpoint:
    """A checkpoint as the cache keeps it."""

    core: Any
    """The `temp_gym.models.policy.PolicyCore` of its model."""
    meta: dict[str, Any]
    """The checkpoint dict without its tensors (robot, planner settings, provenance)."""
    digest: str
    """SHA-256 of the file's bytes."""


_BY_DIGEST: dict[tuple[str, str | None], LoadedCheckpoint] = {}
"""(checkpoint digest, snapshot digest or None) -> what was loaded from them."""
_BY_FILE: dict[str, tuple[tuple, tuple[str, str | None]]] = {}
"""Absolute checkpoint path -> (the stamps of it and its snapshot, the `_BY_DIGEST` key)."""
_LOCK = threading.Lock()


def _file_stamp(path: str | Path) -> tuple[int, int, int]:
    status = os.stat(path)
    return status.st_size, status.st_mtime_ns, status.st_ino


def _stamps(path: str) -> tuple:
    """The stamps of a checkpoint and of its snapshot (None when there is none)."""
    try:
        snapshot = _file_stamp(snapshot_path(path))
    except OSError:
        snapshot = None
    return _file_stamp(path), snapshot


def load_cached(path: str | Path, robot: str | None = None) -> LoadedCheckpoint:
    """The checkpoint at ``path``, loaded once per content digest (module docstring).

    Raises:
        ValueError: not a TEMP checkpoint, or trained for another ``robot`` than asked for.
    """
    from temp_gym.models.policy import PolicyCore
    from temp_gym.models.snapshot import read_snapshot, snapshot_bytes
    from temp_gym.planning.policy import check_compatible

    # An absolute path is key enough (the digests dedup links and copies); resolving it would
    # cost a syscall per path component on every call.
    key = os.path.abspath(os.fspath(path))
    stamps = _stamps(key)
    with _LOCK:
        known = _BY_FILE.get(key)
        loaded = _BY_DIGEST.get(known[1]) if known is not None and known[0] == stamps else None
    if loaded is None:
        path = Path(key)
        data = read_checkpoint_bytes(path)
        digest = hashlib.sha256(data).hexdigest()
        # Keyed by the snapshot's bytes too: a copy of a checkpoint with another snapshot beside
        # it (a damaged or tampered one) never shares a core with the original.
        stored = snapshot_bytes(path)
        cache_key = (digest, None if stored is None else hashlib.sha256(stored).hexdigest())
        with _LOCK:
            loaded = _BY_DIGEST.get(cache_key)
        if loaded is None:
            snapshot = None if stored is None else read_snapshot(path, digest, stored)
            if snapshot is not None:
                core = PolicyCore.from_snapshot(snapshot, _model_loader(path, digest))
                loaded = LoadedCheckpoint(core, snapshot.meta, digest)
            else:
                model, checkpoint = _load_model(path, data)
                meta = {k: v for k, v in checkpoint.items() if k != "state_dict"}
                loaded = LoadedCheckpoint(PolicyCore(model), meta, digest)
        with _LOCK:
            _BY_DIGEST[cache_key] = loaded
            _BY_FILE[key] = (stamps, cache_key)
    if robot is not None:
        info = loaded.core.info
        check_compatible(info.robot, info.dim, robot, None, source=key)
    return loaded


def _load_model(path: Path, data: bytes) -> tuple[Any, dict[str, Any]]:
    """The frozen model and the checkpoint dict of ``path``'s bytes ``data`` (PyTorch)."""
    from temp_gym.models.temp import load_checkpoint

    model, checkpoint = load_checkpoint(path, data=data)
    model.requires_grad_(False)
    return model, checkpoint


def _model_loader(path: Path, digest: str):
    """Loads the model of a snapshot's checkpoint later, if the file still has ``digest``."""

    def load():
        data = read_checkpoint_bytes(path)
        if hashlib.sha256(data).hexdigest() != digest:
            raise RuntimeError(
                f"{path} changed since its policy was loaded (SHA-256 {digest[:12]}...); load "
                "the policy again to use the new file"
            )
        return _load_model(path, data)[0]

    return load


def clear_cache() -> None:
    """Forget every loaded checkpoint (the next load reads its file again)."""
    with _LOCK:
        _BY_DIGEST.clear()
        _BY_FILE.clear()


def policy_from_checkpoint(
    path: str | Path,
    robot: str | None = None,
    noise_std: float | None = None,
    seed: int | None = None,
    attention_nodes: int | None = None,
    horizon: int | None = None,
    **replaced: float | int,
):
    """A `TEMPPolicy` on the cached checkpoint at ``path``, with the settings it carries.

    The checkpoint carries the settings it was shipped with (`trainers/ship.py`;
    `temp_gym.models.checkpoint_settings`): the output noise, the proposals used per MPT
    call (``horizon``), the path window, and the ``temp`` planner's settings a policy may
    carry (the attention-phase budget n, the stall patience, ...), which the planner uses
    where its caller set none. A checkpoint without them gets no noise, its whole chunk, the
    whole path it was trained on and the planner's defaults. Each given by keyword (those of
    `temp_gym.models.checkpoint_settings.CHECKPOINT_SETTINGS`: ``path_window=16``,
    ``attention_rounds=2``, ...) replaces the checkpoint's: a training run not yet shipped is
    then compared under a shipped policy's settings (`benchmarks/policy_speed.py`).

    Raises:
        ValueError: a keyword that is not one of those, or an invalid value (naming it).
    """
    from temp_gym.models.checkpoint_settings import CHECKPOINT_SETTINGS

    unknown = sorted(set(replaced) - set(CHECKPOINT_SETTINGS))
    if unknown:
        raise ValueError(
            f"planner settings: unknown {unknown}; expected some of {list(CHECKPOINT_SETTINGS)}"
        )
    given = {"noise_std": noise_std, "attention_nodes": attention_nodes, "horizon": horizon}
    replaced.update({key: value for key, value in given.items() if value is not None})
    return _policy_on(load_cached(path, robot), seed, replaced)


def _policy_on(loaded: LoadedCheckpoint, seed: int | None = None, replaced: dict | None = None):
    """A new `TEMPPolicy` on a cached checkpoint, with its settings (``replaced`` win)."""
    from temp_gym.models.checkpoint_settings import policy_keywords
    from temp_gym.models.policy import TEMPPolicy

    carried = {**loaded.meta.get("planner", {}), **(replaced or {})}
    return TEMPPolicy(None, seed=seed, core=loaded.core, **policy_keywords(carried))


def load_policy(name: str, noise_std: float | None = None, seed: int | None = None):
    """The shipped `TEMPPolicy` for an env id or robot, e.g. ``load_policy("TEMP-7D-v0")``.

    Cached per process (module docstring). The checkpoint carries the settings it was shipped
    with (its model card says how they were chosen; `policy_from_checkpoint` lists them): the
    output noise, used unless ``noise_std`` is given, and the ``temp`` planner's settings it
    was tuned with (the attention-phase budget n, the stall patience, ...), which ``plan``
    uses where its caller sets none (`temp_gym.planning.TEMPSettings`).
    """
    given = {} if noise_std is None else {"noise_std": noise_std}
    return _policy_on(_load_shipped(robot_of(name)), seed, given)


def _load_shipped(spec: RobotSpec) -> LoadedCheckpoint:
    """The cached checkpoint shipped for ``spec``'s robot, or `_not_shipped`'s error."""
    path = _checkpoint_file(spec)
    try:  # the cache's one stat is the existence check too
        return load_cached(path, spec.name)
    except FileNotFoundError as error:
        if os.path.isfile(path):  # something else was missing
            raise
        raise _not_shipped(spec, Path(path)) from error


_DEFAULTS = threading.local()
"""Per thread: robot name -> (the `LoadedCheckpoint`, the planner's default policy on it)."""


def shipped_policy(robot: str):
    """The ``temp`` planner's default policy for ``robot``: the shipped one, kept per thread.

    The same `TEMPPolicy` is returned on every call in a thread while the checkpoint file
    keeps its digest (the cache's one ``stat`` notices a changed file); the planner resets it
    before each run, so reusing it changes no result. Other threads get their own, so
    concurrent plans share nothing but the read-only core. Use `load_policy` for a policy of
    your own to configure.
    """
    spec = robot_of(robot)
    loaded = _load_shipped(spec)
    policies = getattr(_DEFAULTS, "policies", None)
    if policies is None:
        policies = _DEFAULTS.policies = {}
    known = policies.get(spec.name)
    if known is None or known[0] is not loaded:
        known = policies[spec.name] = (loaded, _policy_on(loaded))
    return known[1]
