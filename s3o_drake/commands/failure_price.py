"""What a pickup's chance of failing costs with recovery, from studies.

    s3o failure-price DIR [DIR ...] [--out models/ur5e/failure_price.yaml]

DIR: studies run with recovery (`s3o evaluate --recovery retry|replan`). The price is
seconds of recovery per expected failure, c = sum of recovery time / sum of (1 - Fea^m),
printed with a 95 % bootstrap interval per study and over all, and written to --out; the
planner uses it with `planner.failure_price: execution`.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter, defaultdict

from s3o_drake.commands.common import command_parser, fail
from s3o_drake.commands.options import (
    add_out,
    add_studies,
    out_file,
    study_folders,
    study_robot,
    write_record,
)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = command_parser("failure-price", __doc__)
    add_studies(parser, "study folders run with recovery (their results.jsonl)")
    add_out(parser, file=True, text="where to write the price (default "
                                    "models/ur5e/failure_price.yaml)")
    return parser.parse_args(argv)


def study_records(rows) -> tuple[list, int]:
    """The `PricedPickup`s of a study's runs with recovery (planning/failure_price.py), and
    how many dishes had no pickup with the plan's Fea^m."""
    from s3o_drake.planning.failure_price import RECOVERY_KINDS, PricedPickup

    records, skipped = [], 0
    for r in rows:
        if "error" in r or r.get("recovery", "none") == "none":
            continue
        cost: dict[str, float] = defaultdict(float)
        for recovery in r.get("recoveries", []):
            if recovery["kind"] in RECOVERY_KINDS:
                cost[recovery["dish"]] += float(recovery["cost"])
        first: dict[str, dict] = {}
        for pickup in r.get("pickups", []):
            first.setdefault(pickup["dish"], pickup)
        for dish, pickup in first.items():
            if pickup.get("planned") is None:
                skipped += 1
                continue
            records.append(PricedPickup(float(pickup["planned"]), cost.get(dish, 0.0)))
    return records, skipped


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    folders = study_folders(args)
    from s3o_drake.experiments.store import ResultStore
    from s3o_drake.planning.failure_price import FailurePrice, derive_price
    from s3o_drake.world.robot import load_robot

    out = out_file(args.out) if args.out else load_robot(study_robot(folders)).files.failure_price
    everything, per_study, codes = [], {}, Counter()
    for folder in folders:
        rows = ResultStore(folder / "results.jsonl", read_only=True).rows()
        records, skipped = study_records(rows)
        if not records:
            fail(f"DIR: {folder}: no pickups with the plan's Fea^m in runs with recovery "
                 f"({skipped} without it: recorded before `planned` was kept)")
        codes.update(r.get("code", "not recorded") for r in rows if "error" not in r)
        per_study[str(folder)] = derive_price(records)
        everything += records
        p = per_study[str(folder)]
        print(f"{folder}: {p['seconds']:.2f} s per expected failure [{p['low']:.2f}, "
              f"{p['high']:.2f}] ({p['pickups']} pickups, {p['expected_failures']:.1f} "
              f"expected failures, {p['recovery_time']:.0f} s of recoveries)")
    total = derive_price(everything)
    price = FailurePrice(total["seconds"], {
        "command": "s3o failure-price " + " ".join(
            sys.argv[1:] if argv is None else argv),
        "interval": [round(total["low"], 3), round(total["high"], 3)],
        "pickups": total["pickups"], "expected_failures": round(total["expected_failures"], 2),
        "recovery_time": round(total["recovery_time"], 2),
        "studies": {k: {"seconds": round(v["seconds"], 3), "pickups": v["pickups"]}
                    for k, v in per_study.items()},
        "code": dict(codes)})
    header = ("# What a pickup's chance of failing costs with recovery (s per expected failure),\n"
              "# planning/failure_price.py. Written by the command below; do not edit.\n")
    write_record(out, header, price.to_dict())
    print(f"all: {total['seconds']:.2f} s [{total['low']:.2f}, {total['high']:.2f}]; "
          f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
