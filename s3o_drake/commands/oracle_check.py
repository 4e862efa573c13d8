"""Which Fea^m model is off: the plan's or the oracle's, at executed pickups.

    s3o bench oracle-executed STUDY [--middle 80] [--high 60] [--samples 100] [--json FILE]
    s3o bench oracle-executed STUDY --by stop|distance [--per-group 100] [--methods NAME ...]

Re-evaluates a study's first pickups with the Drake oracle at the pose the plan sent the
base to, on the task's known world at that moment: its blurred expectation (the network's
labels) and its Monte Carlo over --samples landings, against the observed success, per bin
of the plan's Fea^m (every pickup below 0.8, a draw of --middle and --high above). --by
stop draws --per-group pickups per stop size (1, 2, 3+ dishes), --by distance per band of
the stop's distance to the dish, and tests each also where the base really landed: whether
the landing model is off. About 2 s a pickup (docs/calibration.md).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from s3o_drake.commands.common import command_parser, fail
from s3o_drake.commands.options import (
    add_json,
    add_pickup_methods,
    add_quiet,
    at_least,
    json_store,
)
from s3o_drake.world.resources import REPO_DIR


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = command_parser("bench oracle-executed", __doc__)
    parser.add_argument("study", metavar="STUDY", help="a study's folder (results.jsonl)")
    parser.add_argument("--middle", type=at_least(0), default=80, metavar="N",
                        help="pickups drawn from the plans' 0.8-0.9 (default 80)")
    parser.add_argument("--high", type=at_least(0), default=60, metavar="N",
                        help="pickups drawn from 0.9 up (default 60)")
    parser.add_argument("--by", choices=("value", "stop", "distance"), default="value",
                        help="draw by the plan's Fea^m (default), by the dishes the "
                             "pickup's stop served, or by the stop's distance to the dish")
    parser.add_argument("--per-group", type=at_least(1), default=100, metavar="N",
                        help="with --by stop or distance: pickups drawn per group "
                             "(default 100)")
    add_pickup_methods(parser)
    parser.add_argument("--samples", type=at_least(1), default=100, metavar="N",
                        help="Monte-Carlo landings per pickup (default 100)")
    parser.add_argument("--seed", type=at_least(0), default=0, metavar="N",
                        help="seed of the draw and of the landings (default 0)")
    add_json(parser, "pickup")
    add_quiet(parser)
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    results = Path(args.study) / "results.jsonl"
    if not results.is_file():
        fail(f"STUDY: no results.jsonl in {args.study}")
    store = json_store(args, key=lambda row: row["key"])
    from tqdm import tqdm

    from s3o_drake.experiments.oracle_check import (
        ALL_BELOW,
        by_group,
        evaluate,
        first_pickups,
        group_table,
        oracle_of,
        stratified,
        table,
    )
    from s3o_drake.experiments.store import ResultStore

    pickups = first_pickups(ResultStore(results, read_only=True).rows(),
                            methods=args.methods)
    if not pickups:
        fail(f"STUDY: {results} records no first pickup with its planned Fea^m"
             + (f" by {', '.join(args.methods)}" if args.methods else ""))
    if args.by != "value":
        sample = by_group(pickups, args.per_group, by=args.by, seed=args.seed)
        print(f"{len(sample)} of {len(pickups)} first pickups, up to {args.per_group} per "
              f"group by {args.by}", flush=True)
    else:
        sample = stratified(pickups, {(0.8, 0.9): args.middle, (0.9, 1.0): args.high},
                            seed=args.seed)
        print(f"{len(sample)} of {len(pickups)} first pickups, every one below "
              f"{ALL_BELOW}", flush=True)
    rows, oracles = [], {}
    for pickup in tqdm(sorted(sample, key=lambda p: (p.path, p.before)), unit="pickup",
                       disable=args.quiet):
        if store is not None and store.finished(pickup.key):
            rows.append(store.get(pickup.key))
            continue
        where = (pickup.path, pickup.before)
        if where not in oracles:
            oracles.clear()  # one known world at a time: a Drake scene each
            oracles[where] = oracle_of(pickup, REPO_DIR)
        row = evaluate(pickup, oracles[where], samples=args.samples, seed=args.seed)
        rows.append(row)
        if store is not None:
            store.append(row)
    print(table(rows) if args.by == "value" else
          group_table(rows, by=args.by, seed=args.seed))
    return 0


if __name__ == "__main__":
    sys.exit(main())
