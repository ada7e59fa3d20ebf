"""Connecting to (or starting) a Ray cluster for one command, and gathering its tasks' results.

``address`` is ``"local"`` (start a local cluster for this run and stop it after) or anything
``ray.init(address=...)`` takes: ``"auto"`` (the cluster ``ray start`` runs on this machine),
``"HOST:PORT"`` or ``"ray://HOST:10001"`` (Ray Client, needs ``ray[client]``). Every node needs
this package installed: the tasks import it.

Shared by ``evaluate --ray``, ``record --ray`` and ``train --ray``.
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from bubblerob_cli.errors import fail

__all__ = [
    "CONNECT_TIMEOUT_S",
    "LOCAL",
    "TASK_RETRIES",
    "WORKER_NICENESS",
    "check_address",
    "command_errors",
    "gather",
    "ray_session",
]

LOCAL = "local"
"""The ``--ray`` address that starts a local cluster for one run."""

TASK_RETRIES = 3
"""How often Ray reruns a task whose worker died (killed, out of memory, node lost)."""

WORKER_NICENESS = "0"
"""The niceness of a local cluster's workers (``RAY_worker_niceness``, unless already set).
Ray starts them at 15 to keep a driver responsive; here they do all the work, and at 15 any
other busy process starves them: 200 episodes on 2 cores at load ~4 ran at 0.72x the serial
speed, at niceness 0 at 1.38x (docs/BENCHMARKS.md). Ray's job API runs its jobs' workers at 0."""

CONNECT_TIMEOUT_S = 5.0
"""How long ``HOST:PORT`` gets to accept a connection before ``--ray`` gives up on it."""


def check_address(address: str) -> None:
    """One-line ``ValueError``: not an address; ``ConnectionError``: nothing listens there.

    ``ray.init`` would wait two minutes on an address where nothing listens, then exit.
    """
    if not address.strip():
        raise ValueError("--ray needs an address: 'local', 'auto', HOST:PORT or ray://HOST:PORT")
    if address in (LOCAL, "auto") or address.startswith("ray://"):
        return
    host, sep, port = address.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise ValueError(
            f"--ray {address!r} is not an address: use 'local', 'auto', HOST:PORT or "
            "ray://HOST:PORT"
        )
    import socket

    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as error:
        raise ConnectionError(f"--ray {address}: no Ray cluster answers there ({error})") from None


@contextmanager
def _environment(**defaults: str) -> Iterator[None]:
    """Environment variables set, where the user has not, for the ``with`` block only."""
    added = {name: value for name, value in defaults.items() if name not in os.environ}
    os.environ.update(added)
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


@contextmanager
def ray_session(address: str, num_cpus: int | None = None) -> Iterator[Any]:
    """Ray connected to ``address`` for the ``with`` block; yields the ``ray`` module.

    ``"local"`` starts a cluster of ``num_cpus`` CPUs (default: all) and stops it after. A Ray
    already initialised in this process (a test's cluster, a notebook's) is used as it is and
    left running.
    """
    import ray

    if ray.is_initialized():
        yield ray
        return
    options: dict[str, Any] = {
        "include_dashboard": False,
        "log_to_driver": False,  # the tasks' own output would interleave with the table
        "logging_level": logging.WARNING,
    }
    try:
        if address == LOCAL:
            with _environment(RAY_worker_niceness=WORKER_NICENESS):
                ray.init(address=LOCAL, num_cpus=num_cpus, **options)
        else:
            ray.init(address=address, **options)
    except (ConnectionError, ValueError) as error:  # 'auto' with no cluster, a bad ray:// URL
        raise ConnectionError(f"--ray {address}: {error}") from None
    try:
        yield ray
    finally:
        ray.shutdown()


def gather(
    ray: Any, refs: Sequence[Any], on_done: Callable[[Any], object], timeout_s: float | None = None
) -> list[Any]:
    """Every task's result in submission order, calling ``on_done`` as each one finishes.

    Raises ``TimeoutError`` when ``timeout_s`` passes with tasks still running (they are
    cancelled); a task that failed past its retries raises its error here.
    """
    import time

    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    pending = list(refs)
    results: dict[Any, Any] = {}
    while pending:
        left = None if deadline is None else max(0.0, deadline - time.monotonic())
        done, pending = ray.wait(pending, num_returns=1, timeout=left)
        if not done:
            for ref in pending:
                ray.cancel(ref, force=True)
            raise TimeoutError(f"{len(pending)} Ray task(s) still running after {timeout_s} s")
        for ref in done:
            results[ref] = ray.get(ref)
            on_done(results[ref])
    return [results[ref] for ref in refs]


@contextmanager
def command_errors(command: str, stopped: str = "") -> Iterator[None]:
    """One line for what goes wrong with ``--ray``, and the exit status.

    2: a bad address or argument; 1: no cluster, or a task that failed past its retries; 130:
    Ctrl-C (``stopped`` is added to its line).
    """
    from ray.exceptions import RayError, RayTaskError

    try:
        yield
    except ValueError as error:
        fail(command, str(error))
    except ConnectionError as error:
        fail(command, str(error), 1)
    except KeyboardInterrupt:
        print(file=sys.stderr)  # off the progress bar's line
        fail(command, f"stopped; the cluster's tasks are cancelled{stopped}", 130)
    except RayError as error:  # the remote traceback is in the worker's log; its cause here
        cause = error.cause if isinstance(error, RayTaskError) else error
        fail(command, f"a Ray task failed: {_first_line(cause)}", 1)


def _first_line(error: BaseException) -> str:
    lines = str(error).strip().splitlines()
    return f"{type(error).__name__}: {lines[0] if lines else ''}"
