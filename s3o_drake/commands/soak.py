"""Plan and execute many random scenes: crashes, overruns, hangs, memory.

    s3o bench soak --plan 1000 --execute 200 --out out/soak [--summarize]

Scene i is drawn from --seed and i alone (random rooms, tables, dishes and chairs). The
first --plan scenes are planned by every method and every result checked; the first
--execute are run whole with one method each. Jobs run one at a time in a watched worker
process: longer than --limit is a hang, a worker that dies a crash; its memory is recorded.
Exit status: 0, 1 when something went wrong, 2 on bad input, 130 when interrupted.
"""

import sys

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, fail
from s3o_drake.commands.options import (
    add_out,
    add_quiet,
    add_seed,
    at_least,
    out_folder,
    seconds,
)


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench soak", __doc__)
    parser.add_argument("--plan", type=at_least(0), default=1000, metavar="N",
                        help="scenes planned with every method (default 1000)")
    parser.add_argument("--execute", type=at_least(0), default=200, metavar="M",
                        help="scenes executed, one method each (default 200)")
    add_seed(parser, 0, "scene seed")
    parser.add_argument("--budget", type=seconds, default=5.0, metavar="S",
                        help="planning budget per method and scene (s, default 5)")
    parser.add_argument("--execute-budget", type=seconds, default=60.0, metavar="S",
                        help="planning budget of an executed run (s, default 60)")
    parser.add_argument("--limit", type=seconds, default=900.0, metavar="S",
                        help="wall-time limit per job (s, default 900): longer is a hang")
    parser.add_argument("--dishes", type=at_least(0), default=30, metavar="N",
                        help="most dishes in a scene (default 30)")
    add_out(parser, file=False, default="out/soak")
    add_quiet(parser)
    parser.add_argument("--summarize", action="store_true",
                        help="summarise the rows so far; run nothing")
    parser.add_argument("--again-loaded", action="store_true",
                        help="also run again the jobs whose overruns or hangs were counted "
                             "apart (a loaded machine)")
    args = parser.parse_args(argv)
    out = out_folder(args.out)

    from s3o_drake.experiments.soak import (
        run_soak,
        scene_counts,
        soak_jobs,
        summary_table,
        tally,
    )
    from s3o_drake.experiments.store import OtherRobotRowsError, ResultStore
    from s3o_drake.world.files import write_atomically

    out.mkdir(parents=True, exist_ok=True)
    try:
        store = ResultStore(out / "soak.jsonl")
    except OtherRobotRowsError as e:
        fail(f"--out: {e}")
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
