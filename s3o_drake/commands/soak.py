"""Soak: plan many seeded random scenes with every method, execute some, and count crashes,
budget overruns, hangs and memory growth.

    python -m s3o_drake.commands.soak --plan 1000 --execute 200 --out out/soak
           [--seed 0] [--budget 5] [--execute-budget 60] [--limit 900] [--dishes 30]
           [--quiet] [--summarize] [--again-loaded]

Scene i is drawn from --seed and i alone (s3o_drake/world/random_scenes.py: a room of random
size, 1 to 5 tables anywhere, 0 to --dishes dishes, crowding chairs, sometimes a robot
boxed in). Each of the first --plan scenes is planned by every method through `plan_from`
(Fea^m: a cheap ring around each dish, so that the time measured is the planner's) with a
budget of --budget s, and every result is checked: a plan or a "no plan" with its reason,
the plan checker's task-level preconditions, every goto pose free in the known world, no
more than 5 % over the budget. Each of the first --execute scenes is run whole with one
method (the methods in turn): `execute()`, as `python -m s3o_drake.run` does, without the
playback, planning with a budget of --execute-budget s (the Fea^m of its network, made
before the budget starts, is not counted in it).

Jobs run one at a time in a worker process at low priority; one that takes longer than
--limit s is a hang (the worker is killed and a new one goes on), a worker that dies is a
crash. The worker's memory (RSS) is recorded after each job: the summary gives the first
and last figure and the slope.

Written to --out: soak.jsonl, one line per job as it ends (the resume log: the same
command goes on where a killed one stopped), and summary.md, the table printed at the end.
--summarize prints and writes the summary of the rows so far and runs nothing.
--again-loaded also runs again the jobs whose overruns or hangs were counted apart (their
worker got less than 80 % of a core: a budget is wall time); run it on an idle machine.

Exit status: 0 when nothing went wrong, 1 when a crash, overrun, hang or faulty plan was
counted, 2 on bad input (nothing is written), 130 when interrupted (finished jobs kept).
"""

import sys
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.soak", description=__doc__,
                            formatter_class=doc_formatter())
    parser.add_argument("--plan", type=int, default=1000, metavar="N",
                        help="scenes planned with every method (default 1000)")
    parser.add_argument("--execute", type=int, default=200, metavar="M",
                        help="scenes executed, one method each (default 200)")
    parser.add_argument("--seed", type=int, default=0, help="scene seed (default 0)")
    parser.add_argument("--budget", type=float, default=5.0, metavar="S",
                        help="planning budget per method and scene (s, default 5)")
    parser.add_argument("--execute-budget", type=float, default=60.0, metavar="S",
                        help="planning budget of an executed run (s, default 60)")
    parser.add_argument("--limit", type=float, default=900.0, metavar="S",
                        help="wall-time limit per job (s, default 900): longer is a hang")
    parser.add_argument("--dishes", type=int, default=30, metavar="N",
                        help="most dishes in a scene (default 30)")
    parser.add_argument("--out", metavar="DIR", default="out/soak",
                        help="output folder (default out/soak)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--summarize", action="store_true",
                        help="summarise the rows so far; run nothing")
    parser.add_argument("--again-loaded", action="store_true",
                        help="also run again the jobs whose overruns or hangs were counted "
                             "apart (a loaded machine)")
    args = parser.parse_args(argv)
    for name in ("plan", "execute", "seed", "dishes"):
        if getattr(args, name) < 0:
            fail(f"--{name}: must be a non-negative integer, got {getattr(args, name)}")
    for name in ("budget", "execute_budget", "limit"):
        value = getattr(args, name)
        if not value > 0 or value == float("inf"):
            fail(f"--{name.replace('_', '-')}: must be a positive number of seconds, got {value:g}")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        fail(f"--out: {out} exists and is not a folder")

    from s3o_drake.experiments.soak import (
        run_soak,
        scene_counts,
        soak_jobs,
        summary_table,
        tally,
    )
    from s3o_drake.experiments.store import ResultStore
    from s3o_drake.world.files import write_atomically

    out.mkdir(parents=True, exist_ok=True)
    store = ResultStore(out / "soak.jsonl")
    code = 0
    if not args.summarize:
        try:
            jobs = soak_jobs(args.seed, args.plan, args.execute, args.budget, args.dishes,
                             args.execute_budget)
            run_soak(jobs, store, limit=args.limit, progress=not args.quiet,
                     again_loaded=args.again_loaded)
        except KeyboardInterrupt:
            print("interrupted: the finished jobs are kept in soak.jsonl", file=sys.stderr)
            code = 130
    rows = store.rows()
    planned, executed = scene_counts(rows)
    table = (f"{planned} scenes planned (every method), {executed} executed\n\n"
             + summary_table(rows))
    write_atomically(out / "summary.md", table + "\n")
    print(table)
    if code == 0 and any(tally(rows).values()):
        code = 1
    return code


if __name__ == "__main__":
    sys.exit(main())
