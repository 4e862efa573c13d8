"""The best odds an open-loop plan has: each dish's best stop by the planner's Fea^m.

    python -m s3o_drake.commands.best_stops [--tasks DIR | YAML ...] [--count N]
        [--feasibility fcn|oracle] [--json FILE]

For each task, as the planner sees it at the start (the chairs that perception finds in the
overhead camera's images, Fea^m from `planner.feasibility` or --feasibility), every dish's
highest Fea^m over the stops a plan may command: free as planned (feasibility/stops.py) and
reachable by a drive from the robot's start (`s3o_drake.planning.pipeline.best_stops`).

Fea^m is calibrated against executed pickups (`python -m s3o_drake.commands.calibration`,
docs/calibration.md), so the mean of these figures over dishes is the pickup success that an
open-loop plan can expect when it stands at every dish's own best stop, one stop per dish,
whatever that costs in time: no open-loop plan can expect more. Prints one line per task
and the mean, median and minimum per dish kind and over all dishes, with the number of
dishes whose best stop is below 0.9. A study's observed pickup success is set against it
in docs/calibration.md.

--json FILE: one JSON line per task (its dishes' kinds and best Fea^m), written as each
task is done; the same command resumes from the tasks already in it.
"""

import logging
import statistics
import sys
from pathlib import Path

from s3o_drake.commands.common import (
    ArgumentParser,
    doc_formatter,
    fail,
    task_files,
    task_scenarios,
)
from s3o_drake.world.choices import FEASIBILITY_SOURCES
from s3o_drake.world.resources import TASKS_DIR


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
    parser = ArgumentParser(prog="python -m s3o_drake.commands.best_stops", description=__doc__,
                            formatter_class=doc_formatter())
    parser.add_argument("--tasks", nargs="+", default=[str(TASKS_DIR)], metavar="PATH",
                        help="a folder of task_*.yaml (default scenarios/generated) or files")
    parser.add_argument("--count", type=int, metavar="N", help="only the first N tasks")
    parser.add_argument("--feasibility", choices=FEASIBILITY_SOURCES,
                        help="the Fea^m source (default: each task's planner.feasibility)")
    parser.add_argument("--json", metavar="FILE", help="append one JSON line per task; resumes")
    args = parser.parse_args(argv)
    paths = task_files(args.tasks, args.count)
    json_path = Path(args.json) if args.json else None
    if json_path is not None and not json_path.parent.is_dir():
        fail(f"--json: no folder {json_path.parent}")
    from s3o_drake.experiments.store import ResultStore  # Drake, after the arguments

    tasks = task_scenarios([str(p) for p in paths], len(paths))
    logging.getLogger("drake").setLevel(logging.WARNING)

    store = ResultStore(json_path) if json_path is not None else None
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
