"""Whether two studies' runs did the same, the machine's timings aside.

    s3o bench same-runs BEFORE AFTER [--tolerance T]

BEFORE and AFTER: study folders (their results.jsonl) of the same tasks, methods and seeds,
made by two versions of the code. Runs are paired by task, method, run seed and recovery;
for each pair every field of the row is compared but the bookkeeping and the wall-clock
timings (code, packages, machine, schema, job_seconds, planning_time, realtime_rate and
anything of "wall"); numbers exactly, or with --tolerance within T of their size (at least
1): code that computes the same thing in another order changes the last digits of a pose or
a distance, and nothing else. Prints the pairs compared and each difference, and, when there are
differences, the packages' versions and the processors of both sides if they differ (other
versions of numpy or Drake, or another processor's vector instructions, change the last
digits of a cost, and through the motion search a plan). Exit status 0
when they are identical, 1 when some run did something else, 2 on bad input.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from s3o_drake.commands.common import command_parser, fail


def _tolerance(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0.0 <= value < 1e-3:  # a study's figures are not compared this way
        raise argparse.ArgumentTypeError(f"expected a number from 0 below 1e-3, got {text!r}")
    return value


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = command_parser("bench same-runs", __doc__)
    parser.add_argument("before", metavar="BEFORE", help="a study folder")
    parser.add_argument("after", metavar="AFTER", help="the same study, other code")
    parser.add_argument("--tolerance", type=_tolerance, default=0.0, metavar="T",
                        help="numbers within T times their size (at least 1) are the same "
                             "(default 0: exact)")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    for name, folder in (("BEFORE", args.before), ("AFTER", args.after)):
        if not (Path(folder) / "results.jsonl").is_file():
            fail(f"{name}: no results.jsonl in {folder}")
    from s3o_drake.experiments.run_rows import machine_of, packages_of, run_differences
    from s3o_drake.experiments.store import ResultStore

    rows = [ResultStore(Path(f) / "results.jsonl", read_only=True).rows()
            for f in (args.before, args.after)]
    pairs, differences = run_differences(*rows, tolerance=args.tolerance)
    if pairs == 0:
        fail("AFTER: no run of BEFORE's tasks, methods and seeds")
    for line in differences:
        print(line)
    same = "identical" if args.tolerance == 0 else f"the same within {args.tolerance:g}"
    print(f"{pairs} runs compared: " + (f"{same}, timings aside" if not differences
                                         else f"{len(differences)} differences"))
    for what, of in (("packages", packages_of), ("machines", machine_of)):
        made = [of(r) for r in rows]
        if differences and made[0] != made[1]:
            print(f"made with other {what}: BEFORE {made[0]}; AFTER {made[1]}")
    return 1 if differences else 0


if __name__ == "__main__":
    sys.exit(main())
