"""One unit of benchmark work and the function a worker runs it with.

A job is either a run (plan one task with one method and seed, execute the plan in the
simulation, record the outcome) or a difficulty measurement (the task's pickable area from
the Drake oracle). Jobs are plain data so that they travel to worker processes and Dask
workers; `run_job` is importable by name on the other side.
"""

import dataclasses
import hashlib
import logging
import time
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from s3o_drake.experiments.store import code_version
from s3o_drake.world.scenario import Scenario, load_scenario, with_overrides
from s3o_drake.world.task_generation import layout_of

RUN = "run"
DIFFICULTY = "difficulty"


@dataclass(frozen=True)
class Job:
    """`kind` "run": plan `task` (the scenario at `path`) with `method` and study seed `seed`
    (the run's own seed is `run_seed` of the task's seed and it), execute
    with `recovery` (the scenario's `execution.recovery` replaced); `kind` "difficulty": the
    task's pickable area (the oracle's noise drawn from `seed`)."""

    kind: str
    task: str
    path: str
    digest: str  # of the scenario file's contents: an edited task is a new task
    seed: int
    method: str = ""
    recovery: str = "none"
    overrides: tuple[str, ...] = ()
    """Scenario fields the run replaces (`PATH=VALUE`, `scenario.with_overrides`): a study
    of a variant of the planner or the execution."""

    @property
    def key(self) -> str:
        """Identifies the job's result in a store. Runs say that their noise is seeded per
        task (`run_seed`): the runs of studies made before, when every task of a study seed
        drew the same noise, are other runs."""
        key = f"{self.kind}/{self.task}@{self.digest}/{self.method}/{self.seed}"
        if self.kind == RUN:
            key += "/task-seeded"
        if self.recovery != "none":
            key += f"/{self.recovery}"
        return key + "".join(f"/set:{item}" for item in self.overrides)


def run_seed(task_seed: int, study_seed: int) -> int:
    """The seed a run of a task draws its noise and planning from, for study seed
    `study_seed`: the task's own seed and the study seed mixed. Every task gets draws of its
    own (with the study seed alone, the noise streams, keyed by the seed and the command's
    number, gave the 10th command of every task the same landing and every 15th the same
    reach error), and the methods compared on a task share them."""
    return int(np.random.SeedSequence([int(task_seed), int(study_seed)]).generate_state(1)[0])


def file_digest(path: Path) -> str:
    """A short digest of a file's contents."""
    return hashlib.sha1(Path(path).read_bytes()).hexdigest()[:12]


def run_job(job: Job) -> dict:
    """Runs one job and returns its result row; an exception becomes a row with `error`
    (type and message) so that one broken task does not stop a study."""
    logging.getLogger("drake").setLevel(logging.WARNING)
    start = time.perf_counter()
    try:
        if job.kind == RUN:
            row = _run(job)
        elif job.kind == DIFFICULTY:
            row = _difficulty(job)
        else:
            raise ValueError(f"unknown job kind {job.kind!r}")
    except Exception as e:  # recorded, not raised: the study goes on
        row = {"error": f"{type(e).__name__}: {e}".splitlines()[0],
               "traceback": traceback.format_exc(limit=8)}
    return {"key": job.key, **dataclasses.asdict(job), **row,
            "job_seconds": time.perf_counter() - start, "code": code_version()}


def benchmark_scenario(path: str, recovery: str = "none",
                       overrides: tuple[str, ...] = ()) -> Scenario:
    """The task as the benchmark runs it: searches in this process (the parallelism is
    across runs, and a forked search pool inside a pool worker would oversubscribe it),
    with `recovery` and the fields `overrides` replaces."""
    return as_benchmarked(with_overrides(load_scenario(Path(path)), overrides), recovery)


def as_benchmarked(scenario: Scenario, recovery: str = "none") -> Scenario:
    """`scenario` as a benchmark run runs it: its searches in the run's own process, and
    the execution's `recovery`."""
    return dataclasses.replace(
        scenario, planner=dataclasses.replace(scenario.planner, workers=1),
        execution=dataclasses.replace(scenario.execution, recovery=recovery))


def _run(job: Job) -> dict:
    from s3o_drake.execution.execute import execute  # heavy imports stay in the workers

    scenario = benchmark_scenario(job.path, job.recovery, tuple(job.overrides))
    seed = run_seed(scenario.seed, job.seed)
    run = execute(scenario, method=job.method, seed=seed, meshcat=None, progress=False)
    r = run.report
    # Completion counts every object's goal: on the tray, or standing at its place.
    return {"run_seed": seed, "layout": layout_of(scenario),
            "dishes": r["dishes"], "collected": r["collected"],
            "placed": r["placed"], "placements": r["placements"],
            "complete": r["completed"] == r["dishes"],
            "fraction": r["completed"] / r["dishes"] if r["dishes"] else 1.0,
            "execution_time": r["execution_time"], "planning_time": r["planning_time"],
            "stops": None if run.plan is None else len(run.plan.gotos),
            "predicted_time": None if run.plan is None else run.plan.predicted_time,
            "expected_time": None if run.plan is None else run.plan.expected_time,
            "predicted_completion": _predicted_completion(run.plan),
            "planned": run.plan is not None, "finished": bool(r.get("finished", True)),
            "reason": r.get("reason", ""), "realtime_rate": r["realtime_rate"],
            "outcomes": [f"{action} {arg}: {outcome}" for action, arg, outcome in r["outcomes"]],
            "pickups": r["pickups"], "recoveries": r["recoveries"],
            "unreachable": r["unreachable"], "motion": scenario.execution.motion,
            "robot": scenario.robot_value.name,
            "closest_approach": r["closest_approach"], "time_by_motion": r["time_by_motion"]}


def _predicted_completion(plan) -> float:
    """The first plan's chance of doing every action: the product of its pickups' and
    places' Fea^m; 0 with an object left out, or without a plan."""
    if plan is None or plan.unreachable:
        return 0.0
    return float(np.prod([a.feasibility for a in (*plan.pickups, *plan.places)]))


def _difficulty(job: Job) -> dict:
    from s3o_drake.feasibility.heatmaps import compute_heatmaps

    scenario = load_scenario(Path(job.path))
    heatmaps = compute_heatmaps(scenario, workers=1, progress=False)
    areas = {h.dish: float(h.values.sum()) * h.cell**2 for h in heatmaps}
    return {"dishes": len(areas), "area": sum(areas.values()), "areas": areas}
