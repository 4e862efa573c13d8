"""What a pickup at a shared stop achieves of its Fea^m, from studies.

    s3o shared-stop DIR [DIR ...] [--out models/ur5e/shared_stop.yaml]

DIR: open-loop studies (`s3o evaluate`, recovery none). The share of a stop size is
s_k = sum of successes / sum of Fea^m over the first attempts of the pickups at stops
serving k dishes (2, and 3 or more); printed with a 95 % bootstrap interval per study (which
may lack a size that the others hold) and over all, beside one-dish stops as a check of
Fea^m's calibration, and written to --out.
The planner rates such pickups at s_k Fea^m with `planner.shared_stop: execution`.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter

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
    parser = command_parser("shared-stop", __doc__)
    add_studies(parser, "open-loop study folders (their results.jsonl)")
    add_out(parser, file=True, text="where to write the shares (default "
                                    "models/ur5e/shared_stop.yaml)")
    return parser.parse_args(argv)


def _what(key: str) -> str:
    return "stops serving " + ("1 dish" if key == "1" else f"{key} dishes")


def _line(key: str, found: dict[str, float]) -> str:
    return (f"  {_what(key)}: {found['share']:.3f} [{found['low']:.3f}, "
            f"{found['high']:.3f}] ({found['pickups']} pickups, {found['successes']} picked, "
            f"Fea^m summed {found['predicted']:.1f})")


def _print_shares(shares: dict[str, dict[str, float]], keys: tuple[str, ...]) -> None:
    for key in keys:
        print(_line(key, shares[key]) if key in shares else f"  {_what(key)}: none")


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    folders = study_folders(args)
    from s3o_drake.abstraction.shared_stop import (
        SIZES,
        StopPickup,
        StopShares,
        derive_shares,
    )
    from s3o_drake.experiments.calibration import RecordsError, read_records
    from s3o_drake.experiments.store import ResultStore
    from s3o_drake.world.robot import load_robot

    keys = ("1", *SIZES)  # the one-dish stops, then the shared ones

    out = out_file(args.out) if args.out else load_robot(study_robot(folders)).files.shared_stop
    everything, per_study, codes = [], {}, Counter()
    for folder in folders:
        rows = [r for r in ResultStore(folder / "results.jsonl", read_only=True).rows()
                if "error" not in r]
        modes = {r.get("recovery", "none") for r in rows} - {"none"}
        if modes:
            fail(f"DIR: {folder} ran with recovery ({', '.join(sorted(modes))}); the shares "
                 "come from open-loop runs")
        codes.update(r.get("code", "not recorded") for r in rows)
        try:
            records = read_records([folder / "results.jsonl"])
        except RecordsError as e:
            fail(f"DIR: {e}")
        found = [StopPickup(p.predicted, p.succeeded, size)
                 for p, size in zip(records.pickups, records.stops, strict=True)
                 if p.attempt == 1]
        # A small study may have made no stop of some size; the studies together must.
        per_study[str(folder)] = derive_shares(found, partial=True)
        everything += found
        print(f"{folder}:")
        _print_shares(per_study[str(folder)], keys)
    # The pooled shares are a measurement even where they cannot make a model: printed
    # first, so that a study without large stops still reads.
    pooled = derive_shares(everything, partial=True)
    print("all:")
    _print_shares(pooled, keys)
    missing = [key for key in keys if key not in pooled]
    if missing:
        fail(f"DIR: the studies together have no pickups with Fea^m > 0 at "
             f"{_what(missing[0])}; nothing written")
    shares = StopShares({k: pooled[k]["share"] for k in SIZES}, {
        "command": "s3o shared-stop " + " ".join(sys.argv[1:] if argv is None else argv),
        "intervals": {k: [round(pooled[k]["low"], 4), round(pooled[k]["high"], 4)]
                      for k in SIZES},
        "pickups": {k: pooled[k]["pickups"] for k in pooled},
        "one_dish_check": round(pooled["1"]["share"], 4),
        "studies": {study: {k: round(v["share"], 4) for k, v in found.items()}
                    for study, found in per_study.items()},
        "code": dict(codes)})
    header = ("# What a pickup at a stop serving several dishes achieves of its Fea^m (the\n"
              "# share s_k), abstraction/shared_stop.py. Written by the command below; do not\n"
              "# edit.\n")
    write_record(out, header, shares.to_dict())
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
