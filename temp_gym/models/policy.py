"""`TEMPPolicy`: the learned sampler; stepping `PlanningEnv` with it is attention-based planning.

``reset(problem)`` encodes the workspace once (EISE on its occupancy grid, cached per
workspace); each ``policy(observation)`` runs the MPT once on the cached SEI, the task and the
path so far, and returns the next sample in [-1, 1]^d. With the env's ``fallback="random"``
this is the paper's Algorithm 1: a sample whose edge collides is replaced by random samples.

Backends: the MPT runs in PyTorch, or (``backend="numba"``, what ``"auto"`` picks on the CPU)
in `temp_gym.models.fast_mpt.FastMPT`: the same computation on a snapshot of the weights taken
when the policy is built, 4-10x faster per sample on one core (tens of microseconds instead of
about half a millisecond at the usual path lengths). The per-problem part of the MPT's input
(SEI, goal, start) is computed once in ``reset``. Recording attention needs the PyTorch model: with
``record_attention`` set, ``"auto"`` runs PyTorch.

Stochasticity: with ``noise_std > 0`` the sample gets Gaussian noise of that standard
deviation (in normalized units) from the policy's own seeded generator, and is clipped to
[-1, 1]; so a tree that keeps returning to the same state still spreads out. ``noise_std=0``
(the default) is deterministic.

Chunks: a model with ``chunk = k`` (`temp_gym.models.mpt.MPT`) predicts the next k nodes per
call. ``propose_chunk`` returns the first ``horizon`` of them (all k by default; what the
``temp`` planner uses); ``policy(obs)`` and ``propose`` return the first, so the env steps one
node per call as before.

Path window: ``path_window`` (None: the L the model was trained on) is how many of the newest
path-so-far nodes each MPT call reads; its cost grows with the tokens it reads, and the oldest
nodes of a deep tree's path carry little of where to go next.

Sharing: what does not change between problems (the model in eval mode, its `FastMPT`
snapshot, the SEI of each workspace seen, least recently used first out) lives in a
`PolicyCore`; policies built on one core share it, so a second policy of the same checkpoint
(`temp_gym.load_policy` caches cores per checkpoint file) costs no weight copy and no EISE run
in a workspace already encoded.

Example:
    >>> policy = TEMPPolicy.from_checkpoint("runs/.../best.pt", noise_std=0.05, seed=0)
    >>> env = gymnasium.make("TEMP-2D-v0", fallback="random")
    >>> observation, info = env.reset(seed=0)
    >>> policy.reset(env.unwrapped.problem)
    >>> observation, reward, terminated, truncated, info = env.step(policy(observation))
"""

from __future__ import annotations

import functools
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from temp_gym.models.fast_eise import FastEISE
from temp_gym.models.fast_mpt import FastMPT, Prefix
from temp_gym.models.snapshot import ModelInfo, Snapshot
from temp_gym.planning.policy import check_compatible
from temp_gym.planning.settings import noise_level, seed_value
from temp_gym.planning.temp_settings import DECLARED
from temp_gym.planning.temp_settings import check as check_setting
from temp_gym.policies import TASK_KEYS, carries, problem_signature, task_signature
from temp_gym.problem import Problem, Workspace
from temp_gym.worlds.encoding import clear_occupancy_grids, occupancy_grid
from temp_gym.worlds.normalization import goal_radius_ratio, normalize

if TYPE_CHECKING:  # PyTorch is imported when a model is built or run, not by this module
    import torch

    from temp_gym.models.temp import TEMPModel

SEI_CACHE_SIZE = 256
"""Workspaces whose SEI a `PolicyCore` remembers."""


def _sei_tensor(array: np.ndarray) -> torch.Tensor:
    """A ``(1, n, width)`` CPU tensor sharing the memory of an SEI array ``(n, width)``."""
    import torch

    return torch.from_numpy(array).unsqueeze(0)


def _device_type(device: str | torch.device) -> str:
    """``"cpu"``, ``"cuda"``, ... of a device or its name, without importing PyTorch."""
    return str(device).split(":")[0]


class PolicyCore:
    """What the policies of one model share: the model, its numba kernels, the SEI per workspace.

    Args:
        model: the trained model; put in eval mode and moved to ``device``.
        device: where the PyTorch model runs.
        fast: whether to build the `FastMPT` and `FastEISE` snapshots (CPU only); with them the
            SEI is computed by `FastEISE` for every policy of this core.

    `from_snapshot` builds a core without PyTorch, from a checkpoint's stored inference
    snapshot (`temp_gym.models.snapshot`); its `model` is loaded when first asked for.
    """

    def __init__(self, model: TEMPModel, device: str | torch.device = "cpu", fast: bool = True):
        import torch

        self.device = torch.device(device)
        self._model: TEMPModel | None = model.to(self.device).eval()
        self._load_model: Callable[[], TEMPModel] | None = None
        self.info = ModelInfo.of(model)
        fast = fast and self.device.type == "cpu"
        self.fast = FastMPT(model.mpt) if fast else None
        self.fast_eise = FastEISE(model.eise) if fast else None
        self._sei: OrderedDict[Workspace, tuple[torch.Tensor | None, np.ndarray]] = OrderedDict()
        self._lock = threading.Lock()
        self._model_lock = threading.Lock()

    @classmethod
    def from_snapshot(cls, snapshot: Snapshot, load_model: Callable[[], TEMPModel]) -> PolicyCore:
        """A CPU core on a checkpoint's inference snapshot; imports no PyTorch.

        Args:
            snapshot: `temp_gym.models.snapshot.read_snapshot`'s, of the checkpoint.
            load_model: returns the checkpoint's model (with PyTorch); called once, when
                something first needs the model itself (`model`).
        """
        core = cls.__new__(cls)
        core.device = "cpu"
        core._model = None
        core._load_model = load_model
        core.info = snapshot.info
        core.fast = FastMPT.from_arrays(snapshot.mpt)
        core.fast_eise = FastEISE.from_arrays(snapshot.eise)
        core._sei = OrderedDict()
        core._lock = threading.Lock()
        core._model_lock = threading.Lock()
        return core

    @property
    def model(self) -> TEMPModel:
        """The PyTorch model in eval mode (a snapshot's core loads it now, once)."""
        if self._model is None:
            with self._model_lock:
                if self._model is None:
                    self._model = self._load_model().to(self.device).eval()
        return self._model

    def holds(self, model: TEMPModel) -> bool:
        """Whether ``model`` is this core's (loaded) model."""
        return self._model is model

    def encode(self, occupancy: np.ndarray) -> tuple[torch.Tensor, np.ndarray]:
        """The SEI of one occupancy grid: ``(1, n, width)`` tensor on the device, float32 array.

        `FastEISE` on a fast core (the tensor then shares the array's memory), else the
        model's EISE in PyTorch.
        """
        return self._with_tensor(self._encode(occupancy))

    def sei(self, problem: Problem) -> tuple[torch.Tensor, np.ndarray]:
        """The SEI of the problem's workspace (encoded once per workspace): `encode`'s pair."""
        return self._with_tensor(self._cached(problem))

    def clear_encodings(self) -> None:
        """Forget every workspace's SEI: the next plan in each workspace encodes it again.

        What a policy pays on a workspace it has not seen, as in the paper's protocol, where
        every test task has its own (`benchmarks/policy_speed.py --fresh-encoding`); it also
        frees the memory the encodings hold.
        """
        with self._lock:
            self._sei.clear()

    def forget(self, workspace: Workspace) -> None:
        """Forget one workspace's SEI: the next plan in it encodes it again."""
        with self._lock:
            self._sei.pop(workspace, None)

    def sei_array(self, problem: Problem) -> np.ndarray:
        """`sei`'s float32 array alone: on a fast core no tensor is made (the planner's path)."""
        return self._cached(problem)[1]

    def _encode(self, occupancy: np.ndarray) -> tuple[torch.Tensor | None, np.ndarray]:
        if self.fast_eise is not None:
            return None, self.fast_eise(occupancy)  # the tensor is made when asked for
        import torch

        grid = torch.from_numpy(np.ascontiguousarray(occupancy, np.float32)).unsqueeze(0)
        with torch.inference_mode():
            tensor = self.model.eise(grid.to(self.device))
        return tensor, tensor.cpu().numpy()[0].astype(np.float32)

    def _encode_workspace(self, workspace: Workspace) -> tuple[torch.Tensor | None, np.ndarray]:
        """`_encode` of the workspace's occupancy grid: what `_cached` keeps per workspace.

        A fast core makes the grid and encodes it in one compiled call
        (`FastEISE.encode_workspace`: the same SEI), without the grid cache.
        """
        if self.fast_eise is not None:
            return None, self.fast_eise.encode_workspace(workspace)
        return self._encode(occupancy_grid(workspace, self.info.encoding_resolution))

    @staticmethod
    def _with_tensor(
        pair: tuple[torch.Tensor | None, np.ndarray],
    ) -> tuple[torch.Tensor, np.ndarray]:
        tensor, array = pair
        return (_sei_tensor(array) if tensor is None else tensor), array

    def _cached(self, problem: Problem) -> tuple[torch.Tensor | None, np.ndarray]:
        key = problem.workspace
        with self._lock:
            sei = self._sei.get(key)
            if sei is not None:
                self._sei.move_to_end(key)
                return sei
        sei = self._encode_workspace(problem.workspace)
        with self._lock:
            self._sei[key] = sei
            if len(self._sei) > SEI_CACHE_SIZE:
                self._sei.popitem(last=False)
        return sei


@functools.lru_cache(maxsize=256)
def _seeded_state(seed: int) -> dict:
    """The state of ``numpy.random.default_rng(seed)``'s bit generator (PCG64); not mutated."""
    return np.random.PCG64(seed).state


class TEMPPolicy:
    """A `temp_gym.policies.SamplingPolicy` backed by a `TEMPModel`.

    Args:
        model: the trained model (put in eval mode; kept on CPU unless ``device`` says); None
            with a ``core``, whose model it then is.
        noise_std: standard deviation of the Gaussian output noise (normalized units).
        seed: seed of the noise generator.
        record_attention: keep each step's attention weights in ``attentions`` (PyTorch only;
            may be switched on and off between episodes).
        device: where the model runs.
        backend: ``"torch"``, ``"numba"`` (`FastMPT`, CPU only, takes a snapshot of the
            weights now: build a new policy after training the model further) or ``"auto"``:
            numba on the CPU whenever attention is not recorded, PyTorch otherwise.
        core: a `PolicyCore` of ``model`` to share (None: a new one); `load_policy` passes
            the cached core of its checkpoint, which may be a snapshot's (no PyTorch until
            the model itself is needed).
        horizon: proposals per call, the first ``horizon`` of the model's chunk (None: all);
            later ones continue a longer guess, so fewer can waste fewer samples.
        path_window: the newest nodes of the path so far the MPT reads, at most the L it was
            trained on (None: all L). The path tokens' positions count back from the newest
            node, so a window shows the model the same tokens as the whole path less the oldest
            ones; each MPT call then costs the same in a deep tree as in a shallow one.
        **planner_settings: the ``temp`` planner's settings this policy carries
            (`temp_gym.planning.temp_settings.DECLARED`: ``attention_nodes``,
            ``attention_patience``, ``attention_local_fallback``, ...), each checked as
            `temp_gym.planning.TEMPSettings` checks it; the planner uses them where its
            caller set none. Shipped policies carry theirs (`temp_gym.load_policy`).
    """

    BACKENDS = ("auto", "torch", "numba")

    def __init__(
        self,
        model: TEMPModel | None = None,
        noise_std: float = 0.0,
        seed: int | None = None,
        record_attention: bool = False,
        device: str | torch.device = "cpu",
        backend: str = "auto",
        core: PolicyCore | None = None,
        horizon: int | None = None,
        path_window: int | None = None,
        **planner_settings: Any,
    ) -> None:
        noise_std = noise_level(noise_std)
        if seed is not None:
            seed = seed_value(seed)
        if backend not in self.BACKENDS:
            raise ValueError(f"backend: expected one of {self.BACKENDS}, got {backend!r}")
        for name in DECLARED:  # each set, None when not carried
            value = planner_settings.pop(name, None)
            setattr(self, name, None if value is None else check_setting(name, value))
        if planner_settings:
            raise TypeError(
                f"TEMPPolicy: unknown settings {sorted(planner_settings)}; the planner settings "
                f"a policy carries are {list(DECLARED)}"
            )
        self.device = device
        if backend == "numba" and (_device_type(device) != "cpu" or record_attention):
            raise ValueError(
                "backend 'numba' runs on the CPU and records no attention; got device "
                f"{self.device} and record_attention={record_attention}"
            )
        wants_fast = backend != "torch" and _device_type(device) == "cpu"
        if core is None:
            if model is None:
                raise ValueError("TEMPPolicy: give a model, or a core to share")
            core = PolicyCore(model, device, fast=wants_fast)
        elif (model is not None and not core.holds(model)) or str(core.device) != str(device):
            raise ValueError("core: a PolicyCore of another model or device")
        self.core = core
        self.info = core.info
        self.backend = backend
        self._fast = core.fast if wants_fast else None
        if wants_fast and self._fast is None:
            self._fast = FastMPT(self.model.mpt)
        chunk = self.info.chunk
        if horizon is not None and not (isinstance(horizon, int) and 1 <= horizon <= chunk):
            raise ValueError(
                f"horizon: expected an integer in 1..{chunk} (the chunk), got {horizon!r}"
            )
        self.horizon = chunk if horizon is None else horizon
        trained = self.info.max_path_length
        if path_window is not None and not (
            isinstance(path_window, int) and not isinstance(path_window, bool)
            and 1 <= path_window <= trained
        ):  # fmt: skip
            raise ValueError(
                f"path_window: expected an integer in 1..{trained} (the L the model was trained "
                f"on) or None, got {path_window!r}"
            )
        self.path_window = path_window
        self._prefix: Prefix | None = None
        self._out = np.empty((self.horizon, self.info.dim), np.float32)
        self.noise_std = float(noise_std)
        self.seed = seed
        self._rng_seed = seed
        self._rng: np.random.Generator | None = None
        self.record_attention = record_attention
        self.attentions: list[np.ndarray] = []
        self.problem: Problem | None = None
        self._sei: torch.Tensor | None = None
        self._sei_array: np.ndarray | None = None
        self._task_bytes: bytes | None = None  # the task and grid last planned for, read
        self._grid_bytes: bytes | None = None  # lazily from `problem` after a reset
        self._previous: tuple | None = None  # the problem reset to before this one (`reset`)

    @classmethod
    def from_checkpoint(
        cls,
        path: str | Path,
        robot: str | None = None,
        dim: int | None = None,
        **kwargs,
    ) -> TEMPPolicy:
        """Load a checkpoint (``weights_only=True``); ``robot``/``dim`` are checked if given.

        The settings the checkpoint carries (a shipped one's ``planner`` entry: noise, horizon,
        path window, the planner's settings it was tuned with) apply unless ``kwargs`` give
        others, as `temp_gym.models.registry.policy_from_checkpoint` applies them.
        """
        from temp_gym.models.checkpoint_settings import policy_keywords
        from temp_gym.models.temp import load_checkpoint

        model, loaded = load_checkpoint(path, robot=robot, dim=dim)
        carried = {key: value for key, value in policy_keywords(loaded.get("planner", {})).items()
                   if value is not None}  # fmt: skip
        return cls(model, **{**carried, **kwargs})

    def save(self, path: str | Path) -> None:
        """Write the model's checkpoint (`TEMPModel.save`)."""
        self.model.save(path)

    @property
    def model(self) -> TEMPModel:
        """The PyTorch model (shared by the core; loaded now if the core is a snapshot's)."""
        return self.core.model

    @property
    def robot(self) -> str:
        """The robot the model was trained for."""
        return self.info.robot

    @property
    def dim(self) -> int:
        """The dimension d of the robot's configuration space."""
        return self.info.dim

    def planner_settings(self) -> dict[str, Any]:
        """The ``temp`` planner's settings this policy carries, by name (None: not carried)."""
        return {name: getattr(self, name) for name in DECLARED}

    def fresh(self, **changes: Any) -> TEMPPolicy:
        """A policy of the same model and settings with its own state (noise, problem).

        ``changes`` replace constructor settings, e.g. ``policy.fresh(horizon=1)`` for one
        proposal per MPT call; the loaded model and its caches are shared either way.
        """
        settings = dict(
            noise_std=self.noise_std, seed=self.seed, record_attention=self.record_attention,
            device=self.device, backend=self.backend, core=self.core, horizon=self.horizon,
            path_window=self.path_window, **self.planner_settings(),
        )  # fmt: skip
        unknown = set(changes) - set(settings)
        if unknown:
            raise TypeError(f"fresh(): unknown settings {sorted(unknown)}")
        return TEMPPolicy(None, **{**settings, **changes})

    @property
    def rng(self) -> np.random.Generator:
        """The noise generator (seeded by the constructor's ``seed`` or the last `reset`'s)."""
        if self._rng is None:
            self._rng = np.random.default_rng(self._rng_seed)
        return self._rng

    @property
    def encoding_resolution(self) -> int:
        """Cells per workspace axis of the occupancy grid the model reads."""
        return self.info.encoding_resolution

    @property
    def max_path_length(self) -> int:
        """L: the most path-so-far rows the model was trained on (observations carry L rows)."""
        return self.info.max_path_length

    @property
    def window(self) -> int:
        """The newest rows of the path so far each MPT call reads: ``path_window``, else L."""
        return self.info.max_path_length if self.path_window is None else self.path_window

    @property
    def chunk(self) -> int:
        """Samples proposed per call of the model (`propose_chunk`): the ``horizon``."""
        return self.horizon

    def forget_workspace(self, workspace: Workspace) -> None:
        """Forget everything kept of ``workspace``: its SEI, and the occupancy grids.

        The next `reset` to a problem in it encodes it again, as on a workspace never seen:
        what the paper's protocol times (`temp_gym.evaluation.runner`, ``fresh_workspaces``).
        The occupancy grids are cached by content, all together (`clear_occupancy_grids`).
        """
        self.core.forget(workspace)
        clear_occupancy_grids()
        self._previous = None
        if self.problem is not None and self.problem.workspace == workspace:
            self.problem = None  # so that a reset to the same problem encodes it again

    def reset(self, problem: Problem, seed: int | None = None) -> None:
        """Encode the problem's workspace (cached per workspace); re-seed the noise if asked.

        Resetting to the problem the policy already holds (the same, immutable object, not
        followed away from since) keeps its encoding: only the noise is re-seeded. So does
        resetting to the problem it was reset to just before that one (the TEMP planner's
        turns between its own tree and the goal tree's swapped problem).
        """
        if seed is not None:  # the generator is made when the noise first needs it
            self._rng_seed = seed_value(seed)
            if self._rng is not None and type(self._rng.bit_generator) is np.random.PCG64:
                # default_rng(seed)'s state, set on the generator already made: seeding a
                # new one costs several times more, once per plan
                self._rng.bit_generator.state = _seeded_state(self._rng_seed)
            else:
                self._rng = None
        self.attentions = []
        if problem is self.problem and self._sei_array is not None:
            return
        held = self._task_state() if self.problem is not None else None
        if self._previous is not None and problem is self._previous[0]:
            self._set_task_state(self._previous)  # the goal tree's problem and back: a swap
            self._previous = held
            return
        self._previous = held
        check_compatible(self.info.robot, self.info.dim, problem.robot, problem.dim)
        self.problem = problem
        if self._fast is not None:  # the numba path reads the array; `_torch_sample` makes a
            self._sei, self._sei_array = None, self.core.sei_array(problem)  # tensor if asked
        else:
            self._sei, self._sei_array = self.core.sei(problem)
        # The task as the model reads it, float32; PyTorch's tensors are made when first used.
        ratio = goal_radius_ratio(problem.goal_radius, problem.bounds)
        self._task = None
        if self._fast is not None:  # the task and its prefix in one compiled call
            self._task_arrays, self._prefix = self._fast.task_prefix(
                self._sei_array, problem.start, problem.goal, problem.bounds, ratio
            )
        else:
            goal, start = normalize(np.array([problem.goal, problem.start]), problem.bounds)
            self._task_arrays = (
                goal.astype(np.float32),
                np.array([ratio], np.float32),
                start.astype(np.float32),
            )
        self._task_bytes = self._grid_bytes = None  # made by `_follow` only when it is called

    _TASK_STATE = ("problem", "_sei", "_sei_array", "_task_arrays", "_task", "_prefix",
                   "_task_bytes", "_grid_bytes")  # fmt: skip
    """What `reset` sets for a problem: the previous problem's is kept, so that the TEMP
    planner's turns between its tree and the goal tree's (the swapped problem) cost no
    encoding of the task each time."""

    def _task_state(self) -> tuple:
        return tuple(getattr(self, name) for name in self._TASK_STATE)

    def _set_task_state(self, state: tuple) -> None:
        for name, value in zip(self._TASK_STATE, state, strict=True):
            setattr(self, name, value)

    def _follow(self, observation: dict[str, np.ndarray]) -> None:
        """Plan for the observation's task when it is not the one last planned for.

        The observation carries all the MPT's per-task inputs (the occupancy grid, normalized
        start and goal, the goal radius ratio), so after an env reset the policy was not told
        about (a vector env's automatic reset) it re-encodes instead of going stale. An
        observation without them (a hand-built, path-only one) keeps the task of `reset`.
        """
        keys = ("occupancy", *TASK_KEYS)
        if not carries(observation, keys):
            if self._sei_array is not None:
                return
            raise ValueError(
                f"observation: expected the env's observation with {list(keys)}, or call "
                "policy.reset(problem) first"
            )
        if self._task_bytes is None and self.problem is not None:  # first call since reset
            self._task_bytes = problem_signature(self.problem, TASK_KEYS)
        occupancy = np.asarray(observation["occupancy"], dtype=np.float32)
        same_task = task_signature(observation, TASK_KEYS) == self._task_bytes
        if occupancy.shape != self.info.grid_shape:
            if same_task and self.problem is not None:
                return  # an env at another resolution: the grid of reset(problem) stands
            goal = np.asarray(observation["goal"])
            batched = goal.ndim == 2 and goal.shape[0] == occupancy.shape[0] > 0
            if batched and occupancy.shape[1:] == self.info.grid_shape:
                raise ValueError(
                    f"observation['occupancy']: a batch of {occupancy.shape[0]} grids (a vector "
                    "env's observation); the policy takes one env's observation: call it per "
                    "env, on each sub-observation"
                )
            raise ValueError(
                f"observation['occupancy']: expected shape {self.info.grid_shape} for "
                f"{self.info.robot} (the model's encoding_resolution "
                f"{self.info.encoding_resolution}), got {occupancy.shape}; or call "
                "policy.reset(problem) after each env reset"
            )
        if self._grid_bytes is None and self.problem is not None:
            grid = occupancy_grid(self.problem.workspace, self.info.encoding_resolution)
            self._grid_bytes = np.asarray(grid, dtype=np.float32).tobytes()
        same_grid = occupancy.tobytes() == self._grid_bytes
        if same_task and same_grid:
            return
        for key, size in (("goal", self.info.dim), ("start", self.info.dim), ("goal_radius", 1)):
            value = np.asarray(observation[key])  # a new task: read only if it fits the model
            if value.size != size:
                raise ValueError(
                    f"observation[{key!r}]: expected {size} values for {self.info.robot} "
                    f"(d={self.info.dim}), got shape {value.shape}: an observation of another "
                    "robot's env?"
                )
        if not same_grid:
            self._sei, self._sei_array = self.core.encode(occupancy)
            self._grid_bytes = occupancy.tobytes()
        self._task_arrays = tuple(
            np.asarray(observation[key], dtype=np.float32).reshape(-1)
            for key in ("goal", "goal_radius", "start")
        )
        self._task = None
        if self._fast is not None:
            self._prefix = self._fast.prefix(self._sei_array, *self._task_arrays)
        self._task_bytes = task_signature(observation, TASK_KEYS)
        self.problem = None  # the task is the observation's, not a Problem's

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Run the MPT once; return the next sample, float32 ``(d,)`` in [-1, 1].

        The task is read from the observation: an observation of another task than the last
        one (e.g. after an env reset without ``policy.reset``) is followed, not ignored.
        """
        if not isinstance(observation, Mapping):
            raise ValueError(
                f"observation: expected the env's observation dict, got "
                f"{type(observation).__name__}"
            )
        missing = [key for key in ("path", "path_length") if key not in observation]
        if missing:
            raise ValueError(f"observation: no {missing} (the env's observation has them)")
        self._follow(observation)
        path = np.asarray(observation["path"])
        if path.ndim != 2 or path.shape[1] != self.info.dim:
            raise ValueError(
                f"observation['path']: expected (L, {self.info.dim}) for {self.info.robot}, "
                f"got {path.shape}"
            )
        length = int(np.asarray(observation["path_length"]).reshape(-1)[0])
        if not 1 <= length <= len(path):
            raise ValueError(f"observation['path_length']: expected 1 .. {len(path)}, got {length}")
        if not np.all(np.isfinite(path[:length])):
            raise ValueError("observation['path']: its valid rows must be finite")
        return self.propose(path, length)

    def propose(self, path: np.ndarray, length: int) -> np.ndarray:
        """`__call__` from the path so far alone: float32 ``(d,)`` in [-1, 1].

        ``path`` is ``(L, d)`` float32, normalized, with ``length`` valid rows (the
        observer's rows, `TreeObserver.path_so_far`); the result is the one `__call__` gives
        for an observation with that path: the first row of `propose_chunk`.
        """
        return self.propose_chunk(path, length)[0]

    def propose_chunk(self, path: np.ndarray, length: int) -> np.ndarray:
        """The next `chunk` samples from the path so far: float32 ``(chunk, d)``.

        The planner's path (`temp_gym.planning.attention`): no observation is built per
        step. Noise, when set, is drawn for the whole chunk. The MPT reads the newest `window`
        of the ``length`` rows.
        """
        if self._sei_array is None:
            raise RuntimeError("call policy.reset(problem) before sampling")
        window = self.window
        if length > window:  # the newest rows; their positions are as in the whole path
            path, length = path[length - window : length], window
        if self._fast is not None and not self.record_attention:
            action = self._fast.predict(self._prefix, path, length, self._out)
        else:
            action = self._torch_sample(path, length)
        if self.noise_std > 0:
            action = action + self.rng.normal(0.0, self.noise_std, action.shape)
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    def compiled_proposer(self) -> tuple | None:
        """What the compiled attention loop needs to run this policy, or None if it cannot.

        ``(weights, goal, prefix tokens, prefix qkv, noise generator, noise_std, chunk, L)``
        for `temp_gym.planning._compiled_attention`: the `FastMPT` kernel's weights and this
        problem's prefix (so `reset` first); the generator is None when ``noise_std`` is 0.
        None on the PyTorch backend or while attention is recorded, which only PyTorch can do.
        """
        if self._fast is None or self.record_attention or self._prefix is None:
            return None
        prefix = self._prefix
        noise = self.rng if self.noise_std > 0 else None
        return (self._fast.kernel_weights, prefix.goal, prefix.z, prefix.qkv, noise,
                self.noise_std, self.chunk, self.window)  # fmt: skip

    def _torch_sample(self, path: np.ndarray, length: int) -> np.ndarray:
        """The PyTorch model's chunk (float32 ``(chunk, d)``); records attention if asked."""
        if self.backend == "numba":
            raise ValueError("backend 'numba' records no attention; use 'auto' or 'torch'")
        import torch

        if self._task is None:
            self._task = [
                torch.from_numpy(value).reshape(1, -1).to(self.device)
                for value in self._task_arrays
            ]
        if self._sei is None:  # a fast core's reset keeps the array alone
            self._sei = _sei_tensor(self._sei_array).to(self.device)
        goal, goal_radius, start = self._task
        with torch.inference_mode():
            sample, weights = self.model.mpt(
                self._sei,
                goal,
                goal_radius,
                start,
                torch.from_numpy(np.ascontiguousarray(path[:length], dtype=np.float32))
                .unsqueeze(0)
                .to(self.device),
                torch.tensor([length], device=self.device),
                need_weights=self.record_attention,
            )
        if self.record_attention:
            self.attentions.append(weights[0].cpu().numpy())
        return sample[0, : self.horizon].cpu().numpy()
