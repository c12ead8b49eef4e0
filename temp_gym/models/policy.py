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

Example:
    >>> policy = TEMPPolicy.from_checkpoint("runs/.../best.pt", noise_std=0.05, seed=0)
    >>> env = gymnasium.make("TEMP-2D-v0", fallback="random")
    >>> observation, info = env.reset(seed=0)
    >>> policy.reset(env.unwrapped.problem)
    >>> observation, reward, terminated, truncated, info = env.step(policy(observation))
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import torch

from temp_gym.models.fast_mpt import FastMPT, Prefix
from temp_gym.models.temp import TEMPModel, check_compatible, load_checkpoint
from temp_gym.planning.observation import task_entries
from temp_gym.policies import TASK_KEYS, carries, task_signature
from temp_gym.problem import Problem
from temp_gym.worlds.encoding import occupancy_grid
from temp_gym.worlds.workspace import Workspace


@contextlib.contextmanager
def _single_torch_thread(enabled: bool) -> Iterator[None]:
    """Run PyTorch ops in the block on one thread, then restore the thread count.

    After a multi-threaded op PyTorch's OpenMP workers keep spinning for a while; on the fast
    (numba) path the planner's own thread then competes with them for the cores. Measured on a
    loaded 2-core machine: the attention phase of a 2D plan took 4-5x longer after a 2-thread
    EISE call than after a 1-thread one.
    """
    previous = torch.get_num_threads()
    if not enabled or previous == 1:
        yield
        return
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


class TEMPPolicy:
    """A `temp_gym.policies.SamplingPolicy` backed by a `TEMPModel`.

    Args:
        model: the trained model (put in eval mode; kept on CPU unless ``device`` says).
        noise_std: standard deviation of the Gaussian output noise (normalized units).
        seed: seed of the noise generator.
        record_attention: keep each step's attention weights in ``attentions`` (PyTorch only;
            may be switched on and off between episodes).
        device: where the model runs.
        backend: ``"torch"``, ``"numba"`` (`FastMPT`, CPU only, takes a snapshot of the
            weights now: build a new policy after training the model further) or ``"auto"``:
            numba on the CPU whenever attention is not recorded, PyTorch otherwise.
        attention_nodes: the attention-phase budget n the ``temp`` planner uses with this
            policy when ``plan`` is given none (None: all of ``max_nodes``); shipped policies
            carry theirs (`temp_gym.load_policy`).
    """

    BACKENDS = ("auto", "torch", "numba")

    def __init__(
        self,
        model: TEMPModel,
        noise_std: float = 0.0,
        seed: int | None = None,
        record_attention: bool = False,
        device: str | torch.device = "cpu",
        backend: str = "auto",
        attention_nodes: int | None = None,
    ) -> None:
        if noise_std < 0:
            raise ValueError(f"noise_std: must be non-negative, got {noise_std}")
        if backend not in self.BACKENDS:
            raise ValueError(f"backend: expected one of {self.BACKENDS}, got {backend!r}")
        if attention_nodes is not None and int(attention_nodes) < 1:
            raise ValueError(f"attention_nodes: expected >= 1 or None, got {attention_nodes}")
        self.attention_nodes = None if attention_nodes is None else int(attention_nodes)
        self.device = torch.device(device)
        if backend == "numba" and (self.device.type != "cpu" or record_attention):
            raise ValueError(
                "backend 'numba' runs on the CPU and records no attention; got device "
                f"{self.device} and record_attention={record_attention}"
            )
        self.model = model.to(self.device).eval()
        self.backend = backend
        self._fast = (
            FastMPT(self.model.mpt) if backend != "torch" and self.device.type == "cpu" else None
        )
        self._prefix: Prefix | None = None
        self._out = np.empty(self.model.dim, np.float32)  # the fast MPT's output row
        self.noise_std = float(noise_std)
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.record_attention = record_attention
        self.attentions: list[np.ndarray] = []
        self.problem: Problem | None = None
        self._sei: torch.Tensor | None = None
        self._sei_key: tuple | None = None
        self._grid_bytes: bytes | None = None  # the occupancy grid and task last encoded
        self._task_bytes: bytes | None = None

    @classmethod
    def from_checkpoint(
        cls,
        path: str | Path,
        robot: str | None = None,
        dim: int | None = None,
        **kwargs,
    ) -> TEMPPolicy:
        """Load a checkpoint (``weights_only=True``); ``robot``/``dim`` are checked if given."""
        model, _ = load_checkpoint(path, robot=robot, dim=dim)
        return cls(model, **kwargs)

    def save(self, path: str | Path) -> None:
        """Write the model's checkpoint (`TEMPModel.save`)."""
        self.model.save(path)

    @property
    def robot(self) -> str:
        """The robot the model was trained for."""
        return self.model.robot

    def reset(self, problem: Problem, seed: int | None = None) -> None:
        """Encode the problem's workspace (cached per workspace); re-seed the noise if asked."""
        check_compatible(self.model.robot, self.model.dim, problem.robot, problem.dim)
        self.problem = problem
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.attentions = []
        key = (problem.obstacle_centers.tobytes(), problem.obstacle_half_extents.tobytes())
        if key != self._sei_key:
            self._encode(occupancy_grid(Workspace.of(problem), self.model.encoding_resolution))
            self._sei_key = key
        self._set_task(task_entries(problem))

    def _encode(self, grid: np.ndarray) -> None:
        """The SEI of an occupancy grid (EISE, one thread on the fast path)."""
        grid = np.ascontiguousarray(grid, dtype=np.float32)
        with torch.inference_mode(), _single_torch_thread(self._fast is not None):
            self._sei = self.model.eise(torch.from_numpy(grid).unsqueeze(0).to(self.device))
        self._grid_bytes = grid.tobytes()

    def _set_task(self, entries: dict[str, np.ndarray]) -> None:
        """The per-task MPT inputs (goal, goal radius, start) and the fast path's prefix."""
        self._task_bytes = task_signature(entries, TASK_KEYS)
        self._task = [
            torch.as_tensor(entries[key], dtype=torch.float32, device=self.device).reshape(1, -1)
            for key in ("goal", "goal_radius", "start")
        ]
        if self._fast is not None:  # the same float32 inputs as the PyTorch model's
            goal, goal_radius, start = (value.cpu().numpy()[0] for value in self._task)
            self._prefix = self._fast.prefix(self._sei.cpu().numpy(), goal, goal_radius, start)

    def _follow(self, observation: dict[str, np.ndarray]) -> None:
        """Plan for the observation's task when it is not the one last encoded.

        The observation carries all the MPT's per-task inputs (the occupancy grid, normalized
        start and goal, the goal radius ratio), so after an env reset the policy was not told
        about (a vector env's automatic reset) it re-encodes instead of going stale.
        """
        keys = ("occupancy", *TASK_KEYS)
        if not carries(observation, keys):
            if self._task_bytes is not None:
                return  # a path-only observation: the task given to reset(problem)
            raise ValueError(
                f"observation: expected the env's observation with {list(keys)}, or call "
                "policy.reset(problem) first"
            )
        occupancy = np.asarray(observation["occupancy"], dtype=np.float32)
        same_task = task_signature(observation, TASK_KEYS) == self._task_bytes
        if occupancy.shape != self.model.eise.grid_shape:
            if same_task and self._sei_key is not None:
                return  # an env at another resolution: the grid of reset(problem) stands
            raise ValueError(
                f"observation['occupancy']: expected shape {self.model.eise.grid_shape} for "
                f"{self.model.robot} (the model's encoding_resolution "
                f"{self.model.encoding_resolution}), got {occupancy.shape}; or call "
                "policy.reset(problem) after each env reset"
            )
        same_grid = occupancy.tobytes() == self._grid_bytes
        if same_task and same_grid:
            return
        if not same_grid:
            self._encode(occupancy)
            self._sei_key = None  # the next reset(problem) encodes its own workspace
        self._set_task({key: observation[key] for key in TASK_KEYS})
        self.problem = None  # the task is the observation's, not a Problem's

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Run the MPT once; return the next sample, float32 ``(d,)`` in [-1, 1].

        The task is read from the observation: an observation of another task than the last
        one (e.g. after an env reset without ``policy.reset``) is followed, not ignored.
        """
        self._follow(observation)
        path = np.asarray(observation["path"])
        if path.ndim != 2 or path.shape[1] != self.model.dim:
            raise ValueError(
                f"observation['path']: expected (L, {self.model.dim}) for {self.model.robot}, "
                f"got {path.shape}"
            )
        length = int(np.asarray(observation["path_length"]).reshape(-1)[0])
        return self.propose(path, length)

    def propose(self, path: np.ndarray, length: int) -> np.ndarray:
        """`__call__` from the path so far alone: float32 ``(d,)`` in [-1, 1].

        The planner's fast path (`temp_gym.planning.temp_planner`): it hands over the
        observer's path rows (`TreeObserver.path_so_far`) instead of a whole observation, so
        no observation is built per step. ``path`` is ``(L, d)`` float32, normalized, with
        ``length`` valid rows; the result is the one `__call__` gives for an observation
        with that path.
        """
        if self._fast is not None and not self.record_attention:
            action = self._fast.predict(self._prefix, path, length, self._out)
        else:
            action = self._torch_sample(path, length)
        if self.noise_std > 0:
            action = action + self.rng.normal(0.0, self.noise_std, action.shape)
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    def _torch_sample(self, path: np.ndarray, length: int) -> np.ndarray:
        """The PyTorch model's sample (float32 ``(d,)``); records attention if asked."""
        if self.backend == "numba":
            raise ValueError("backend 'numba' records no attention; use 'auto' or 'torch'")
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
        return sample[0].cpu().numpy()
