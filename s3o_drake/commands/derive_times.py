"""Derive the planner's time model from the robot's own motions.

    s3o build time-model [--samples 400] [--seed 0] [--out out/time_model.yaml]

Plans --samples pickups from base positions the feasibility check accepts near the shipped
tasks' dishes, as the ArmController runs them, fits candidate models of their duration by
the base-dish distance, and records the one with the least held-out error, with the
command overheads of the control period. Deterministic for a seed; re-run it whenever the
arm's or the base's motion changes.
"""

from __future__ import annotations

import logging
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

# Light imports only: --help and bad arguments answer before Drake loads; the functions
# import the planner's and the arm's modules where they use them.
from s3o_drake.commands.common import command_parser
from s3o_drake.commands.options import add_out, add_seed, at_least, out_file
from s3o_drake.world.resources import REPO_DIR, TIME_MODEL

if TYPE_CHECKING:
    from s3o_drake.feasibility.check import FeasibilityChecker
    from s3o_drake.planning.time_model import PickupModel, TimeModel

DEFAULT_OUT = Path("out") / TIME_MODEL.name
"""Where the model goes unless --out says otherwise: not over the shipped one."""
FOLDS = 5
CANDIDATES_PER_ROUND = 64
ROUNDS = 5
#: Nearest base-dish distance drawn (m): the base's half-length keeps it further anyway.
MIN_DISTANCE = 0.3
#: How far beyond the planner's reach base positions are drawn (m): a location's stops lie
#: within reach of its own dish, but a merged stop picks its other dishes from further
#: (1.2 m was seen), where the arm's motion changes (the side grasp of a cup).
BEYOND_REACH = 0.5


def sample_pickups(paths: Sequence[Path], samples: int, seed: int, *,
                   progress: bool = True) -> list[dict]:
    """Feasible pickups planned with `plan_pickup` (see the module docstring): one row per
    planned pickup with the task, dish, kind, distance (m), grasp, outcome and duration (s)."""
    from s3o_drake.execution.arm.pickup import plan_pickup
    from s3o_drake.feasibility.check import FeasibilityChecker
    from s3o_drake.feasibility.scene import FeasibilityScene
    from s3o_drake.world.scenario import load_scenario

    rng = np.random.default_rng(seed)
    per_task = math.ceil(samples / len(paths))
    rows: list[dict] = []
    for path in paths:
        if len(rows) >= samples:
            break
        scenario = load_scenario(path)
        if not scenario.dishes:
            continue
        scene = FeasibilityScene(scenario.contents)
        checker = FeasibilityChecker(scene)
        order = rng.permutation(len(scenario.dishes))
        for k in range(min(per_task, samples - len(rows))):
            dish = scenario.dishes[int(order[k % len(order)])]
            base = _feasible_base(checker, dish.name, np.asarray(dish.position, float),
                                  scenario.planner.reach + BEYOND_REACH, rng)
            if base is None:
                continue
            plan = plan_pickup(scene, checker, base, dish.name,
                               seed=int(rng.integers(2**31 - 1)))
            rows.append({"task": path.stem, "dish": dish.name, "kind": dish.kind,
                         "distance": float(np.linalg.norm(base[:2] - dish.position)),
                         "grasp": plan.grasp, "ok": plan.ok, "reason": plan.reason,
                         "duration": plan.duration if plan.ok else None})
        if progress:
            print(f"  {path.stem}: {len(rows)} pickups so far", file=sys.stderr, flush=True)
    return rows


def _feasible_base(checker: FeasibilityChecker, dish: str, p_WD: np.ndarray, radius: float,
                   rng: np.random.Generator) -> np.ndarray | None:
    """A base pose facing the dish, uniform over the disc of `radius` around it, that the
    feasibility check accepts; None if no round of draws found one."""
    from s3o_drake.world.angles import facing_yaw

    for _ in range(ROUNDS):
        r = np.sqrt(rng.uniform(MIN_DISTANCE**2, radius**2, CANDIDATES_PER_ROUND))
        a = rng.uniform(-math.pi, math.pi, CANDIDATES_PER_ROUND)
        xy = p_WD + np.column_stack([r * np.cos(a), r * np.sin(a)])
        yaw = facing_yaw(xy, p_WD)
        bases = np.column_stack([xy, yaw])
        ok = np.flatnonzero(checker.check_many(bases, dish))
        if len(ok):
            return bases[ok[0]]
    return None


#: Per candidate form: the polynomial's degree in d and how the samples are grouped.
FORMS = {"constant": (0, "all"), "per_kind": (0, "kind"), "linear": (1, "all"),
         "per_kind_linear": (1, "kind"), "per_kind_grasp": (0, "kind/grasp"),
         "per_kind_grasp_linear": (1, "kind/grasp"),
         "per_kind_grasp_quadratic": (2, "kind/grasp")}
"""The forms of planning/time_model.PICKUP_FORMS, in its order
(tests/planning/test_time_model.py)."""


def side_thresholds(kinds: np.ndarray, grasps: np.ndarray, d: np.ndarray) -> dict[str, float]:
    """Per kind that was ever grasped from the side: the distance beyond which the side
    grasp is predicted, the one that misclassifies the fewest samples (a midpoint between
    two samples' distances; ties: the nearest)."""
    out = {}
    for kind in sorted(set(kinds[grasps == "side"].tolist())):
        mine = kinds == kind
        dk, side = d[mine], grasps[mine] == "side"
        cuts = np.unique(dk)
        cuts = np.concatenate([[cuts[0] - 1e-3], (cuts[:-1] + cuts[1:]) / 2, [cuts[-1] + 1e-3]])
        wrong = [int(((dk > c) != side).sum()) for c in cuts]
        out[kind] = float(cuts[int(np.argmin(wrong))])
    return out


def fit(form: str, kinds: np.ndarray, grasps: np.ndarray, d: np.ndarray,
        y: np.ndarray) -> PickupModel:
    """Least-squares polynomials of one candidate form, per group; every model also holds
    "*" (all samples, same degree) for a group its samples did not have."""
    from s3o_drake.planning.time_model import PickupModel

    degree, grouping = FORMS[form]
    keys = {"all": np.full(len(d), "*"), "kind": kinds,
            "kind/grasp": np.char.add(np.char.add(kinds.astype(str), "/"), grasps.astype(str))
            }[grouping]
    coefficients = {}
    for key in ["*", *sorted(set(keys.tolist()) - {"*"})]:
        rows = np.ones(len(d), bool) if key == "*" else keys == key
        deg = min(degree, int(rows.sum()) - 1, len(np.unique(d[rows])) - 1)
        c = np.polynomial.polynomial.polyfit(d[rows], y[rows], max(deg, 0))
        coefficients[key] = tuple(float(v) for v in c)
    side = side_thresholds(kinds, grasps, d) if grouping == "kind/grasp" else {}
    return PickupModel(form, coefficients, side)


def held_out_errors(rows: list[dict], folds: int = FOLDS) -> dict[str, dict[str, float]]:
    """Per candidate form, the mean absolute and root-mean-square error (s) of predictions
    for tasks held out of the fit (tasks split into `folds` groups in name order); the
    grasp of a held-out pickup is the predicted one, as the planner has it."""
    tasks = sorted({r["task"] for r in rows})
    fold_of = {t: i % folds for i, t in enumerate(tasks)}
    fold = np.array([fold_of[r["task"]] for r in rows])
    kinds, grasps, d, y = _arrays(rows)
    out = {}
    for form in FORMS:
        errors = np.full(len(rows), np.nan)
        for f in range(folds):
            test, train = fold == f, fold != f
            if not test.any():
                continue
            model = fit(form, kinds[train], grasps[train], d[train], y[train])
            errors[test] = [float(model.duration(k, x)) - yy
                            for k, x, yy in zip(kinds[test], d[test], y[test], strict=True)]
        out[form] = {"mae": float(np.mean(np.abs(errors))),
                     "rmse": float(np.sqrt(np.mean(errors**2)))}
    return out


def _arrays(rows: list[dict]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    return (np.array([r["kind"] for r in rows]), np.array([r["grasp"] for r in rows]),
            np.array([r["distance"] for r in rows]), np.array([r["duration"] for r in rows]))


def derive(samples: int, seed: int, command: str, *, progress: bool = True
           ) -> tuple[TimeModel, list[dict]]:
    """The time model from `samples` planned pickups (docs/commands.md, "s3o build
    time-model")."""
    from s3o_drake.planning.navigation.base_motion import (
        ACCELERATION,
        SETTLE_TIME,
        YAW_ACCELERATION,
        YAW_RATE,
    )
    from s3o_drake.planning.time_model import TURN_TOLERANCE, TimeModel, command_overheads
    from s3o_drake.world.resources import RESTAURANT, shipped_tasks
    from s3o_drake.world.robot import CONTROL_PERIOD

    paths = [RESTAURANT, *shipped_tasks()]
    rows = sample_pickups(paths, samples, seed, progress=progress)
    good = [r for r in rows if r["ok"]]
    if len(good) < 2 * FOLDS:
        raise RuntimeError(f"only {len(good)} pickups could be planned; need {2 * FOLDS}")
    errors = held_out_errors(good)
    best = min(FORMS, key=lambda f: errors[f]["rmse"])
    kinds, grasps, d, y = _arrays(good)
    model = fit(best, kinds, grasps, d, y)
    residual = y - np.array([model.duration(k, x) for k, x in zip(kinds, d, strict=True)])
    failed: dict[str, int] = {}
    for r in rows:
        if not r["ok"]:
            failed[r["reason"]] = failed.get(r["reason"], 0) + 1
    grasps: dict[str, int] = {}
    for r in good:
        grasps[r["grasp"]] = grasps.get(r["grasp"], 0) + 1
    provenance = {
        "command": command, "seed": seed, "samples": len(good),
        "tasks": f"scenarios/restaurant.yaml and the first {len({r['task'] for r in rows}) - 1}"
                 " of scenarios/generated/",
        "control_period": CONTROL_PERIOD,
        "base": {"acceleration": ACCELERATION, "yaw_rate": YAW_RATE,
                 "yaw_acceleration": YAW_ACCELERATION, "settle_time": SETTLE_TIME},
    }
    fit_info = {
        "feature": "d, the distance (m) from the base's centre to the dish",
        "chosen_by": f"least RMSE on held-out tasks ({FOLDS} folds)",
        "held_out": errors,
        "residual_rmse": float(np.sqrt(np.mean(residual**2))),
        "duration": {"min": float(y.min()), "median": float(np.median(y)),
                     "max": float(y.max())},
        "distance": {"min": float(d.min()), "median": float(np.median(d)),
                     "max": float(d.max())},
        "kinds": {k: int((kinds == k).sum()) for k in sorted(set(kinds.tolist()))},
        "grasps": grasps, "not_planned": failed,
    }
    overheads = command_overheads(CONTROL_PERIOD, SETTLE_TIME)
    return TimeModel(overheads=overheads, pickup=model, turn_tolerance=TURN_TOLERANCE,
                     provenance=provenance, fit=fit_info), rows


def write_model(model: TimeModel, path: Path) -> None:
    """The model as YAML, written whole or not at all."""
    import yaml

    from s3o_drake.world.files import write_atomically

    header = ("# The planner's time model for our robot (s3o_drake/planning/time_model.py).\n"
              "# Written by the command below; do not edit by hand: re-run it whenever the\n"
              "# arm's or the base's motion changes.\n")
    body = yaml.safe_dump(_rounded(model.to_dict()), sort_keys=False, default_flow_style=None,
                          width=96)
    write_atomically(path, header + body)


def _rounded(value):
    """Floats to 6 decimals (µs and µm: far below what the model can tell), for a file
    that people read."""
    if isinstance(value, float):
        return round(value, 6)
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_rounded(v) for v in value]
    return value


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("build time-model", __doc__)
    parser.add_argument("--samples", type=at_least(2 * FOLDS), default=400, metavar="N",
                        help="pickups to plan (default 400)")
    add_seed(parser, 0, "seed of the draws")
    add_out(parser, file=True, default=str(DEFAULT_OUT),
            note=f"the shipped model is replaced only when told: --out "
                 f"{TIME_MODEL.relative_to(REPO_DIR)}")
    args = parser.parse_args(argv)
    out = out_file(args.out)
    logging.getLogger("drake").setLevel(logging.WARNING)
    command = f"s3o build time-model --samples {args.samples} --seed {args.seed}"
    t0 = time.perf_counter()
    model, rows = derive(args.samples, args.seed, command)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_model(model, out)
    print(f"{len(rows)} pickups planned in {time.perf_counter() - t0:.0f} s, "
          f"{model.provenance['samples']} ok")
    print(f"{'model':<26} {'held-out MAE':>13} {'RMSE':>7}")
    for form, e in model.fit["held_out"].items():
        mark = "  <- chosen" if form == model.pickup.form else ""
        print(f"{form:<26} {e['mae']:12.3f}s {e['rmse']:6.3f}s{mark}")
    for key, c in sorted(model.pickup.coefficients.items()):
        terms = " + ".join(f"{v:.3f}" + ("" if i == 0 else " d" if i == 1 else f" d^{i}")
                           for i, v in enumerate(c))
        print(f"  pickup duration [{key}] = {terms} (s, d in m)")
    for kind, beyond in sorted(model.pickup.side_beyond.items()):
        print(f"  {kind}: side grasp beyond d = {beyond:.3f} m")
    o = model.overheads
    print(f"gamma {o.gamma:.3f} s per base command, pickup hand-over {o.pickup:.3f} s, "
          f"plan {o.plan:+.3f} s")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
