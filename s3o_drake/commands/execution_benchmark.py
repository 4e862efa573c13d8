"""How much faster than real time a plan runs, and the playback's size.

    s3o bench execution [--tasks PATH ...] [--seeds 3] [--json FILE]

For each scenario (default scenarios/restaurant.yaml, six dishes) and seed, plans with
S3O-GROP* and executes the plan with the Meshcat recording on, as `s3o run` does; prints
dishes collected, simulated and wall time and their ratio (target: at least 10x faster
than real time), and the playback's size extrapolated to five minutes (target: < 20 MB).
"""

import logging
import statistics
import sys
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, read_scenario, start_meshcat
from s3o_drake.commands.options import (
    add_json,
    add_seeds,
    add_tasks,
    json_store,
    one_robot,
    task_paths,
)
from s3o_drake.world.resources import RESTAURANT

RATE_TARGET = 10.0
SIZE_TARGET_MB = 20.0
FIVE_MINUTES = 300.0


def row_key(row: dict) -> str:
    """A run is reused for the same scenario and seed."""
    return f"{row['scenario']}|{row['seed']}"


def measure(path: Path, seed: int) -> dict:
    from s3o_drake.execution.execute import execute
    from s3o_drake.world.scenario import load_scenario

    scenario = load_scenario(path)
    run = execute(scenario, seed=seed, meshcat=start_meshcat(), progress=False)
    r = run.report
    size = len(run.html.encode())
    # The page holds the viewer and the scene once, then a share per simulated second.
    empty = len(start_meshcat().StaticHtml().encode())
    per_second = (size - empty) / max(r["simulated_time"], 1e-9)
    return {"scenario": str(path), "seed": seed, "dishes": r["dishes"],
            "collected": r["collected"], "execution_time": r["execution_time"],
            "simulated_time": r["simulated_time"], "wall_time": r["wall_time"],
            "realtime_rate": r["realtime_rate"], "planning_time": r["planning_time"],
            "playback_mb": size / 1e6, "playback_mb_per_s": per_second / 1e6,
            "playback_mb_5min": (size + per_second * (FIVE_MINUTES - r["simulated_time"])) / 1e6}


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench execution", __doc__)
    add_tasks(parser, default=(RESTAURANT,))
    add_seeds(parser, 1)
    add_json(parser, "run")
    args = parser.parse_args(argv)
    paths = task_paths(args)
    robot = one_robot((path, read_scenario(path)) for path in paths)
    store = json_store(args, key=row_key, robot=robot)
    logging.getLogger("drake").setLevel(logging.WARNING)

    print(f"{'scenario':<16} {'seed':>4} {'dishes':>7} {'exec s':>7} {'wall s':>7} "
          f"{'x real':>7} {'page MB':>8} {'MB/5min':>8}", flush=True)
    rows = []
    for path in paths:
        for seed in range(args.seeds):
            key = row_key({"scenario": str(path), "seed": seed})
            if store is not None and store.finished(key):
                row = store.get(key)
            else:
                row = measure(path, seed)
                if store is not None:
                    row = store.append({"key": key, **row})
            rows.append(row)
            print(f"{path.stem:<16} {seed:>4} {row['collected']:>3}/{row['dishes']:<3} "
                  f"{row['execution_time']:7.1f} {row['wall_time']:7.1f} "
                  f"{row['realtime_rate']:7.1f} {row['playback_mb']:8.2f} "
                  f"{row['playback_mb_5min']:8.2f}", flush=True)
    rate = statistics.median(r["realtime_rate"] for r in rows)
    slowest = min(r["realtime_rate"] for r in rows)
    size = max(r["playback_mb_5min"] for r in rows)
    print(f"real-time factor: median {rate:.1f}x, slowest run {slowest:.1f}x (target >= "
          f"{RATE_TARGET:g}x in every run: {'met' if slowest >= RATE_TARGET else 'NOT met'}); "
          "playback extrapolated to five "
          f"minutes: at most {size:.1f} MB (target < {SIZE_TARGET_MB:g} MB: "
          f"{'met' if size < SIZE_TARGET_MB else 'NOT met'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
