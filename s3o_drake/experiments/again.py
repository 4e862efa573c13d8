"""Runs of a study run again with other code: which to run, and what changed.

`evaluate --again DIR` runs again, into its own --out, the runs of the study in DIR that
did not complete (or, with --ended, those whose ending names one of the given words), with
the same task, method, seed and recovery, so that each new run meets its old twin. A fix
is measured on the runs it was made for without running the whole study.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

from s3o_drake.experiments.recovery_summary import incomplete_cause


def chosen(jobs: Iterable, before: Mapping[str, Mapping], ended: Sequence[str] = ()) -> list:
    """The jobs whose run in `before` (rows by key) did not complete, or, with `ended`,
    whose ending (the row's `reason`) contains one of those words."""
    picked = []
    for job in jobs:
        row = before.get(job.key)
        if row is None or "error" in row:
            continue
        reason = str(row.get("reason", ""))
        if any(word in reason for word in ended) if ended else not row.get("complete"):
            picked.append(job)
    return picked


def _ending(row: Mapping) -> str:
    """How a run ended, in again.md's columns; the cause of a run that fell short is
    `recovery_summary.incomplete_cause`'s, so the two tables count the same runs alike."""
    if row.get("complete"):
        return "complete"
    cause = incomplete_cause(row)
    return {"no plan": "no plan", "blocked drive": "blocked"}.get(cause, "a dish not collected")


def comparison(before: Mapping[str, Mapping], after: Sequence[Mapping],
               methods: Sequence[str]) -> str:
    """Markdown: per method, the runs run again, how many completed before and now, the
    dishes collected, and how the new runs ended."""
    lines = ["| method | runs | complete before -> now | dishes collected before -> now "
             "| now ending: complete / a dish not collected / blocked / no plan |",
             "|---|---|---|---|---|"]
    for method in methods:
        pairs = [(before[r["key"]], r) for r in after
                 if r.get("method") == method and r["key"] in before and "error" not in r]
        if not pairs:
            continue
        ends = [_ending(r) for _, r in pairs]
        counts = " / ".join(str(ends.count(e)) for e in
                            ("complete", "a dish not collected", "blocked", "no plan"))
        lines.append(
            f"| {method} | {len(pairs)} | {sum(bool(o.get('complete')) for o, _ in pairs)} "
            f"-> {sum(bool(r.get('complete')) for _, r in pairs)} | "
            f"{sum(o.get('collected', 0) for o, _ in pairs)} -> "
            f"{sum(r.get('collected', 0) for _, r in pairs)} of "
            f"{sum(r.get('dishes', 0) for _, r in pairs)} | {counts} |")
    return "\n".join(lines) + "\n"
