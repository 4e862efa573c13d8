"""Benchmark study: plan and execute every task x method x seed, group the tasks by
difficulty, and write the paper's Fig. 5 and Table I.

    python -m s3o_drake.commands.evaluate --tasks DIR --methods all --seeds 3 --out results/
           [--recovery none|retry|replan] [--workers N | --scheduler tcp://HOST:PORT]
           [--limit N] [--quiet] [--summarize] [--open-loop DIR] [--set PATH=VALUE ...]

Each run plans the task (the scenario file) with the method, the noise and the planner's
randomness drawn from the seed, and executes the plan in the full Drake simulation, as
`python -m s3o_drake.run` does but without the playback. It records whether every dish was
collected (task completion), the share of dishes collected, the execution time (simulated)
and the planning time, and per executed pickup the plan's Fea^m against the outcome (read
by `python -m s3o_drake.commands.calibration`), and the recoveries. Study seeds are 0 to
N-1; a run draws its noise and planning from its own seed, mixed from the task's seed and
the study seed (`jobs.run_seed`, recorded as `run_seed`), so that every task gets noise of
its own while the methods compared on a task share it.

--recovery sets every run's `execution.recovery`, whatever the task files say: "none" (the
default) is the paper's open loop, the protocol of its study; "retry" corrects stops and
retries pickups; "replan" also replans what remains after a blocked drive or a dish that
fails its tries (docs/execution.md). Runs of another recovery are other runs. --open-loop
DIR names the same study run open loop (its --out): summary.md then sets each run against
its open-loop twin (same task, method and run seed) for the time that recovery costs.

Difficulty (the paper's measure): Σ_o ∫ Fea^m(y, o) dy, the expected area from which each
dish can be picked, from the Drake oracle under the scenario's noise model, summed over the
task's dishes. Tasks are sorted by it and split into thirds: easy, moderate, difficult.

Written to --out:
  results.jsonl     one line per finished run, written as it finishes (the resume log)
  difficulty.jsonl  one line per task: its pickable area, per dish and in all
  results.csv       one row per run, with the task's area and group
  results.json      settings, areas, groups, the per-group figures, the claims, the paired
                    comparison, every run
  figure5.png       completion rate and execution time per group and method (Fig. 5)
  table1.png        S3O-GROP* against S3O-Random (and S3O-Random-Paper) per group (Table I)
  summary.md        the same as Markdown tables, the claims checked, S3O-GROP* against each
                    method on the same tasks (wins, losses, sign test, time saved),
                    completion under other splits of the tasks (hardest dish, area per
                    dish, number of dishes), why dishes were lost, errors if any

--summarize writes those from the runs finished so far and runs nothing (safe beside a
running study: the result files are only read); `--out DIR --summarize` alone takes the
study's tasks, methods, seeds, recovery and --set from DIR/results.json.

--again DIR runs again, into --out, only the runs of the study in DIR (the same --tasks,
--methods, --seeds and --recovery) that did not complete, or with --ended WORD... those
whose ending names one of the words (e.g. --ended blocked "no plan"): a fix measured on
the runs it was made for. Each new run keeps its old twin's seed; again.md (also printed)
sets them side by side per method. The tasks' difficulty is read from DIR.

Scale-out: a local pool of --workers spawned processes (default: one per core), or, with
--scheduler, the workers of a Dask distributed cluster (they need s3o_drake installed; each
run plans with one search process, the parallelism being across runs). Ctrl-C or `kill
PID` stops the study at once, abandoning the runs in flight. Interrupted or crashed, the
same command resumes: finished runs are read back from results.jsonl and not run again; a
run abandoned or ended in an error is run again. Editing a task file makes its runs
new ones. A progress bar shows the rate and the time left.

Exit status: 0 when every run finished, 1 when some ended in an error (listed in
summary.md) or a result could not be written (a full disk: one line says so; the finished
runs are kept), 2 on bad input (nothing is written), 130 when interrupted (finished runs
kept).
"""

from __future__ import annotations

import json
import os
import re
import signal
import sys
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail, read_scenario

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.world.choices import METHODS, RECOVERY_MODES, Recovery

if TYPE_CHECKING:
    from s3o_drake.experiments.jobs import Job

DIFFICULTY_SEED = 0
"""The oracle's noise draws for the difficulty measure: one fixed seed, so that a task's
group does not depend on how many seeds the study runs."""
SCHEDULER = re.compile(r"^(tcp|tls|inproc|ucx)://\S+$")


def parse_args(argv: list[str] | None):
    parser = ArgumentParser(prog="python -m s3o_drake.commands.evaluate", description=__doc__,
                            formatter_class=doc_formatter())
    parser.add_argument("--tasks", metavar="DIR",
                        help="folder of task scenarios (*.yaml), e.g. scenarios/generated "
                             "(with --summarize: by default the study's own)")
    parser.add_argument("--methods", nargs="+", default=["all"], metavar="NAME",
                        help=f"'all' or some of: {', '.join(METHODS)} (default all)")
    parser.add_argument("--seeds", type=int, default=3, metavar="N",
                        help="seeds 0..N-1 per task and method (default 3)")
    parser.add_argument("--out", required=True, metavar="DIR", help="results folder")
    parser.add_argument("--recovery", choices=RECOVERY_MODES, default=Recovery.NONE.value,
                        help="what execution does when an action fails (default none: the "
                             "paper's open loop)")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                        dest="overrides",
                        help="replace a scenario field in every run, e.g. "
                             "planner.group_positions=shared (repeatable; a variant's runs "
                             "are runs of their own)")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1, metavar="N",
                        help="local worker processes (default: one per core)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="a Dask scheduler, tcp://HOST:PORT, instead of the local pool")
    parser.add_argument("--limit", type=int, metavar="N",
                        help="only the first N tasks of the folder (by name)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.add_argument("--open-loop", metavar="DIR",
                        help="with --recovery retry|replan: the same study run open loop "
                             "(its --out), for the time recovery costs in summary.md")
    parser.add_argument("--again", metavar="DIR",
                        help="run again only the runs of the study in DIR that did not "
                             "complete (or that --ended names), and compare")
    parser.add_argument("--ended", nargs="+", metavar="WORD",
                        help="with --again: the runs whose ending contains one of these "
                             "words, e.g. blocked 'no plan'")
    parser.add_argument("--summarize", action="store_true",
                        help="run nothing: write the tables and figures from the runs "
                             "finished so far (e.g. while the study runs elsewhere)")
    return parser.parse_args(argv)


def _study_settings(args, argv: list[str]) -> None:
    """--summarize with no --tasks: the study's own settings (its results.json) fill in
    the options not given."""
    if args.tasks is not None:
        return
    if not args.summarize:
        fail("--tasks: required (a folder of task scenarios)")
    saved = Path(args.out) / "results.json"
    try:
        settings = json.loads(saved.read_text())["settings"]
    except (OSError, ValueError, KeyError, TypeError):
        fail(f"--tasks: required: no study settings to take it from in {saved}")
    given = {a.split("=", 1)[0] for a in argv if a.startswith("--")}
    args.tasks = settings["tasks"]
    if "--methods" not in given:
        args.methods = list(settings["methods"])
    if "--seeds" not in given:
        args.seeds = len(settings["seeds"])
    if "--limit" not in given and settings.get("limit") is not None:
        args.limit = settings["limit"]
    if "--recovery" not in given and "recovery" in settings:
        args.recovery = settings["recovery"]
    if "--set" not in given:
        args.overrides = list(settings.get("overrides", []))


def _validate(args) -> tuple[list[Path], list[str]]:
    folder = Path(args.tasks)
    if not folder.is_dir():
        fail(f"--tasks: no folder {folder}")
    paths = sorted(folder.glob("*.yaml"))
    if not paths:
        fail(f"--tasks: no *.yaml task in {folder}")
    if args.limit is not None:
        if args.limit < 1:
            fail(f"--limit: must be at least 1, got {args.limit}")
        paths = paths[:args.limit]
    for path in paths:
        scenario = read_scenario(path)
    if args.overrides:
        from s3o_drake.world.scenario import with_overrides
        from s3o_drake.world.scenario_checks import ScenarioError

        try:
            with_overrides(scenario, args.overrides)
        except ScenarioError as e:
            fail(f"--set {e}")
    if args.methods == ["all"]:
        methods = list(METHODS)
    else:
        unknown = [m for m in args.methods if m not in METHODS]
        if unknown:
            fail(f"--methods: unknown method {unknown[0]!r} (choose from 'all', "
                 f"{', '.join(METHODS)})")
        methods = list(dict.fromkeys(args.methods))
    if args.seeds < 1:
        fail(f"--seeds: must be at least 1, got {args.seeds}")
    if args.workers < 1:
        fail(f"--workers: must be at least 1, got {args.workers}")
    if args.open_loop is not None:
        if args.recovery == Recovery.NONE.value:
            fail("--open-loop: compares a study with recovery (--recovery retry or replan) "
                 "with its open-loop runs; this study is open loop")
        if not (Path(args.open_loop) / "results.jsonl").is_file():
            fail(f"--open-loop: no results.jsonl in {args.open_loop}")
    if args.ended is not None and args.again is None:
        fail("--ended: chooses among the runs of --again DIR; give --again")
    if args.again is not None:
        if not (Path(args.again) / "results.jsonl").is_file():
            fail(f"--again: no results.jsonl in {args.again}")
        if Path(args.again).resolve() == Path(args.out).resolve():
            fail("--again: the runs go to a folder of their own; --out names the same one")
    if args.scheduler is not None and not SCHEDULER.match(args.scheduler):
        fail(f"--scheduler: expected an address like tcp://HOST:PORT, got {args.scheduler!r}")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        fail(f"--out: {out} is a file, not a folder")
    return paths, methods


def study_jobs(paths: list[Path], methods: list[str], seeds: int,
               recovery: str = Recovery.NONE.value, overrides: tuple[str, ...] = ()
               ) -> tuple[list[Job], list[Job]]:
    """The difficulty jobs (one per task) and the run jobs, seed by seed, then task by task,
    all methods of a task together: an interrupted study has whole comparisons done."""
    from s3o_drake.experiments.jobs import DIFFICULTY, RUN, Job, file_digest

    digests = {p: file_digest(p) for p in paths}
    difficulty = [Job(DIFFICULTY, p.stem, str(p), digests[p], DIFFICULTY_SEED) for p in paths]
    runs = [Job(RUN, p.stem, str(p), digests[p], seed, method, recovery, tuple(overrides))
            for seed in range(seeds) for p in paths for method in methods]
    return difficulty, runs


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def _cannot_write(error: OSError, then: str) -> None:
    """One line on stderr: what could not be written, why, and what was kept."""
    where = f" {error.filename}" if error.filename else ""
    print(f"error: cannot write{where}: {error.strerror or error}; {then}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    _study_settings(args, sys.argv[1:] if argv is None else argv)
    paths, methods = _validate(args)
    from s3o_drake.experiments.difficulty import GROUPS, difficulty_groups
    from s3o_drake.experiments.scheduler import run_jobs
    from s3o_drake.experiments.store import ResultStore
    from s3o_drake.experiments.summary import markdown_tables, summarize, write_outputs

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    difficulty_jobs, run_job_list = study_jobs(paths, methods, args.seeds, args.recovery,
                                                 tuple(args.overrides))
    difficulty_store = ResultStore(out / "difficulty.jsonl", read_only=args.summarize)
    store = ResultStore(out / "results.jsonl", read_only=args.summarize)
    before: dict[str, dict] = {}
    known = None  # the difficulty rows of --again's study
    if args.again is not None:
        from s3o_drake.experiments.again import chosen

        earlier = Path(args.again)
        before = {r["key"]: r for r in
                  ResultStore(earlier / "results.jsonl", read_only=True).rows()}
        run_job_list = chosen(run_job_list, before, args.ended or ())
        known = ResultStore(earlier / "difficulty.jsonl", read_only=True)
        if not args.summarize:  # the same tasks: their areas need no new measure
            for job in difficulty_jobs:
                if known.finished(job.key) and not difficulty_store.finished(job.key):
                    difficulty_store.append(known.get(job.key))
    again = "" if args.again is None else \
        f" ({len(run_job_list)} of them chosen again from {args.again})"
    print(f"{len(paths)} tasks x {len(methods)} methods x {args.seeds} seeds = "
          f"{len(paths) * len(methods) * args.seeds} runs{again}; "
          f"{sum(store.finished(j.key) for j in run_job_list)} already finished in {out}",
          flush=True)
    options = {"workers": args.workers, "scheduler": args.scheduler,
               "progress": not args.quiet}
    # `kill PID` stops the study like Ctrl-C: finished runs kept, workers shut down.
    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        if not args.summarize:
            run_jobs(difficulty_jobs, difficulty_store, desc="difficulty", **options)
            run_jobs(run_job_list, store, desc="runs", **options)
    except KeyboardInterrupt:
        print(f"\ninterrupted: the finished runs are kept in {out / 'results.jsonl'}; "
              "run the same command to go on", file=sys.stderr)
        return 130
    except OSError as e:  # e.g. the disk full: the store kept every line it finished
        _cannot_write(e, f"the finished runs are kept in {out / 'results.jsonl'}; make room "
                         "and run the same command to go on")
        return 1
    finally:
        signal.signal(signal.SIGTERM, previous)

    wanted = {j.key for j in run_job_list}
    runs = [r for r in store.rows() if r["key"] in wanted]
    measured = [difficulty_store.get(j.key) or (known and known.get(j.key))
                for j in difficulty_jobs]
    areas = {r["task"]: r["area"] for r in measured if r is not None and "error" not in r}
    groups = difficulty_groups(areas)
    settings = {"tasks": str(Path(args.tasks)), "task_count": len(paths), "methods": methods,
                "seeds": list(range(args.seeds)), "difficulty_seed": DIFFICULTY_SEED,
                "overrides": list(args.overrides), "recovery": args.recovery,
                "limit": args.limit,
                "command": "python -m s3o_drake.commands.evaluate " + " ".join(
                    sys.argv[1:] if argv is None else argv)}
    # Which code made the runs: a study that resumed across commits says so.
    settings["code"] = dict(Counter(r.get("code", "not recorded") for r in runs).most_common())
    dish_areas = {r["task"]: r["areas"] for r in measured
                  if r is not None and "error" not in r}
    open_loop = [] if args.open_loop is None else \
        ResultStore(Path(args.open_loop) / "results.jsonl", read_only=True).rows()
    try:
        written = write_outputs(out, runs, areas, groups, methods, settings, dish_areas,
                                open_loop)
    except OSError as e:
        _cannot_write(e, f"the runs are kept in {out / 'results.jsonl'}; make room and "
                         "run the same command with --summarize")
        return 1
    print(markdown_tables(summarize(runs, groups, methods), methods))
    if args.again is not None:
        from s3o_drake.experiments.again import comparison

        table = comparison(before, runs, methods)
        try:
            (out / "again.md").write_text(
                f"The runs of {args.again} run again (`{settings['command']}`):\n\n{table}")
        except OSError as e:
            _cannot_write(e, "the runs are kept; run the same command with --summarize")
            return 1
        print(f"Run again, against the runs of {args.again}:\n{table}")
    print("Group sizes: " + ", ".join(
        f"{g} {sum(v == g for v in groups.values())}" for g in GROUPS))
    print("wrote " + ", ".join(str(p) for p in written))
    if len(settings["code"]) > 1:
        print("the runs come from several versions of the code: " + ", ".join(
            f"{code} ({n})" for code, n in settings["code"].items()))
    if args.summarize:
        left = sum(not store.finished(j.key) for j in run_job_list)
        print("every run finished" if not left else
              f"{left} of {len(run_job_list)} runs still to run; the tables compare the "
              "methods on the finished (task, seed) pairs")
    errors = [r for r in runs if "error" in r] + [r for r in measured
                                                   if r is not None and "error" in r]
    if errors:
        print(f"{len(errors)} jobs ended in an error (see {out / 'summary.md'}); "
              "run the same command to try them again", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
