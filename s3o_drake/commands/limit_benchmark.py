"""How far from the best plan: a reference planner, rations lifted alone.

    s3o bench limit [--tasks DIR ...] [--count 30] [--seed 0] [--json FILE]

For each task, S3O-GROP* plans by default, with each ration lifted alone (true_chairs,
oracle, all_candidates, long_search) and with all of them (the reference plan); each plan
is judged by the true world's Fea^m at its stops. Prints a line per plan, then per
configuration the median gap to the reference (time, judged completion, utility) and, per
ration, the share of the default's gap it closes, of the time gap and of the utility gap,
each (default - ration) / default.
With --json the rows are kept as they are made, and a rerun resumes from them.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, fail, read_scenario
from s3o_drake.commands.options import (
    add_json,
    add_seed,
    add_tasks,
    at_least,
    json_store,
    one_robot,
    task_paths,
)
from s3o_drake.world.resources import repo_path

if TYPE_CHECKING:
    from s3o_drake.world.scenario import Scenario

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
    elif not r.get("planned", True):
        print(f"{name:<10} {r['configuration']:<14} no plan: {r['error']}", flush=True)
    elif r["configuration"].startswith("executed:"):
        print(f"{name:<10} {r['configuration']:<20} {r['collected']}/{r['dishes']} collected "
              f"in {r['execution_time']:6.1f} s (predicted {r['predicted_time']:.1f} s)",
              flush=True)
    else:
        print(f"{name:<10} {r['configuration']:<14} predicted {r['predicted_time']:7.1f} s  "
              f"judged completion {r['judged_completion']:.3f}  utility {r['utility']:8.2f}  "
              f"{r['stops']} stops  planned in {r['planning_s']:6.1f} s", flush=True)


def _row(scenario: Scenario, configuration: str, plan_of: str | None, seed: int,
         made: dict[str, Any]) -> dict[str, Any]:
    """The row of one configuration ("bound", a plan, or "executed:PLAN:SEED"), with what
    the task's earlier rows made in this process (`made`) and adding to it."""
    from s3o_drake.experiments.limit import plan_rationed
    from s3o_drake.experiments.limit_study import (
        bound_row,
        executed_row,
        lifted_by,
        plan_row,
    )
    from s3o_drake.feasibility.heatmaps import compute_heatmaps
    from s3o_drake.world.builder import render_overhead

    if "truth" not in made:
        made["truth"] = compute_heatmaps(scenario, progress=False)
        made["images"] = render_overhead(scenario)
    if configuration == "bound":
        return bound_row(scenario, made["truth"])
    name = plan_of or configuration
    if name not in made:  # a resumed run plans again: the same seed gives the same plan
        made[name] = plan_rationed(scenario, lifted_by(name), seed=seed,
                                   images=made["images"])
    if plan_of is None:
        return plan_row(made[name], made["truth"])
    if made[name].plan is None:
        return {"planned": False, "error": made[name].error}
    return executed_row(scenario, made[name], study_seed=int(configuration.split(":")[2]))


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench limit", __doc__)
    add_tasks(parser, count=30)
    add_seed(parser, 0, "planning seed (the long search also plans from the next two)")
    parser.add_argument("--configurations", nargs="+", default=list(CONFIGURATIONS),
                        choices=CONFIGURATIONS, metavar="NAME",
                        help=f"which plans to make (default all: {' '.join(CONFIGURATIONS)})")
    parser.add_argument("--execute-seeds", type=at_least(0), default=3, metavar="N",
                        help="execute the default and the reference plans with noise, study "
                             "seeds 0..N-1, open loop (default 3; 0: none)")
    add_json(parser, "plan")
    parser.add_argument("--rows", nargs="+", metavar="FILE",
                        help="plan nothing: summarize the rows of earlier runs (--json files, "
                             "one per room, say)")
    parser.add_argument("--picture", metavar="FILE.png",
                        help="draw each configuration's gap to the reference, task by task, "
                             "one column per room")
    args = parser.parse_args(argv)
    if args.rows:
        missing = [f for f in args.rows if not Path(f).is_file()]
        if missing:
            fail(f"--rows: no such file {missing[0]}")
        from s3o_drake.experiments.store import ResultStore

        rows = [r for f in args.rows for r in ResultStore(Path(f), read_only=True).rows()]
        _summarize(rows, args.picture)
        return 0
    paths = task_paths(args)
    scenarios = [read_scenario(path) for path in paths]  # a bad task: one line, no work
    store = json_store(args, key=row_key, robot=one_robot(zip(paths, scenarios, strict=True)))

    import logging

    logging.getLogger("drake").setLevel(logging.WARNING)
    print(f"{len(paths)} tasks x {len(args.configurations)} plans, seed {args.seed}",
          flush=True)
    rows = []
    for path, scenario in zip(paths, scenarios, strict=True):
        made: dict[str, Any] = {}  # per task: the truth, the images, the plans made here
        wanted = [("bound", None), *((c, None) for c in args.configurations)]
        wanted += [(f"executed:{c}:{k}", c) for c in ("default", "reference")
                   if c in args.configurations for k in range(args.execute_seeds)]
        for configuration, plan_of in wanted:
            key = row_key({"task": repo_path(path), "configuration": configuration,
                           "seed": args.seed})
            row = store.get(key) if store is not None and store.finished(key) else None
            if row is None:
                start = time.perf_counter()
                row = _row(scenario, configuration, plan_of, args.seed, made)
                row.update(task=repo_path(path), configuration=configuration,
                           seed=args.seed, wall_s=time.perf_counter() - start)
                if store is not None:
                    row = store.append({"key": key, **row})
            rows.append(row)
            _print_row(row)
    _summarize(rows, args.picture)
    return 0


def _summarize(rows: list[dict[str, Any]], picture: str | None) -> None:
    """The summary per room, and the picture when asked for."""
    from s3o_drake.experiments.limit_study import by_room, gaps_by_room, summary_lines

    for room, mine in by_room(rows).items():
        print(f"\n{room}:")
        for line in summary_lines(mine):
            print(line)
    if picture:
        from s3o_drake.viz.limit import plot_gaps

        Path(picture).parent.mkdir(parents=True, exist_ok=True)
        plot_gaps(gaps_by_room(rows), Path(picture))
        print(f"wrote {picture}")


if __name__ == "__main__":
    sys.exit(main())
