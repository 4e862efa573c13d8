"""What recovery did in a study's runs (`evaluate --recovery retry|replan`): the table of
summary.md's recovery section.

Per method, over the runs that finished without an error: the recoveries by kind, their
simulated cost per run, the replans' planning time, the dishes the Drake oracle can pick
from some free pose of the true world (the task's per-dish pickable area from the
difficulty measure is positive) against those collected, and the runs that ended before
their plan did (a blocked drive past the replan limit, no plan, the time limit or a failed
simulation): with recovery none of these should remain while something could be tried.
The runs that did not collect every dish are counted by their cause (`incomplete_cause`).

Given the same runs in open loop (`open_loop`: the same tasks, methods and run seeds, with
`--recovery none`), it also sets each run against its open-loop twin: completion, the mean
execution time of both, and the time recovery adds where both runs collected every dish
(there the two did the same work, so the difference is what the recoveries cost).
"""

from collections import defaultdict
from collections.abc import Mapping, Sequence

from s3o_drake.execution.messages import ran_to_end
from s3o_drake.experiments.run_rows import code_of, has_time

KINDS = ("correction", "retry", "replan", "give_up")
PLURALS = {"correction": "corrections", "retry": "retries", "replan": "replans",
           "give_up": "dishes given up"}
#: Why a run did not collect every dish, in the order `incomplete_cause` tells them apart.
CAUSES = ("no plan", "blocked drive", "dish given up", "dish unreachable on the map", "other")


def incomplete_cause(run: Mapping) -> str:
    """Why `run`, which did not collect every dish, fell short (one of CAUSES): it ended
    with no plan (at the start or at a replan), on a blocked drive past the replan limit,
    or its plan ran to the end with a dish given up after its tries in every plan it was
    given, or with a dish that no free pose of the known map picks (`unreachable`)."""
    reason = run.get("reason") or ""
    if not run.get("planned", True) or reason.startswith("no plan"):
        return "no plan"
    if reason.endswith("failed: blocked"):
        return "blocked drive"
    if ran_to_end(reason):
        if any(r.get("kind") == "give_up" for r in run.get("recoveries", [])):
            return "dish given up"
        if run.get("unreachable"):
            return "dish unreachable on the map"
    return "other"


def collected_dishes(run: Mapping) -> set[str]:
    """The dishes a run put on the tray, from its pickup records."""
    return {p["dish"] for p in run.get("pickups", []) if p.get("outcome") == "done"}


def recovery_figures(runs: Sequence[Mapping], methods: Sequence[str],
                     dish_areas: Mapping[str, Mapping[str, float]],
                     open_loop: Sequence[Mapping] = ()) -> dict[str, dict]:
    """The figures of the module docstring, per method."""
    twins = {(r["task"], r["method"], r.get("run_seed")): r for r in open_loop
             if "error" not in r and r.get("recovery", "none") == "none"}
    figures: dict[str, dict] = {}
    for method in methods:
        mine = [r for r in runs if r.get("method") == method and "error" not in r]
        counts: dict[str, int] = defaultdict(int)
        cost = planning = 0.0
        pickable = collected_pickable = ended_early = 0
        missed: list[str] = []
        for r in mine:
            for record in r.get("recoveries", []):
                counts[record["kind"]] += 1
                cost += record["cost"]
                planning += record["planning_time"]
            areas = dish_areas.get(r["task"], {})
            can = {d for d, area in areas.items() if area > 0}
            got = collected_dishes(r)
            pickable += len(can)
            collected_pickable += len(can & got)
            missed += [f"{r['task']}/{d}" for d in sorted(can - got)]
            if not ran_to_end(r.get("reason")):
                ended_early += 1
        runs_n = len(mine)
        figures[method] = {
            "runs": runs_n, "complete": sum(bool(r.get("complete")) for r in mine),
            "recoveries": dict(counts),
            "runs_with_recovery": sum(bool(r.get("recoveries")) for r in mine),
            "cost_per_run": cost / runs_n if runs_n else 0.0,
            "replan_planning_per_run": planning / runs_n if runs_n else 0.0,
            "pickable": pickable, "pickable_collected": collected_pickable,
            "pickable_missed": missed, "ended_early": ended_early,
            "incomplete": {cause: sum(incomplete_cause(r) == cause for r in mine
                                      if not r.get("complete")) for cause in CAUSES}}
        pairs = [(r, twins[key]) for r in mine
                 if (key := (r["task"], method, r.get("run_seed"))) in twins]
        if pairs:
            both = [(r, o) for r, o in pairs if r.get("complete") and o.get("complete")]
            # Runs without a plan have no execution time: the means are over the pairs
            # where both runs made one.
            timed = [(r, o) for r, o in pairs if has_time(r) and has_time(o)]
            figures[method]["open_loop"] = {
                "pairs": len(pairs), "timed_pairs": len(timed),
                "code": code_of([o for _, o in pairs]),
                "complete": sum(bool(o.get("complete")) for _, o in pairs),
                "complete_with_recovery": sum(bool(r.get("complete")) for r, _ in pairs),
                "time": _mean([o["execution_time"] for _, o in timed]),
                "time_with_recovery": _mean([r["execution_time"] for r, _ in timed]),
                "both_complete": len(both),
                "extra_time_both_complete": _mean([r["execution_time"] - o["execution_time"]
                                                   for r, o in both])}
    return figures


def _mean(values: Sequence[float]) -> float:
    return sum(values) / len(values) if values else float("nan")


def recovery_table(figures: Mapping[str, Mapping]) -> str:
    """The figures as a Markdown table, methods as columns."""
    methods = list(figures)
    rows = [("runs", lambda f: str(f["runs"])),
            ("completion", lambda f: f"{f['complete'] / f['runs']:.2f}" if f["runs"] else "-"),
            ("runs with a recovery", lambda f: str(f["runs_with_recovery"]))]
    rows += [(PLURALS[kind], lambda f, k=kind: str(f["recoveries"].get(k, 0))) for kind in KINDS]
    rows += [("recovery motion per run (simulated s)", lambda f: f"{f['cost_per_run']:.1f}"),
             ("replanning per run (wall s)", lambda f: f"{f['replan_planning_per_run']:.1f}"),
             ("pickable dishes collected",
              lambda f: f"{f['pickable_collected']} of {f['pickable']}"),
             ("runs ended before their plan", lambda f: str(f["ended_early"]))]
    rows += [(f"incomplete runs: {cause}", lambda f, c=cause: str(f["incomplete"][c]))
             for cause in CAUSES]
    if all("open_loop" in figures[m] for m in methods):
        rows += [("open loop: same runs (their commit)",
                  lambda f: f"{f['open_loop']['pairs']} ({f['open_loop']['code']})"),
                 ("completion, open loop -> recovery",
                  lambda f: "{:.2f} -> {:.2f}".format(
                      f["open_loop"]["complete"] / f["open_loop"]["pairs"],
                      f["open_loop"]["complete_with_recovery"] / f["open_loop"]["pairs"])),
                 ("execution time, mean s, open loop -> recovery (pairs with two plans)",
                  lambda f: f"{f['open_loop']['time']:.1f} -> "
                            f"{f['open_loop']['time_with_recovery']:.1f} "
                            f"({f['open_loop']['timed_pairs']})"),
                 ("time recovery adds where both collected all (s, runs)",
                  lambda f: f"{f['open_loop']['extra_time_both_complete']:+.1f} "
                            f"({f['open_loop']['both_complete']})")]
    lines = ["| | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    lines += [f"| {name} | " + " | ".join(cell(figures[m]) for m in methods) + " |"
              for name, cell in rows]
    return "\n".join(lines) + "\n"
