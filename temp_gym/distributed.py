"""Run independent work units on local processes or on a Ray cluster, with one interface.

Demonstration generation and evaluation both split their work into units (a workspace's
plans, a test task) that are pure functions of their arguments. `map_units` runs them and
yields ``(index, result)`` as they finish, in any order; the caller, on the driver, writes
each result to disk, so:

* results do not depend on the backend or on the order of completion (each unit seeds its own
  generators), so ``--backend ray`` gives the same files as ``--backend local``;
* workers need no shared file system: results travel back to the driver;
* resumability stays with the caller: a unit whose file exists is never submitted again.

Backends:

* ``local``: a ``spawn`` process pool of ``workers`` processes (1: in this process).
* ``ray``: one Ray task per unit (``num_cpus=1``). It connects to the cluster at ``address``
  or ``$RAY_ADDRESS`` (``auto``: the cluster this machine belongs to, started with
  ``ray start --head``); without either it starts a local Ray instance with ``workers`` CPUs.
  No cluster at the address is a `RayUnavailableError` saying so, never a silent local
  instance. Install it with ``pip install -e ".[distributed]"``.

Ctrl-C: local workers ignore SIGINT, so only the driver sees it and the pool is terminated
cleanly (no tracebacks from the workers); the caller's units written so far stay.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import signal
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from temp_gym.jobs import JobError

BACKENDS = ("local", "ray")


def _worker_count(text: str) -> int:
    """``--workers``: a positive integer (argparse reports anything else as a usage error)."""
    try:
        count = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if count < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {count}")
    return count


def add_backend_arguments(parser, workers_default: str, unit: str) -> None:
    """The flags of a script whose work units run on a backend: workers, backend, Ray."""
    parser.add_argument(
        "--workers", type=_worker_count, default=None, help=f"processes (None: {workers_default})"
    )
    parser.add_argument("--backend", choices=BACKENDS, default="local", help=f"where {unit} run")
    parser.add_argument(
        "--ray-address",
        default=None,
        help="Ray cluster: an address or 'auto' (None: $RAY_ADDRESS, else a local instance)",
    )
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def _check_backend(backend: str) -> None:
    if backend not in BACKENDS:
        raise ValueError(f"backend: expected one of {BACKENDS}, got {backend!r}")


def _call(packed: tuple[Callable[[Any], Any], int, Any, tuple[str, ...]]) -> tuple[int, Any]:
    function, index, argument, descriptions = packed
    _register_arms(descriptions)
    return index, function(argument)


def described_arms() -> tuple[str, ...]:
    """The description files of the arms registered in this process beyond the shipped ones.

    A worker registers them before its first unit (`_register_arms`), so that a unit may name
    a user's arm as this process does: workers start fresh (``spawn``, Ray), knowing only the
    shipped robots. On a cluster, each file must be at the same path on every node.
    """
    from temp_gym import hooks

    return () if hooks.described_arms is None else hooks.described_arms()


_ARMS_REGISTERED: set[str] = set()
"""The description files this worker registered (`_register_arms`)."""


def _register_arms(descriptions: tuple[str, ...]) -> None:
    missing = [path for path in descriptions if path not in _ARMS_REGISTERED]
    if not missing:
        return
    import temp_gym  # noqa: F401  (sets the loader)
    from temp_gym import hooks

    for path in missing:
        hooks.robot_file_loader(path)
        _ARMS_REGISTERED.add(path)


def _ignore_interrupts() -> None:
    """Pool initializer: Ctrl-C is the driver's to handle (it terminates the pool)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _local(function, arguments, workers: int) -> Iterator[tuple[int, Any]]:
    if workers <= 1 or len(arguments) <= 1:
        for index, argument in enumerate(arguments):
            yield index, function(argument)
        return
    descriptions = described_arms()
    packed = [(function, index, argument, descriptions)
              for index, argument in enumerate(arguments)]  # fmt: skip
    # spawn: workers import only what the unit needs, never a forked torch or Ray state.
    context = multiprocessing.get_context("spawn")
    # Workers are born ignoring SIGINT (an ignored signal stays ignored across exec), so a
    # Ctrl-C while one is still starting up prints no traceback; the initializer makes sure.
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        pool = context.Pool(min(workers, len(packed)), initializer=_ignore_interrupts)
    finally:
        signal.signal(signal.SIGINT, previous)
    try:
        yield from pool.imap_unordered(_call, packed, chunksize=1)
        pool.close()
    except BaseException:
        pool.terminate()
        raise
    finally:
        pool.join()


class RayUnavailableError(JobError, ConnectionError):
    """No Ray cluster answers at the address given."""


def init_ray(address: str | None = None, workers: int | None = None):
    """Connect to ``address`` (or ``$RAY_ADDRESS``), or start a local instance; return ray.

    Without an address the local instance is a new one with ``workers`` CPUs, even when a
    cluster already runs on this machine (one joins that only by naming it).

    Raises:
        ImportError: Ray is not installed.
        RayUnavailableError: no cluster answers at the address (the message says how to
            start one, or how to run on a local instance instead).
    """
    try:
        import ray
    except ImportError as error:
        raise ImportError('backend "ray" needs Ray: pip install -e ".[distributed]"') from error
    if not ray.is_initialized():
        address = address or os.environ.get("RAY_ADDRESS")
        options: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
        if address:
            try:
                ray.init(address=address, **options)
            except ConnectionError:
                raise RayUnavailableError(
                    f"no Ray cluster at --ray-address {address!r}: start one with "
                    "`ray start --head` on this machine (then workers join it with "
                    "`ray start --address=<head>:6379`), or leave out --ray-address and "
                    "$RAY_ADDRESS to run on a local Ray instance"
                ) from None
        else:
            # "local": a new instance of our own, even while a cluster runs on this machine
            # (ray.init() would join that cluster and refuse num_cpus).
            ray.init(address="local", num_cpus=workers or os.cpu_count(), **options)
    return ray


def _ray(function, arguments, workers: int, address: str | None) -> Iterator[tuple[int, Any]]:
    ray = init_ray(address, workers)
    remote = ray.remote(num_cpus=1)(_call)
    descriptions = described_arms()
    pending = {
        remote.remote((function, index, argument, descriptions)): index
        for index, argument in enumerate(arguments)
    }
    while pending:
        done, _ = ray.wait(list(pending), num_returns=1)
        for reference in done:
            del pending[reference]
            yield ray.get(reference)


def map_units(
    function: Callable[[Any], Any],
    arguments: Sequence[Any],
    backend: str = "local",
    workers: int = 1,
    address: str | None = None,
) -> Iterator[tuple[int, Any]]:
    """Yield ``(index, function(arguments[index]))`` for every argument, as each finishes.

    ``function`` must be picklable (a module-level function or a `functools.partial` of one).
    Workers register the arms this process has registered (`described_arms`) first.
    """
    _check_backend(backend)
    if backend == "ray":
        return _ray(function, list(arguments), workers, address)
    return _local(function, list(arguments), workers)
