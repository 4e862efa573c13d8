"""Variants of one method against a baseline and against the method as it is: the
attribution table.

A variant is a study of the same tasks and seeds with some scenario fields replaced
(`evaluate --set`); its runs pair with the baseline's and the reference's by (task, seed),
whose run seeds, and so noise, are the same. Per variant: completion (Wilson 95 % interval),
the plans' predicted completion, the stops, the sign test and the paired execution time
(`summary.paired_runs`: on pairs with two plans and on pairs where both collected every dish)
against the baseline and against the reference, and on the complete pairs the stops saved
against the baseline and the seconds each saves.
"""

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import binomtest

from s3o_drake.experiments.run_rows import code_of, has_time, predicted_completion
from s3o_drake.experiments.summary import Paired, paired_runs


@dataclass(frozen=True)
class VariantFigures:
    label: str
    runs: int
    completion: float
    completion_low: float
    completion_high: float
    predicted_completion: float
    stops: float
    against_baseline: Paired | None
    against_reference: Paired | None
    code: str


def variant_figures(label: str, runs: Sequence[Mapping], baseline: Sequence[Mapping],
                    reference: Sequence[Mapping] | None, *, baseline_name: str,
                    reference_name: str) -> VariantFigures:
    """One variant's figures (module docstring); `reference` None for the reference itself,
    `baseline` empty when the study ran no baseline (its columns are then left empty)."""
    runs = [r for r in runs if "error" not in r]
    done = sum(bool(r["complete"]) for r in runs)
    low, high = binomtest(done, len(runs)).proportion_ci(method="wilson") if runs else \
        (np.nan, np.nan)
    stops = [r["stops"] for r in runs if has_time(r) and r.get("stops") is not None]
    return VariantFigures(
        label, len(runs), done / len(runs) if runs else np.nan, float(low), float(high),
        float(np.mean([predicted_completion(r) for r in runs])) if runs else np.nan,
        float(np.mean(stops)) if stops else np.nan,
        paired_runs(runs, baseline, baseline_name, method=label) if baseline else None,
        None if reference is None else paired_runs(runs, reference, reference_name,
                                                   method=label),
        code_of(runs))


def variant_table(figures: Sequence[VariantFigures], *, baseline_name: str,
                  reference_name: str) -> str:
    """The figures as a Markdown table, a row per variant."""
    lines = [f"| variant | runs | completion (95 %) | predicted completion | stops | against "
             f"{baseline_name}: only it completes / only {baseline_name} / sign test p | time "
             f"against {baseline_name}, both with a plan | the same, both complete | there: "
             f"stops fewer / pairs with as many / s per stop saved | against "
             f"{reference_name}: only it / only {reference_name} / p | time against "
             f"{reference_name}, both complete |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for f in figures:
        b, r = f.against_baseline, f.against_reference
        lines.append(
            f"| {f.label} | {f.runs} | {f.completion:.2f} [{f.completion_low:.2f}, "
            f"{f.completion_high:.2f}] | {f.predicted_completion:.3f} | {f.stops:.2f} | "
            + ("– | – | – | – | " if b is None else f"{b.wins} / {b.losses} / "
               f"{b.p_value:.2f} | {b.timed.text()} | {b.complete.text()} | "
               f"{b.stops.text()} | ")
            + ("–" if r is None else f"{r.wins} / {r.losses} / {r.p_value:.2f}") + " | "
            + ("–" if r is None else r.complete.text()) + " |")
    return "\n".join(lines) + "\n"
