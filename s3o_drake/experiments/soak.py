"""The soak: many seeded random scenes, planned by every method and some executed, in a
worker process watched for crashes, budget overruns, hangs and memory growth.

Scene i is `random_scene(seed, i)` (s3o_drake/world/random_scenes.py: a room of random size,
1 to 5 tables anywhere, 0 to 30 dishes, crowding chairs, sometimes a robot boxed in).
A plan job plans it with every method through `plan_from`, on a cheap Fea^m
(`plan_checks.ring_heatmaps`) so that the planner's own time is what is measured, under
the budget, and checks every result (`plan_checks.plan_and_check`). An execute job runs
the whole `execute()` (perception, the scenario's Fea^m source, planning, the Drake
simulation, recovery) with one method, the methods taken in turn.

Jobs run one at a time in one long-lived worker process, so that its memory over the jobs
is what a long user session would see (its RSS is recorded after each job; `execute()`
frees each run's diagram, s3o_drake/world/system_lifetime.py). The summary gives the memory
growth over one job of each kind. A job that
exceeds the wall-time limit is a hang: the worker is killed and a fresh one goes on; a
worker that dies is a crash. Rows go to soak.jsonl as each job ends (the evaluation's
ResultStore: a killed soak resumes where it stopped).
"""

from __future__ import annotations

import multiprocessing
import time
import traceback
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

from s3o_drake.experiments.store import ResultStore, code_version
from s3o_drake.world.choices import METHODS

PLAN, EXECUTE = "plan", "execute"
OVERRUN = 0.05  # as plan_checks.OVERRUN: a run over its budget by more is an overrun
LOADED_SHARE = 0.8
"""A worker that got less of a core than this over a job ran on a loaded machine
(`loaded`): one beside the developers' test runs, nice 19, got a third of one."""
WARM_UP = 5
"""A worker's first jobs, whose memory growth is loading, not leaking (`memory`)."""


@dataclass(frozen=True)
class SoakJob:
    """Plan scene `index` of `seed` with every method, or execute it with `method`."""

    kind: str
    seed: int
    index: int
    budget: float
    method: str = ""
    max_dishes: int = 30

    @property
    def key(self) -> str:
        return (f"{self.kind}/{self.seed}/{self.index}/{self.method}/{self.budget:g}/"
                f"{self.max_dishes}")


def soak_jobs(seed: int, plans: int, executions: int, budget: float,
              max_dishes: int = 30, execute_budget: float | None = None) -> list[SoakJob]:
    """The plan jobs of scenes 0..plans-1 with the execute jobs of scenes
    0..executions-1 spread among them (so that a soak cut short has some of both);
    executions plan with `execute_budget` (default `budget`)."""
    run_budget = budget if execute_budget is None else execute_budget
    jobs: list[SoakJob] = []
    executed = 0
    for i in range(max(plans, executions)):
        if i < plans:
            jobs.append(SoakJob(PLAN, seed, i, budget, max_dishes=max_dishes))
        while executed < executions and executed * max(plans, 1) <= i * executions:
            jobs.append(SoakJob(EXECUTE, seed, executed, run_budget,
                                METHODS[executed % len(METHODS)], max_dishes))
            executed += 1
    return jobs


def _scene(job: SoakJob):
    from s3o_drake.world.random_scenes import SceneShape, random_scene
    from s3o_drake.world.settings import PlanningSettings

    return random_scene(job.seed, job.index, SceneShape(max_dishes=job.max_dishes),
                        planner=PlanningSettings(time_budget=job.budget, workers=1))


def run_soak_job(job: SoakJob) -> dict:
    """Runs one job here; an exception is a crash row (type, message, traceback)."""
    start = time.perf_counter()
    try:
        scene = _scene(job)
        row: dict = {"dishes": len(scene.dishes), "tables": len(scene.tables),
                     "chairs": len(scene.chairs), "crash": ""}
        row.update(_plan(scene, job) if job.kind == PLAN else _execute(scene, job))
    except Exception as e:  # the soak counts it
        row = {"crash": f"{type(e).__name__}: {e}".splitlines()[0],
               "traceback": traceback.format_exc(limit=8)}
    return {"key": job.key, **asdict(job), **row, "seconds": time.perf_counter() - start}


def _plan(scene, job: SoakJob) -> dict:
    from s3o_drake.belief.known_world import KnownWorld
    from s3o_drake.experiments.plan_checks import plan_and_check, ring_heatmaps
    from s3o_drake.feasibility.check import FeasibilityChecker
    from s3o_drake.feasibility.scene import FeasibilityScene

    known = KnownWorld.perfect(scene)
    checker = FeasibilityChecker(FeasibilityScene(known.contents))
    methods = plan_and_check(known, heatmaps=ring_heatmaps(known), budget=job.budget,
                             base_free=checker.base_free)
    crashes = [m for m, r in methods.items() if r["crash"]]
    return {"methods": methods, "crash": "; ".join(f"{m}: {methods[m]['crash']}"
                                                   for m in crashes)}


def _execute(scene, job: SoakJob) -> dict:
    import logging

    from s3o_drake.execution.execute import execute

    logging.getLogger("drake").setLevel(logging.WARNING)
    run = execute(scene, method=job.method, seed=scene.seed, meshcat=None, progress=False)
    r = run.report
    # Each plan (the first, then each replan) against its own budget. Fea^m (perception,
    # the network) comes before a budget starts; without a plan there is no breakdown, and
    # the overrun is not known (None).
    ratios = [None if p["feasibility_time"] is None else
              (p["planning_time"] - p["feasibility_time"]) / p["budget"] for p in r["plans"]]
    known = [x for x in ratios if x is not None]
    fea = None if run.plan is None else float(run.plan.timing.get("feasibility", 0.0))
    return {"collected": r["collected"], "planned": run.plan is not None,
            "finished": bool(r.get("finished", True)), "reason": r.get("reason", ""),
            "planning_time": r["planning_time"], "feasibility_time": fea,
            "plans": r["plans"], "budget_ratio": max(known) if known else None,
            "overrun": None if not known else max(known) > 1 + OVERRUN,
            "execution_time": r["execution_time"], "wall_time": r.get("wall_time", 0.0),
            "error": "" if run.result is None else run.result.error}


def _rss_mb() -> float:
    import psutil

    return psutil.Process().memory_info().rss / 2**20


def _cpu_seconds() -> float:
    """The CPU time (user and system, s) this process has used so far."""
    import psutil

    times = psutil.Process().cpu_times()
    return times.user + times.system


def _worker(conn) -> None:
    """A worker process: runs the jobs it receives until it receives None."""
    while True:
        job = conn.recv()
        if job is None:
            return
        cpu = _cpu_seconds()
        row = run_soak_job(job)
        row["rss_mb"] = _rss_mb()
        row["cpu"] = _cpu_seconds() - cpu
        conn.send(row)


def loaded(row: dict) -> bool:
    """Whether the job ran on a loaded machine: its worker got less than LOADED_SHARE of
    a core over the job's wall time. A budget is wall time, so a starved planner overruns
    whatever its code does; such overruns are reported apart, to be run again idle."""
    cpu, wall = row.get("cpu"), row.get("wall")
    return cpu is not None and bool(wall) and cpu / wall < LOADED_SHARE


def method_loaded(row: dict, method: str) -> bool:
    """Whether one method's plan in a plan job ran on a loaded machine: its own CPU share
    when the row has it (a job's share can hide one method that was starved while the
    others were not), else the job's (`loaded`)."""
    r = row.get("methods", {}).get(method, {})
    if r.get("cpu") is not None and r.get("seconds"):
        return r["cpu"] / r["seconds"] < LOADED_SHARE
    return loaded(row)


def run_again(row: dict) -> bool:
    """Whether a row's overrun or hang was counted apart (`loaded`, `method_loaded`): its
    job is to be run again on an idle machine (`run_soak`'s `again_loaded`)."""
    methods = row.get("methods", {})
    if any(r["overrun"] and method_loaded(row, m) for m, r in methods.items()):
        return True
    return loaded(row) and bool(row.get("overrun") or row.get("hang"))


class _Worker:
    def __init__(self) -> None:
        ctx = multiprocessing.get_context("spawn")  # a fork would copy Drake's threads
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_worker, args=(child,), daemon=True)
        self.process.start()
        child.close()
        self.jobs = 0

    def run(self, job: SoakJob, limit: float) -> dict:
        """The job's row; a hang (no answer within `limit` s: the worker is killed) or a
        crash of the worker becomes a row that says so."""
        self.conn.send(job)
        self.jobs += 1
        if not self.conn.poll(limit):
            self.stop(kill=True)
            return {"key": job.key, **asdict(job), "hang": True, "crash": "",
                    "seconds": limit}
        try:
            return self.conn.recv()
        except (EOFError, OSError):
            self.process.join(5)
            return {"key": job.key, **asdict(job), "hang": False,
                    "crash": f"the worker process died (exit code {self.process.exitcode})"}

    def stop(self, kill: bool = False) -> None:
        if not kill and self.process.is_alive():
            try:
                self.conn.send(None)
            except OSError:
                kill = True
            self.process.join(10)
        if self.process.is_alive():
            self.process.kill()
            self.process.join(10)
        self.conn.close()


def run_soak(jobs: Iterable[SoakJob], store: ResultStore, *, limit: float,
             progress: bool = True, again_loaded: bool = False) -> int:
    """Runs the jobs the store has no row for, one at a time in a worker process (a new
    one after a hang or a crash), storing each row as it ends; returns how many ran.
    `again_loaded`: also the jobs whose overrun or hang was counted apart (`run_again`);
    the new row replaces the old one (the store's last row of a key wins)."""
    from tqdm import tqdm

    todo = [job for job in jobs if (row := store.get(job.key)) is None
            or (again_loaded and run_again(row))]
    code = code_version()
    bar = tqdm(total=len(todo), desc="soak", unit="job", disable=not progress)
    worker: _Worker | None = None
    try:
        for job in todo:
            if worker is None or not worker.process.is_alive():
                worker = _Worker()
            start = time.perf_counter()
            row = worker.run(job, limit)
            row.update(worker=worker.process.pid, worker_job=worker.jobs,
                       wall=time.perf_counter() - start, code=code)
            row.setdefault("hang", False)
            if row["hang"] or (row.get("crash") and "worker process died" in row["crash"]):
                worker = None
            store.append(row)
            bar.update()
            bar.set_postfix(tally(store.rows()), refresh=False)
    finally:
        bar.close()
        if worker is not None:
            worker.stop()
    return len(todo)


def tally(rows: Sequence[dict]) -> dict[str, int]:
    """Crashes, overruns, hangs and faulty plans over the rows (per method for plans);
    overruns and hangs of jobs that ran on a loaded machine (`loaded`) are counted apart."""
    out = {"crashes": 0, "overruns": 0, "hangs": 0, "faults": 0, "loaded": 0}
    for row in rows:
        apart = loaded(row)
        if row.get("kind") == PLAN and "methods" in row:
            for m, r in row["methods"].items():
                out["crashes"] += bool(r["crash"])
                out["faults"] += bool(r["faults"])
                out["loaded" if method_loaded(row, m) else "overruns"] += bool(r["overrun"])
        else:
            out["crashes"] += bool(row.get("crash"))
            out["loaded" if apart else "overruns"] += bool(row.get("overrun"))
        out["loaded" if apart else "hangs"] += bool(row.get("hang"))
    return out


def memory(rows: Sequence[dict]) -> dict | None:
    """RSS of the worker that ran the most jobs: first and last (MB), and the slope of a
    line fitted over the second half of its jobs (MB per 100 jobs: the first ones load
    Drake, the network and the caches, growth that stops); None without rows that carry
    it. Only the rows of the code that ran last count (`code`): memory is a property of the
    code, and a soak resumed at a newer commit measures that one."""
    latest = rows[-1].get("code") if rows else None
    if latest is not None:
        rows = [r for r in rows if r.get("code") == latest]
    by_worker: dict[int, list[tuple[int, float]]] = {}
    for row in rows:
        if "rss_mb" in row:
            by_worker.setdefault(row["worker"], []).append((row["worker_job"], row["rss_mb"]))
    if not by_worker:
        return None
    series = sorted(max(by_worker.values(), key=len))
    n = np.array([s[0] for s in series], float)
    rss = np.array([s[1] for s in series], float)
    half = len(series) // 2
    slope = float(np.polyfit(n[half:], rss[half:], 1)[0]) * 100 if len(series) > 3 else 0.0
    return {"jobs": len(series), "first_mb": float(rss[0]), "last_mb": float(rss[-1]),
            "max_mb": float(rss.max()), "slope_mb_per_100_jobs": slope,
            "workers": len(by_worker), "code": latest, **_growth_by_kind(rows)}


def _growth_by_kind(rows: Sequence[dict]) -> dict[str, float]:
    """The median RSS growth (MB) over one job of each kind, past each worker's first
    WARM_UP jobs (they load Drake, the network and the caches): plan jobs should add
    nothing, and neither should an execute job (docs/reliability.md)."""
    last: dict[int, float] = {}
    growth: dict[str, list[float]] = {PLAN: [], EXECUTE: []}
    for row in sorted((r for r in rows if "rss_mb" in r),
                      key=lambda r: (r["worker"], r["worker_job"])):
        before = last.get(row["worker"])
        last[row["worker"]] = row["rss_mb"]
        if before is not None and row["worker_job"] > WARM_UP and row.get("kind") in growth:
            growth[row["kind"]].append(row["rss_mb"] - before)
    return {f"{kind}_growth_mb": float(np.median(g)) if g else float("nan")
            for kind, g in growth.items()}


def summary_table(rows: Sequence[dict]) -> str:
    """The soak's figures as Markdown: per method, plans and executions; then memory."""
    lines = ["| kind | method | runs | planned | no plan | crashes | overruns | hangs | "
             "faults | max s / budget (unloaded) |", "|---|---|---|---|---|---|---|---|---|---|"]
    plans = [r for r in rows if r.get("kind") == PLAN]
    for method in METHODS:
        rs = [r["methods"][method] for r in plans if method in r.get("methods", {})]
        idle = [r["methods"][method] for r in plans
                if method in r.get("methods", {}) and not method_loaded(r, method)]
        hangs = sum(bool(r.get("hang")) for r in plans if not loaded(r))
        # As the overruns: over the plans that had a core (a budget is wall time).
        ratio = max((r["seconds"] / p["budget"] for p in plans
                     for m, r in p.get("methods", {}).items()
                     if m == method and not method_loaded(p, m)), default=0.0)
        lines.append(f"| plan | {method} | {len(rs)} | {sum(r['planned'] for r in rs)} | "
                     f"{sum(not r['planned'] and not r['crash'] for r in rs)} | "
                     f"{sum(bool(r['crash']) for r in rs)} | "
                     f"{sum(r['overrun'] for r in idle)} | {hangs} | "
                     f"{sum(bool(r['faults']) for r in rs)} | {ratio:.3f} |")
    executed = [r for r in rows if r.get("kind") == EXECUTE]
    for method in METHODS:
        rs = [r for r in executed if r["method"] == method]
        if not rs:
            continue
        ok = [r for r in rs if "planned" in r]
        ratio = max((_budget_ratio(r) for r in ok
                     if not loaded(r) and _budget_ratio(r) is not None), default=0.0)
        lines.append(f"| execute | {method} | {len(rs)} | {sum(r['planned'] for r in ok)} | "
                     f"{sum(not r['planned'] for r in ok)} | "
                     f"{sum(bool(r.get('crash')) for r in rs)} | "
                     f"{sum(bool(r.get('overrun')) for r in rs if not loaded(r))} | "
                     f"{sum(bool(r.get('hang')) for r in rs if not loaded(r))} | "
                     f"{sum(not r['finished'] for r in ok)} | {ratio:.3f} |")
    lines.append("")
    codes = sorted({r.get("code", "unrecorded") for r in rows})
    lines.append(f"code: {', '.join(codes)} (the package's commit when each row ran)")
    lines.append("faults: plan jobs, plans that fail a check (plan_checks); execute jobs, "
                 "runs the simulation did not finish.")
    apart = tally(rows)["loaded"]
    if apart:
        lines.append(f"Not counted above: {apart} overruns and hangs of plans or jobs that "
                     f"got less than {LOADED_SHARE:.0%} of a core (a loaded machine: a budget "
                     "is wall time); run them again on an idle machine.")
    mem = memory(rows)
    if mem is not None:
        lines.append(f"memory (at {mem['code'] or 'an unrecorded commit'}; RSS of the worker "
                     f"that ran most jobs, {mem['jobs']} jobs): "
                     f"first {mem['first_mb']:.0f} MB, last {mem['last_mb']:.0f} MB, max "
                     f"{mem['max_mb']:.0f} MB, slope {mem['slope_mb_per_100_jobs']:+.1f} MB "
                     f"per 100 jobs over its second half ({mem['workers']} worker "
                     "process(es) in all); median growth over one job: plan "
                     f"{mem['plan_growth_mb']:+.1f} MB, execute "
                     f"{mem['execute_growth_mb']:+.1f} MB")
    return "\n".join(lines)


def _budget_ratio(row: dict) -> float | None:
    """An executed run's largest planning time over budget, Fea^m aside: of its plans
    (rows since `plans` was recorded), else of its summed planning time (older rows)."""
    if "budget_ratio" in row:
        return row["budget_ratio"]
    if row.get("feasibility_time") is None:
        return None
    return (row["planning_time"] - row["feasibility_time"]) / row["budget"]


def scene_counts(rows: Sequence[dict]) -> tuple[int, int]:
    """How many scenes were planned and how many executed."""
    return (sum(r.get("kind") == PLAN for r in rows),
            sum(r.get("kind") == EXECUTE for r in rows))
