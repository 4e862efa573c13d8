"""Each dish's best stop by Fea^m: the best odds of an open-loop plan.

    s3o bench best-stops [--tasks PATH ...] [--count N] [--feasibility fcn|oracle]

For each task as the planner sees it at the start (perceived chairs, Fea^m from the
scenario's source), every dish's highest Fea^m over the stops a plan may command. Fea^m is
calibrated, so their mean is the pickup success an open-loop plan can expect at best.
Prints a line per task and the mean, median and minimum per dish kind and over all.
"""

import logging
import statistics
import sys

from s3o_drake.commands.common import command_parser, read_scenario
from s3o_drake.commands.options import add_json, add_tasks, json_store, one_robot, task_paths
from s3o_drake.world.choices import FEASIBILITY_SOURCES


def task_best_stops(scenario, feasibility: str) -> dict[str, float]:
    """Each dish's best stop (Fea^m) as the planner sees the task (a Scenario) at its
    start."""
    from s3o_drake.belief import perceive_known_world
    from s3o_drake.belief.known_world import Briefing
    from s3o_drake.planning.pipeline import best_stops, heatmaps_for
    from s3o_drake.world.builder import render_overhead

    color, depth, label, robot_labels = render_overhead(scenario)
    known = perceive_known_world(Briefing.of(scenario), (color, depth, label),
                                 pose=scenario.robot.start,
                                 dishes=[d.name for d in scenario.dishes],
                                 robot_labels=robot_labels)
    return best_stops(known, heatmaps_for(known, source=feasibility))


def summary_lines(rows: list[dict]) -> list[str]:
    """Mean, median, minimum and count below 0.9 of the dishes' best Fea^m, per kind and in
    all."""
    values: dict[str, list[float]] = {}
    for row in rows:
        for dish, best in row["best"].items():
            values.setdefault(row["kinds"][dish], []).append(best)
            values.setdefault("all", []).append(best)
    lines = [f"{'dishes':<8} {'n':>5} {'mean':>7} {'median':>7} {'min':>7} {'< 0.9':>6}"]
    for kind in [*sorted(k for k in values if k != "all"), "all"]:
        v = values.get(kind, [])
        if v:
            lines.append(f"{kind:<8} {len(v):5d} {statistics.fmean(v):7.4f} "
                         f"{statistics.median(v):7.4f} {min(v):7.4f} "
                         f"{sum(x < 0.9 for x in v):6d}")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench best-stops", __doc__)
    add_tasks(parser)
    parser.add_argument("--feasibility", choices=FEASIBILITY_SOURCES,
                        help="the Fea^m source (default: each task's planner.feasibility)")
    add_json(parser, "task")
    args = parser.parse_args(argv)
    paths = task_paths(args)
    tasks = [(path.stem, read_scenario(path)) for path in paths]
    store = json_store(args, robot=one_robot(zip(paths, (s for _, s in tasks), strict=True)))
    logging.getLogger("drake").setLevel(logging.WARNING)
    rows = []
    for name, scenario in tasks:
        source = args.feasibility or scenario.planner.feasibility
        key = f"{name}|{source}"
        if store is not None and store.finished(key):
            row = store.get(key)
        else:
            row = {"key": key, "task": name, "feasibility": source,
                   "kinds": {d.name: d.kind for d in scenario.dishes},
                   "best": task_best_stops(scenario, source)}
            if store is not None:
                store.append(row)
        rows.append(row)
        print(f"{name:<10} " + "  ".join(f"{d} {v:.3f}" for d, v in row["best"].items()),
              flush=True)
    print(f"\nbest stop per dish (Fea^m, {len(rows)} tasks):")
    print("\n".join(summary_lines(rows)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
