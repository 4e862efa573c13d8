"""Runs jobs on a local process pool or a Dask cluster, storing each result as it arrives.

Both executors are driven by the same loop: at most `window` jobs are handed out at a time,
in the order given (so an interrupted study has whole groups done, not a scatter), and a
result is stored the moment it comes back. Jobs whose result is already in the store are
skipped, which is how a study resumes.

A worker process that dies (killed, out of memory, a crash in native code) breaks a local
pool: the jobs it was running go back to the end of the queue and a fresh pool takes over;
a job in flight at `max_attempts` breakages is recorded as an error instead of run again.
On Dask the scheduler itself re-runs the work of a lost worker and reports `KilledWorker`
after its own retries; that too becomes an error row.

A Dask worker must run one job at a time (`dask worker ADDRESS --nthreads 1`; start more
workers with --nworkers for more at once): OMPL seeds its samplers from one generator per
process, so two runs as threads of one process could draw each other's seeds and a run
would not be what its seed says. A cluster with more threads per worker is refused.
`--lifetime 60m --lifetime-restart` renews a worker, as the local pool renews a process
after TASKS_PER_CHILD jobs.
"""

import ctypes
import itertools
import multiprocessing
import signal
import sys
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict
from typing import TYPE_CHECKING

from tqdm import tqdm

from s3o_drake.experiments.jobs import Job, run_job
from s3o_drake.experiments.store import ResultStore
from s3o_drake.world.worker_processes import process_pool

if TYPE_CHECKING:
    from distributed import Client

WORKER_MODULES = ("s3o_drake.experiments.jobs", "s3o_drake.execution.execute",
                  "s3o_drake.feasibility.heatmaps", "s3o_drake.feasibility.learned.fcn")
"""What a run or a difficulty job imports: the fork server imports it once. The network's
module (torch, about 1.5 s of a core) too: a run plans with the network by default, and
the planner imports it only when it is first asked for, in every worker."""
TASKS_PER_CHILD = 10
"""Local workers are replaced after this many jobs, a bound on what any leak costs a long
study. Until execute() freed its diagram (s3o_drake/world/system_lifetime.py) each executed run
left 60-150 MB behind (docs/reliability.md); since, 6 runs in one process grew 25 MB."""


WAKE_EVERY = 0.5
"""Seconds between the study's looks at its signals while it waits for runs."""
ABANDON_WAIT = 5.0
"""Seconds an abandoned worker has to end on SIGTERM before it is killed."""


class ClusterError(ValueError):
    """A Dask cluster whose workers could make runs differ from their seeds."""


def pending_jobs(jobs: Iterable[Job], store: ResultStore) -> list[Job]:
    """The jobs that have no finished result in the store, in order."""
    return [job for job in jobs if not store.finished(job.key)]


def run_jobs(jobs: Iterable[Job], store: ResultStore, *, workers: int = 2,
             scheduler: str | None = None, fn: Callable[[Job], dict] = run_job,
             progress: bool = True, desc: str = "runs", max_attempts: int = 3) -> int:
    """Runs the jobs that the store has no finished result for; returns how many ran.

    `scheduler`: None for a local pool of `workers` processes (`local_pool`), or the address of a
    Dask scheduler ("tcp://HOST:PORT"), whose workers must have s3o_drake installed.
    """
    todo = deque(pending_jobs(jobs, store))
    total = len(todo)
    if not todo:
        return 0
    bar = tqdm(total=total, desc=desc, unit="job", disable=not progress, smoothing=0.1)
    attempts: dict[str, int] = {}
    client = None
    try:
        if scheduler is not None:
            from distributed import Client

            client = Client(scheduler)
            check_cluster(client)
            window = max(1, 2 * sum(client.nthreads().values()))
            _drive(client.get_executor(), todo, store, fn, window, bar)
        else:
            while todo:
                others = set(multiprocessing.active_children())
                with local_pool(workers) as pool:
                    try:
                        broken = _drive(pool, todo, store, fn, workers, bar)
                    except KeyboardInterrupt:
                        _abandon(pool, keep=others)
                        raise
                for job in broken:
                    attempts[job.key] = attempts.get(job.key, 0) + 1
                    if attempts[job.key] >= max_attempts:
                        store.append({"key": job.key, **asdict(job),
                                      "error": f"a worker process died running it "
                                               f"{attempts[job.key]} times"})
                        bar.update()
                    else:
                        todo.append(job)
    finally:
        bar.close()
        if client is not None:
            client.close()
    return total


def ordered_map(executor: Executor, fn: Callable, items: Iterable, window: int) -> Iterator:
    """`fn` over `items` on `executor`, the results in the items' order, with at most `window`
    submitted and unfinished at a time. A local pool replaces its workers (TASKS_PER_CHILD),
    and on Python 3.11-3.13 a ProcessPoolExecutor that replaces a worker while calls are
    queued behind the busy ones can stop for good (CPython gh-115634): `Executor.map`
    queues every call at once."""
    pending = iter(items)
    running: deque[Future] = deque(executor.submit(fn, item)
                                   for item in itertools.islice(pending, window))
    while running:
        result = running.popleft().result()
        for item in itertools.islice(pending, 1):
            running.append(executor.submit(fn, item))
        yield result


def check_cluster(client: "Client") -> None:
    """Raises ClusterError when a worker of the `distributed.Client`'s cluster runs jobs as
    threads (module docstring)."""
    threads = client.nthreads()
    shared = {worker: n for worker, n in threads.items() if n > 1}
    if shared:
        worker, n = next(iter(shared.items()))
        raise ClusterError(
            f"{len(shared)} of {len(threads)} Dask workers run jobs as threads ({worker}: "
            f"{n}); runs then share OMPL's seeds and may differ from theirs: start each "
            "worker with --nthreads 1 (more workers: --nworkers)")


def local_pool(workers: int) -> ProcessPoolExecutor:
    """`workers` worker processes (`world.worker_processes`), each replaced after
    TASKS_PER_CHILD jobs, that end with this process: where a command executes many runs."""
    return process_pool(workers, preload=WORKER_MODULES, initializer=_die_with_parent,
                        max_tasks_per_child=TASKS_PER_CHILD)


def _abandon(pool: ProcessPoolExecutor, *, keep: set) -> None:
    """Ctrl-C or `kill PID`: ends the pool's workers now (the child processes not in
    `keep`). Their runs in flight have no row and run again on resume either way. Left to
    the pool's exit, a stopped study waited a minute or more for them, only to throw their
    results away, and one (2026-11-26) did not end until its idle worker was killed."""
    pool.shutdown(wait=False, cancel_futures=True)
    workers = set(multiprocessing.active_children()) - keep
    for process in workers:
        process.terminate()
    # Gone when this returns, not a moment later: a busy machine can take that moment.
    for process in workers:
        process.join(timeout=ABANDON_WAIT)
        if process.is_alive():
            process.kill()
            process.join(timeout=ABANDON_WAIT)


def _die_with_parent() -> None:
    """Worker start-up: on Linux, ask for SIGTERM when the study's process dies, so that a
    killed study leaves no idle workers behind (elsewhere they end with their queue)."""
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGTERM)


def _drive(executor: Executor, todo: deque, store: ResultStore, fn: Callable[[Job], dict],
           window: int, bar: tqdm) -> list[Job]:
    """Feeds `todo` to `executor`, `window` at a time, storing results; returns the jobs
    that were in flight when the executor broke (empty when all went well)."""
    running: dict[Future, Job] = {}
    while todo or running:
        while todo and len(running) < window:
            job = todo.popleft()
            try:
                running[executor.submit(fn, job)] = job
            except BrokenProcessPool:
                todo.appendleft(job)
                return list(running.values())
        # Python runs a signal's handler (Ctrl-C, `kill PID`) only when the main thread
        # runs bytecode; a wait without a timeout can sleep through one that the kernel
        # handed to another thread, until a run finishes minutes later.
        done, _ = wait(running, timeout=WAKE_EVERY, return_when=FIRST_COMPLETED)
        broken = []
        for future in done:
            job = running.pop(future)
            try:
                row = future.result()
            except BrokenProcessPool:
                broken.append(job)
                continue
            except Exception as e:  # e.g. Dask's KilledWorker: recorded, the study goes on
                row = {"key": job.key, **asdict(job),
                       "error": f"{type(e).__name__}: {e}".splitlines()[0]}
            store.append(row)
            bar.update()
        if broken:
            # The pool is gone: everything still out with it comes back too.
            return broken + list(running.values())
    return []
