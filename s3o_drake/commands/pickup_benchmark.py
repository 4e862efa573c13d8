"""Pickup durations: TOPPRA under the UR5e's limits against trapezoids.

    s3o bench pickup [--poses 200] [--count 5] [--seed 0] [--json FILE]

Samples feasible pickups as a planner's landings look, an equal share of --poses in each of
the tasks (by default the restaurant and the first four shipped tasks), plans each with
`plan_pickup`, and times the same paths three ways: the plan's own TOPPRA timing, TOPPRA
stopping at every waypoint, and the old trapezoids. Prints each timing's distribution,
the median per segment and the failures by reason (target: median pickup <= 8 s).
"""

from __future__ import annotations

import itertools
import json
import logging
import math
import sys
from collections import Counter
from typing import TYPE_CHECKING

import numpy as np

# Light imports only: --help and bad arguments answer before Drake loads.
from s3o_drake.commands.common import command_parser, read_scenario
from s3o_drake.commands.options import (
    add_json,
    add_seed,
    add_tasks,
    at_least,
    json_file,
    one_robot,
    task_paths,
)
from s3o_drake.world.files import write_atomically
from s3o_drake.world.resources import RESTAURANT, TASKS_DIR

if TYPE_CHECKING:
    from s3o_drake.execution.arm.pickup import PickupPlan
    from s3o_drake.feasibility.check import FeasibilityChecker
    from s3o_drake.feasibility.scene import FeasibilityScene

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
    """The reference timing's limits of the robot's positions in segment `name`."""
    from s3o_drake.execution.arm.pickup import (
        FINGER_MAX_ACCELERATION,
        FINGER_MAX_VELOCITY,
        SLOW_SEGMENTS,
    )

    v = np.concatenate([np.ones(3), np.full(6, TRAPEZOID_ARM_VELOCITY),
                        np.full(2, FINGER_MAX_VELOCITY)])
    a = np.concatenate([np.ones(3), np.full(6, TRAPEZOID_ARM_ACCELERATION),
                        np.full(2, FINGER_MAX_ACCELERATION)])
    if name in SLOW_SEGMENTS:
        v, a = v * TRAPEZOID_SLOW, a * TRAPEZOID_SLOW
    return v, a


def durations(plan: PickupPlan, scene: FeasibilityScene) -> dict[str, dict[str, float]]:
    """Each segment's duration under each of TIMINGS (s), by timing and segment name."""
    from s3o_drake.execution.arm.arm_motion import time_parameterize
    from s3o_drake.execution.arm.pickup import segment_limits

    plant = scene.checker.plant()
    out = {timing: {} for timing in TIMINGS}
    for segment in plan.segments:
        v, a = segment_limits(plant, segment.name, robot=scene.robot,
                              positions=scene.positions)
        out["toppra"][segment.name] = segment.duration
        out["toppra_stops"][segment.name] = time_parameterize(
            segment.waypoints, plant, max_velocity=v, max_acceleration=a,
            positions=scene.positions).duration
        out["trapezoid"][segment.name] = trapezoid_duration(
            segment.waypoints, *trapezoid_limits(segment.name))
    return out


def feasible_poses(scene: FeasibilityScene, checker: FeasibilityChecker, count: int,
                   rng: np.random.Generator) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """`count` (dish, base, reach offset) that `checker.check` calls feasible."""
    from s3o_drake.experiments.reachability_agreement import sample_queries

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
    parser = command_parser("bench pickup", __doc__)
    parser.add_argument("--poses", type=at_least(1), default=200, metavar="N",
                        help="feasible poses in all, split over the tasks (default 200)")
    add_tasks(parser, default=(RESTAURANT, TASKS_DIR), count=5)
    add_seed(parser)
    add_json(parser, None)
    args = parser.parse_args(argv)
    paths = task_paths(args)
    robot = one_robot((path, read_scenario(path)) for path in paths)
    json_path = json_file(args)
    from tqdm import tqdm

    from s3o_drake.execution.arm.pickup import SEGMENT_NAMES, plan_pickup
    from s3o_drake.feasibility.check import FeasibilityChecker
    from s3o_drake.feasibility.pickup_geometry import REASONS
    from s3o_drake.feasibility.reachability.map import ReachabilityMap
    from s3o_drake.feasibility.scene import FeasibilityScene
    from s3o_drake.world.robot import load_robot
    from s3o_drake.world.scenario import load_scenario

    logging.getLogger("drake").setLevel(logging.WARNING)

    rng = np.random.default_rng(args.seed)
    rmap = ReachabilityMap.load(robot=load_robot(robot))
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
