"""Worker processes take this process's environment and working directory as they are when
their pool starts, though the fork server that makes them started before."""

import os

from s3o_drake.world.worker_processes import (
    THREADS_VARIABLE,
    core_count,
    drake_parallelism,
    process_pool,
    worker_pool,
)

MARK = "S3O_WORKER_TEST_MARK"


def surroundings(_: object = None) -> tuple[str | None, str]:
    return os.environ.get(MARK), os.getcwd()


def test_a_worker_sees_the_environment_and_folder_of_its_pools_start(monkeypatch, tmp_path):
    monkeypatch.setenv(MARK, "first")
    with process_pool(1, preload=()) as pool:
        assert pool.submit(surroundings).result() == ("first", os.getcwd())
    # The fork server now runs with "first"; the next pools are started otherwise.
    monkeypatch.setenv(MARK, "second")
    monkeypatch.chdir(tmp_path)
    with process_pool(2, preload=()) as pool:
        assert set(pool.map(surroundings, range(4))) == {("second", str(tmp_path))}
    monkeypatch.delenv(MARK)
    with worker_pool(1, preload=()) as pool:
        assert pool.map(surroundings, [0]) == [(None, str(tmp_path))]


def mark(value: str) -> None:
    os.environ[MARK] = value


def test_an_initializer_runs_in_each_worker_before_its_jobs():
    with process_pool(1, preload=(), initializer=mark, initargs=("set",)) as pool:
        assert pool.submit(surroundings).result()[0] == "set"
    assert MARK not in os.environ


def drake_threads(_: object = None) -> int:
    return drake_parallelism().num_threads()


def test_workers_share_the_cores_unless_told_how_many_threads_to_use(monkeypatch):
    """Drake's own reading of DRAKE_NUM_THREADS is fixed when the fork server imports
    pydrake.planning; each worker still gets its share."""
    monkeypatch.delenv(THREADS_VARIABLE, raising=False)
    with process_pool(2, preload=("pydrake.planning",)) as pool:
        assert set(pool.map(drake_threads, range(2))) == {max(1, core_count() // 2)}
    with worker_pool(1, preload=()) as pool:
        assert pool.map(drake_threads, [0]) == [core_count()]
    monkeypatch.setenv(THREADS_VARIABLE, "1")
    with process_pool(1, preload=()) as pool:
        assert pool.submit(drake_threads).result() == 1
    assert drake_threads() == 1
