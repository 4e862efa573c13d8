"""Benchmark the pickup's duration: TOPPRA under the UR5e's limits against the old trapezoids.

    python -m s3o_drake.commands.pickup_benchmark [--poses 200] [--tasks 4] [--seed 0]
                                                   [--json FILE]

Samples feasible pickups with a fixed seed, an equal share of --poses in each scene:
scenarios/restaurant.yaml and the first --tasks shipped tasks of scenarios/generated/. Base
poses are drawn as a planner's landings look (`feasibility.agreement.sample_queries`: within
1.1 m of a random dish, yaw facing it with 0.05 rad of noise, a horizontal reach offset of
1 cm) and kept when `FeasibilityChecker.check` says feasible. Each is planned with
`plan_pickup` from the stow configuration (planner seed: the pose's number). A plan's paths
do not depend on their timing, so three timings are measured on the same paths, approach to
stow (all seven segments, the fingers' close and release included):

- toppra: the plan's own: TOPPRA under the model's joint limits, corners rounded where the
  rounded curve is collision-free, `SLOW` of the limits near the dish;
- toppra_stops: TOPPRA with the same limits, stopping at every waypoint (what the rounding
  gains);
- trapezoid (the reference, the timing before TOPPRA): a rest-to-rest trapezoid along each
  straight edge at 1 rad/s and 2 rad/s² for the arm (half of it near the dish), the fingers
  at 0.1 m/s and 0.5 m/s².

Prints each timing's duration distribution (median, quartiles, 90th percentile, max), the
median of each segment, and the plans' failures by reason. Failures are the same for every
timing: they time the same paths, and a timing cannot fail a pickup (TOPPRA failing on a
rounded curve falls back to stops; on a straight edge it raises). Also prints how many
multi-waypoint motions were rounded.
--json FILE writes the figures and one record per pose.
"""

import itertools
import json
import logging
import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np
from tqdm import tqdm

from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail, first_tasks
from s3o_drake.execution.arm.arm_motion import time_parameterize
from s3o_drake.execution.arm.pickup import (
    FINGER_MAX_ACCELERATION,
    FINGER_MAX_VELOCITY,
    SEGMENT_NAMES,
    SLOW_SEGMENTS,
    PickupPlan,
    plan_pickup,
    segment_limits,
)
from s3o_drake.feasibility.agreement import sample_queries
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.pickup_geometry import REASONS
from s3o_drake.feasibility.reachability import ReachabilityMap
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.files import write_atomically
from s3o_drake.world.resources import RESTAURANT
from s3o_drake.world.scenario import load_scenario

TIMINGS = ("toppra", "toppra_stops", "trapezoid")
#: The timing before TOPPRA (the reference): the arm's speed and acceleration (rad/s, rad/s²),
#: a third of the UR5e's speed limit, and the share of them near the dish.
TRAPEZOID_ARM_VELOCITY = 1.0
TRAPEZOID_ARM_ACCELERATION = 2.0
TRAPEZOID_SLOW = 0.5
#: The issue's target for the median pickup (s).
TARGET_MEDIAN = 8.0
#: Candidate poses drawn per feasibility check batch.
BATCH = 64


def trapezoid_duration(path: np.ndarray, max_velocity: np.ndarray,
                       max_acceleration: np.ndarray) -> float:
    """Duration (s) of rest-to-rest trapezoids along each straight edge of `path` (n, d).

    On an edge q = q0 + s Δ the path parameter's limits are the tightest over the moving
    joints (|Δ_j| ṡ <= v_j, |Δ_j| s̈ <= a_j): a triangle when cruise speed is never reached,
    else accelerate, cruise, decelerate.
    """
    total = 0.0
    for q0, q1 in itertools.pairwise(np.asarray(path, dtype=float)):
        delta = np.abs(q1 - q0)
        moving = delta > 1e-12
        if not moving.any():
            continue
        rate = float(np.min(max_velocity[moving] / delta[moving]))
        acceleration = float(np.min(max_acceleration[moving] / delta[moving]))
        if rate * rate / acceleration >= 1.0:
            total += 2.0 * math.sqrt(1.0 / acceleration)
        else:
            total += 1.0 / rate + rate / acceleration
    return total


def trapezoid_limits(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The reference timing's limits of the robot's 11 positions in segment `name`."""
    v = np.concatenate([np.ones(3), np.full(6, TRAPEZOID_ARM_VELOCITY),
                        np.full(2, FINGER_MAX_VELOCITY)])
    a = np.concatenate([np.ones(3), np.full(6, TRAPEZOID_ARM_ACCELERATION),
                        np.full(2, FINGER_MAX_ACCELERATION)])
    if name in SLOW_SEGMENTS:
        v, a = v * TRAPEZOID_SLOW, a * TRAPEZOID_SLOW
    return v, a


def durations(plan: PickupPlan, scene: FeasibilityScene) -> dict[str, dict[str, float]]:
    """Each segment's duration under each of TIMINGS (s), by timing and segment name."""
    plant = scene.checker.plant()
    out = {timing: {} for timing in TIMINGS}
    for segment in plan.segments:
        v, a = segment_limits(plant, segment.name)
        out["toppra"][segment.name] = segment.duration
        out["toppra_stops"][segment.name] = time_parameterize(
            segment.waypoints, plant, max_velocity=v, max_acceleration=a).duration
        out["trapezoid"][segment.name] = trapezoid_duration(
            segment.waypoints, *trapezoid_limits(segment.name))
    return out


def feasible_poses(scene: FeasibilityScene, checker: FeasibilityChecker, count: int,
                   rng: np.random.Generator) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """`count` (dish, base, reach offset) that `checker.check` calls feasible."""
    found = []
    while len(found) < count:
        queries = sample_queries(scene, BATCH, rng)
        for dish, base, offset in zip(queries.dishes, queries.bases, queries.offsets,
                                      strict=True):
            if len(found) < count and checker.check(base, dish, offset[:2]).feasible:
                found.append((dish, base, offset[:2]))
    return found


def distribution(values: list[float]) -> dict[str, float]:
    """Median, quartiles, 90th percentile and max of `values`."""
    q = np.percentile(values, [25, 50, 75, 90])
    return {"q1": float(q[0]), "median": float(q[1]), "q3": float(q[2]), "p90": float(q[3]),
            "max": float(np.max(values))}


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.pickup_benchmark",
                            description=__doc__, formatter_class=doc_formatter())
    parser.add_argument("--poses", type=int, default=200,
                        help="feasible poses in all, split over the scenes (default 200)")
    parser.add_argument("--tasks", type=int, default=4,
                        help="shipped tasks used besides the restaurant (default 4)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--json", metavar="FILE", help="also write the figures here")
    args = parser.parse_args(argv)
    if args.poses < 1:
        fail(f"--poses: must be at least 1, got {args.poses}")
    if args.seed < 0:
        fail(f"--seed: must be a non-negative integer, got {args.seed}")
    if args.tasks < 0:
        fail(f"--tasks: must be at least 0, got {args.tasks}")
    json_path = Path(args.json) if args.json else None
    if json_path is not None and not json_path.parent.is_dir():
        fail(f"--json: no folder {json_path.parent}")
    paths = [RESTAURANT] + (first_tasks(args.tasks) if args.tasks > 0 else [])
    logging.getLogger("drake").setLevel(logging.WARNING)

    rng = np.random.default_rng(args.seed)
    rmap = ReachabilityMap.load()
    records = []
    with tqdm(total=args.poses, desc="pickups", unit="pose", file=sys.stderr) as bar:
        for k, path in enumerate(paths):
            scene = FeasibilityScene(load_scenario(path).contents)
            checker = FeasibilityChecker(scene, rmap)
            count = args.poses // len(paths) + (k < args.poses % len(paths))
            for dish, base, offset in feasible_poses(scene, checker, count, rng):
                plan = plan_pickup(scene, checker, base, dish, reach_offset=offset,
                                   seed=len(records))
                record = {"scene": path.stem, "dish": dish, "base": base.tolist(),
                          "reach_offset": offset.tolist(), "reason": plan.reason}
                if plan.ok:
                    record["segments"] = durations(plan, scene)
                    record.update({timing: sum(record["segments"][timing].values())
                                   for timing in TIMINGS})
                    record["rounded"] = sum(s.smoothed for s in plan.segments)
                    record["multi_waypoint"] = sum(len(s.waypoints) > 2 for s in plan.segments)
                records.append(record)
                bar.update()

    ok = [r for r in records if r["reason"] == "ok"]
    failures = Counter(r["reason"] for r in records if r["reason"] != "ok")
    figures = {"poses": len(records), "seed": args.seed,
               "scenes": [p.stem for p in paths], "ok": len(ok),
               "failures": {reason: failures.get(reason, 0) for reason in REASONS[1:]},
               "rounded": sum(r["rounded"] for r in ok),
               "multi_waypoint": sum(r["multi_waypoint"] for r in ok)}
    print(f"{len(records)} feasible poses ({', '.join(figures['scenes'])}; seed {args.seed}): "
          f"{len(ok)} planned; failures by reason (the same paths for every timing): " +
          ", ".join(f"{reason} {n}" for reason, n in figures["failures"].items()))
    if ok:
        print(f"pickup duration, approach to stow (s), {len(ok)} pickups:")
        print(f"  {'timing':<14} {'q1':>6} {'median':>7} {'q3':>6} {'p90':>6} {'max':>6}")
        for timing in TIMINGS:
            d = distribution([r[timing] for r in ok])
            figures[timing] = d
            print(f"  {timing:<14} {d['q1']:6.2f} {d['median']:7.2f} {d['q3']:6.2f} "
                  f"{d['p90']:6.2f} {d['max']:6.2f}")
        print("  median per segment, toppra / trapezoid: " + ", ".join(
            f"{name} {np.median([r['segments']['toppra'][name] for r in ok]):.2f}/"
            f"{np.median([r['segments']['trapezoid'][name] for r in ok]):.2f}"
            for name in SEGMENT_NAMES))
        ratio = [r["toppra"] / r["trapezoid"] for r in ok]
        figures["ratio_median"] = float(np.median(ratio))
        median = figures["toppra"]["median"]
        print(f"toppra / trapezoid on the same paths: median {figures['ratio_median']:.2f}; "
              f"rounded corners on {figures['rounded']} of {figures['multi_waypoint']} "
              f"multi-waypoint motions; median {median:.2f} s (target <= {TARGET_MEDIAN:g} s: "
              f"{'met' if median <= TARGET_MEDIAN else 'NOT met'})")
    if json_path is not None:
        write_atomically(json_path, json.dumps({"figures": figures, "poses": records},
                                               indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
