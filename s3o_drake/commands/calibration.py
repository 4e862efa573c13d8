"""Calibration of Fea^m against executed pickups: reliability, ECE, Brier.

    s3o calibrate RESULTS [RESULTS ...] [--out DIR] [--methods NAME ...]
                  [--by all|method|source|action|stop|facing|turn|order|distance] [--bins N]

Is a pickup rated p picked a share p of the time? RESULTS: a study's results.jsonl (or its
folder), or the report.json files of `s3o run`. Prints the pickups, their observed success,
the expected calibration error (ECE) and the Brier score, over all and per method, source
and action; writes reliability.png (the reliability diagram) and calibration.json.
Exit status: 0, or 2 on bad input (one line on stderr; nothing is written).
"""

import argparse
import json
import sys

from s3o_drake.commands.common import command_parser, fail
from s3o_drake.commands.options import add_out, add_pickup_methods, at_least, out_folder

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.world.choices import CALIBRATION_GROUPINGS
from s3o_drake.world.files import write_atomically


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = command_parser("calibrate", __doc__)
    parser.add_argument("results", nargs="+", metavar="RESULTS",
                        help="results.jsonl, a folder holding one or run outputs, or "
                             "report.json files")
    add_out(parser, file=False, default="out/calibration")
    add_pickup_methods(parser)
    parser.add_argument("--by", choices=CALIBRATION_GROUPINGS, default="all",
                        help="the diagram's curves: all pickups (default), per method, "
                             "source of Fea^m, action, dishes served by the stop, those "
                             "and whether the base faced the dish, how far it was "
                             "turned from it, the pickup's place at its stop, or the "
                             "stop's distance to the dish")
    parser.add_argument("--bins", type=at_least(1), default=10, metavar="N",
                        help="equal-width bins of the predictions (default 10)")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    out = out_folder(args.out)
    from s3o_drake.experiments.calibration import (
        RecordsError,
        calibrate_records,
        figures_table,
        grouped,
        read_records,
    )
    from s3o_drake.viz.calibration import reliability_figure

    try:
        records = read_records(args.results)
    except RecordsError as e:
        fail(str(e))
    if args.methods:
        missing = [m for m in args.methods if not any(p.method == m for p in records.pickups)]
        if missing:
            fail(f"--methods: no executed pickup of {missing[0]!r} in the results")
        records = records.of_methods(args.methods)
    pickups = list(records.pickups)
    aspects = {"stops": list(records.stops), "orders": list(records.orders),
               "facing": list(records.facing), "distances": list(records.distances)}
    if not pickups:
        fail(f"{' '.join(args.results)}: {records.runs} runs, but no executed pickup")

    figures = {"all": calibrate_records(pickups, bins=args.bins)}
    for by in CALIBRATION_GROUPINGS[1:]:
        for name, group in grouped(pickups, by, **aspects).items():
            figures[f"{by} {name}"] = calibrate_records(group, bins=args.bins)
    curves = {name: calibrate_records(group, bins=args.bins)
              for name, group in grouped(pickups, args.by, **aspects).items()}

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
