"""Derive the planner's time model from the robot's own motions.

    s3o build time-model [--robot ur5e] [--samples 400] [--seed 0] [--out FILE]
                         [--departure-tasks 10] [--noise-tasks 20] [--workers 1]
                         [--smooth-only | --departure-only | --noise-only]

Plans --samples pickups as the ArmController runs them, from base positions the feasibility
check accepts near the shipped tasks' dishes; fits candidate models of their duration by the
base-dish distance and records the one with the least held-out error, with the command
overheads of the control period. For smooth motion it fits the arm's motions that a smooth
plan overlaps with the base's from the same pickups, and measures the base's wait for the
arm when it leaves a stop on --departure-tasks tasks simulated without noise. Last, for each
motion, what the noise adds on average to a goto and to a pickup: the last --noise-tasks
shipped tasks executed open loop with the noise off and on, the same plan both ways. The
--*-only flags keep the model at --out and make again only the smooth terms, the departure
wait or the noise's terms. Deterministic for a seed; re-run it whenever the arm's or the
base's motion changes.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import yaml

# Light imports only: --help and bad arguments answer before Drake loads; the functions
# import the planner's and the arm's modules where they use them.
from s3o_drake.commands.common import command_parser, fail
from s3o_drake.commands.options import add_out, add_robot, add_seed, at_least, out_file

if TYPE_CHECKING:
    from s3o_drake.feasibility.check import FeasibilityChecker
    from s3o_drake.planning.time_model import NoiseTerms, PickupModel, TimeModel

DEFAULT_OUT = Path("out") / "time_model.yaml"
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


def sample_pickups(paths: Sequence[Path], samples: int, seed: int, *, robot: str,
                   progress: bool = True) -> list[dict]:
    """Feasible pickups of `robot` planned with `plan_pickup` (see the module docstring):
    one row per planned pickup with the task, dish, kind, distance (m), grasp, outcome and
    duration (s)."""
    from s3o_drake.execution.arm.pickup import plan_pickup
    from s3o_drake.feasibility.check import FeasibilityChecker
    from s3o_drake.feasibility.scene import FeasibilityScene
    from s3o_drake.world.scenario import load_scenario, with_overrides

    rng = np.random.default_rng(seed)
    per_task = math.ceil(samples / len(paths))
    rows: list[dict] = []
    for path in paths:
        if len(rows) >= samples:
            break
        scenario = with_overrides(load_scenario(path), (f"robot.name={robot}",))
        if not scenario.dishes:
            continue
        scene = FeasibilityScene(scenario.contents)
        checker = FeasibilityChecker(scene)
        order = rng.permutation(len(scenario.dishes))
        for k in range(min(per_task, samples - len(rows))):
            dish = scenario.dishes[int(order[k % len(order)])]
            reach = scenario.planner.reach_for(scenario.robot_value)
            base = _feasible_base(checker, dish.name, np.asarray(dish.position, float),
                                  reach + BEYOND_REACH, rng)
            if base is None:
                continue
            plan = plan_pickup(scene, checker, base, dish.name,
                               seed=int(rng.integers(2**31 - 1)))
            row = {"task": path.stem, "dish": dish.name, "kind": dish.kind,
                   "distance": float(np.linalg.norm(base[:2] - dish.position)),
                   "grasp": plan.grasp, "ok": plan.ok, "reason": plan.reason,
                   "duration": plan.duration if plan.ok else None}
            if plan.ok:
                # Its own seed: the draws above stay what they were before smooth motion.
                row.update(smooth_parts(scene, checker, base, dish.name,
                                        seed=int(np.random.default_rng([seed, len(rows)])
                                                 .integers(2**31 - 1))))
            rows.append(row)
        if progress:
            print(f"  {path.stem}: {len(rows)} pickups so far", file=sys.stderr, flush=True)
    return rows


def smooth_parts(scene, checker: FeasibilityChecker, base: np.ndarray, dish: str, *,
                 seed: int) -> dict:
    """The durations (s) of the arm's motions a smooth plan is timed with
    (`time_model.SMOOTH_PARTS`), for picking `dish` from `base` as the smooth execution
    does it (the pickup from the stow leaving the arm over the tray; from there to the
    pre-grasp, as the next pickup at a stop goes, and to the stow): each under
    "smooth_<part>", all None where one could not be planned."""
    from s3o_drake.execution.arm.arm_motion import plan_arm_path
    from s3o_drake.execution.arm.pickup import plan_pickup, timed_segment
    from s3o_drake.feasibility.pickup_geometry import with_gripper
    from s3o_drake.planning.time_model import SMOOTH_PARTS

    robot = scene.robot
    none = {f"smooth_{part}": None for part in SMOOTH_PARTS}
    plan = plan_pickup(scene, checker, base, dish, seed=seed, stow=False)
    if not plan.ok:
        return none
    took = {s.name: s.duration for s in plan.segments}
    q_release = plan.segments[-1].waypoints[-1]
    q_pre = plan.segments[1].waypoints[0]  # where "descend" starts
    q_stow = with_gripper(scene.q(q_release[:3]), robot.gripper_open, robot=robot)
    out = {"smooth_grasp": took["descend"] + took["close"] + took["lift"],
           "smooth_tail": took["to_tray"] + took["release"],
           "smooth_prepare": took["approach"]}
    for part, goal in (("from_tray", q_pre), ("stow", q_stow)):
        try:
            path = plan_arm_path(scene.checker, q_release, goal, robot=robot, seed=seed)
        except ValueError:
            path = None
        if path is None:
            return none
        out[f"smooth_{part}"] = timed_segment("approach" if part == "from_tray" else "stow",
                                              path, scene.checker, robot=robot).duration
    return out


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


def held_out_errors(rows: list[dict], folds: int = FOLDS, *, key: str = "duration"
                    ) -> dict[str, dict[str, float]]:
    """Per candidate form, the mean absolute and root-mean-square error (s) of predictions
    for tasks held out of the fit (tasks split into `folds` groups in name order); the
    grasp of a held-out pickup is the predicted one, as the planner has it."""
    tasks = sorted({r["task"] for r in rows})
    fold_of = {t: i % folds for i, t in enumerate(tasks)}
    fold = np.array([fold_of[r["task"]] for r in rows])
    kinds, grasps, d, y = _arrays(rows, key)
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


def _arrays(rows: list[dict], key: str = "duration"
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    return (np.array([r["kind"] for r in rows]), np.array([r["grasp"] for r in rows]),
            np.array([r["distance"] for r in rows]), np.array([r[key] for r in rows]))


def best_fit(rows: list[dict], key: str) -> tuple[PickupModel, dict]:
    """The candidate form of least held-out RMSE for the durations `key` of `rows`, fitted
    to all of them, and how it was chosen."""
    errors = held_out_errors(rows, key=key)
    best = min(FORMS, key=lambda f: errors[f]["rmse"])
    kinds, grasps, d, y = _arrays(rows, key)
    model = fit(best, kinds, grasps, d, y)
    residual = y - np.array([model.duration(k, x) for k, x in zip(kinds, d, strict=True)])
    return model, {"held_out": errors, "residual_rmse": float(np.sqrt(np.mean(residual**2))),
                   "duration": {"min": float(y.min()), "median": float(np.median(y)),
                                "max": float(y.max())}}


def derive(samples: int, seed: int, command: str, *, robot: str, progress: bool = True
           ) -> tuple[TimeModel, list[dict]]:
    """`robot`'s time model from `samples` planned pickups (docs/commands.md, "s3o build
    time-model")."""
    from s3o_drake.planning.navigation.base_motion import (
        ACCELERATION,
        SETTLE_TIME,
        YAW_ACCELERATION,
        YAW_RATE,
    )
    from s3o_drake.planning.time_model import (
        SMOOTH_PARTS,
        TURN_TOLERANCE,
        SmoothArm,
        TimeModel,
        command_overheads,
    )
    from s3o_drake.world.resources import RESTAURANT, shipped_tasks
    from s3o_drake.world.robot import CONTROL_PERIOD

    paths = [RESTAURANT, *shipped_tasks()]
    rows = sample_pickups(paths, samples, seed, robot=robot, progress=progress)
    good = [r for r in rows if r["ok"]]
    if len(good) < 2 * FOLDS:
        raise RuntimeError(f"only {len(good)} pickups could be planned; need {2 * FOLDS}")
    model, chosen = best_fit(good, "duration")
    errors = chosen["held_out"]
    kinds, grasps, d, _ = _arrays(good)
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
        "residual_rmse": chosen["residual_rmse"],
        "duration": chosen["duration"],
        "distance": {"min": float(d.min()), "median": float(np.median(d)),
                     "max": float(d.max())},
        "kinds": {k: int((kinds == k).sum()) for k in sorted(set(kinds.tolist()))},
        "grasps": grasps, "not_planned": failed,
    }
    overheads = command_overheads(CONTROL_PERIOD, SETTLE_TIME)
    smooth_rows = [r for r in good if r.get("smooth_grasp") is not None]
    parts, how = {}, {}
    for part in SMOOTH_PARTS:
        parts[part], how[part] = best_fit(smooth_rows, f"smooth_{part}")
    smooth = SmoothArm(parts=parts, departure=0.0,
                       fit={"samples": len(smooth_rows), "parts": how})
    return TimeModel(overheads=overheads, pickup=model, turn_tolerance=TURN_TOLERANCE,
                     provenance=provenance, fit=fit_info, smooth=smooth), rows


def unmeasured_ratings(robot: str) -> tuple[str, ...]:
    """Overrides for the measured runs of a robot whose shared-stop shares are not recorded
    yet: they come from its calibration's open-loop runs, which plan with this time model,
    so a robot being built rates shared stops as the paper does. The time measured is the
    motion's; the shares only choose which stops the plans make."""
    from s3o_drake.world.robot import load_robot

    if load_robot(robot).files.shared_stop.is_file():
        return ()
    return ("planner.shared_stop=paper",)


def measure_departure(model_path: Path, tasks: Sequence[Path], *, seed: int, robot: str,
                      progress: bool = True) -> tuple[float, list[dict]]:
    """The base's wait for the arm when it leaves a stop, with smooth motion: the median over
    `tasks` (planned with S3O-GROP* on the model at `model_path`, whose departure is 0, and
    simulated without noise) of (simulated - predicted time) per departure, and the runs."""
    from s3o_drake.commands.time_benchmark import measure
    from s3o_drake.experiments.jobs import as_benchmarked
    from s3o_drake.world.scenario import load_scenario, with_overrides

    runs, waits = [], []
    for path in tasks:
        scenario = as_benchmarked(with_overrides(load_scenario(path), (
            "execution.motion=smooth", f"planner.time_model={model_path}",
            f"robot.name={robot}", *unmeasured_ratings(robot))))
        row = measure(path.stem, scenario, method="S3O-GROP*", seed=seed, noise=False)
        n = row["departures"]
        runs.append(row)
        if row["all_done"] and n:
            waits.append((row["execution_time"] - row["predicted_time"]) / n)
        if progress:
            print(f"  {path.stem}: simulated {row['execution_time']:.1f} s, predicted "
                  f"{row['predicted_time']:.1f} s, {n} departures", file=sys.stderr,
                  flush=True)
    if not waits:
        raise RuntimeError("no task was executed as planned: the departure wait is unknown")
    return float(np.median(waits)), runs


def _ratings_fit(robot: str) -> dict:
    """The runs' overrides beyond the scenario's, for the model's record (none: no key)."""
    overrides = unmeasured_ratings(robot)
    return {"planned_with": list(overrides)} if overrides else {}


def noise_terms(pairs: Sequence[tuple[dict, dict]]) -> tuple[float, float, dict]:
    """What the noise adds on average (s) to a goto and to a pickup, from `pairs` of
    `time_benchmark.measure` rows of one plan executed with the noise off and on: each
    action's time (between its report and the one before) with the noise less without, over
    the pairs that did every action in both, in the same order. Returns the two means and
    the counts they rest on."""
    extra: dict[str, list[float]] = {"goto": [], "pickup": []}
    used = 0
    for off, on in pairs:
        if not (off["all_done"] and on["all_done"]
                and off["outcome_actions"] == on["outcome_actions"]):
            continue
        used += 1
        before = np.diff([0.0, *off["outcome_times"]])
        after = np.diff([0.0, *on["outcome_times"]])
        for action, a, b in zip(off["outcome_actions"], before, after, strict=True):
            if action in extra:
                extra[action].append(float(b - a))
    if not extra["goto"] or not extra["pickup"]:
        raise RuntimeError("no plan was executed as planned both with and without the noise: "
                           "what the noise adds is unknown")
    return (float(np.mean(extra["goto"])), float(np.mean(extra["pickup"])),
            {"pairs": len(pairs), "as_planned": used, "gotos": len(extra["goto"]),
             "pickups": len(extra["pickup"])})


def measure_noise(model_path: Path, tasks: Sequence[Path], motion: str, *, seed: int,
                  robot: str, workers: int = 1, progress: bool = True) -> NoiseTerms:
    """`NoiseTerms` of `motion`: `tasks` planned with S3O-GROP* on the model at `model_path`
    and executed with the noise off and on (`noise_terms`), at the scenarios' noise."""
    from s3o_drake.commands.time_benchmark import local_pool, measure_job
    from s3o_drake.experiments.jobs import as_benchmarked
    from s3o_drake.experiments.scheduler import ordered_map
    from s3o_drake.planning.time_model import NOISE_FIELDS, NoiseTerms
    from s3o_drake.world.scenario import load_scenario, with_overrides

    jobs, noise = [], None
    for path in tasks:
        scenario = as_benchmarked(with_overrides(load_scenario(path), (
            f"execution.motion={motion}", f"planner.time_model={model_path}",
            f"robot.name={robot}", *unmeasured_ratings(robot))))
        at = {name: float(getattr(scenario.uncertainty, name)) for name in NOISE_FIELDS}
        if noise is not None and at != noise:
            raise ValueError(f"{path}: its noise {at} is not the other tasks' {noise}")
        noise = at
        jobs += [((path.stem, path.stem, scenario, seed, setting), "S3O-GROP*", "")
                 for setting in ("off", "on")]
    rows: dict[tuple[str, bool], dict] = {}
    with local_pool(workers) as pool:
        for row in ordered_map(pool, measure_job, jobs, window=workers):
            rows[row["task"], row["noise"]] = row
            if progress:
                print(f"  {motion} {row['task']} noise {'on' if row['noise'] else 'off'}: "
                      f"simulated {row['execution_time']:.1f} s, predicted "
                      f"{row['predicted_time'] or float('nan'):.1f} s", file=sys.stderr,
                      flush=True)
    pairs = [(rows[path.stem, False], rows[path.stem, True]) for path in tasks]
    goto, pickup, counts = noise_terms(pairs)
    return NoiseTerms(goto=goto, pickup=pickup, uncertainty=noise, fit={
        "tasks": f"the last {len(tasks)} of scenarios/generated/",
        "measured": "mean over the actions of (time with the noise - time without), "
                    "S3O-GROP*, open loop, runs that did every action in both", **counts})


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
    parser.add_argument("--departure-tasks", type=at_least(1), default=10, metavar="N",
                        help="shipped tasks simulated to measure the smooth base's wait "
                             "for the arm (default 10)")
    parser.add_argument("--noise-tasks", type=at_least(1), default=20, metavar="N",
                        help="shipped tasks (the last N) simulated with the noise off and on "
                             "to measure what it adds, per motion (default 20)")
    parser.add_argument("--workers", type=at_least(1), default=1, metavar="N",
                        help="simulations at once, for the noise's terms (default 1)")
    only = parser.add_mutually_exclusive_group()
    only.add_argument("--smooth-only", action="store_true",
                      help="keep the stop-and-go terms of the model at --out; make only "
                           "the smooth ones")
    only.add_argument("--departure-only", action="store_true",
                      help="keep every term of the model at --out but the departure wait; "
                           "measure it again")
    only.add_argument("--noise-only", action="store_true",
                      help="keep every term of the model at --out but the noise's; measure "
                           "them again")
    add_seed(parser, 0, "seed of the draws")
    add_robot(parser, "the robot timed")
    add_out(parser, file=True, default=str(DEFAULT_OUT),
            note="the shipped model is replaced only when told: --out "
                 "models/NAME/time_model.yaml")
    args = parser.parse_args(argv)
    out = out_file(args.out)
    from s3o_drake.world.resources import repo_path
    from s3o_drake.world.robot import load_robot

    # Every mode measures the noise's terms on runs that plan as the robot plans.
    network = load_robot(args.robot).files.fcn_weights
    if not network.is_file():
        fail(f"--robot: {args.robot!r} has no {repo_path(network)}, which the measured runs "
             f"plan with; make it first with `s3o build robot {args.robot} --steps fcn-data "
             "fcn`")
    logging.getLogger("drake").setLevel(logging.WARNING)
    command = (f"s3o build time-model --robot {args.robot} --samples {args.samples} "
               f"--seed {args.seed} --departure-tasks {args.departure_tasks} "
               f"--noise-tasks {args.noise_tasks}")
    from s3o_drake.planning.time_model import TimeModel

    kept = None
    if args.smooth_only or args.departure_only or args.noise_only:
        flag = ("--smooth-only" if args.smooth_only else "--departure-only"
                if args.departure_only else "--noise-only")
        try:
            kept = TimeModel.from_dict(yaml.safe_load(out.read_text()))
        except (OSError, ValueError, KeyError, TypeError, yaml.YAMLError) as e:
            fail(f"{flag}: no time model to keep at {out}: {e}")
        if (args.departure_only or args.noise_only) and kept.smooth is None:
            fail(f"{flag}: the time model at {out} has no smooth terms")
    t0 = time.perf_counter()
    if args.departure_only:  # measured against the model without it
        model, rows = dataclasses.replace(kept, smooth=dataclasses.replace(
            kept.smooth, departure=0.0)), []
    elif args.noise_only:
        model, rows = kept, []
    else:
        model, rows = derive(args.samples, args.seed, command, robot=args.robot)
    if kept is not None and args.smooth_only:
        model = dataclasses.replace(kept, smooth=dataclasses.replace(
            model.smooth, fit={**model.smooth.fit, "command": command + " --smooth-only"}))
    out.parent.mkdir(parents=True, exist_ok=True)
    from s3o_drake.world.resources import shipped_tasks

    if not args.noise_only:
        write_model(model, out)
        tasks = list(shipped_tasks())[:args.departure_tasks]
        wait, runs = measure_departure(out.resolve(), tasks, seed=args.seed, robot=args.robot)
        model = dataclasses.replace(model, smooth=dataclasses.replace(
            model.smooth, departure=wait, fit={**model.smooth.fit, "departure_measured": {
                "command": command + (" --departure-only" if args.departure_only else ""),
                "tasks": f"the first {len(tasks)} of scenarios/generated/",
                "measured": "median over the tasks of (simulated - predicted) / departures, "
                            "S3O-GROP*, no noise",
                "runs": len(runs), "as_planned": sum(r["all_done"] for r in runs),
                **_ratings_fit(args.robot)}}))
    # The plans do not depend on the noise's terms (the utility leaves them out); they are
    # measured against the model without them all the same.
    model = dataclasses.replace(model, noise={})
    write_model(model, out)
    from s3o_drake.world.choices import Motion

    tasks = list(shipped_tasks())[-args.noise_tasks:]
    noise = {}
    for motion in Motion:
        terms = measure_noise(out.resolve(), tasks, motion.value, seed=args.seed, robot=args.robot,
                              workers=args.workers)
        noise[motion.value] = dataclasses.replace(terms, fit={
            "command": command + (" --noise-only" if args.noise_only else ""), **terms.fit,
            **_ratings_fit(args.robot)})
    model = dataclasses.replace(model, noise=noise)
    write_model(model, out)
    print(f"{len(rows)} pickups planned in {time.perf_counter() - t0:.0f} s, "
          f"{model.provenance['samples']} ok in the stop-and-go terms")
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
    for part, p in model.smooth.parts.items():
        print(f"  smooth {part}: {p.form}, median "
              f"{model.smooth.fit['parts'][part]['duration']['median']:.2f} s")
    print(f"  smooth departure wait {model.smooth.departure:.3f} s")
    for motion, terms in model.noise.items():
        print(f"  the noise adds, {motion}: {terms.goto:.2f} s per goto, {terms.pickup:.2f} s "
              f"per pickup ({terms.fit['as_planned']} of {terms.fit['pairs']} tasks as "
              f"planned both ways)")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
