"""The benchmark study: jobs, the result store, resume, killed workers, Dask, grouping by
difficulty, the tables and figures, and the command end to end on small tasks."""

import contextlib
import io
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from s3o_drake.commands.calibration import main as calibration
from s3o_drake.commands.evaluate import main as evaluate
from s3o_drake.execution.messages import PickupRecord
from s3o_drake.experiments.difficulty import difficulty_groups
from s3o_drake.experiments.jobs import RUN, Job
from s3o_drake.experiments.limit import lower_bound
from s3o_drake.experiments.run_rows import run_differences
from s3o_drake.experiments.scheduler import run_jobs
from s3o_drake.experiments.store import ResultStore
from s3o_drake.experiments.summary import (
    claims,
    comparable_runs,
    failure_table,
    other_measures_table,
    paired_comparison,
    placement_table,
    summarize,
    table_one,
    write_outputs,
)
from s3o_drake.world.scenario import load_scenario
from tests.conftest import BOWL_NORTH, CUP, PLATE, one_dish

REPO = Path(__file__).resolve().parents[2]
SMALL = REPO / "scenarios" / "small"
METHODS = ("S3O-GROP*", "S3O-Random")


# --- difficulty groups -------------------------------------------------------------------

def test_largest_areas_are_easy_smallest_difficult_in_even_thirds():
    areas = {f"t{i}": float(a) for i, a in enumerate([5, 1, 9, 3, 7, 2, 8, 4, 6])}
    groups = difficulty_groups(areas)
    by_group = {g: sorted(areas[t] for t in groups if groups[t] == g)
                for g in ("easy", "moderate", "difficult")}
    assert by_group == {"easy": [7, 8, 9], "moderate": [4, 5, 6], "difficult": [1, 2, 3]}
    # The order the tasks come in does not matter.
    assert difficulty_groups(dict(reversed(list(areas.items())))) == groups


def test_uneven_counts_and_ties_are_split_deterministically():
    areas = {f"t{i:02d}": 1.0 for i in range(10)}
    groups = difficulty_groups(areas)
    sizes = [sum(g == name for g in groups.values())
             for name in ("easy", "moderate", "difficult")]
    assert sizes == [4, 3, 3]
    assert [groups[f"t{i:02d}"] for i in range(4)] == ["easy"] * 4  # ties: by name
    assert difficulty_groups({}) == {}


# --- the store and the scheduler ---------------------------------------------------------

def _toy_job(i: int, marker: Path) -> Job:
    return Job(RUN, f"toy{i}", str(marker), "d", i, "toy")


def toy_work(job: Job) -> dict:
    """A stand-in for a run: logs that it ran; job toy1 kills its own worker process the
    first time (its `path` names the marker file that says it already did)."""
    marker = Path(job.path)
    with (marker.parent / "calls.log").open("a") as log:
        log.write(job.key + "\n")
    if job.seed == 1 and not marker.exists():
        marker.touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return {"key": job.key, "task": job.task, "value": job.seed**2}


def test_store_keeps_complete_lines_and_cuts_a_line_cut_short(tmp_path):
    path = tmp_path / "results.jsonl"
    store = ResultStore(path)
    store.append({"key": "a", "v": 1})
    store.append({"key": "b", "v": 2, "error": "boom"})
    with path.open("a") as f:
        f.write('{"key": "c", "v"')  # the process died while writing
    store = ResultStore(path)
    assert store.finished("a") and not store.finished("b") and store.get("c") is None
    store.append({"key": "c", "v": 3})
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert [row["key"] for row in lines] == ["a", "b", "c"]
    # Read-only (beside a running study): a line being written is skipped, not cut.
    with path.open("a") as f:
        f.write('{"key": "d"')
    reader = ResultStore(path, read_only=True)
    assert reader.get("d") is None and reader.finished("c")
    assert path.read_text().endswith('{"key": "d"')
    with pytest.raises(PermissionError):
        reader.append({"key": "e"})


def test_rows_say_their_schema_and_code_and_rows_from_before_still_read(tmp_path):
    from s3o_drake.experiments.store import (
        SCHEMA,
        code_version,
        machine_version,
        packages_version,
        robot_of,
        schema_of,
    )

    path = tmp_path / "results.jsonl"
    path.write_text('{"key": "old", "v": 1}\n{"task": "t", "v": 2}\n')  # before the schema
    store = ResultStore(path)
    assert store.finished("old") and schema_of(store.get("old")) == 0
    assert store.get("t") is None  # a row without a key is not a result...
    keyed = ResultStore(path, key=lambda row: row["task"])  # ...unless its reader keys it
    assert keyed.get("t")["v"] == 2 and keyed.get("old")["v"] == 1
    store.append({"key": "new", "v": 3})
    store.append({"key": "copied", "code": "abc", "schema": 0})  # keeps what it says
    new, copied = (json.loads(line) for line in path.read_text().splitlines()[2:])
    assert (new["schema"], new["code"]) == (SCHEMA, code_version()) and schema_of(new) == 1
    assert new["packages"] == packages_version() and "numpy " in new["packages"]
    assert new["machine"] == machine_version() and new["machine"].count(", ") >= 2
    assert (copied["schema"], copied["code"]) == (0, "abc")
    assert ResultStore(path).get("new") == new
    assert new["robot"] == "ur5e" and robot_of(store.get("old")) == "ur5e"


def test_a_folder_of_another_robots_runs_is_read_but_not_written(tmp_path):
    from s3o_drake.experiments.store import OtherRobotRowsError, robot_of

    path = tmp_path / "results.jsonl"
    path.write_text('{"key": "a", "robot": "panda"}\n{"key": "b"}\n')
    assert [robot_of(r) for r in ResultStore(path, read_only=True).rows()] == ["panda", "ur5e"]
    with pytest.raises(OtherRobotRowsError, match=r"holds runs of robot panda.*'ur5e'"):
        ResultStore(path)
    with pytest.raises(OtherRobotRowsError, match=r"holds runs of robot ur5e.*'panda'"):
        ResultStore(path, robot="panda")
    only_panda = tmp_path / "panda.jsonl"
    only_panda.write_text('{"key": "a", "robot": "panda"}\n')
    store = ResultStore(only_panda, robot="panda")  # the Panda's study goes on
    assert store.append({"key": "c"})["robot"] == "panda"


def test_a_study_runs_one_robot_and_says_which_tasks_differ(tmp_path, capsys):
    tasks = tmp_path / "tasks"
    tasks.mkdir()
    text = (SMALL / "two_dishes.yaml").read_text()
    (tasks / "a_ur5e.yaml").write_text(text)
    (tasks / "b_panda.yaml").write_text(text.replace("robot:\n", "robot:\n  name: panda\n", 1))
    with pytest.raises(SystemExit) as info:
        evaluate(["--tasks", str(tasks), "--out", str(tmp_path / "out")])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a_ur5e.yaml is for robot 'ur5e'" in err, err
    assert "b_panda.yaml for 'panda'" in err
    assert not (tmp_path / "out" / "results.jsonl").exists()


def test_a_killed_worker_is_replaced_and_no_result_is_lost_or_repeated(tmp_path):
    marker = tmp_path / "killed"
    jobs = [_toy_job(i, marker) for i in range(6)]
    store = ResultStore(tmp_path / "results.jsonl")
    assert run_jobs(jobs, store, workers=2, fn=toy_work, progress=False) == 6
    assert marker.exists()  # the worker really died
    rows = [json.loads(line) for line in store.path.read_text().splitlines()]
    assert sorted(row["key"] for row in rows) == sorted(job.key for job in jobs)
    assert all("error" not in row for row in rows)
    assert {row["task"]: row["value"] for row in rows} == {f"toy{i}": i**2 for i in range(6)}
    calls = (tmp_path / "calls.log").read_text().splitlines()
    assert calls.count(jobs[1].key) == 2  # killed once, run again


def sleepy_work(job: Job) -> dict:
    """A stand-in for a long run: says which process runs it, then sleeps."""
    (Path(job.path) / f"{job.task}.pid").write_text(str(os.getpid()))
    time.sleep(120)
    return {"key": job.key}


def _alive(pid: int) -> bool:
    """Running or sleeping (a zombie waiting to be reaped has ended)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="uses /proc")
def test_workers_do_not_outlive_a_killed_study(tmp_path):
    script = (f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
              "from pathlib import Path; from test_evaluate import sleepy_work; "
              "from s3o_drake.experiments.jobs import Job; "
              "from s3o_drake.experiments.scheduler import run_jobs; "
              "from s3o_drake.experiments.store import ResultStore; "
              f"d = Path({str(tmp_path)!r}); "
              "jobs = [Job('run', f't{i}', str(d), 'x', i, 'm') for i in range(2)]; "
              "run_jobs(jobs, ResultStore(d / 'r.jsonl'), workers=2, fn=sleepy_work, "
              "progress=False)")
    study = subprocess.Popen([sys.executable, "-c", script], cwd=REPO)
    pids = [tmp_path / "t0.pid", tmp_path / "t1.pid"]
    deadline = time.monotonic() + 120
    while not all(p.exists() and p.read_text() for p in pids):
        assert time.monotonic() < deadline and study.poll() is None
        time.sleep(0.2)
    workers = [int(p.read_text()) for p in pids]
    study.kill()  # the study's process only, as an out-of-memory kill would
    study.wait()
    deadline = time.monotonic() + 20
    while any(_alive(pid) for pid in workers):
        assert time.monotonic() < deadline, "a worker outlived the study"
        time.sleep(0.2)


def test_every_row_says_which_code_made_it():
    """A study resumes across commits: each row carries the commit of the checkout (or the
    package's version outside one), even a row whose job failed."""
    import re

    from s3o_drake.experiments.jobs import code_version, run_job

    row = run_job(Job(kind="nope", task="t", path="p", digest="d", seed=0))
    assert row["error"].startswith("ValueError") and row["code"] == code_version()
    assert re.fullmatch(r"[0-9a-f]{12}(\+changes)?|s3o_drake \S+", row["code"])


def test_resume_runs_only_the_jobs_without_a_finished_result(tmp_path):
    marker = tmp_path / "killed"
    marker.touch()  # no kills here
    jobs = [_toy_job(i, marker) for i in range(5)]
    store = ResultStore(tmp_path / "results.jsonl")
    store.append({"key": jobs[0].key, "task": "toy0", "value": 0})
    store.append({"key": jobs[3].key, "task": "toy3", "value": 9})
    store.append({"key": jobs[4].key, "task": "toy4", "error": "ValueError: earlier"})
    assert run_jobs(jobs, ResultStore(store.path), workers=1, fn=toy_work,
                    progress=False) == 3
    calls = sorted((tmp_path / "calls.log").read_text().splitlines())
    assert calls == sorted(jobs[i].key for i in (1, 2, 4))
    assert all(ResultStore(store.path).finished(job.key) for job in jobs)
    assert run_jobs(jobs, ResultStore(store.path), workers=1, fn=toy_work,
                    progress=False) == 0


def _two_dishes_task(tmp_path):
    """A folder of one task, two_dishes.yaml, and the study's folder beside it."""
    tasks = tmp_path / "tasks"
    tasks.mkdir()
    shutil.copy(SMALL / "two_dishes.yaml", tasks)
    return tasks, tmp_path / "results"


def _three_tasks(folder: Path) -> Path:
    """Three scenes of one dish each, in two rooms: three pickable areas, a difficulty
    group each. The cheapest task sorts first: a study with `--count 1` runs it alone."""
    folder.mkdir()
    for name, scene, left_out in (("a_one_plate", "two_dishes", CUP),
                                  ("b_one_bowl", "opposite_sides", BOWL_NORTH),
                                  ("c_one_cup", "two_dishes", PLATE)):
        (folder / f"{name}.yaml").write_text(one_dish(scene, left_out))
    return folder


def _command(tasks: Path, out: Path) -> list[str]:
    return ["--tasks", str(tasks), "--methods", *METHODS, "--seeds", "1", "--out", str(out),
            "--workers", "2", "--quiet"]


@pytest.fixture(scope="module")
def local_study(tmp_path_factory) -> dict:
    """Three small tasks, two methods, seed 0, on the local pool (2 processes): first the
    cheapest task alone (`--count 1`), then all three by the same folder, which keeps the
    first task's rows and runs only the others. (A study killed with its workers, and a
    killed worker, are test_faults.py's: each costs a study of its own.) Its tasks and
    folder, the rows of the first study and what the second printed."""
    root = tmp_path_factory.mktemp("local_study")
    tasks = _three_tasks(root / "tasks")
    out = root / "results"
    with contextlib.redirect_stdout(io.StringIO()):
        assert evaluate([*_command(tasks, out), "--count", "1"]) == 0
    before = (out / "results.jsonl").read_text().splitlines()
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = evaluate(_command(tasks, out))
    return {"tasks": tasks, "out": out, "before": before, "status": status,
            "printed": printed.getvalue()}


def test_a_dask_cluster_started_as_documented_runs_what_the_local_pool_runs(
        local_study, tmp_path, capsys):
    """The local study's first task on Dask workers started by the command that
    `evaluate --help` and the README give: every run's row the same, timings aside."""
    distributed = pytest.importorskip("distributed")
    tasks, local = local_study["tasks"], local_study["out"]
    # The tasks' difficulty (the oracle's areas) is the tasks', whoever measures it: the
    # Dask study resumes from it and runs the runs.
    (tmp_path / "dask").mkdir()
    shutil.copy(local / "difficulty.jsonl", tmp_path / "dask")
    # No --workers; the first task's S3O-GROP* run stands for the six: the rows the two
    # schedulers make are compared run by run.
    command = [*_command(tasks, tmp_path / "dask")[:-3], "--quiet", "--count", "1",
               "--methods", "S3O-GROP*"]
    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp",
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        # A scheduler alone, on TCP: the worker is a process of its own (one: each one
        # imports the package, and two runs need no more to be compared).
        workers = subprocess.Popen(
            [str(Path(sys.executable).parent / "dask"), "worker", cluster.scheduler_address,
             "--nthreads", "1", "--nworkers", "1", "--lifetime", "60m", "--lifetime-restart"],
            cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            with distributed.Client(cluster) as client:
                client.wait_for_workers(1, timeout=60)
            capsys.readouterr()
            assert evaluate([*command, "--scheduler", cluster.scheduler_address]) == 0
        finally:
            workers.terminate()
            workers.wait(timeout=60)
    assert "1 tasks x 1 methods x 1 seeds" in capsys.readouterr().out
    local, dask = (ResultStore(f / "results.jsonl", read_only=True).rows()
                   for f in (local, tmp_path / "dask"))
    assert run_differences(local, dask) == (1, [])
    run = next(r for r in dask if r["task"] == "a_one_plate" and r["method"] == "S3O-GROP*")
    # The run went to its end; whether its pickup succeeds depends on the plan and the seed's
    # noise draws (about 0.97 per pickup), not on the scheduler.
    assert run["dishes"] == 1 and run["finished"]
    assert run["execution_time"] > 10.0 and run["outcomes"][-1].endswith("done")
    # A record per executed pickup, in the order of the outcomes, as plain JSON.
    records = [PickupRecord.from_dict(r) for r in run["pickups"]]
    assert [f"pickup {r.dish}: done" for r in records] == [
        o for o in run["outcomes"] if o.startswith("pickup")]
    assert all(r.method == "S3O-GROP*" and 0 <= r.predicted <= 1 for r in records)


def test_a_dask_cluster_whose_workers_run_jobs_as_threads_is_refused(tmp_path, capsys):
    """Two jobs as threads of one worker process would share OMPL's seed generator: the
    study says how to start the workers, and writes nothing."""
    distributed = pytest.importorskip("distributed")
    tasks, out = _two_dishes_task(tmp_path)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, \
            pytest.raises(SystemExit) as e:
        evaluate(["--tasks", str(tasks), "--methods", "V-GROP*", "--seeds", "1", "--out",
                  str(out), "--scheduler", cluster.scheduler_address, "--quiet"])
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.count("\n") == 1
    assert "--scheduler:" in err and "--nthreads 1" in err
    assert not out.exists()


# --- the tables ----------------------------------------------------------------------------

def _row(task, method, seed, complete, time_s, fraction=None):
    return {"task": task, "method": method, "seed": seed, "complete": complete,
            "fraction": (1.0 if complete else 0.5) if fraction is None else fraction,
            "execution_time": time_s, "planning_time": 1.0}


def test_table_one_sets_both_random_ablations_beside_the_papers_figures():
    """The paper's one-draw ablation and ours each get a column where they were run; the
    paper's S3O-Random figures stand beside both."""
    groups = {"a": "easy", "b": "moderate", "c": "difficult"}
    three = ("S3O-GROP*", "S3O-Random-Paper", "S3O-Random")
    runs = [_row(t, m, 0, m != "S3O-Random-Paper", 100.0) for t in groups for m in three]
    table = table_one(summarize(runs, groups, three))
    assert "| difficulty | S3O (S3O-GROP*) | S3O-Random-Paper | S3O-Random |" in table
    assert "| easy | 1.00 / 100.0 [0.52 ± 0.02 / 107.9 ± 5.3] | 0.00 / 100.0 [0.30 ± 0.06 / " \
        "97.0 ± 2.4] | 1.00 / 100.0 [0.30 ± 0.06 / 97.0 ± 2.4] |" in table
    two = table_one(summarize([r for r in runs if r["method"] != "S3O-Random-Paper"], groups,
                              three[::2]))
    assert "| difficulty | S3O (S3O-GROP*) | S3O-Random |" in two


def test_summary_averages_per_seed_and_compares_methods_on_the_same_runs():
    groups = {"a": "easy", "b": "moderate", "c": "difficult"}
    runs = []
    for seed, (ok_a, t) in enumerate([(True, 100.0), (False, 120.0)]):
        for task in groups:
            runs.append(_row(task, "S3O-GROP*", seed, ok_a, t))
            runs.append(_row(task, "S3O-Random", seed, False, t + 10))
    runs.append(_row("a", "S3O-GROP*", 2, True, 50.0))  # no S3O-Random run: not compared
    runs.append({**_row("a", "S3O-Random", 2, True, 50.0), "error": "boom"})
    assert len(comparable_runs(runs, METHODS)) == 12
    cells = {(c.group, c.method): c for c in summarize(runs, groups, METHODS)}
    mine = cells[("easy", "S3O-GROP*")]
    assert (mine.runs, mine.seeds, mine.tasks) == (2, 2, 1)
    assert mine.completion == pytest.approx(0.5)
    assert mine.completion_std == pytest.approx(math.sqrt(0.5))
    assert mine.execution_time == pytest.approx(110.0)
    assert cells[("easy", "S3O-Random")].completion == 0.0
    verdict = dict(claims(list(cells.values())))
    assert verdict["S3O-GROP* completion >= 0.9 on easy tasks"] is False
    assert verdict["S3O-GROP* ahead of every baseline in completion (difficult)"] is True
    assert verdict["S3O-GROP* has the lowest execution time (moderate)"] is True


def test_paired_comparison_counts_disagreements_on_the_same_tasks():
    runs = []
    for i in range(10):
        runs.append(_row(f"t{i}", "S3O-GROP*", 0, i <= 7, 100.0 + i))
        runs.append(_row(f"t{i}", "S3O-Random", 0, i in (7, 8), 110.0 + i))
    runs.append(_row("t10", "S3O-GROP*", 0, True, 1.0))  # no partner: not compared
    (row,) = paired_comparison(runs, METHODS)
    assert (row.baseline, row.pairs, row.wins, row.losses) == ("S3O-Random", 10, 7, 1)
    assert row.p_value == pytest.approx(2 * 9 / 256)  # P(>= 7 of 8 heads), both tails
    assert row.time_difference == pytest.approx(-10.0)
    assert (row.timed.low, row.timed.high) == pytest.approx((-10.0, -10.0))
    assert row.timed.pairs == 10 and row.complete.pairs == 1  # t7: the only pair both complete
    assert row.complete.relative == pytest.approx(-10.0 / 117.0)


def test_the_relative_time_difference_is_a_ratio_of_means_and_the_summary_says_so(tmp_path):
    from s3o_drake.experiments.summary import TIME_DIFFERENCE_MEANING, time_difference

    mine = [{"execution_time": 90.0}, {"execution_time": 190.0}]
    theirs = [{"execution_time": 100.0}, {"execution_time": 200.0}]
    found = time_difference(mine, theirs, np.random.default_rng(0))
    # -10 s on a mean of 150 s: -6.7 %, not the mean of -10 % and -5 % (-7.5 %).
    assert found.mean == pytest.approx(-10.0)
    assert found.relative == pytest.approx(-10.0 / 150.0)
    groups = {"a": "easy"}
    runs = [{**_row("a", m, 0, True, 100.0), "planned": True, "code": "abc"} for m in METHODS]
    write_outputs(tmp_path, runs, {"a": 1.0}, groups, list(METHODS), {})
    assert TIME_DIFFERENCE_MEANING in (tmp_path / "summary.md").read_text()


def test_a_run_without_a_plan_has_no_time_counts_incomplete_and_is_listed(tmp_path):
    groups = {"a": "easy", "b": "moderate", "c": "difficult"}
    runs = [{**_row(t, m, 0, True, 100.0), "planned": True, "code": "abc"}
            for t in groups for m in METHODS]
    runs[1] = {**_row("a", "S3O-Random", 0, False, 0.0, fraction=0.0), "planned": False,
               "reason": "no plan: S3O-Random: no valid plan", "code": "abc"}
    cells = {(c.group, c.method): c for c in summarize(runs, groups, METHODS)}
    easy = cells[("easy", "S3O-Random")]
    assert (easy.completion, easy.no_plan, easy.predicted_completion) == (0.0, 1, 0.0)
    assert math.isnan(easy.execution_time)  # not 0 s
    (row,) = paired_comparison(runs, METHODS)
    assert (row.losses, row.wins, row.pairs, row.timed.pairs) == (0, 1, 3, 2)
    write_outputs(tmp_path, runs, {t: 1.0 for t in groups}, groups, list(METHODS), {})
    summary = (tmp_path / "summary.md").read_text()
    assert "Every table below: 6 runs made at abc." in summary
    assert "**1 runs without a plan** (incomplete; no execution time):" in summary
    assert "- a S3O-Random seed 0: no plan: S3O-Random: no valid plan" in summary


def test_the_paired_time_is_traced_to_the_stops_saved():
    """On pairs where both complete: how many stops fewer, how often as many, and the seconds
    a saved stop is worth (the slope of the time saved on the stops saved)."""
    from s3o_drake.experiments.summary import paired_runs

    mine, theirs = [], []
    for i, saved in enumerate((0, 0, 1, 1, 2)):
        mine.append({**_row(f"t{i}", "S3O-GROP*", 0, True, 100.0), "stops": 5 - saved})
        theirs.append({**_row(f"t{i}", "V-GROP*", 0, True, 100.0 + 11.0 * saved + 1.0),
                       "stops": 5})
    mine.append({**_row("t9", "S3O-GROP*", 0, False, 50.0), "stops": 1})  # not complete
    theirs.append({**_row("t9", "V-GROP*", 0, True, 100.0), "stops": 5})
    stops = paired_runs(mine, theirs, "V-GROP*").stops
    assert (stops.pairs, stops.same) == (5, 2)
    assert stops.fewer == pytest.approx(0.8) and stops.seconds_per_stop == pytest.approx(11.0)
    assert stops.text() == "+0.80 / 2 of 5 / 11.0 s"


def test_variants_pair_with_the_baseline_and_the_method_as_it_is(tmp_path, capsys):
    from s3o_drake.commands.compare_variants import main as compare_variants
    from s3o_drake.experiments.summary import TIME_DIFFERENCE_MEANING

    def store(folder, rows):
        folder.mkdir()
        (folder / "results.jsonl").write_text(
            "".join(json.dumps({"key": f"{r['task']}{r['method']}", "code": "abc", "stops": 3,
                                "predicted_completion": 0.5, **r}) + "\n" for r in rows))

    store(tmp_path / "study", [_row(f"t{i}", m, 0, i < 8, 100.0 if m == "V-GROP*" else 90.0)
                               for i in range(10) for m in ("V-GROP*", "S3O-GROP*")])
    store(tmp_path / "shared", [_row(f"t{i}", "S3O-GROP*", 0, True, 80.0) for i in range(10)])
    out = tmp_path / "table.md"
    assert compare_variants(["--study", str(tmp_path / "study"), f"shared={tmp_path / 'shared'}",
                             "--out", str(out)]) == 0
    lines = out.read_text().splitlines()
    as_it_is = next(line for line in lines if line.startswith("| as it is |"))
    shared = next(line for line in lines if line.startswith("| shared |"))
    assert "| 10 | 0.80 [" in as_it_is and "| 0 / 0 / 1.00 | -10.0 [-10.0, -10.0] s, -10.0 %" \
        in as_it_is
    # The variant completes the two tasks nobody else did, and is 10 s faster than as it is.
    assert "| 2 / 0 / 0.50 | -20.0 [-20.0, -20.0] s, -20.0 %" in shared
    assert shared.endswith("| 2 / 0 / 0.50 | -10.0 [-10.0, -10.0] s, -11.1 % [-11.1, -11.1] "
                           "(8 pairs) |")
    # A study of the method alone (with recovery, say): the variants against it only.
    store(tmp_path / "alone", [_row(f"t{i}", "S3O-GROP*", 0, True, 90.0) for i in range(10)])
    assert compare_variants(["--study", str(tmp_path / "alone"), f"shared={tmp_path / 'shared'}",
                             "--out", str(out)]) == 0
    text = out.read_text()
    assert text.startswith("S3O-GROP* variants (no V-GROP* in the study)")
    assert TIME_DIFFERENCE_MEANING in text
    assert "| shared | 10 | 1.00 [" in text and "| – | – | – | 0 / 0 / 1.00 | -10.0 [" in text
    with pytest.raises(SystemExit) as e:
        compare_variants(["--study", str(tmp_path / "study"), "shared"])
    assert e.value.code == 2 and "LABEL=DIR" in capsys.readouterr().err


def test_other_splits_group_tasks_by_their_hardest_dish_and_their_size():
    # Task "wide" has the largest total area but one nearly unreachable dish.
    dish_areas = {"wide": {"a": 3.0, "b": 3.0, "c": 0.1}, "mid": {"a": 2.0, "b": 2.0},
                  "small": {"a": 0.5, "b": 0.5}}
    runs = [_row("wide", m, 0, False, 1.0) for m in METHODS]
    runs += [_row(t, m, 0, True, 1.0) for t in ("mid", "small") for m in METHODS]
    groups = difficulty_groups({t: sum(a.values()) for t, a in dish_areas.items()})
    lines = other_measures_table(runs, dish_areas, METHODS, groups).splitlines()
    assert "| paper's (total area) | easy | 1 | 0.00 | 0.00 |" in lines
    assert "| smallest dish area | difficult | 1 | 0.00 | 0.00 |" in lines
    assert "| smallest dish area | easy | 1 | 1.00 | 1.00 |" in lines
    assert "| number of dishes | 2 dishes | 2 | 1.00 | 1.00 |" in lines


def test_failure_table_counts_reasons_and_dishes_left_behind():
    runs = [{**_row("a", "S3O-GROP*", 0, False, 100.0), "dishes": 3,
             "outcomes": ["goto l0: done", "pickup cup: failed: no_ik",
                          "goto l1: failed: blocked"]},
            {**_row("a", "V-PETLON", 0, True, 90.0), "dishes": 1,
             "outcomes": ["goto l0: done", "pickup cup: done"]}]
    table = failure_table(runs, ["S3O-GROP*", "V-PETLON"])
    assert "| pickup failed: no_ik | 1 | 0 |" in table
    assert "| goto failed: blocked | 1 | 0 |" in table
    assert "| not planned or not reached | 2 | 0 |" in table
    assert "| runs | 1 | 1 |" in table



def test_placement_table_counts_objects_at_and_off_their_places():
    def placement(state, error, placed):
        return {"object": "cup_1", "target": [1.0, 2.0, 0.75], "state": state,
                "final": [1.0 + error, 2.0, 0.75], "error": error, "upright": True,
                "placed": placed}
    runs = [{**_row("a", "S3O-GROP*", 0, True, 100.0), "placements": [
                placement("placed", 0.012, True)]},
            {**_row("b", "S3O-GROP*", 0, False, 100.0), "placements": [
                placement("placed", 0.034, False)]},
            {**_row("a", "V-PETLON", 0, False, 90.0), "placements": [
                placement("gripper", 0.5, False)]}]
    table = placement_table(runs, ["S3O-GROP*", "V-PETLON"])
    assert "| S3O-GROP* | 2 | 1 | 1 | 0 | 2.3 / 3.4 |" in table
    assert "| V-PETLON | 1 | 0 | 0 | 1 | – |" in table

# --- the command ----------------------------------------------------------------------------

def test_three_tasks_two_methods_end_to_end_then_resumed(local_study, tmp_path, capsys):
    tasks, out, before = local_study["tasks"], local_study["out"], local_study["before"]
    results = out / "results.jsonl"
    assert len(before) == 2 and {json.loads(r)["task"] for r in before} == {"a_one_plate"}
    # Resumed on all the tasks: the finished runs kept, not run again.
    assert local_study["status"] == 0
    assert f"{len(before)} already finished" in local_study["printed"]
    after = results.read_text().splitlines()
    assert after[:len(before)] == before
    rows = [json.loads(line) for line in after]
    assert len(rows) == 6 and len({r["key"] for r in rows}) == 6
    # Every run planned and went to its end (each pickup succeeds about 0.97 of the time
    # with the default noise: that is the plan's and the seed's, not the study's).
    assert all(r["planned"] and r["finished"] and r["collected"] >= 1 for r in rows)

    # No complete run is faster than the task's lower bound (experiments/limit.py; its
    # oracle maps are the ones the study's difficulty measured, read back).
    bounds = {task: lower_bound(load_scenario(path))
              for task, path in {(r["task"], r["path"]) for r in rows}}
    for r in rows:
        bound = bounds[r["task"]]
        assert 0.0 < bound.total < math.inf and bound.drive_time > 0.0
        if r["complete"]:
            assert r["execution_time"] >= bound.total, (r["task"], r["method"], bound)

    csv_lines = (out / "results.csv").read_text().splitlines()
    assert csv_lines[0].startswith("task,layout,group,area,method,seed,recovery,dishes,"
                                   "collected,placed,complete")
    # Every row says its layout (the small scenes are rooms of their own) and recovery.
    assert {(r["layout"], r["recovery"]) for r in rows} == {("custom", "none")}
    assert len(csv_lines) == 7
    study = json.loads((out / "results.json").read_text())
    assert sorted(study["groups"].values()) == ["difficult", "easy", "moderate"]
    least = min(study["areas"], key=study["areas"].get)
    assert study["groups"][least] == "difficult"
    assert {c["method"] for c in study["cells"]} == set(METHODS)
    from s3o_drake.experiments.jobs import code_version
    assert study["settings"]["code"] == {code_version(): 6}  # the code that made the runs
    for picture in ("figure5.png", "table1.png"):
        image = matplotlib.image.imread(out / picture)
        assert image.shape[0] > 150 and image.shape[1] > 500 and image.std() > 0.01
    summary = (out / "summary.md").read_text()
    assert "Table I" in summary and "Task completion rate" in summary
    # The calibration command reads the study's pickups.
    pickups = sum(len(r["pickups"]) for r in rows)
    assert pickups >= 6
    assert calibration([str(out), "--out", str(tmp_path / "calibration")]) == 0
    assert f"{pickups} executed pickups from 6 runs" in capsys.readouterr().out

    # Once more: nothing left to run; --summarize only rewrites the tables.
    assert evaluate(_command(tasks, out)) == 0
    assert results.read_text().splitlines() == after
    (out / "figure5.png").unlink()
    assert evaluate([*_command(tasks, out), "--summarize"]) == 0
    assert (out / "figure5.png").exists() and results.read_text().splitlines() == after
    # The study's folder alone is enough to summarize it again: its settings fill in the rest.
    before = json.loads((out / "results.json").read_text())
    capsys.readouterr()
    assert evaluate(["--out", str(out), "--summarize"]) == 0
    assert "every run finished" in capsys.readouterr().out
    again = json.loads((out / "results.json").read_text())
    assert again["cells"] == before["cells"] and again["settings"]["tasks"] == str(tasks)


@pytest.mark.parametrize("args, field", [
    (["--methods", "FOO"], "--methods"),
    (["--seeds", "0"], "--seeds"),
    (["--workers", "0"], "--workers"),
    (["--scheduler", "localhost"], "--scheduler"),
    (["--count", "0"], "--count"),
    (["--count", "9"], "--count"),  # more than the folder holds
    (["--limit", "2"], "--count"),  # renamed
    (["--open-loop", "."], "--open-loop"),  # the study is open loop itself
    (["--recovery", "replan", "--open-loop", "nowhere"], "--open-loop"),
    (["--set", "planner.top_k=none"], "--set planner.top_k"),
    (["--set", "planner.failure_price=maybe"], "--set planner.failure_price"),
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys, args, field):
    out = tmp_path / "results"
    with pytest.raises(SystemExit) as exit_info:
        evaluate(["--tasks", str(SMALL), "--out", str(out), *args])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0]
    assert not out.exists()


@pytest.mark.parametrize("args", [["--summarize"], []])
def test_without_tasks_and_without_a_study_to_take_them_from_is_one_line(tmp_path, capsys,
                                                                         args):
    with pytest.raises(SystemExit) as exit_info:
        evaluate(["--out", str(tmp_path / "nothing"), *args])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--tasks" in err[0]
    assert not (tmp_path / "nothing").exists()


def test_a_broken_task_file_is_named(tmp_path, capsys):
    tasks = tmp_path / "tasks"
    tasks.mkdir()
    (tasks / "bad.yaml").write_text("dishes: 3\n")
    with pytest.raises(SystemExit) as exit_info:
        evaluate(["--tasks", str(tasks), "--out", str(tmp_path / "r")])
    assert exit_info.value.code == 2
    assert "bad.yaml" in capsys.readouterr().err


def test_a_variant_s_runs_are_runs_of_their_own():
    from s3o_drake.commands.evaluate import study_jobs

    paths = sorted(SMALL.glob("*.yaml"))[:1]
    _, plain = study_jobs(paths, ["S3O-GROP*"], 1)
    _, variant = study_jobs(paths, ["S3O-GROP*"], 1,
                            overrides=("planner.group_positions=shared",))
    assert plain[0].key.endswith("/task-seeded")  # as before: earlier rows still resume
    assert variant[0].key == plain[0].key + "/set:planner.group_positions=shared"


def test_each_task_draws_noise_of_its_own_and_the_methods_share_it():
    """A study seed alone seeded every task's noise streams alike (the same landing error on
    every task's 10th command); the run seed mixes in the task's own seed."""
    from s3o_drake.experiments.jobs import RUN, Job, run_seed

    seeds = {run_seed(task_seed, 0) for task_seed in range(200)}
    assert len(seeds) == 200  # every task its own
    assert run_seed(907713895, 0) == run_seed(907713895, 0)  # deterministic
    assert run_seed(907713895, 0) != run_seed(907713895, 1)  # and per study seed
    a = Job(RUN, "task_000", "t.yaml", "abc", 0, "S3O-GROP*")
    b = Job(RUN, "task_000", "t.yaml", "abc", 0, "V-PETLON")
    assert a.key.endswith("/task-seeded") and a.key != b.key
