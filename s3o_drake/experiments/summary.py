"""The study's tables and figures: per difficulty group and method, the completion rate, the
share of dishes collected, the execution time and the planning time.

Spread is over seeds, as in the paper: each seed gives a rate (or a mean time) over the
group's tasks; the table shows the mean of those and their standard deviation. Only
(task, seed) pairs that every compared method has finished count, so that a study cut
short compares the methods on the same tasks.

A run without a plan has no execution time: it counts as incomplete, stays out of every
time mean, and is listed. Time comparisons are made twice: on every pair where both runs
had a plan (failed runs end early, so these mix shorter work in), and on the pairs where
both runs collected every dish (the same work done). Every table names the commit its rows
were made at.
"""

import csv
import json
import math
from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy.stats import binomtest

from s3o_drake.experiments.difficulty import GROUPS, difficulty_groups
from s3o_drake.experiments.motion_summary import motion_table, time_by_motion_table
from s3o_drake.experiments.recovery_summary import recovery_figures, recovery_table
from s3o_drake.experiments.run_rows import code_of, has_time, predicted_completion
from s3o_drake.viz.study import plot_figure_five, plot_table

METHOD = "S3O-GROP*"
ABLATION = "S3O-Random"
PAPER_ABLATION = "S3O-Random-Paper"
"""The paper's ablation as its text describes it (one uniform draw); ABLATION is ours."""
TARGETS = {"easy": 0.9, "difficult": 0.8}
"""The issue's completion targets for S3O-GROP* (the paper reports 0.52 and 0.29)."""
PAPER_TABLE_I = {  # completion / execution time (s), mean ± spread over seeds
    "easy": ((0.52, 0.02, 107.90, 5.35), (0.30, 0.06, 96.95, 2.40)),
    "moderate": ((0.36, 0.03, 118.68, 2.78), (0.18, 0.08, 97.89, 4.22)),
    "difficult": ((0.29, 0.02, 131.25, 3.64), (0.17, 0.08, 102.85, 6.30)),
}
CSV_FIELDS = ("task", "layout", "group", "area", "method", "seed", "recovery", "dishes",
              "collected", "placed", "complete", "fraction", "execution_time", "planning_time",
              "stops", "finished", "reason", "error")


@dataclass(frozen=True)
class Cell:
    """One method in one difficulty group."""

    group: str
    method: str
    tasks: int  # distinct tasks
    runs: int
    seeds: int
    completion: float
    completion_std: float
    fraction: float
    fraction_std: float
    execution_time: float  # runs with a plan only
    execution_time_std: float
    planning_time: float  # median over runs
    no_plan: int = 0  # runs that made no plan: incomplete, no execution time
    predicted_completion: float = math.nan  # mean of `predicted_completion` over runs
    stops: float = math.nan  # mean stops of the runs with a plan


def comparable_runs(runs: Sequence[dict], methods: Sequence[str]) -> list[dict]:
    """The runs of (task, seed) pairs that every method has finished without error."""
    ok = [r for r in runs if "error" not in r]
    have = defaultdict(set)
    for r in ok:
        have[(r["task"], r["seed"])].add(r["method"])
    full = {pair for pair, ms in have.items() if set(methods) <= ms}
    return [r for r in ok if (r["task"], r["seed"]) in full and r["method"] in methods]


def _mean_std(values: list[float]) -> tuple[float, float]:
    if not values:
        return math.nan, math.nan
    std = float(np.std(values, ddof=1)) if len(values) > 1 else math.nan
    return float(np.mean(values)), std


def summarize(runs: Sequence[dict], groups: dict[str, str],
              methods: Sequence[str]) -> list[Cell]:
    """A Cell per group and method (groups in GROUPS order, methods in the given order)."""
    runs = [r for r in comparable_runs(runs, methods) if r["task"] in groups]
    cells = []
    for group in GROUPS:
        for method in methods:
            mine = [r for r in runs if groups[r["task"]] == group and r["method"] == method]
            by_seed = defaultdict(list)
            for r in mine:
                by_seed[r["seed"]].append(r)
            per_seed = [(np.mean([r["complete"] for r in rs]), np.mean([r["fraction"] for r in rs]))
                        for rs in by_seed.values()]
            completion = _mean_std([float(p[0]) for p in per_seed])
            fraction = _mean_std([float(p[1]) for p in per_seed])
            timed = [[r["execution_time"] for r in rs if has_time(r)] for rs in by_seed.values()]
            execution = _mean_std([float(np.mean(t)) for t in timed if t])
            planning = float(np.median([r["planning_time"] for r in mine])) if mine else math.nan
            stops = [r["stops"] for r in mine if has_time(r) and r.get("stops") is not None]
            cells.append(Cell(group, method, len({r["task"] for r in mine}), len(mine),
                              len(by_seed), *completion, *fraction, *execution, planning,
                              no_plan=sum(not has_time(r) for r in mine),
                              predicted_completion=float(np.mean(
                                  [predicted_completion(r) for r in mine])) if mine else math.nan,
                              stops=float(np.mean(stops)) if stops else math.nan))
    return cells


def _pm(mean: float, std: float, digits: int) -> str:
    if math.isnan(mean):
        return "–"
    return f"{mean:.{digits}f}" + ("" if math.isnan(std) else f" ± {std:.{digits}f}")


def _table_one_cell(c: Cell | None) -> str:
    """Completion rate / execution time, as Table I shows them."""
    if c is None:
        return "–"
    return (f"{_pm(c.completion, c.completion_std, 2)} / "
            f"{_pm(c.execution_time, c.execution_time_std, 1)}")


def claims(cells: Sequence[Cell]) -> list[tuple[str, bool | None]]:
    """The issue's targets and the paper's claims, each with whether it holds (None: no
    data)."""
    at = {(c.group, c.method): c for c in cells}
    out = []
    for group, target in TARGETS.items():
        c = at.get((group, METHOD))
        ok = None if c is None or math.isnan(c.completion) else c.completion >= target
        out.append((f"{METHOD} completion >= {target} on {group} tasks", ok))
    for group in GROUPS:
        mine = at.get((group, METHOD))
        others = [c for c in cells if c.group == group and c.method != METHOD]
        if mine is None or math.isnan(mine.completion) or not others:
            out.append((f"{METHOD} ahead of every baseline in completion ({group})", None))
            out.append((f"{METHOD} has the lowest execution time ({group})", None))
            continue
        out.append((f"{METHOD} ahead of every baseline in completion ({group})",
                    all(mine.completion > o.completion for o in others)))
        out.append((f"{METHOD} has the lowest execution time ({group})",
                    all(mine.execution_time < o.execution_time for o in others)))
    return out


@dataclass(frozen=True)
class TimeDifference:
    """Paired execution times, one method minus another, on some pairs of runs."""

    pairs: int
    mean: float  # s; nan without pairs
    low: float  # 95 % bootstrap interval of the mean, resampling pairs
    high: float
    relative: float  # mean / the other method's mean time
    relative_low: float
    relative_high: float

    def text(self) -> str:
        if not self.pairs:
            return "– (0 pairs)"
        return (f"{self.mean:+.1f} [{self.low:+.1f}, {self.high:+.1f}] s, "
                f"{100 * self.relative:+.1f} % [{100 * self.relative_low:+.1f}, "
                f"{100 * self.relative_high:+.1f}] ({self.pairs} pairs)")


TIME_DIFFERENCE_MEANING = (
    "A time difference is the mean, over the pairs, of one method's execution time minus "
    "the other's (s), and that mean over the other method's mean time (%): a ratio of "
    "means, not the mean of each pair's relative difference. Its 95 % intervals come from "
    "a bootstrap over the pairs.")
"""What `time_difference` computes, in words: every table that quotes it says so once."""


def time_difference(mine: Sequence[Mapping], theirs: Sequence[Mapping],
                    rng: np.random.Generator, resamples: int = 2000) -> TimeDifference:
    """The mean of mine's execution time minus theirs over the pairs given (runs with a
    plan), with bootstrap intervals of it and of its share of theirs: the mean difference
    over their mean time (TIME_DIFFERENCE_MEANING). A ratio of means weighs each pair by
    its time, as the total time saved does; the mean of each pair's ratio would weigh the
    short runs more."""
    a = np.array([r["execution_time"] for r in mine], dtype=float)
    b = np.array([r["execution_time"] for r in theirs], dtype=float)
    if len(a) == 0:
        return TimeDifference(0, *(math.nan,) * 6)
    picks = rng.integers(0, len(a), (resamples, len(a)))
    means = (a[picks] - b[picks]).mean(axis=1)
    ratios = means / b[picks].mean(axis=1)
    d = float((a - b).mean())
    return TimeDifference(len(a), d, *map(float, np.percentile(means, [2.5, 97.5])),
                          d / float(b.mean()), *map(float, np.percentile(ratios, [2.5, 97.5])))


@dataclass(frozen=True)
class StopsDifference:
    """Where a paired time difference comes from: the stops one method makes fewer than
    another, and what each costs, on the pairs where both collected every dish."""

    pairs: int
    fewer: float  # mean of the other's stops minus mine; nan without pairs
    same: int  # pairs where both made as many stops
    seconds_per_stop: float  # least-squares slope of the time difference on the stops
    #                          difference, in s per stop saved; nan when the stops never differ

    def text(self) -> str:
        if not self.pairs:
            return "– (0 pairs)"
        slope = "–" if math.isnan(self.seconds_per_stop) else f"{self.seconds_per_stop:.1f} s"
        return f"{self.fewer:+.2f} / {self.same} of {self.pairs} / {slope}"


def stops_difference(mine: Sequence[Mapping], theirs: Sequence[Mapping]) -> StopsDifference:
    """Stops saved per pair and the seconds each saves (`StopsDifference`); runs paired."""
    pairs = [(a, b) for a, b in zip(mine, theirs, strict=True)
             if a.get("stops") is not None and b.get("stops") is not None]
    if not pairs:
        return StopsDifference(0, math.nan, 0, math.nan)
    saved = np.array([b["stops"] - a["stops"] for a, b in pairs], dtype=float)
    gained = np.array([b["execution_time"] - a["execution_time"] for a, b in pairs],
                      dtype=float)
    slope = math.nan
    if np.ptp(saved) > 0:
        slope = float(np.polyfit(saved, gained, 1)[0])
    return StopsDifference(len(pairs), float(saved.mean()), int((saved == 0).sum()), slope)


@dataclass(frozen=True)
class Paired:
    """One method against another on the same (task, seed) pairs, all groups together."""

    baseline: str
    pairs: int
    wins: int  # the method completed the task and the baseline did not
    losses: int  # the other way round
    p_value: float  # exact two-sided sign test (McNemar) on wins against losses
    timed: TimeDifference  # pairs where both made a plan
    complete: TimeDifference  # pairs where both collected every dish
    method: str = METHOD
    stops: StopsDifference = StopsDifference(0, math.nan, 0, math.nan)  # on `complete`'s pairs

    @property
    def time_difference(self) -> float:
        return self.timed.mean


def paired_runs(method_runs: Sequence[Mapping], baseline_runs: Sequence[Mapping],
                baseline: str, *, method: str = METHOD, seed: int = 0) -> Paired:
    """`method_runs` against `baseline_runs`, paired by (task, seed): the sign test on the
    pairs that only one completes, and the time difference on the pairs with two plans and
    on those with two complete runs."""
    theirs = {(r["task"], r["seed"]): r for r in baseline_runs}
    pairs = [(r, theirs[(r["task"], r["seed"])]) for r in
             sorted(method_runs, key=lambda r: (r["task"], r["seed"]))
             if (r["task"], r["seed"]) in theirs]
    wins = sum(a["complete"] and not b["complete"] for a, b in pairs)
    losses = sum(b["complete"] and not a["complete"] for a, b in pairs)
    p_value = binomtest(wins, wins + losses, 0.5).pvalue if wins + losses else 1.0
    rng = np.random.default_rng(seed)
    timed = [(a, b) for a, b in pairs if has_time(a) and has_time(b)]
    done = [(a, b) for a, b in timed if a["complete"] and b["complete"]]
    return Paired(baseline, len(pairs), int(wins), int(losses), float(p_value),
                  time_difference([a for a, _ in timed], [b for _, b in timed], rng),
                  time_difference([a for a, _ in done], [b for _, b in done], rng),
                  method=method,
                  stops=stops_difference([a for a, _ in done], [b for _, b in done]))


def paired_comparison(runs: Sequence[dict], methods: Sequence[str],
                      seed: int = 0) -> list[Paired]:
    """Differences between methods of a few tasks in a group of ~30 are within chance; the
    paired view says whether S3O-GROP* wins the tasks it and a baseline disagree on more
    often than a coin would, and how much execution time it saves on the same tasks."""
    if METHOD not in methods:
        return []
    comparable = comparable_runs(runs, methods)
    mine = [r for r in comparable if r["method"] == METHOD]
    if not mine:
        return []
    return [paired_runs(mine, [r for r in comparable if r["method"] == baseline], baseline,
                        seed=seed)
            for baseline in methods if baseline != METHOD]


def paired_table(rows: Sequence[Paired]) -> str:
    """The paired comparison in Markdown."""
    method = rows[0].method if rows else METHOD
    lines = [f"| {method} against | pairs | completes, the other not | the other completes, "
             "it not | sign test p | execution time difference, both with a plan (95 % "
             "interval) | the same, both collected every dish | there: stops fewer / pairs "
             "with as many / s per stop saved |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r.baseline} | {r.pairs} | {r.wins} | {r.losses} | {r.p_value:.2f} | "
              f"{r.timed.text()} | {r.complete.text()} | {r.stops.text()} |" for r in rows]
    return "\n".join(lines) + "\n"


def other_measures_table(runs: Sequence[dict], dish_areas: Mapping[str, Mapping[str, float]],
                         methods: Sequence[str], groups: Mapping[str, str]) -> str:
    """Completion rate per method with the tasks split into thirds by other measures than
    the paper's total area (the smallest dish area, the mean area per dish) and by the
    number of dishes: a check of whether the paper's measure is what separates the hard
    tasks. `groups` is the paper's split, as the other tables use it. Pooled over seeds, on
    the comparable runs."""
    runs = [r for r in comparable_runs(runs, methods) if r["task"] in dish_areas]
    splits = {
        "paper's (total area)": groups,
        "smallest dish area": difficulty_groups(
            {t: min(a.values()) for t, a in dish_areas.items() if a}),
        "mean area per dish": difficulty_groups(
            {t: sum(a.values()) / len(a) for t, a in dish_areas.items() if a}),
        "number of dishes": {t: f"{len(a)} dishes" for t, a in dish_areas.items()},
    }
    lines = ["| split | group | tasks | " + " | ".join(methods) + " |",
             "|---|---|---|" + "---|" * len(methods)]
    for name, split in splits.items():
        present = set(split.values())
        for group in [g for g in GROUPS if g in present] + sorted(present - set(GROUPS)):
            mine = [r for r in runs if split.get(r["task"]) == group]
            rates = []
            for method in methods:
                done = [r["complete"] for r in mine if r["method"] == method]
                rates.append(f"{np.mean(done):.2f}" if done else "–")
            lines.append(f"| {name} | {group} | {len({r['task'] for r in mine})} | "
                         + " | ".join(rates) + " |")
    return "\n".join(lines) + "\n"


def markdown_tables(cells: Sequence[Cell], methods: Sequence[str]) -> str:
    """Fig. 5 as tables (completion, share of dishes, execution time, planning time) and
    Table I (S3O against S3O-Random), in Markdown."""
    at = {(c.group, c.method): c for c in cells}
    lines = []
    for title, fmt in (
            ("Task completion rate", lambda c: _pm(c.completion, c.completion_std, 2)),
            ("Predicted completion (the plan's product of Fea^m, mean)",
             lambda c: _pm(c.predicted_completion, math.nan, 2)),
            ("Share of dishes collected", lambda c: _pm(c.fraction, c.fraction_std, 2)),
            ("Execution time (s, simulated; runs with a plan)",
             lambda c: _pm(c.execution_time, c.execution_time_std, 1)),
            ("Stops (mean, runs with a plan)", lambda c: _pm(c.stops, math.nan, 2)),
            ("Planning time (s, median)", lambda c: _pm(c.planning_time, math.nan, 2))):
        lines += [f"**{title}**", "", "| group | " + " | ".join(methods) + " |",
                  "|---|" + "---|" * len(methods)]
        for group in GROUPS:
            lines.append(f"| {group} | " + " | ".join(fmt(at[(group, m)]) for m in methods)
                         + " |")
        lines.append("")
    lines.append("Runs per cell (tasks x seeds): " + ", ".join(
        f"{g} {at[(g, methods[0])].tasks} x {at[(g, methods[0])].seeds}" for g in GROUPS))
    no_plan = {m: sum(at[(g, m)].no_plan for g in GROUPS) for m in methods}
    if any(no_plan.values()):
        lines.append("Runs without a plan (counted incomplete, left out of the times): "
                     + ", ".join(f"{m} {n}" for m, n in no_plan.items() if n))
    lines.append("")
    lines.append(table_one(cells))
    return "\n".join(lines)


def _table_one_methods(cells: Sequence[Cell]) -> list[tuple[str, int]]:
    """Table I's columns: S3O(-GROP*), then the ablations the runs have (the paper's first),
    each with the index of the paper's column it sits beside."""
    present = {c.method for c in cells if c.tasks}
    ablations = [m for m in (PAPER_ABLATION, ABLATION) if m in present] or [ABLATION]
    return [(METHOD, 0), *((m, 1) for m in ablations)]


def table_one(cells: Sequence[Cell]) -> str:
    """Table I: completion rate / execution time of S3O(-GROP*) and S3O-Random (the
    paper's one draw and ours, where run) per group, beside the paper's figures."""
    at = {(c.group, c.method): c for c in cells}
    columns = _table_one_methods(cells)
    lines = ["**Table I** (completion rate / execution time in s; paper's figures in brackets)",
             "", "| difficulty | " + " | ".join(
                 f"S3O ({m})" if m == METHOD else m for m, _ in columns) + " |",
             "|---|" + "---|" * len(columns)]
    for group in GROUPS:
        row = [group]
        for method, i in columns:
            c = at.get((group, method))
            paper = PAPER_TABLE_I[group][i]
            row.append(f"{_table_one_cell(c)} [{paper[0]:.2f} ± {paper[1]:.2f} / "
                       f"{paper[2]:.1f} ± {paper[3]:.1f}]")
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def failure_table(runs: Sequence[dict], methods: Sequence[str]) -> str:
    """Why dishes were not collected, per method: failed actions by reason, and dishes the
    plan left out (unreachable by its model), over the runs that record their outcomes."""
    counts = {m: defaultdict(int) for m in methods}
    for r in runs:
        if "error" in r or r.get("method") not in counts or "outcomes" not in r:
            continue
        mine = counts[r["method"]]
        mine["runs"] += 1
        for outcome in r["outcomes"]:
            _, _, result = outcome.partition(": ")
            if result.startswith("failed"):
                mine[outcome.split(" ", 1)[0] + " " + result] += 1
        # Distinct dishes: with recovery a dish's retries are pickups of their own.
        planned = len({o.split(":", 1)[0] for o in r["outcomes"] if o.startswith("pickup ")})
        mine["not planned or not reached"] += r["dishes"] - planned
    reasons = sorted({k for c in counts.values() for k in c if k != "runs"})
    lines = ["| reason | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods),
             "| runs | " + " | ".join(str(counts[m]["runs"]) for m in methods) + " |"]
    lines += [f"| {reason} | " + " | ".join(str(counts[m][reason]) for m in methods) + " |"
              for reason in reasons]
    return "\n".join(lines) + "\n"


def placement_table(runs: Sequence[dict], methods: Sequence[str]) -> str:
    """The objects to place, per method: how many, how many stand at their places (within
    the tolerance, upright, on the place's surface), how many were put down elsewhere, and
    the horizontal error of those put down (median and largest, cm)."""
    rows = {m: [p for r in runs if r.get("method") == m and "error" not in r
                for p in r.get("placements", ())] for m in methods}
    lines = ["| method | objects to place | placed | put down off the place | not put "
             "down | error, median / max (cm) |", "|---|---|---|---|---|---|"]
    for m in methods:
        mine = rows[m]
        put = [p for p in mine if p["state"] == "placed"]
        errors = sorted(100 * p["error"] for p in put)
        spread = (f"{float(np.median(errors)):.1f} / {errors[-1]:.1f}" if errors else "–")
        placed = sum(p["placed"] for p in mine)
        lines.append(f"| {m} | {len(mine)} | {placed} | {len(put) - placed} | "
                     f"{len(mine) - len(put)} | {spread} |")
    return "\n".join(lines) + "\n"


def write_outputs(out: Path, runs: Sequence[dict], areas: dict[str, float],
                  groups: dict[str, str], methods: Sequence[str], settings: dict,
                  dish_areas: Mapping[str, Mapping[str, float]] | None = None,
                  open_loop: Sequence[dict] = ()) -> list[Path]:
    """results.csv (one row per run), results.json (settings, groups, the cells, the runs),
    figure5.png, table1.png and summary.md; returns the paths written. `open_loop`: the
    same runs without recovery, for the recovery section."""
    cells = summarize(runs, groups, methods)
    paired = paired_comparison(runs, methods)
    written = []
    path = out / "results.csv"
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=CSV_FIELDS, extrasaction="ignore")
        writer.writeheader()
        for r in sorted(runs, key=lambda r: (r["task"], r["method"], r["seed"])):
            writer.writerow({**r, "group": groups.get(r["task"], ""),
                             "area": areas.get(r["task"], "")})
    written.append(path)
    path = out / "results.json"
    path.write_text(json.dumps({
        "settings": settings, "areas": areas, "groups": groups,
        "cells": [asdict(c) for c in cells],
        "claims": [{"claim": text, "holds": ok} for text, ok in claims(cells)],
        "paired": [asdict(p) for p in paired],
        "runs": sorted(runs, key=lambda r: (r["task"], r["method"], r["seed"]))},
        indent=1, default=float))
    written.append(path)
    plot_figure_five(cells, methods, GROUPS, out / "figure5.png")
    written.append(out / "figure5.png")
    if METHOD in methods:  # the ablations' columns say "–" where they were not run
        at = {(c.group, c.method): c for c in cells}
        columns = [m for m, _ in _table_one_methods(cells)]
        plot_table([[g.capitalize(), *(_table_one_cell(at.get((g, m))) for m in columns)]
                    for g in GROUPS],
                   ["Task difficulty", *("S3O" if m == METHOD else m for m in columns)],
                   "Table I: task completion rate / execution time (s)", out / "table1.png")
        written.append(out / "table1.png")
    code = code_of(runs)
    lines = ["# Benchmark summary", "",
             f"Every table below: {len(runs)} runs made at {code}"
             + (" (a comparison across commits)" if "," in code else "") + ".", "",
             markdown_tables(cells, methods), "**Claims**", ""]
    for text, ok in claims(cells):
        lines.append(f"- {text}: " + {True: "holds", False: "does NOT hold",
                                       None: "no data"}[ok])
    if paired:
        lines += ["", f"**Paired comparison** ({METHOD} against each method on the same "
                  "tasks and seeds, all groups). " + TIME_DIFFERENCE_MEANING, "",
                  paired_table(paired)]
    if dish_areas:
        lines += ["", "**Other splits of the tasks** (completion rate; does the paper's "
                  "measure separate the hard tasks?)", "",
                  other_measures_table(runs, dish_areas, methods, groups)]
    if dish_areas and any("recoveries" in r for r in runs):
        lines += ["", "**Recovery** (recoveries by kind and their cost; dishes the Drake "
                  "oracle can pick from some free pose against those collected)", "",
                  recovery_table(recovery_figures(runs, methods, dish_areas, open_loop))]
    if any(r.get("placements") for r in runs):
        lines += ["", "**Objects to place** (where each stands at the end of its run; "
                  "completion counts an object at its place as done)", "",
                  placement_table(runs, methods)]
    lines += ["", "**How the robot moved** (per method and motion: the closest approach to "
              "the true world, measured in the simulation; the plan's predicted time against "
              "the simulated one on the runs that collected every dish; each stop's landing "
              "against the stop as planned, at its first pickup)", "",
              motion_table(runs, methods)]
    by_motion = time_by_motion_table(runs, methods)
    if by_motion:
        lines += ["", "**Where the time went** (mean seconds of a complete run: the base "
                  "driving with the arm still, turning in place, the base and the arm moving "
                  "together, the arm alone, neither moving)", "", by_motion]
    lines += ["", "**Why dishes were not collected** (failed actions by reason; dishes that "
              "no pickup was planned for or that a failed goto left behind)", "",
              failure_table(runs, methods)]
    without = [r for r in runs if "error" not in r and not has_time(r)]
    if without:
        lines += ["", f"**{len(without)} runs without a plan** (incomplete; no execution time):"]
        lines += [f"- {r['task']} {r['method']} seed {r['seed']}: {r.get('reason', '')}"
                  for r in sorted(without, key=lambda r: (r["method"], r["task"], r["seed"]))]
    errors = [r for r in runs if "error" in r]
    if errors:
        lines += ["", f"**{len(errors)} runs ended in an error** (not counted above):"]
        lines += [f"- {r['task']} {r['method']} seed {r['seed']}: {r['error']}"
                  for r in errors[:20]]
    path = out / "summary.md"
    path.write_text("\n".join(lines) + "\n")
    written.append(path)
    return written
