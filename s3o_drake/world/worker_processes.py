"""Worker processes for parallel work, started without importing the package again.

A spawned worker imports numpy, scipy, torch, pydrake and the package anew: about 3 s of a
core each, every time a pool starts or the scheduler renews a worker. A plain fork of a
process that has run Drake would copy its thread pools mid-use, so the workers are forked
from a server that has only imported modules (`multiprocessing`'s "forkserver"; spawned
where the platform has none). Measured on 2 cores: a pool of 2 spawned workers that import
the execution took 3.1 s to start, every time; forked from the server, the first pool of a
process took 3.3 s and each one after it 0.02 s.

One server serves a process: the first pool starts it with the modules its workers run
(`preload`); a later pool's workers import what that list lacked. A worker takes the
environment of the process as it is when its pool starts, as a spawned one would: the
server keeps that of the moment it started (the working directory and sys.path come with
multiprocessing's own preparation of every child). The server ends
with the process that started it; a forked worker lets go of the descriptor by which it
would keep the server alive, so that a worker asked to end with its parent (the server)
ends with that process too, killed or not.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.forkserver
import multiprocessing.pool
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from multiprocessing.context import BaseContext


def worker_context(preload: Sequence[str]) -> BaseContext:
    """The start method of the project's worker processes: the fork server, which imports
    the modules `preload` names when it starts (the first call in a process decides)."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(list(preload))
    return context


def process_pool(max_workers: int, *, preload: Sequence[str],
                 initializer: Callable[..., object] | None = None, initargs: tuple = (),
                 max_tasks_per_child: int | None = None) -> ProcessPoolExecutor:
    """A `ProcessPoolExecutor` of `max_workers` worker processes (`worker_context`), each
    running `initializer(*initargs)` when it starts."""
    return ProcessPoolExecutor(max_workers=max_workers, mp_context=worker_context(preload),
                               initializer=_start,
                               initargs=(dict(os.environ), initializer, initargs),
                               max_tasks_per_child=max_tasks_per_child)


def worker_pool(processes: int, *, preload: Sequence[str],
                initializer: Callable[..., object] | None = None,
                initargs: tuple = ()) -> multiprocessing.pool.Pool:
    """A `multiprocessing.Pool` of `processes` worker processes (`worker_context`), each
    running `initializer(*initargs)` when it starts."""
    return worker_context(preload).Pool(processes, initializer=_start,
                                        initargs=(dict(os.environ), initializer, initargs))


def _start(environment: dict[str, str], initializer: Callable[..., object] | None,
           initargs: tuple) -> None:
    # multiprocessing hands each forked child the server's keep-alive descriptor, so that
    # the child could start processes through the same server; a worker never does.
    server = getattr(multiprocessing.forkserver, "_forkserver", None)
    alive = getattr(server, "_forkserver_alive_fd", None)
    if alive is not None:
        os.close(alive)
        server._forkserver_alive_fd = None
    os.environ.clear()
    os.environ.update(environment)
    if initializer is not None:
        initializer(*initargs)
