"""How well Fea^m's oracle models the executed pickup: the two measurements behind it.

    python -m s3o_drake.commands.oracle_pinning [--tasks 5] [--poses 40] [--positions 20]
                                            [--seed 0] [--json FILE]

1. The success test against the ArmController's pickup. On exact base poses (no noise)
   around every dish of the first --tasks shipped tasks (scenarios/generated), the oracle's
   test (`FeasibilityOracle.success`: the pickup's configurations, without the arm's
   joint-space paths) is compared with `plan_pickup`, which is what the ArmController runs
   (without noise, a planned pickup plays open loop and holds the dish: its outcome is the
   plan's). --poses per task, half of them feasible by the oracle where there are enough.
   The disagreements are the pickups that RRT-Connect's paths decided.
2. The heatmap's expectation against Monte Carlo. At --positions per task where the
   heatmap is between 0.05 and 0.95, the heatmap's value (`heatmap`: the landing's success
   blurred by the noise) is compared with `probabilities` (100 landings of the execution's
   landing model: drive heading towards the dish, stop short, turn to the noisy yaw, turn
   to face the dish when more than 0.03 rad off; reach noise in the grasp target). Their
   difference is what the blur's simplifications cost; the Monte-Carlo standard error is
   at most 0.05.

Prints both figures; --json writes them with the per-pose and per-position rows.
"""

import json
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail, task_scenarios
from s3o_drake.execution.arm.pickup import plan_pickup
from s3o_drake.feasibility.heatmaps import make_oracle
from s3o_drake.feasibility.oracle import FeasibilityOracle
from s3o_drake.world.angles import facing_yaw
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
    plan = plan_pickup(oracle.checker.scene, oracle.checker, base, dish, seed=seed)
    return "ok" if plan.ok else plan.reason


def compare_tests(scenario: Scenario, poses: int, seed: int) -> list[dict]:
    """Measurement 1 on one task: one row per pose."""
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
    parser = ArgumentParser(prog="python -m s3o_drake.commands.oracle_pinning",
                            description=__doc__, formatter_class=doc_formatter())
    parser.add_argument("--tasks", type=int, default=5, help="first shipped tasks (default 5)")
    parser.add_argument("--poses", type=int, default=40,
                        help="exact poses per task for the test comparison (default 40)")
    parser.add_argument("--positions", type=int, default=20,
                        help="positions per task for the expectation comparison (default 20)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sampling (default 0)")
    parser.add_argument("--json", type=Path, help="write the figures and rows here")
    args = parser.parse_args(argv)
    if args.poses < 1:
        fail(f"--poses: must be at least 1, got {args.poses}")
    if args.positions < 0:
        fail(f"--positions: must be at least 0, got {args.positions}")
    tasks = task_scenarios(None, args.tasks)
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
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"settings": vars(args) | {"json": str(args.json)},
                                         "figures": figures, "poses": test_rows,
                                         "positions": expectation_rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
