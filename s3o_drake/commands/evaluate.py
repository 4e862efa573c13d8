"""The benchmark study: every task x method x seed, Fig. 5 and Table I.

    s3o evaluate --tasks scenarios/generated --methods all --seeds 3 --out results/

Plans and executes every run as `s3o run` does (without the playback) on local worker
processes or a Dask cluster. Each finished run is a line of OUT/results.jsonl at once, and
the same command resumes an interrupted study. Groups the tasks by the paper's difficulty
and writes results.csv, results.json, figure5.png, table1.png and summary.md. Exit status:
0; 1 when some run ended in an error; 2 on bad input (nothing written); 130 interrupted.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import signal
import sys
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

from s3o_drake.commands.common import command_parser, fail, read_scenario
from s3o_drake.commands.options import (
    add_out,
    add_overrides,
    add_quiet,
    add_seeds,
    add_tasks,
    add_workers,
    one_robot,
    out_folder,
    task_paths,
    with_overrides_or_fail,
)

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.world.choices import METHODS, RECOVERY_MODES, Recovery

if TYPE_CHECKING:
    from s3o_drake.experiments.jobs import Job

DIFFICULTY_SEED = 0
"""The oracle's noise draws for the difficulty measure: one fixed seed, so that a task's
group does not depend on how many seeds the study runs."""
SCHEDULER = re.compile(r"^(tcp|tls|inproc|ucx)://\S+$")


def _renamed(text: str) -> str:
    raise argparse.ArgumentTypeError("now --count N (the first N tasks)")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = command_parser("evaluate", __doc__)
    add_tasks(parser, default=(), required="required, but with --summarize the study's own")
    parser.add_argument("--limit", type=_renamed, help=argparse.SUPPRESS)
    parser.add_argument("--methods", nargs="+", default=["all"], metavar="NAME",
                        help=f"'all' or some of: {', '.join(METHODS)} (default all)")
    add_seeds(parser, 3)
    add_out(parser, file=False, required=True, text="the study's folder")
    parser.add_argument("--recovery", choices=RECOVERY_MODES, default=Recovery.NONE.value,
                        help="what execution does when an action fails (default none: the "
                             "paper's open loop)")
    add_overrides(parser, "replace a scenario field in every run, e.g. "
                          "planner.group_positions=shared (repeatable)")
    add_workers(parser, os.cpu_count() or 1, "local worker processes")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="a Dask scheduler, tcp://HOST:PORT, instead of the local pool "
                             "(workers: dask worker ADDRESS --nthreads 1 --nworkers N)")
    add_quiet(parser)
    parser.add_argument("--open-loop", metavar="DIR",
                        help="with --recovery retry|replan: the same study open loop, for "
                             "the time recovery costs")
    parser.add_argument("--again", metavar="DIR",
                        help="run again the runs of the study in DIR that did not complete")
    parser.add_argument("--ended", nargs="+", metavar="WORD",
                        help="with --again: the runs whose ending has one of these words")
    parser.add_argument("--summarize", action="store_true",
                        help="run nothing: the tables and figures of the runs so far")
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
    tasks = settings["tasks"]
    args.tasks = [tasks] if isinstance(tasks, str) else list(tasks)
    if "--methods" not in given:
        args.methods = list(settings["methods"])
    if "--seeds" not in given:
        args.seeds = len(settings["seeds"])
    # Studies from before --count recorded it as "limit".
    count = settings.get("count", settings.get("limit"))
    if "--count" not in given and count is not None:
        args.count = count
    if "--recovery" not in given and "recovery" in settings:
        args.recovery = settings["recovery"]
    if "--set" not in given:
        args.overrides = list(settings.get("overrides", []))


def _validate(args: argparse.Namespace) -> tuple[list[Path], list[str], str]:
    """The tasks, the methods and the robot of the study (one: a study's rows are one
    robot's); a bad argument is one line and exit status 2."""
    paths = task_paths(args)
    tasks = [(path, with_overrides_or_fail(read_scenario(path), args.overrides))
             for path in paths]
    robot = one_robot(tasks)
    scenario = tasks[-1][1]
    from s3o_drake.planning.robot_files import missing_robot_files

    missing = missing_robot_files(dataclasses.replace(
        scenario, execution=dataclasses.replace(scenario.execution,
                                                recovery=args.recovery)).settings,
                                  scenario.robot_value)
    if missing:
        fail(missing[0])
    if args.methods == ["all"]:
        methods = list(METHODS)
    else:
        unknown = [m for m in args.methods if m not in METHODS]
        if unknown:
            fail(f"--methods: unknown method {unknown[0]!r} (choose from 'all', "
                 f"{', '.join(METHODS)})")
        methods = list(dict.fromkeys(args.methods))
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
    out_folder(args.out)
    return paths, methods, robot


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
    paths, methods, robot = _validate(args)
    from s3o_drake.experiments.difficulty import GROUPS, difficulty_groups
    from s3o_drake.experiments.scheduler import ClusterError, check_cluster, run_jobs

    if args.scheduler is not None and not args.summarize:  # before anything is written
        from distributed import Client

        try:
            with Client(args.scheduler) as client:
                check_cluster(client)
        except ClusterError as e:
            fail(f"--scheduler: {e}")
        except OSError as e:
            fail(f"--scheduler: cannot reach {args.scheduler}: {e}")
    from s3o_drake.experiments.store import OtherRobotRowsError, ResultStore
    from s3o_drake.experiments.summary import markdown_tables, summarize, write_outputs

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    difficulty_jobs, run_job_list = study_jobs(paths, methods, args.seeds, args.recovery,
                                                 tuple(args.overrides))
    try:
        difficulty_store = ResultStore(out / "difficulty.jsonl", robot=robot,
                                       read_only=args.summarize)
        store = ResultStore(out / "results.jsonl", robot=robot, read_only=args.summarize)
    except OtherRobotRowsError as e:
        fail(f"--out: {e}")
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
    except ClusterError as e:
        fail(f"--scheduler: {e}")
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
    tasks = [str(Path(t)) for t in args.tasks]
    settings = {"tasks": tasks[0] if len(tasks) == 1 else tasks, "task_count": len(paths),
                "methods": methods, "seeds": list(range(args.seeds)),
                "difficulty_seed": DIFFICULTY_SEED, "overrides": list(args.overrides),
                "recovery": args.recovery, "count": args.count,
                "command": "s3o evaluate " + " ".join(sys.argv[1:] if argv is None else argv)}
    # Which code and packages made the runs: a study that resumed across commits, or in
    # another environment, says so.
    for field in ("code", "packages"):
        settings[field] = dict(Counter(r.get(field, "not recorded") for r in runs).most_common())
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
