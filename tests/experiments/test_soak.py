"""The soak command (issue 19, item 2): jobs, rows, resume, the summary, bad arguments."""

import json
import subprocess
import sys

import pytest

from s3o_drake.commands.soak import main
from s3o_drake.experiments.soak import (
    EXECUTE,
    PLAN,
    loaded,
    memory,
    method_loaded,
    soak_jobs,
    tally,
)


def test_jobs_interleave_plans_and_executions_and_take_the_methods_in_turn():
    jobs = soak_jobs(0, 10, 4, 2.0)
    assert [j.index for j in jobs if j.kind == PLAN] == list(range(10))
    runs = [j for j in jobs if j.kind == EXECUTE]
    assert [j.index for j in runs] == [0, 1, 2, 3]
    assert len({j.method for j in runs}) == 4
    assert jobs.index(runs[-1]) < len(jobs) - 1  # spread among the plans, not all at the end
    assert len({j.key for j in jobs}) == len(jobs)


def test_memory_is_the_longest_lived_worker():
    rows = [{"worker": 1, "worker_job": i + 1, "rss_mb": 100.0 + i} for i in range(8)]
    rows += [{"worker": 2, "worker_job": 1, "rss_mb": 50.0}]
    m = memory(rows)
    assert m["jobs"] == 8 and m["first_mb"] == 100 and m["last_mb"] == 107
    assert m["slope_mb_per_100_jobs"] == pytest.approx(100.0)


@pytest.mark.parametrize("args, field", [(["--plan", "-1"], "--plan"),
                                         (["--budget", "0"], "--budget"),
                                         (["--limit", "nan"], "--limit"),
                                         (["--execute-budget", "-1"], "--execute-budget")])
def test_bad_arguments_are_one_line_and_exit_2(tmp_path, capsys, args, field):
    with pytest.raises(SystemExit) as e:
        main([*args, "--out", str(tmp_path / "o")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and field in err
    assert not (tmp_path / "o").exists()


def test_soak_plans_executes_resumes_and_sums_up(tmp_path):
    """3 small scenes planned by every method, 1 executed; then the same command again
    runs nothing (resume) and prints the same table."""
    cmd = [sys.executable, "-m", "s3o_drake.commands.soak", "--plan", "3", "--execute", "1",
           "--seed", "4", "--dishes", "2", "--budget", "1", "--limit", "300", "--quiet",
           "--out", str(tmp_path)]
    # The timeouts guard against a hang, wide enough for a machine busy with a study.
    first = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert first.returncode == 0, first.stderr[-2000:]
    rows = [json.loads(line) for line in (tmp_path / "soak.jsonl").read_text().splitlines()]
    assert sorted(r["kind"] for r in rows) == [EXECUTE, PLAN, PLAN, PLAN]
    for r in rows:
        assert not r["crash"] and not r["hang"] and r["rss_mb"] > 0
        assert r["cpu"] > 0  # the worker's CPU time over the job, for `loaded`
        if r["kind"] == PLAN:
            assert all(m["planned"] or m["error"] for m in r["methods"].values())
            assert not any(m["faults"] for m in r["methods"].values())
            # A budget is wall time here (a benchmark's): an overrun counts only where the
            # method had its core, as the summary counts it.
            assert not any(m["overrun"] and not method_loaded(r, name)
                           for name, m in r["methods"].items())
            assert all(m["cpu"] > 0 for m in r["methods"].values())  # `method_loaded`
    # Every row says which code it measured (this checkout's commit).
    head = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    assert {r["code"].removesuffix("+changes") for r in rows} == {head}
    assert f"code: {rows[0]['code']}" in first.stdout
    run = next(r for r in rows if r["kind"] == EXECUTE)
    assert run["planned"] and run["finished"]
    assert run["overrun"] is False and 0 < run["budget_ratio"] <= 1.05
    assert [p["budget"] for p in run["plans"]][:1] == [60.0]  # --execute-budget's default
    assert "3 scenes planned (every method), 1 executed" in first.stdout
    assert (tmp_path / "summary.md").read_text().strip() == first.stdout.strip()
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and again.stdout == first.stdout
    assert len((tmp_path / "soak.jsonl").read_text().splitlines()) == 4


def test_memory_growth_is_told_per_kind_of_job_past_the_warm_up():
    """The median growth over one job of each kind, past each worker's warm-up: here
    plan jobs add nothing and execute jobs 60 MB each."""
    from s3o_drake.experiments.soak import EXECUTE, PLAN, WARM_UP

    rss, rows = 100.0, []
    for i in range(WARM_UP + 6):
        kind = EXECUTE if i % 2 else PLAN
        rss += 500.0 if i < WARM_UP else (60.0 if kind == EXECUTE else 0.0)
        rows.append({"worker": 1, "worker_job": i + 1, "rss_mb": rss, "kind": kind})
    m = memory(rows)
    assert m["plan_growth_mb"] == 0.0 and m["execute_growth_mb"] == 60.0


def test_memory_is_the_latest_codes():
    """A soak resumed at a newer commit: the memory figures are the new code's alone."""
    old = [{"worker": 1, "worker_job": i + 1, "rss_mb": 100.0 + 80 * i, "kind": EXECUTE,
            "code": "aaaaaaa"} for i in range(12)]
    new = [{"worker": 2, "worker_job": i + 1, "rss_mb": 500.0, "kind": EXECUTE,
            "code": "bbbbbbb"} for i in range(8)]
    m = memory(old + new)
    assert m["code"] == "bbbbbbb" and m["jobs"] == 8 and m["workers"] == 1
    assert m["execute_growth_mb"] == 0.0 and abs(m["slope_mb_per_100_jobs"]) < 1e-6


def test_one_worker_runs_every_job_executions_included(tmp_path, monkeypatch):
    """A long user session: the worker is kept over plans and executions alike (execute()
    frees its diagram), and replaced only after a hang or a crash."""
    from dataclasses import asdict

    from s3o_drake.experiments import soak
    from s3o_drake.experiments.store import ResultStore

    started = []

    class FakeWorker:  # the worker process's interface, without the process
        def __init__(self):
            started.append(self)
            self.jobs = 0
            self.process = type("P", (), {"pid": len(started), "is_alive": lambda s: True})()

        def run(self, job, limit):
            self.jobs += 1
            hang = job.index == 4
            return {"key": job.key, **asdict(job), "crash": "", "rss_mb": 1.0, "hang": hang}

        def stop(self, kill=False):
            pass

    monkeypatch.setattr(soak, "_Worker", FakeWorker)
    jobs = [soak.SoakJob(EXECUTE if i in (1, 2, 3) else PLAN, 0, i, 5.0) for i in range(7)]
    soak.run_soak(jobs, ResultStore(tmp_path / "soak.jsonl"), limit=60.0, progress=False)
    # Jobs 0-4 in the first worker (job 4 hangs), 5-6 in the second.
    assert [w.jobs for w in started] == [5, 2]


def test_overruns_and_hangs_on_a_loaded_machine_are_counted_apart():
    """A budget is wall time: a worker that got a third of a core over its job overran
    for want of CPU, not for its code; its overruns and hangs are told apart (to be run
    again on an idle machine). A row without the CPU time (older rows) counts as before."""
    def plan(cpu, wall, overrun):
        return {"kind": PLAN, "cpu": cpu, "wall": wall, "hang": False, "methods": {
            "S3O-GROP*": {"crash": "", "overrun": overrun, "faults": []},
            "V-PETLON": {"crash": "", "overrun": overrun, "faults": []}}}
    rows = [plan(5.0, 5.2, True), plan(2.0, 6.0, True), plan(2.0, 6.0, False),
            {"kind": EXECUTE, "wall": 900.0, "hang": True, "crash": "", "overrun": None},
            {"kind": EXECUTE, "cpu": 100.0, "wall": 400.0, "hang": True, "crash": "",
             "overrun": None}]
    assert [loaded(r) for r in rows] == [False, True, True, False, True]
    assert tally(rows) == {"crashes": 0, "overruns": 2, "hangs": 1, "faults": 0,
                           "loaded": 3}


def test_a_starved_method_is_told_apart_by_its_own_cpu_share():
    """A job's CPU share can hide one method that was starved: with each method's own CPU
    time in the row, that method's overrun is counted apart (and run again), while an
    overrun with a full core counts, whatever the job's share."""
    from s3o_drake.experiments.soak import run_again

    row = {"kind": PLAN, "cpu": 9.0, "wall": 10.0, "hang": False, "methods": {
        "S3O-GROP*": {"crash": "", "overrun": False, "faults": [], "seconds": 4.0, "cpu": 4.0},
        "S3O-Random-Paper": {"crash": "", "overrun": True, "faults": [], "seconds": 5.4,
                             "cpu": 2.1}}}
    assert not loaded(row) and method_loaded(row, "S3O-Random-Paper")
    assert not method_loaded(row, "S3O-GROP*")
    assert tally([row])["overruns"] == 0 and tally([row])["loaded"] == 1 and run_again(row)
    row["methods"]["S3O-Random-Paper"]["cpu"] = 5.3  # it had its core: the overrun counts
    assert tally([row])["overruns"] == 1 and not run_again(row)


def test_jobs_counted_apart_run_again_on_request(tmp_path, monkeypatch):
    """--again-loaded runs again the jobs whose overrun or hang was counted apart, and the
    new row replaces the old one; a loaded job that overran nothing is kept."""
    from dataclasses import asdict

    from s3o_drake.experiments import soak
    from s3o_drake.experiments.store import ResultStore

    ran = []

    class FakeWorker:
        def __init__(self):
            self.jobs = self.executed = 0
            self.process = type("P", (), {"pid": 1, "is_alive": lambda s: True})()

        def run(self, job, limit):
            ran.append(job.index)
            self.jobs += 1
            return {"key": job.key, **asdict(job), "crash": "", "cpu": 5.0, "methods": {
                "V-PETLON": {"crash": "", "overrun": False, "faults": []}}}

        def stop(self, kill=False):
            pass

    monkeypatch.setattr(soak, "_Worker", FakeWorker)
    monkeypatch.setattr(soak.time, "perf_counter", iter(range(0, 10**6, 5)).__next__)
    jobs = [soak.SoakJob(PLAN, 0, i, 5.0) for i in range(3)]
    store = ResultStore(tmp_path / "soak.jsonl")
    starved = {"cpu": 1.0, "wall": 6.0, "hang": False, "crash": ""}
    for job, overrun in zip(jobs[:2], (True, False), strict=True):
        store.append({"key": job.key, **asdict(job), **starved, "methods": {
            "V-PETLON": {"crash": "", "overrun": overrun, "faults": []}}})
    soak.run_soak(jobs, store, limit=60.0, progress=False)
    assert ran == [2]  # only the job without a row
    soak.run_soak(jobs, store, limit=60.0, progress=False, again_loaded=True)
    assert ran == [2, 0]  # the loaded overrun, not the loaded job that overran nothing
    again = ResultStore(tmp_path / "soak.jsonl").get(jobs[0].key)
    assert not loaded(again) and tally([again])["loaded"] == 0
