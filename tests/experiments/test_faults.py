"""Faults (issue 19, item 4): a worker killed during a study, the study itself killed and
resumed, a disk that fills up under the result store, and the simulation's solver failing.
Each is what a user meets on a long study or an odd scene; none may lose finished work,
repeat it, or end a run without its outputs. (tests/experiments/test_evaluate.py holds the
same for a killed worker with stand-in jobs and for a study killed by SIGKILL.)"""

import contextlib
import errno
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest

from s3o_drake.commands.evaluate import main as evaluate
from s3o_drake.commands.evaluate import study_jobs
from s3o_drake.experiments.jobs import RUN, Job
from s3o_drake.experiments.scheduler import run_jobs
from s3o_drake.experiments.store import ResultStore
from tests.conftest import CUP, one_dish
from tests.experiments.test_evaluate import _toy_job, toy_work

REPO = Path(__file__).resolve().parents[2]
TWO_DISHES = REPO / "scenarios" / "small" / "two_dishes.yaml"


def _wait_for(condition, what: str, timeout: float = 240.0, process=None) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert process is None or process.poll() is None, f"the study ended before {what}"
        assert time.monotonic() < deadline, f"no {what} after {timeout} s"
        time.sleep(0.2)


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines() if path.exists() else []


def _pool_workers(pid: int) -> list[psutil.Process]:
    """The pool workers that process `pid` started, running or not yet reaped: spawned
    ones, or forked by its fork server (`world.worker_processes`); not the fork server
    itself, nor multiprocessing's resource tracker. Processes that end or cannot be read
    while they are looked at are left out: this runs beside processes that come and go."""
    def command(process: psutil.Process) -> str:
        with contextlib.suppress(psutil.Error):
            return " ".join(process.cmdline())
        return ""

    def parent(process: psutil.Process) -> int | None:
        with contextlib.suppress(psutil.Error):
            return process.ppid()
        return None

    descendants = psutil.Process(pid).children(recursive=True)
    servers = {p.pid for p in descendants if parent(p) == pid and "forkserver" in command(p)}
    return [p for p in descendants
            if "spawn_main" in command(p) or parent(p) in servers]


def _workers(study: subprocess.Popen) -> list[psutil.Process]:
    """The study's pool workers."""
    return _pool_workers(study.pid)


# --- a worker killed, the study killed, then resumed -----------------------------------------

def test_a_killed_worker_and_a_killed_study_lose_and_repeat_nothing(tmp_path):
    tasks = tmp_path / "tasks"
    tasks.mkdir()
    task = tasks / "one_plate.yaml"
    task.write_text(one_dish("two_dishes", CUP))
    out = tmp_path / "results"
    command = ["--tasks", str(tasks), "--methods", "V-PETLON", "--seeds", "2", "--workers",
               "1", "--out", str(out), "--quiet"]
    # The task's difficulty measured already, as a study killed during its runs has it: the
    # study's one pool is the runs', and the worker killed below holds a run.
    (difficulty,), _ = study_jobs([task], ["V-PETLON"], 2)
    out.mkdir()
    (out / "difficulty.jsonl").write_text(json.dumps(
        {"key": difficulty.key, "task": task.stem, "area": 2.9, "areas": {"plate_a": 2.9},
         "dishes": 1}) + "\n")
    study = subprocess.Popen([sys.executable, "-m", "s3o_drake.commands.evaluate", *command],
                             cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             text=True)
    try:
        # A worker dies (SIGKILL: out of memory, a crash in native code) while it holds the
        # first run: the study replaces it and runs that run again.
        _wait_for(lambda: _workers(study), "run worker", process=study)
        (worker,) = _workers(study)
        time.sleep(1.0)  # into the run (about 2 s of a core): planning
        worker.kill()
        # Then the study is stopped as `kill PID` stops it, after its first row.
        _wait_for(lambda: _lines(out / "results.jsonl"), "finished run", process=study)
        study.send_signal(signal.SIGTERM)
        stopping = time.monotonic()
        _, err = study.communicate(timeout=240)
        stopped_in = time.monotonic() - stopping
    finally:
        if study.poll() is None:
            study.kill()
    assert study.returncode == 130 and "interrupted" in err
    before = _lines(out / "results.jsonl")
    # The run whose worker was killed went to the end of the queue; the other one finished.
    assert len(before) == 1 and "error" not in json.loads(before[0])
    assert stopped_in < 60.0

    # Resumed by the same command: the finished run is not run again, the other one is.
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(io.StringIO()):
        assert evaluate(command) == 0
    assert f"{len(before)} already finished" in printed.getvalue()
    after = _lines(out / "results.jsonl")
    assert after[:len(before)] == before
    rows = [json.loads(line) for line in after]
    assert sorted(r["seed"] for r in rows) == [0, 1]  # every run's row, once
    assert all("error" not in r and r["planned"] and r["finished"] for r in rows)


def slow_work(job: Job) -> dict:
    """A stand-in for a long run: says it started (the file `job.path`), then takes 40 s."""
    Path(job.path).touch()
    time.sleep(40.0)
    return {"key": job.key, "task": job.task}


def test_an_interrupted_study_stops_at_once_not_after_its_runs(tmp_path):
    # Ctrl-C (or `kill PID`, which evaluate turns into the same) while a worker is in the
    # middle of a run: the worker ends now, the run gets no row and runs again on resume.
    started = tmp_path / "started"
    store = ResultStore(tmp_path / "results.jsonl")
    sent: dict = {}

    def interrupt() -> None:
        try:
            deadline = time.monotonic() + 240.0
            while not started.exists() and time.monotonic() < deadline:
                time.sleep(0.05)
            if not started.exists():
                return  # no run started: the check below says so
            try:
                sent["workers"] = len(_pool_workers(os.getpid()))  # the worker can be seen
            finally:
                # The signal goes whatever the look at the workers did. To the main thread,
                # as a terminal's Ctrl-C mostly lands (a signal to the process may land on
                # any thread; the study's wait wakes for it either way).
                sent["at"] = time.monotonic()
                signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)
        except BaseException as e:  # told by the test, not lost in this thread
            sent["error"] = e

    # Ctrl-C as a terminal delivers it to a study in the foreground. A process started in
    # the background of a non-interactive shell (`pytest &` in a script) inherits SIGINT
    # ignored, and Python keeps it so: the signal below would be dropped, and the run would
    # end after its 40 s.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    thread = threading.Thread(target=interrupt, daemon=True)
    try:
        thread.start()
        try:
            run_jobs([Job(RUN, "slow", str(started), "d", 0, "slow")], store, workers=1,
                     fn=slow_work, progress=False)
        except KeyboardInterrupt:
            stopped = time.monotonic()
        else:
            stopped = None
        thread.join(timeout=60.0)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert "error" not in sent, f"the interrupting thread failed: {sent.get('error')!r}"
    assert "at" in sent, "no SIGINT was sent: the run did not start within 240 s"
    assert stopped is not None, "the study ran to its end: the SIGINT did not stop it"
    assert stopped - sent["at"] < 15.0
    assert sent["workers"] == 1 and store.rows() == []
    assert not [p for p in _pool_workers(os.getpid()) if _running(p)]


def _running(process: psutil.Process) -> bool:
    """Whether `process` runs (a zombie waiting to be reaped has ended)."""
    with contextlib.suppress(psutil.Error):
        return process.is_running() and process.status() != psutil.STATUS_ZOMBIE
    return False


# --- the disk full --------------------------------------------------------------------------

def _fill_disk_under(path: Path, monkeypatch, nth_row: int) -> None:
    """From the `nth_row`-th line on, a write to `path` writes half a line and fails with
    ENOSPC, as a full disk does (writes to other files, such as the pool's pipes, go on)."""
    calls = {"rows": 0}
    real_write = os.write

    def write(fd, data):
        if os.readlink(f"/proc/self/fd/{fd}") != str(path):
            return real_write(fd, data)
        calls["rows"] += 1
        if calls["rows"] < nth_row:
            return real_write(fd, data)
        real_write(fd, data[:len(data) // 2])
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "write", write)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="uses /proc")
def test_a_full_disk_keeps_every_finished_row_readable(tmp_path, monkeypatch):
    marker = tmp_path / "killed"
    marker.touch()  # the stand-in jobs do not kill their workers here
    jobs = [_toy_job(i, marker) for i in range(5)]
    path = tmp_path / "results.jsonl"
    _fill_disk_under(path, monkeypatch, nth_row=3)
    with pytest.raises(OSError) as info:
        run_jobs(jobs, ResultStore(path), workers=1, fn=toy_work, progress=False)
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(path)
    # Two rows finished and stored; the third's half line was taken back.
    text = path.read_text()
    assert text.endswith("\n") and len(text.splitlines()) == 2
    assert [ResultStore(path, read_only=True).finished(j.key) for j in jobs] == [
        True, True, False, False, False]

    # Room again: the same study goes on from there, and every job has one row.
    monkeypatch.undo()
    assert run_jobs(jobs, ResultStore(path), workers=1, fn=toy_work, progress=False) == 3
    rows = [json.loads(line) for line in path.read_text().splitlines()]
    assert sorted(r["key"] for r in rows) == sorted(j.key for j in jobs)
    assert path.read_text().startswith(text)


def test_the_study_says_in_one_line_that_the_disk_is_full(tmp_path, monkeypatch):
    import s3o_drake.experiments.scheduler as scheduler

    tasks = tmp_path / "tasks"
    tasks.mkdir()
    shutil.copy(TWO_DISHES, tasks)
    out = tmp_path / "results"

    def full(jobs, store, **options):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(store.path))

    monkeypatch.setattr(scheduler, "run_jobs", full)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = evaluate(["--tasks", str(tasks), "--methods", "V-PETLON", "--seeds", "1",
                           "--out", str(out), "--quiet"])
    assert status == 1
    lines = err.getvalue().splitlines()
    assert len(lines) == 1 and "No space left on device" in lines[0]
    assert lines[0].startswith(f"error: cannot write {out / 'difficulty.jsonl'}: ")
    assert "run the same command" in lines[0]


# --- the simulation's solver failing --------------------------------------------------------

FAILS_AT = 8.0  # s of simulated time: after the first plan, during the drive


class _FailingSimulator:
    """Drake's Simulator whose contact solver gives up at FAILS_AT s, as SAP does when it
    fails to converge (RuntimeError from AdvanceTo)."""

    def __init__(self, diagram):
        from pydrake.systems.analysis import Simulator

        self._simulator = Simulator(diagram)

    def __getattr__(self, name):
        return getattr(self._simulator, name)

    def AdvanceTo(self, t: float):
        self._simulator.AdvanceTo(min(t, FAILS_AT))
        raise RuntimeError("SAP solver failed to converge at time 8.0 with a time step of "
                           "0.01.\nConsider a smaller time step.")


def test_a_failing_solver_is_reported_and_the_outputs_are_written(tmp_path, monkeypatch,
                                                                   capsys):
    import s3o_drake.execution.execute as execute_module
    from s3o_drake.commands.run_scenario import main as run_main

    monkeypatch.setattr(execute_module, "Simulator", _FailingSimulator)
    out = tmp_path / "out"
    # The outputs below, not the pictures of what the plan was made on (about a second
    # each).
    unchecked = [item for field in ("overhead", "feasibility", "state_space")
                 for item in ("--set", f"outputs.{field}=false")]
    status = run_main([str(TWO_DISHES), "--out", str(out), "--feasibility", "fcn",
                       *unchecked])
    assert status == 1  # the task was not completed; not a crash
    report = json.loads((out / "report.json").read_text())
    reason = "the simulation failed at t = 8.00 s: SAP solver failed to converge"
    assert not report["finished"] and report["reason"].startswith(reason)
    assert report["execution_time"] == pytest.approx(FAILS_AT)
    assert report["collected"] < report["dishes"] == 2
    for name in ("plan.json", "playback.html", "plan.png"):
        assert (out / name).stat().st_size > 0, name
    printed = capsys.readouterr().out
    assert reason in printed and "Traceback" not in printed


def test_a_failing_solver_ends_a_study_run_with_its_reason_not_an_error(monkeypatch):
    import s3o_drake.execution.execute as execute_module
    from s3o_drake.experiments.jobs import RUN, Job, file_digest, run_job

    monkeypatch.setattr(execute_module, "Simulator", _FailingSimulator)
    job = Job(RUN, "two_dishes", str(TWO_DISHES), file_digest(TWO_DISHES), 0, "V-PETLON")
    row = run_job(job)  # in this process, as a pool worker runs it
    # A run that went wrong in the simulation, recorded as such: the study goes on and does
    # not try it again (an error row would be).
    assert "error" not in row and row["planned"] and not row["finished"]
    assert row["reason"].startswith("the simulation failed at t = 8.00 s: SAP solver")
    assert row["execution_time"] == pytest.approx(FAILS_AT)


def test_the_local_pool_keeps_going_past_its_workers_renewal():
    """A local pool renews each worker after TASKS_PER_CHILD jobs. Fed a backlog, Python 3.11's
    ProcessPoolExecutor stopped for good at the first renewal (CPython gh-115634): a time
    benchmark hung after 20 runs. `ordered_map` keeps no backlog, and returns in order."""
    from s3o_drake.experiments.scheduler import TASKS_PER_CHILD, local_pool, ordered_map

    n = 2 * TASKS_PER_CHILD + 5
    results: list[int] = []

    def work():
        with local_pool(1) as pool:
            results.extend(ordered_map(pool, abs, range(-n, 0), window=1))

    thread = threading.Thread(target=work, daemon=True)
    thread.start()
    thread.join(timeout=120)
    assert not thread.is_alive(), "the pool stopped at a worker's renewal"
    assert results == list(range(n, 0, -1))
