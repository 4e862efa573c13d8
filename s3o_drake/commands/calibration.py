"""Calibration of Fea^m against executed pickups: is a pickup rated p picked a share p of
the time?

    python -m s3o_drake.commands.calibration RESULTS [RESULTS ...] [--out DIR] [--methods NAME ...]
                                    [--by all|method|source|action] [--bins N]

RESULTS: a results.jsonl of `python -m s3o_drake.commands.evaluate`, a folder holding one (else the
report.json files below it), or report.json files of `python -m s3o_drake.run`. Each executed
pickup there carries the plan's Fea^m of it (from the planned stop), the source of that
model (planner.feasibility: fcn or oracle), the planned and the real stop, and the outcome.
Pickups a run never reached (after a blocked drive) are not executions and do not count.

Prints, over all pickups, per method, per source and per action (pickup, or place: the
putting down of an object at its place, which succeeds when the object stands there,
report.json's placements): the number of pickups, their observed
success and mean predicted Fea^m, the expected calibration error (ECE: the predictions in
--bins equal-width bins of [0, 1], |mean prediction - observed success| per bin weighted by
its count), the Brier score (mean squared difference between prediction and outcome, 1 or
0), and the observed success of the pickups predicted >= 0.9 with their count and a 95 %
binomial (Clopper-Pearson) interval.

Written to --out (default out/calibration):
  reliability.png   per bin, the mean prediction against the observed success (with its
                    95 % interval and the count beside the point), the diagonal of a
                    calibrated model, and the pickups per bin below; one curve for all
                    pickups, or one per method, source or action (pickup, place) with --by
  calibration.json  the figures above, per group and per bin, and the inputs read

Rows written before pickups were recorded (results of an older version) carry no
prediction per pickup: they are refused, not guessed.

Exit status: 0, or 2 on bad input (one line on stderr naming the problem; nothing is
written).
"""

import json
import sys
from pathlib import Path

from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.world.choices import CALIBRATION_GROUPINGS, METHODS
from s3o_drake.world.files import write_atomically


def parse_args(argv: list[str] | None):
    parser = ArgumentParser(prog="python -m s3o_drake.commands.calibration", description=__doc__,
                            formatter_class=doc_formatter())
    parser.add_argument("results", nargs="+", metavar="RESULTS",
                        help="results.jsonl, a folder holding one or run outputs, or "
                             "report.json files")
    parser.add_argument("--out", default="out/calibration", metavar="DIR",
                        help="output folder (default out/calibration)")
    parser.add_argument("--methods", nargs="+", metavar="NAME",
                        help=f"only these methods' pickups, some of: {', '.join(METHODS)}")
    parser.add_argument("--by", choices=CALIBRATION_GROUPINGS, default="all",
                        help="the diagram's curves: all pickups (default), per method or "
                             "per source of Fea^m")
    parser.add_argument("--bins", type=int, default=10, metavar="N",
                        help="equal-width bins of the predictions (default 10)")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.bins < 1:
        fail(f"--bins: must be at least 1, got {args.bins}")
    unknown = [m for m in args.methods or () if m not in METHODS]
    if unknown:
        fail(f"--methods: unknown method {unknown[0]!r} (choose from {', '.join(METHODS)})")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        fail(f"--out: {out} is a file, not a folder")
    from s3o_drake.experiments.calibration import (
        RecordsError,
        calibrate_records,
        figures_table,
        grouped,
        read_records,
        reliability_figure,
    )

    try:
        records = read_records(args.results)
    except RecordsError as e:
        fail(str(e))
    pickups = list(records.pickups)
    if args.methods:
        missing = [m for m in args.methods if not any(p.method == m for p in pickups)]
        if missing:
            fail(f"--methods: no executed pickup of {missing[0]!r} in the results")
        pickups = [p for p in pickups if p.method in args.methods]
    if not pickups:
        fail(f"{' '.join(args.results)}: {records.runs} runs, but no executed pickup")

    figures = {"all": calibrate_records(pickups, bins=args.bins)}
    for by in CALIBRATION_GROUPINGS[1:]:
        for name, group in grouped(pickups, by).items():
            figures[f"{by} {name}"] = calibrate_records(group, bins=args.bins)
    curves = {name: calibrate_records(group, bins=args.bins)
              for name, group in grouped(pickups, args.by).items()}

    out.mkdir(parents=True, exist_ok=True)
    f = figures["all"]
    runs = f"{records.runs} run" + ("" if records.runs == 1 else "s")
    title = (f"Fea^m against {f.count} executed pickups ({runs}): "
             f"ECE {f.ece:.3f}, Brier {f.brier:.3f}")
    reliability_figure(curves, out / "reliability.png", title=title)
    summary = {"inputs": [str(p) for p in records.files], "runs": records.runs,
               "methods": args.methods, "bins": args.bins,
               "figures": {name: c.to_dict() for name, c in figures.items()}}
    write_atomically(out / "calibration.json", json.dumps(summary, indent=1) + "\n")

    failures: dict[str, int] = {}
    for p in pickups:
        if not p.succeeded:
            failures[p.outcome] = failures.get(p.outcome, 0) + 1
    print(f"{len(pickups)} executed pickups from {runs}; ECE over {args.bins} "
          "equal-width bins")
    print(figures_table(figures))
    if failures:
        print("failures: " + ", ".join(f"{reason} {n}" for reason, n in
                                       sorted(failures.items(), key=lambda kv: (-kv[1], kv[0]))))
    print(f"wrote {out / 'reliability.png'}, {out / 'calibration.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
