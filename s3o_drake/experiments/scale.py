"""The figures of the scale benchmark (`s3o bench scale`): for
one planned task, the planning time by stage, and for every state space that clingo
ordered, its order against the exact optimum of the same ordering problem on the same
costs (`planning.exact_order`); over the tasks of each size, the medians, the worst cases
and the targets of issue 22 (docs/planning.md).
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Sequence
from typing import Any

from s3o_drake.planning.result import PlanningResult
from s3o_drake.planning.task.exact_order import exact_order
from s3o_drake.planning.task.problem import TaskPlanResult
from s3o_drake.planning.task.visit_order import visit_matrix, visits_only

STAGES = ("feasibility", "navigation", "abstraction", "task_planning", "motion_search")
TASK_TARGET = 2.0
"""Task planning of one state space at most this long (s), at 30 dishes and more."""
ORDER_TARGET = 0.02
"""Every state space's best order within this share above the exact optimum."""
PLAN_TARGET = 5.0
"""The whole plan (median over the tasks of a size, Fea^m included) at most this long (s)."""
TARGET_SIZES = 30
"""The targets hold from this many dishes on."""


def state_space_row(groups: Sequence[Sequence[str]], task: TaskPlanResult, *,
                    reference_limit: float) -> dict[str, Any]:
    """One state space that clingo ordered: its locations, clingo's time and best order,
    what it proved, the cost of local search's order that it started from ("hint"), and
    the exact optimum of the same problem (None where the problem is not a visiting
    order: capacity, depot or places)."""
    row: dict[str, Any] = {
        "locations": len(groups), "task_s": task.elapsed, "cost": task.best.cost,
        "proven": task.best.optimal, "bound": task.lower_bound, "found": len(task.plans),
        "asked": task.asked, "hint": task.stats.get("hint"), "reference": None,
        "reference_s": None, "above": None}
    problem = task.problem
    if problem is None or not visits_only(problem):
        return row
    _, costs = visit_matrix(problem, task.unreachable)
    t = time.perf_counter()
    try:
        _, optimum = exact_order(costs, time_limit=reference_limit)
    except TimeoutError:
        return row
    row.update(reference=optimum, reference_s=time.perf_counter() - t,
               above=task.best.cost / optimum - 1.0 if optimum > 0 else 0.0)
    return row


def plan_row(result: PlanningResult, *, reference_limit: float = 120.0) -> dict[str, Any]:
    """The planning figures of one task: the plan's time by stage, its stops and order,
    and a row per state space (`state_space_row`); "error" when there is no plan."""
    plan = result.plan
    if plan is None:
        return {"error": result.error, "planning_s": result.planning_time}
    spaces = [state_space_row(g, t, reference_limit=reference_limit)
              for g, t in result.task_plans]
    chosen = next((s for (g, _), s in zip(result.task_plans, spaces, strict=True)
                   if tuple(map(tuple, g)) == tuple(map(tuple, plan.groups))), None)
    above = None
    if plan.order is not None and chosen is not None and chosen["reference"]:
        above = plan.order.cost / chosen["reference"] - 1.0
    return {
        "planning_s": plan.planning_time,
        "timing": {k: float(plan.timing.get(k, 0.0)) for k in STAGES},
        "complete": plan.complete, "stops": len(plan.gotos),
        "locations": len(plan.groups), "unreachable": list(plan.unreachable),
        "order_cost": None if plan.order is None else plan.order.cost,
        "order_above": above,
        "state_spaces": spaces,
    }


def _median(values: Sequence[float]) -> float:
    return statistics.median(values) if values else math.nan


def _max(values: Sequence[float]) -> float:
    return max(values) if values else math.nan


def summarize(rows: Sequence[dict[str, Any]]) -> dict[int, dict[str, Any]]:
    """Per dish count: tasks, plans, median plan time and stages, the slowest task
    planning of one state space, the median and worst order above the optimum, the share
    of orders proven, executed completion (where executed), and whether the targets hold
    (from TARGET_SIZES dishes on; None below)."""
    out: dict[int, dict[str, Any]] = {}
    for size in sorted({r["dishes"] for r in rows}):
        these = [r for r in rows if r["dishes"] == size]
        ok = [r for r in these if "error" not in r]
        spaces = [s for r in ok for s in r["state_spaces"]]
        above = [s["above"] for s in spaces if s["above"] is not None]
        task_s = [s["task_s"] for s in spaces]
        ran = [r for r in these if "collected" in r]
        summary = {
            "tasks": len(these), "planned": len(ok),
            "plan_s": _median([r["planning_s"] for r in ok]),
            "stages": {k: _median([r["timing"][k] for r in ok]) for k in STAGES},
            "state_spaces": len(spaces),
            "locations": _median([s["locations"] for s in spaces]),
            "task_s_median": _median(task_s), "task_s_max": _max(task_s),
            "above_median": _median(above), "above_max": _max(above),
            "proven": sum(s["proven"] for s in spaces) / len(spaces) if spaces else math.nan,
            "reference_s": _median([s["reference_s"] for s in spaces
                                    if s["reference_s"] is not None]),
            "executed": len(ran),
            "completion": (sum(r["collected"] for r in ran) / sum(r["dishes"] for r in ran)
                           if ran else math.nan),
        }
        if size >= TARGET_SIZES and ok:
            summary["targets"] = {
                "task_s": summary["task_s_max"] <= TASK_TARGET,
                "order": len(above) == len(spaces) and summary["above_max"] <= ORDER_TARGET,
                "plan_s": summary["plan_s"] <= PLAN_TARGET,
            }
        out[size] = summary
    return out


def _f(value: float, spec: str) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) \
        else format(value, spec)


def summary_table(summary: dict[int, dict[str, Any]]) -> str:
    """The per-size summary as a Markdown table (what docs/planning.md shows)."""
    lines = ["| dishes | tasks planned | plan s (median) | feasibility | navigation | "
             "abstraction | task planning | motion search | locations (median) | "
             "clingo s per state space (median / max) | orders proven | "
             "order above optimum (median / max) | exact s (median) | completion |",
             "|" + "---|" * 14]
    for size, s in summary.items():
        st = s["stages"]
        done = (f"{s['completion']:.2f} ({s['executed']} run)" if s["executed"]
                else "not executed")
        lines.append(
            f"| {size} | {s['planned']}/{s['tasks']} | {_f(s['plan_s'], '.2f')} | "
            + " | ".join(_f(st[k], ".2f") for k in STAGES)
            + f" | {_f(s['locations'], '.0f')} | {_f(s['task_s_median'], '.2f')} / "
            f"{_f(s['task_s_max'], '.2f')} | {_f(s['proven'], '.0%')} | "
            f"{_f(s['above_median'], '.2%')} / {_f(s['above_max'], '.2%')} | "
            f"{_f(s['reference_s'], '.2f')} | {done} |")
    return "\n".join(lines)


def target_lines(summary: dict[int, dict[str, Any]]) -> list[str]:
    """One line per size with targets: each target, held or not."""
    names = {"task_s": f"task planning <= {TASK_TARGET:g} s per state space",
             "order": f"orders within {ORDER_TARGET:.0%} of the optimum",
             "plan_s": f"whole plan <= {PLAN_TARGET:g} s (median)"}
    return [f"{size} dishes: " + "; ".join(
        f"{names[k]}: {'holds' if held else 'MISSED'}" for k, held in s["targets"].items())
        for size, s in summary.items() if "targets" in s]
