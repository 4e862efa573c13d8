"""Variants of a method against a baseline, paired: the attribution table.

    s3o bench compare-variants --study DIR LABEL=DIR [LABEL=DIR ...] [--out FILE]

--study DIR holds the runs of --baseline and of --method as it is; each LABEL=DIR is a study
of --method with some scenario fields replaced (`s3o evaluate --set ...`) on the same tasks
and seeds. Per row: completion, predicted completion, stops, the sign test and the paired
execution time against the baseline and against the method as it is. A study without the
baseline's runs compares the variants with the method as it is only.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from s3o_drake.commands.common import command_parser, fail
from s3o_drake.commands.options import add_method, add_out, method, out_file


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = command_parser("bench compare-variants", __doc__)
    parser.add_argument("--study", required=True, metavar="DIR",
                        help="the study with the baseline and the method as it is")
    parser.add_argument("variants", nargs="*", metavar="LABEL=DIR",
                        help="a variant's study folder and its label")
    add_method(parser)
    parser.add_argument("--baseline", default="V-GROP*", type=method, metavar="NAME",
                        help="the baseline (default V-GROP*)")
    add_out(parser, file=True, text="write the table here (Markdown)")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    folders = {"as it is": Path(args.study)}
    for item in args.variants:
        label, sep, folder = item.partition("=")
        if not sep or not label or not folder:
            fail(f"LABEL=DIR: expected a label and a folder, got {item!r}")
        if label in folders:
            fail(f"LABEL=DIR: the label {label!r} is given twice")
        folders[label] = Path(folder)
    for label, folder in folders.items():
        if not (folder / "results.jsonl").is_file():
            fail(f"{'--study' if label == 'as it is' else label}: no results.jsonl in {folder}")
    from s3o_drake.experiments.store import ResultStore
    from s3o_drake.experiments.summary import TIME_DIFFERENCE_MEANING
    from s3o_drake.experiments.variants import variant_figures, variant_table

    def runs_of(folder: Path, method: str) -> list[dict]:
        return [r for r in ResultStore(folder / "results.jsonl", read_only=True).rows()
                if r.get("method") == method and "error" not in r]

    baseline = runs_of(folders["as it is"], args.baseline)
    reference = runs_of(folders["as it is"], args.method)
    if not reference:
        fail(f"--study: {folders['as it is']} has no runs of {args.method}")
    figures = [variant_figures(label, reference if label == "as it is" else
                               runs_of(folder, args.method), baseline,
                               None if label == "as it is" else reference,
                               baseline_name=args.baseline, reference_name="as it is")
               for label, folder in folders.items()]
    codes = sorted({f.code for f in figures} | ({f"{args.baseline}: " + variant_figures(
        "b", baseline, baseline, None, baseline_name="", reference_name="").code}
        if baseline else set()))
    against = f"against {args.baseline}" if baseline else f"(no {args.baseline} in the study)"
    table = (f"{args.method} variants {against} (runs at: {'; '.join(codes)})\n\n"
             + variant_table(figures, baseline_name=args.baseline, reference_name="as it is")
             + "\n" + TIME_DIFFERENCE_MEANING + "\n")
    print(table)
    if args.out:
        out_file(args.out)
        try:
            Path(args.out).write_text(table)
        except OSError as e:
            fail(f"--out: cannot write {args.out}: {e.strerror or e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
