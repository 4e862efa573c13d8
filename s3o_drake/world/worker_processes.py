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

Workers share the cores: each one's Drake work in parallel (the collision checker's batches)
gets its share of them (`drake_parallelism`). Two workers on two cores with two threads each
wait on each other's threads: the oracle's tests took 5-8 % more CPU that way.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.forkserver
import multiprocessing.pool
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from multiprocessing.context import BaseContext
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pydrake is imported where Drake's parallelism is asked for
    from pydrake.common import Parallelism


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
                               initargs=(_environment(max_workers), initializer, initargs),
                               max_tasks_per_child=max_tasks_per_child)


def worker_pool(processes: int, *, preload: Sequence[str],
                initializer: Callable[..., object] | None = None,
                initargs: tuple = ()) -> multiprocessing.pool.Pool:
    """A `multiprocessing.Pool` of `processes` worker processes (`worker_context`), each
    running `initializer(*initargs)` when it starts."""
    return worker_context(preload).Pool(processes, initializer=_start,
                                        initargs=(_environment(processes), initializer,
                                                  initargs))


THREADS_VARIABLE = "DRAKE_NUM_THREADS"
"""Drake's variable for the threads of its parallel work. Drake reads it once, when
pydrake.planning is imported (a fork server's workers would all keep the server's): the
project reads it at each use instead (`drake_parallelism`)."""


def drake_parallelism() -> Parallelism:
    """The threads this process gives Drake's parallel work: THREADS_VARIABLE as the
    environment says now (a pool's worker: its share of the cores), else all the cores."""
    from pydrake.common import Parallelism

    threads = os.environ.get(THREADS_VARIABLE, "")
    return Parallelism(int(threads)) if threads.isdigit() and int(threads) > 0 \
        else Parallelism(core_count())


def core_count() -> int:
    """The cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _environment(workers: int) -> dict[str, str]:
    """The environment of a pool's workers: this process's, with their share of the cores
    for Drake's threads."""
    environment = dict(os.environ)
    environment.setdefault(THREADS_VARIABLE, str(max(1, core_count() // max(1, workers))))
    return environment


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
