"""Fea^m's oracle against the executed pickup and against Monte Carlo.

    s3o bench oracle-pinning [--count 5] [--poses 40] [--positions 20] [--json FILE]

1. On exact base poses around every dish of the tasks, the oracle's success test against
   `plan_pickup`, what the ArmController runs: the disagreements are the pickups that
   RRT-Connect's paths decided. 2. Where a heatmap is between 0.05 and 0.95, its value
   against 100 executed landings (Monte Carlo): what the blur's simplifications cost.
"""

from __future__ import annotations

import json
import sys
import time
from typing import TYPE_CHECKING

import numpy as np

# Light imports only: --help and bad arguments answer before Drake loads.
from s3o_drake.commands.common import command_parser, read_scenario
from s3o_drake.commands.options import (
    add_json,
    add_robot,
    add_seed,
    add_tasks,
    at_least,
    json_file,
    task_paths,
    with_overrides_or_fail,
)
from s3o_drake.world.angles import facing_yaw

if TYPE_CHECKING:
    from s3o_drake.feasibility.oracle import FeasibilityOracle
    from s3o_drake.world.scenario import Scenario

#: Base positions drawn around each dish before choosing the poses.
CANDIDATES = 150


def sample_poses(oracle: FeasibilityOracle, count: int,
                 rng: np.random.Generator) -> list[tuple[str, np.ndarray, bool]]:
    """(dish, base pose, oracle feasible) for `count` free base poses around the dishes,
    facing each within 0.1 rad, half of them feasible by the oracle where possible."""
    scene = oracle.checker.scene
    feasible: list = []
    infeasible: list = []
    for dish in scene.dishes:
        p = np.asarray(scene.dish_p_WD(dish)[0])
        r = rng.uniform(0.3, 1.3, CANDIDATES)
        theta = rng.uniform(-np.pi, np.pi, CANDIDATES)
        xy = p + np.column_stack([r * np.cos(theta), r * np.sin(theta)])
        bases = np.column_stack([xy, facing_yaw(xy, p) + rng.normal(0.0, 0.1, CANDIDATES)])
        bases = bases[oracle.checker.base_free(bases)]
        ok = oracle.success(bases, dish)
        feasible += [(dish, b, True) for b in bases[ok]]
        infeasible += [(dish, b, False) for b in bases[~ok]]
    half = min(count // 2, len(feasible))
    pick_f = rng.permutation(len(feasible))[:half]
    pick_i = rng.permutation(len(infeasible))[:count - half]
    return [feasible[i] for i in pick_f] + [infeasible[i] for i in pick_i]


def executed(oracle: FeasibilityOracle, dish: str, base: np.ndarray, seed: int) -> str:
    """The ArmController's pickup from `base` without noise: "ok" or the failure reason."""
    from s3o_drake.execution.arm.pickup import plan_pickup

    plan = plan_pickup(oracle.checker.scene, oracle.checker, base, dish, seed=seed)
    return "ok" if plan.ok else plan.reason


def compare_tests(scenario: Scenario, poses: int, seed: int) -> list[dict]:
    """Measurement 1 on one task: one row per pose."""
    from s3o_drake.feasibility.heatmaps import make_oracle

    oracle = make_oracle(scenario)
    rng = np.random.default_rng([seed, 1])
    rows = []
    for k, (dish, base, predicted) in enumerate(sample_poses(oracle, poses, rng)):
        outcome = executed(oracle, dish, base, seed=seed * 1000 + k)
        rows.append({"dish": dish, "base": [float(v) for v in base], "oracle": bool(predicted),
                     "executed": outcome})
    return rows


def compare_expectation(scenario: Scenario, positions: int, seed: int) -> list[dict]:
    """Measurement 2 on one task: one row per position."""
    from s3o_drake.feasibility.heatmaps import make_oracle

    oracle = make_oracle(scenario)
    rng = np.random.default_rng([seed, 2])
    rows = []
    per_dish = max(1, positions // max(1, len(scenario.dishes)))
    for dish in scenario.dishes:
        heatmap = oracle.heatmap(dish.name)
        values = heatmap.values.ravel()
        middle = np.flatnonzero((values > 0.05) & (values < 0.95))
        chosen = rng.permutation(middle)[:per_dish]
        centres = heatmap.centers().reshape(-1, 2)[chosen]
        mc = oracle.probabilities(centres, dish.name, rng=rng)
        rows += [{"dish": dish.name, "position": [float(v) for v in c], "heatmap": float(h),
                  "monte_carlo": float(m)} for c, h, m in zip(centres, values[chosen], mc,
                                                               strict=True)]
    return rows


def summarize(test_rows: list[dict], expectation_rows: list[dict]) -> dict:
    """The printed figures."""
    predicted = np.array([r["oracle"] for r in test_rows], dtype=bool)
    succeeded = np.array([r["executed"] == "ok" for r in test_rows], dtype=bool)
    reasons: dict[str, int] = {}
    for r in test_rows:
        if r["oracle"] != (r["executed"] == "ok"):
            reasons[r["executed"]] = reasons.get(r["executed"], 0) + 1
    diff = np.array([r["heatmap"] - r["monte_carlo"] for r in expectation_rows])
    return {
        "poses": len(test_rows),
        "oracle_feasible": int(predicted.sum()),
        "feasible_executed": int((predicted & succeeded).sum()),
        "infeasible_failed": int((~predicted & ~succeeded).sum()),
        "disagreements": int((predicted != succeeded).sum()),
        "disagreement_reasons": reasons,
        "positions": len(expectation_rows),
        "mean_abs_difference": float(np.abs(diff).mean()) if diff.size else float("nan"),
        "mean_difference": float(diff.mean()) if diff.size else float("nan"),
        "p90_abs_difference": float(np.percentile(np.abs(diff), 90)) if diff.size
        else float("nan"),
    }


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench oracle-pinning", __doc__)
    add_tasks(parser, count=5)
    parser.add_argument("--poses", type=at_least(1), default=40, metavar="N",
                        help="exact poses per task for the test comparison (default 40)")
    parser.add_argument("--positions", type=at_least(0), default=20, metavar="N",
                        help="positions per task for the expectation comparison (default 20)")
    add_seed(parser, 0, "seed of the sampling")
    add_robot(parser, "the robot of the tasks", default=None, shown="each task's")
    add_json(parser, None)
    args = parser.parse_args(argv)
    tasks = [(path.stem, read_scenario(path)) for path in task_paths(args)]
    if args.robot is not None:
        tasks = [(name, with_overrides_or_fail(scenario, [f"robot.name={args.robot}"]))
                 for name, scenario in tasks]
    json_path = json_file(args)
    from tqdm import tqdm

    start = time.perf_counter()
    test_rows: list[dict] = []
    expectation_rows: list[dict] = []
    for name, scenario in tqdm(tasks, desc="tasks", unit="task"):
        for row in compare_tests(scenario, args.poses, args.seed):
            test_rows.append({"task": name, **row})
        if args.positions:
            for row in compare_expectation(scenario, args.positions, args.seed):
                expectation_rows.append({"task": name, **row})
    figures = summarize(test_rows, expectation_rows)
    print(f"success test vs the executed pickup, {figures['poses']} exact poses on "
          f"{len(tasks)} tasks (seed {args.seed}):")
    print(f"  oracle feasible {figures['oracle_feasible']}: executed ok "
          f"{figures['feasible_executed']}; oracle infeasible "
          f"{figures['poses'] - figures['oracle_feasible']}: failed "
          f"{figures['infeasible_failed']}; disagreements {figures['disagreements']} "
          f"{figures['disagreement_reasons'] or ''}")
    if expectation_rows:
        print(f"heatmap vs Monte Carlo (100 executed landings), {figures['positions']} "
              f"positions: mean |difference| {figures['mean_abs_difference']:.3f}, "
              f"90th percentile {figures['p90_abs_difference']:.3f}, mean difference "
              f"{figures['mean_difference']:+.3f}")
    print(f"({time.perf_counter() - start:.0f} s)")
    if json_path is not None:
        settings = {k: v for k, v in vars(args).items() if k != "task_defaults"}
        json_path.write_text(json.dumps({"settings": settings, "figures": figures,
                                         "poses": test_rows, "positions": expectation_rows},
                                        indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
