"""The planner's two Fea^m sources end to end: plan, execute, count dishes.

    s3o bench compare-feasibility [--count 6] [--seed 0] [--json FILE]

For each task and each source of Fea^m ("oracle": the Drake check under the noise model;
"fcn": the network), plans with S3O-GROP* and executes the plan open loop with the same
seed, as `s3o run` does. Prints per task the dishes collected and the planning time with
each source, then per source the completion rate, the share of dishes collected and the
median planning time.
"""

import dataclasses
import logging
import statistics
import sys
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, read_scenario, start_meshcat
from s3o_drake.commands.options import (
    add_json,
    add_seed,
    add_tasks,
    json_store,
    one_robot,
    task_paths,
)
from s3o_drake.world.choices import FEASIBILITY_SOURCES, Recovery

SOURCES = FEASIBILITY_SOURCES


def row_key(row: dict) -> str:
    """A run is reused for the same task, source and seed."""
    return f"{row['task']}|{row['source']}|{row['seed']}"


def run_task(path: Path, source: str, seed: int) -> dict:
    """One task planned with one source of Fea^m and executed open loop: its row."""
    from s3o_drake.execution.execute import execute

    scenario = read_scenario(path)
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
    parser = command_parser("bench compare-feasibility", __doc__)
    add_tasks(parser, count=6)
    add_seed(parser, 0, "seed of every run")
    add_json(parser, "run")
    args = parser.parse_args(argv)
    tasks = task_paths(args)
    robot = one_robot((path, read_scenario(path)) for path in tasks)
    store = json_store(args, key=row_key, robot=robot)
    logging.getLogger("drake").setLevel(logging.WARNING)

    print(f"{'task':<10} " + "  ".join(f"{s + ' dishes':>13} {s + ' plan s':>12}"
                                       for s in SOURCES), flush=True)
    rows = []
    for path in tasks:
        cells = []
        for source in SOURCES:
            key = row_key({"task": path.stem, "source": source, "seed": args.seed})
            if store is not None and store.finished(key):
                row = store.get(key)
            else:
                row = run_task(path, source, args.seed)
                if store is not None:
                    row = store.append({"key": key, **row})
            rows.append(row)
            cells.append(f"{row['collected']:>9}/{row['dishes']:<3} "
                         f"{row['planning_time']:12.2f}")
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
