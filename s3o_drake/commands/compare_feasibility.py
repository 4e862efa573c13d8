"""Compare the planner's two Fea^m sources end to end: plan with each, execute, count dishes.

    python -m s3o_drake.commands.compare_feasibility --tasks 6 [--seed 0] [--json FILE]

For each of the first N shipped tasks (scenarios/generated, never used to train the network)
and each source (`planner.feasibility`: "oracle", the Drake check under the noise model;
"fcn", the network in models/fcn/), plans with S3O-GROP* and executes the plan in the full
diagram with the same seed (so the same noise draws per command), as `python -m
s3o_drake.run` does. Prints per task the dishes collected and the planning time with each
source, then the completion rate (all dishes collected), the share of dishes collected and
the median planning time per source. --json FILE appends one JSON line per run as it ends.
"""

import dataclasses
import json
import logging
import statistics
import sys
from pathlib import Path

from s3o_drake.commands.common import (
    ArgumentParser,
    doc_formatter,
    fail,
    first_tasks,
    start_meshcat,
)
from s3o_drake.execution.execute import execute
from s3o_drake.world.choices import FEASIBILITY_SOURCES, Recovery
from s3o_drake.world.scenario import load_scenario

SOURCES = FEASIBILITY_SOURCES


def run_task(path: Path, source: str, seed: int) -> dict:
    scenario = load_scenario(path)
    # Open loop (the paper's): a model's worth shows in what its plan does unaided.
    scenario = dataclasses.replace(
        scenario, planner=dataclasses.replace(scenario.planner, feasibility=source),
        execution=dataclasses.replace(scenario.execution, recovery=Recovery.NONE.value))
    run = execute(scenario, seed=seed, meshcat=start_meshcat(), progress=False)
    r = run.report
    return {"task": path.stem, "source": source, "seed": seed, "dishes": r["dishes"],
            "collected": r["collected"], "complete": r["collected"] == r["dishes"],
            "execution_time": r["execution_time"], "planning_time": r["planning_time"]}


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.compare_feasibility",
                            description=__doc__, formatter_class=doc_formatter())
    parser.add_argument("--tasks", type=int, default=6, help="first N shipped tasks (default 6)")
    parser.add_argument("--seed", type=int, default=0, help="seed of every run (default 0)")
    parser.add_argument("--json", metavar="FILE", help="append one JSON line per run")
    args = parser.parse_args(argv)
    tasks = first_tasks(args.tasks)
    if args.seed < 0:
        fail(f"--seed: must be a non-negative integer, got {args.seed}")
    json_path = Path(args.json) if args.json else None
    if json_path is not None and not json_path.parent.is_dir():
        fail(f"--json: no folder {json_path.parent}")
    logging.getLogger("drake").setLevel(logging.WARNING)

    print(f"{'task':<10} " + "  ".join(f"{s + ' dishes':>13} {s + ' plan s':>12}"
                                       for s in SOURCES), flush=True)
    rows = []
    for path in tasks:
        cells = []
        for source in SOURCES:
            row = run_task(path, source, args.seed)
            rows.append(row)
            cells.append(f"{row['collected']:>9}/{row['dishes']:<3} "
                         f"{row['planning_time']:12.2f}")
            if json_path is not None:
                with json_path.open("a") as out:
                    out.write(json.dumps(row) + "\n")
        print(f"{path.stem:<10} " + "  ".join(cells), flush=True)
    for source in SOURCES:
        mine = [r for r in rows if r["source"] == source]
        completion = sum(r["complete"] for r in mine) / len(mine)
        share = sum(r["collected"] for r in mine) / sum(r["dishes"] for r in mine)
        planning = statistics.median(r["planning_time"] for r in mine)
        print(f"{source:<7} completion rate {completion:.2f}, dishes collected {share:.2f}, "
              f"median planning time {planning:.2f} s ({len(mine)} tasks)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
