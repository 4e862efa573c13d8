"""The rows and the summary of `s3o bench limit`: each task's plans with the rations lifted
one at a time and all together (the reference), judged on one model, and its lower bound
(`experiments.limit`). A plan's utility is rated by the Fea^m it was made with; rows
"pickups:NAME" (plans made again, each pickup's own and judged Fea^m) rate it on the judging
model too."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from s3o_drake.experiments.limit import RATIONS, judged_completion, lower_bound
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.planning.pipeline import PlanningResult
from s3o_drake.world.scenario import Scenario

COMPLETION_TOLERANCE = 0.005
"""A plan's judged completion at most this below the reference's counts as equal."""


def lifted_by(configuration: str) -> tuple[str, ...]:
    """The rations a configuration lifts: none ("default"), one (its name), or all
    ("reference")."""
    if configuration == "default":
        return ()
    if configuration == "reference":
        return RATIONS
    if configuration not in RATIONS:
        raise ValueError(f"unknown configuration {configuration!r}")
    return (configuration,)


def bound_row(scenario: Scenario, truth: Sequence[Heatmap]) -> dict[str, Any]:
    """The task's lower bound on a complete execution's time, and its parts."""
    bound = lower_bound(scenario, truth)
    return {"bound_s": bound.total, "tour_m": bound.tour_length,
            "drive_s": bound.drive_time, "hand_s": bound.hand_time, "arm_s": bound.arm_time}


def plan_row(result: PlanningResult, truth: Sequence[Heatmap]) -> dict[str, Any]:
    """One plan's figures (`plan_rationed`'s result): its utility and predicted time, its
    completion by its own Fea^m and judged by the true world's (`truth`), its stops and
    how long it took."""
    plan = result.plan
    if plan is None:
        return {"planned": False, "error": result.error}
    own = 0.0 if plan.unreachable else float(np.prod(
        [a.feasibility for a in (*plan.pickups, *plan.places)]))
    return {"planned": True, "utility": plan.utility, "predicted_time": plan.predicted_time,
            "planned_completion": own, "judged_completion": judged_completion(plan, truth),
            "stops": len(plan.gotos), "unreachable": list(plan.unreachable),
            "order_optimal": None if plan.order is None else plan.order.optimal,
            "planning_s": plan.planning_time}


def executed_row(scenario: Scenario, result: PlanningResult, *, study_seed: int
                 ) -> dict[str, Any]:
    """The plan of `result` executed in the simulation, open loop, with the noise of the
    study seed `study_seed` (each task's own draws, as `s3o evaluate` draws them): whether
    every dish was collected, and in what simulated time."""
    from s3o_drake.execution.execute import execute
    from s3o_drake.experiments.jobs import as_benchmarked, run_seed
    from s3o_drake.planning.pipeline import plan_from

    given = [result]

    def first_this_plan(known, **kwargs) -> PlanningResult:
        # The plan under test at initialization; a later plan (none in open loop) as usual.
        return given.pop() if given else plan_from(known, **kwargs)

    run = execute(as_benchmarked(scenario, "none"), seed=run_seed(scenario.seed, study_seed),
                  meshcat=None, progress=False, plan_from=first_this_plan)
    report = run.report
    return {"study_seed": study_seed, "complete": report["completed"] == report["dishes"],
            "collected": report["collected"], "dishes": report["dishes"],
            "execution_time": report["execution_time"],
            "predicted_time": None if result.plan is None else result.plan.predicted_time}


def gaps(rows: Sequence[dict[str, Any]], configuration: str) -> list[dict[str, Any]]:
    """Per task where both planned (`task`), `configuration`'s plan against the
    reference's: the relative gap in predicted time, and the gaps in judged completion and
    utility (each plan's own, by the Fea^m it was made with); `level`: whether the
    reference's judged completion is at least the plan's less COMPLETION_TOLERANCE,
    `strict`: at least the plan's."""
    by = {(r["task"], r["configuration"]): r for r in rows}
    out = []
    for (task, name), row in by.items():
        reference = by.get((task, "reference"))
        if name != configuration or reference is None or not (
                row.get("planned") and reference.get("planned")):
            continue
        out.append({
            "task": task,
            "time": row["predicted_time"] / reference["predicted_time"] - 1.0,
            "completion": row["judged_completion"] - reference["judged_completion"],
            "utility": row["utility"] - reference["utility"],
            "level": reference["judged_completion"] >= row["judged_completion"]
            - COMPLETION_TOLERANCE,
            "strict": reference["judged_completion"] >= row["judged_completion"]})
    return out


def closed_share(default_gap: float, gap: float) -> float:
    """The share of the default's gap to the reference that a configuration closes,
    (default_gap - gap) / default_gap, whatever the gap's sign; nan when the default has
    none. Taken on the medians the summary prints, as a reader takes it from them."""
    if default_gap == 0:
        return float("nan")
    return (default_gap - gap) / default_gap + 0.0  # equal gaps give 0, not -0


SAME_UTILITY = 0.01
"""A plan made again within this of the study's utility, with every pickup's stop in the same
cell of the judging maps, is the study's plan (`same_plan`): the last digits of a cost can
differ between runs."""


def utility_by_truth(again: dict[str, Any]) -> float:
    """The utility of a plan made again (a "pickups:NAME" row) with each pickup's own Fea^m
    replaced by the true world's at its stop, at the reward λ its utility gives a unit of
    a pickup's Fea^m (`reward`): the plans of the limit study (dc6683e) count λ Fea^m per
    pickup, where later code rates a shared stop's pickups at a share of it."""
    return again["utility"] + again["reward"] * sum(
        p["judged"] - p["own"] for p in again["pickups"])


def judged_utility(row: dict[str, Any], again: dict[str, Any] | None) -> float | None:
    """The utility on the judging model of a configuration's plan for a task, so that plans
    made on different models compare: from its "pickups:NAME" row (`again`) when there is
    one (`utility_by_truth`); a plan made on the oracle's Fea^m (`row`) keeps its own
    utility: with the true chairs that is the judging model, with the perceived ones the
    oracle's on those (`model_lines` says how close). None otherwise."""
    if again is not None:
        return utility_by_truth(again) if again.get("planned", True) else None
    if "oracle" in lifted_by(row["configuration"]):
        return row["utility"]
    return None


def same_plan(row: dict[str, Any], pickups: dict[str, Any]) -> bool:
    """Whether the plan of a "pickups:NAME" row is the study's plan of `row`: its utility
    within SAME_UTILITY and its pickups' judged Fea^m the row's judged completion. The
    planner's limits are wall-clock, so a plan made again can be another."""
    if not (pickups.get("planned", True) and row.get("planned")):
        return False
    judged = math.prod(p["judged"] for p in pickups["pickups"])
    return (abs(pickups["utility"] - row["utility"]) <= SAME_UTILITY
            and math.isclose(judged, row["judged_completion"], rel_tol=0.0, abs_tol=1e-9))


def judged_utility_gaps(rows: Sequence[dict[str, Any]], configuration: str
                        ) -> list[dict[str, Any]]:
    """Per task where both are known (`judged_utility`), `configuration`'s plan against the
    reference's: `utility`, the gap in utility on the judging model; `own`, the gap in the
    compared plan's own utility; `same`, whether it is the study's plan (`same_plan`; a
    plan not made again is)."""
    by = {(r["task"], r["configuration"]): r for r in rows}
    out = []
    for (task, name), row in by.items():
        reference = by.get((task, "reference"))
        if name != configuration or reference is None or not (
                row.get("planned") and reference.get("planned")):
            continue
        again = by.get((task, f"pickups:{name}"))
        mine = judged_utility(row, again)
        theirs = judged_utility(reference, by.get((task, "pickups:reference")))
        if mine is not None and theirs is not None:
            own = row["utility"] if again is None else again["utility"]
            out.append({"task": task, "utility": mine - theirs,
                        "own": own - reference["utility"],
                        "same": again is None or same_plan(row, again)})
    return out


def _median(values: Sequence[float]) -> float:
    return float(np.median(values)) if len(values) else float("nan")


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per configuration, the median gaps to the reference; what share of the default's
    gap in time and in utility lifting that ration alone closes; how far each plan's own
    Fea^m stands from the judging model's at its stops; with "pickups:NAME" rows, the gaps
    in utility on the judging model and the default's pickups; then the executed plans
    and the reference against the bound."""
    lines = ["gap to the reference plan, median over tasks (time: predicted, relative; "
             "completion: judged by the true world's Fea^m; utility: the plan's own, by the "
             "Fea^m it was made with)"]
    found = {c: g for c in ("default", *RATIONS) if (g := gaps(rows, c))}
    medians = {c: {k: _median([x[k] for x in g]) for k in ("time", "completion", "utility")}
               for c, g in found.items()}
    for configuration, g in found.items():
        level = [x["time"] for x in g if x["level"]]
        strict = [x["time"] for x in g if x["strict"]]
        m = medians[configuration]
        lines.append(
            f"  {configuration:<15} time {m['time']:+.1%} ({len(g)} tasks), completion "
            f"{m['completion']:+.3f}, utility {m['utility']:+.2f}; time where the "
            f"reference completes at least as often: {_median(level):+.1%} ({len(level)} "
            f"tasks, within {COMPLETION_TOLERANCE}), {_median(strict):+.1%} ({len(strict)}, "
            f"strictly)")
    if "default" in medians and len(found) > 1:
        lines.append("share of the default's median gap that lifting the ration alone "
                     "closes, (default - ration) / default:")
        for configuration in found:
            if configuration != "default":
                shares = {k: closed_share(medians["default"][k], medians[configuration][k])
                          for k in ("time", "utility")}
                lines.append(f"  {configuration:<15} of the time gap {shares['time']:.0%}, "
                             f"of the utility gap {shares['utility']:.0%}")
    lines += model_lines(rows)
    lines += judged_utility_lines(rows, medians)
    by = {(r["task"], r["configuration"]): r for r in rows}
    lines += executed_lines(rows)
    ratios = [by[(t, "reference")]["predicted_time"] / r["bound_s"]
              for (t, c), r in by.items() if c == "bound" and (t, "reference") in by
              and by[(t, "reference")].get("planned") and r["bound_s"] > 0]
    if ratios:
        below = sum(x < 1.0 for x in ratios)
        lines.append(f"reference plan's predicted time / lower bound: median "
                     f"{float(np.median(ratios)):.2f} ({len(ratios)} tasks, {below} below "
                     f"the bound)")
    return lines


MODEL_OFF = 0.05
"""A plan's own completion this far from its judged one counts as off (`model_lines`)."""


def model_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per configuration, how far each plan's completion by its own Fea^m (the product the
    utility was maximised with) stands from its judged completion at the same stops: the
    utility gaps compare plans rated by different models where these differ."""
    lines = []
    for configuration in ("default", *RATIONS, "reference"):
        off = [r["planned_completion"] - r["judged_completion"] for r in rows
               if r["configuration"] == configuration and r.get("planned")
               and "planned_completion" in r]
        if not off:
            continue
        q25, q75 = np.quantile(off, [0.25, 0.75])
        lines.append(
            f"  {configuration:<15} {_median(off):+.3f} [{q25:+.3f}, {q75:+.3f}], "
            f"{sum(x > MODEL_OFF for x in off)} above, {sum(x < -MODEL_OFF for x in off)} "
            f"below, largest {max(off, key=abs):+.3f} ({len(off)} plans)")
    if lines:
        lines.insert(0, f"own completion minus judged, at the plan's stops: median "
                        f"[quartiles], plans off by more than {MODEL_OFF} either way, the "
                        f"largest")
    return lines


def judged_utility_lines(rows: Sequence[dict[str, Any]],
                         medians: dict[str, dict[str, float]]) -> list[str]:
    """With "pickups:NAME" rows (plans made again, each pickup's own and judged Fea^m): each
    configuration's median gap in utility on the judging model (`judged_utility`) beside
    its own, the share of the default's it closes; then the default's pickups, the
    network's Fea^m against the true world's at the stops its plans chose, what that
    misstates of each plan's utility, and what the oracle's ration gains per task on the
    judging model."""
    if not any(r["configuration"].startswith("pickups:") for r in rows):
        return []
    lines = ["utility on the judging model (each pickup at the true world's Fea^m at its "
             "stop; plans made again: rows \"pickups:NAME\"), gap to the reference, median:"]
    judged = {c: g for c in ("default", *RATIONS)
              if (g := judged_utility_gaps(rows, c)) and len(g) == len(gaps(rows, c))}
    median = {c: _median([x["utility"] for x in g]) for c, g in judged.items()}
    for configuration, g in judged.items():
        share = ("" if configuration == "default" or "default" not in judged else
                 f", closes {closed_share(median['default'], median[configuration]):.0%} "
                 f"of the default's")
        made_again = any(r["configuration"] == f"pickups:{configuration}" for r in rows)
        how = (f"by their own Fea^m {_median([x['own'] for x in g]):+.2f}, the study's "
               f"{medians[configuration]['utility']:+.2f}; {sum(x['same'] for x in g)} of "
               f"the {len(g)} plans made again are the study's" if made_again else
               "its own, made on the oracle's Fea^m" + (
                   " with the perceived chairs"
                   if "true_chairs" not in lifted_by(configuration) else ""))
        lines.append(f"  {configuration:<15} {median[configuration]:+.2f} ({len(g)} tasks; "
                     f"{how}){share}")
    again = [r for r in rows if r["configuration"] == "pickups:default"
             and r.get("planned", True)]
    if again:
        off = np.array([p["own"] - p["judged"] for r in again for p in r["pickups"]])
        misstated = [r["utility"] - utility_by_truth(r) for r in again]
        lines.append(
            f"the default plans' {len(off)} pickups, the network's Fea^m minus the true "
            f"world's at the stop chosen: median {np.median(off):+.3f}, mean "
            f"{off.mean():+.3f}, mean |.| {np.abs(off).mean():.3f}; "
            f"{int((off > MODEL_OFF).sum())} above by more than {MODEL_OFF}, "
            f"{int((off < -MODEL_OFF).sum())} below")
        lines.append(
            f"  per plan, λ x their sum, its own utility less the judged: median "
            f"{_median(misstated):+.2f}, mean {float(np.mean(misstated)):+.2f} "
            f"({len(misstated)} plans)")
        by = {(r["task"], r["configuration"]): r for r in rows}
        gained, over = [], []
        for r in again:
            oracle = by.get((r["task"], "oracle"))
            theirs = None if oracle is None or not oracle.get("planned") else \
                judged_utility(oracle, by.get((r["task"], "pickups:oracle")))
            if theirs is not None:
                gained.append(theirs - utility_by_truth(r))
                over.append(any(p["own"] - p["judged"] > MODEL_OFF for p in r["pickups"]))
        if gained:
            gain, split = np.array(gained), np.array(over)
            lines.append(
                f"  per task, the oracle's plan's utility less the default's, on the judging "
                f"model: median {_median(gained):+.2f}, mean {gain.mean():+.2f} "
                f"({len(gained)} tasks); mean {_mean(gain[split]):+.2f} on the "
                f"{int(split.sum())} where the network rates a pickup of the default plan "
                f"more than {MODEL_OFF} above the true world, {_mean(gain[~split]):+.2f} on "
                f"the others")
    return lines


def _mean(values: np.ndarray) -> float:
    return float(np.mean(values)) if len(values) else float("nan")


def executed_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """The default's and the reference's plans executed (rows "executed:NAME:SEED"): their
    completion rates, and the median relative gap in mean execution time on the tasks
    where both completed at least once; with the predicted gap on the same tasks beside
    it, and how many complete runs fell below their task's bound (none may)."""
    runs: dict[tuple[str, str], list[dict]] = {}
    bounds = {r["task"]: r["bound_s"] for r in rows if r["configuration"] == "bound"}
    for r in rows:
        if r["configuration"].startswith("executed:"):
            runs.setdefault((r["task"], r["configuration"].split(":")[1]), []).append(r)
    if not runs:
        return []
    lines = ["executed, open loop, with noise:"]
    for name in ("default", "reference"):
        mine = [r for (t, n), rs in runs.items() if n == name for r in rs]
        if mine:
            lines.append(f"  {name:<15} completion {np.mean([r['complete'] for r in mine]):.2f} "
                         f"({len(mine)} runs)")
    executed, predicted = [], []
    for (task, name), rs in runs.items():
        other = runs.get((task, "reference"))
        if name != "default" or other is None:
            continue
        mine = [r["execution_time"] for r in rs if r["complete"]]
        theirs = [r["execution_time"] for r in other if r["complete"]]
        if mine and theirs:
            executed.append(np.mean(mine) / np.mean(theirs) - 1.0)
            predicted.append(rs[0]["predicted_time"] / other[0]["predicted_time"] - 1.0)
    if executed:
        lines.append(f"  default against the reference: time {np.median(executed):+.1%} "
                     f"executed, {np.median(predicted):+.1%} predicted (median of "
                     f"{len(executed)} tasks where both completed)")
    below = sum(r["complete"] and r["execution_time"] < bounds.get(t, 0.0)
                for (t, _), rs in runs.items() for r in rs)
    lines.append(f"  complete runs below their task's bound: {below}")
    return lines


def by_room(rows: Sequence[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    """The rows per room: the folder of the task's file (generated, generated_dense, ...)."""
    rooms: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        rooms.setdefault(Path(r["task"]).parent.name, []).append(r)
    return rooms


def gaps_by_room(rows: Sequence[dict[str, Any]]) -> dict[str, dict[str, list[dict]]]:
    """`gaps` of every configuration but the reference, per room (`by_room`)."""
    return {room: {c: found for c in ("default", *RATIONS) if (found := gaps(mine, c))}
            for room, mine in by_room(rows).items()}
