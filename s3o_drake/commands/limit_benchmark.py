"""How far from the best plan: a reference planner, rations lifted alone.

    s3o bench limit [--tasks DIR ...] [--count 30] [--seed 0] [--json FILE]

For each task, S3O-GROP* plans as it does by default, with each of its rations lifted
alone (true_chairs: the scenario's chairs instead of the perceived ones; oracle: the Drake
oracle's Fea^m instead of the network's; all_candidates: every state space instead of the
top K; long_search: ten times the CMA-ES generations from three seeds) and with all of
them (the reference plan, within 600 s). Every plan is judged by the true world's Fea^m at
the stops it commands, and each task gets a lower bound on any complete execution's time
(s3o_drake/experiments/limit.py). Prints a line per plan, then per configuration the
median gap to the reference in predicted time, judged completion and utility.
With --json the rows are kept as they are made, and a rerun resumes from them.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, read_scenario
from s3o_drake.commands.options import (
    add_json,
    add_seed,
    add_tasks,
    json_store,
    task_name,
    task_paths,
)

CONFIGURATIONS = ("default", "true_chairs", "oracle", "all_candidates", "long_search",
                  "reference")


def row_key(row: dict[str, Any]) -> str:
    """A plan's row is reused for the same task, configuration and seed."""
    return "|".join(str(row[k]) for k in ("task", "configuration", "seed"))


def _print_row(r: dict[str, Any]) -> None:
    name = Path(r["task"]).stem
    if r["configuration"] == "bound":
        print(f"{name:<10} bound      {r['bound_s']:7.1f} s (tour {r['tour_m']:.2f} m)",
              flush=True)
    elif not r["planned"]:
        print(f"{name:<10} {r['configuration']:<14} no plan: {r['error']}", flush=True)
    else:
        print(f"{name:<10} {r['configuration']:<14} predicted {r['predicted_time']:7.1f} s  "
              f"judged completion {r['judged_completion']:.3f}  utility {r['utility']:8.2f}  "
              f"{r['stops']} stops  planned in {r['planning_s']:6.1f} s", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench limit", __doc__)
    add_tasks(parser, count=30)
    add_seed(parser, 0, "planning seed (the long search also plans from the next two)")
    parser.add_argument("--configurations", nargs="+", default=list(CONFIGURATIONS),
                        choices=CONFIGURATIONS, metavar="NAME",
                        help=f"which plans to make (default all: {' '.join(CONFIGURATIONS)})")
    add_json(parser, "plan")
    args = parser.parse_args(argv)
    paths = task_paths(args)
    for path in paths:
        read_scenario(path)  # a bad task is one line, before any work
    store = json_store(args, key=row_key)

    import logging

    from s3o_drake.experiments.limit_study import bound_row, plan_row, summary_lines
    from s3o_drake.feasibility.heatmaps import compute_heatmaps
    from s3o_drake.world.builder import render_overhead

    logging.getLogger("drake").setLevel(logging.WARNING)
    print(f"{len(paths)} tasks x {len(args.configurations)} plans, seed {args.seed}",
          flush=True)
    rows = []
    for path in paths:
        scenario = read_scenario(path)
        truth = images = None  # the true world's Fea^m and the overhead images, once a task
        for configuration in ("bound", *args.configurations):
            key = row_key({"task": task_name(path), "configuration": configuration,
                           "seed": args.seed})
            row = store.get(key) if store is not None and store.finished(key) else None
            if row is None:
                start = time.perf_counter()
                if truth is None:
                    truth = compute_heatmaps(scenario, progress=False)
                    images = render_overhead(scenario)
                row = (bound_row(scenario, truth) if configuration == "bound" else
                       plan_row(scenario, configuration, seed=args.seed, truth=truth,
                                images=images))
                row.update(task=task_name(path), configuration=configuration, seed=args.seed,
                           wall_s=time.perf_counter() - start)
                if store is not None:
                    row = store.append({"key": key, **row})
            rows.append(row)
            _print_row(row)
    print()
    for line in summary_lines(rows):
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
