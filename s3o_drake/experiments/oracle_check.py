"""Fea^m's models against executed pickups, one pickup at a time: which model is off.

A study's calibration (`experiments/calibration.py`) says whether the Fea^m the plans used
(the network's, by default) matches the pickups' outcomes. When it does not, the question is
which model is off: the network against the Drake oracle it imitates, or the oracle against
the execution. This re-evaluates a sample of a study's first pickup attempts with the
oracle, at the pose the plan sent the base to, on the known world at that moment (the true
chairs, the dishes not yet collected), in both of its ways: the blurred expectation (what
the heatmaps and the network's labels are) and the Monte Carlo over executed landings (its
reference). Then, per bin of the plan's Fea^m, the four against the observed success.

The sample is stratified by the plan's value: every pickup below `ALL_BELOW` (where a
study's pickups are few and the disagreements large), and a seeded draw from each bin
above. Or by a group (`by_group`) where a study's calibration is off: how many dishes the
pickup's stop served, or the stop's distance to the dish. Then each pickup is also tested
where the base really landed, with the reach error the arm really drew (`landed`): the
oracle's success averaged over the executed landings, against its Monte Carlo over the
landings its noise model draws, says whether the landing model is what is off.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ALL_BELOW = 0.8
"""Every first pickup the plan valued below this is in the sample."""
BINS = ((0.0, 0.7), (0.7, 0.8), (0.8, 0.9), (0.9, 1.0))
GROUPINGS = ("stop", "distance")
"""How `by_group` groups the pickups: by the dishes their stop served, or by the stop's
distance to the dish (`calibration.distance_group`)."""


@dataclass(frozen=True)
class ExecutedPickup:
    """A first pickup attempt of a run: where the plan sent the base, what the plan valued
    it, what happened, and the dishes the run had collected before it."""

    key: str
    path: str
    dish: str
    planned: float
    planned_pose: tuple[float, float, float]
    done: bool
    before: tuple[str, ...]
    stop_size: int = 1
    """How many dishes the pickup's stop served (`calibration.stop_sizes`)."""
    landed: tuple[float, float] | None = None
    """Where the base really stood, (x, y), when the pickup was commanded."""
    reach_noise: tuple[float, float] | None = None
    """The reach error the arm really drew (m), None when none was recorded."""
    kind: str = ""
    distance: float | None = None
    """The planned stop's distance (m) to the dish, None where the task file is not found."""


def first_pickups(rows: Iterable[Mapping], *,
                  methods: Sequence[str] | None = None) -> list[ExecutedPickup]:
    """The first attempt at each dish of every run (of `methods`, default all) that recorded
    its pickups."""
    from s3o_drake.experiments.calibration import dish_positions, stop_distance, stop_sizes

    out = []
    for row in rows:
        if methods and row.get("method") not in methods:
            continue
        pickups = row.get("pickups") or []
        sizes = stop_sizes([(p.get("attempt"), p["planned_pose"]) for p in pickups])
        dishes = dish_positions(row["path"])
        collected: list[str] = []
        for i, p in enumerate(pickups):
            if p.get("attempt") == 1 and p.get("planned") is not None:
                actual, noise = p.get("actual_pose"), p.get("reach_noise")
                out.append(ExecutedPickup(
                    f"{row['key']}#{i}", row["path"], p["dish"], float(p["planned"]),
                    tuple(float(v) for v in p["planned_pose"]), p["outcome"] == "done",
                    tuple(collected), stop_size=sizes[i],
                    landed=None if actual is None else (float(actual[0]), float(actual[1])),
                    reach_noise=None if noise is None else (float(noise[0]), float(noise[1])),
                    kind=p.get("kind", ""),
                    distance=stop_distance(p["planned_pose"], p["dish"], dishes)))
            if p["outcome"] == "done":
                collected.append(p["dish"])
    return out


def stop_group(pickup: ExecutedPickup) -> str:
    """The group (`calibration.STOP_SIZES`) of the pickup's stop."""
    from s3o_drake.experiments.calibration import stop_size_group

    return stop_size_group(pickup.stop_size)


def group_names(by: str) -> tuple[str, ...]:
    """The groups of a grouping (`GROUPINGS`), in order."""
    from s3o_drake.experiments.calibration import DISTANCE_EDGES, STOP_SIZES, distance_group

    if by not in GROUPINGS:
        raise ValueError(f"by: expected one of {', '.join(GROUPINGS)}, got {by!r}")
    if by == "stop":
        return STOP_SIZES
    return (*(distance_group(edge) for edge in (0.0, *DISTANCE_EDGES)),
            distance_group(None))


def group_of(pickup: ExecutedPickup, by: str) -> str:
    """The pickup's group by "stop" (`stop_group`) or by "distance"."""
    from s3o_drake.experiments.calibration import distance_group

    return stop_group(pickup) if by == "stop" else distance_group(pickup.distance)


def stratified(pickups: Sequence[ExecutedPickup],
               per_bin: Mapping[tuple[float, float], int], *, seed: int) -> list[ExecutedPickup]:
    """Every pickup valued below ALL_BELOW, and `per_bin[(low, high)]` drawn without
    replacement from each bin at or above it (numpy's default_rng(seed))."""
    rng = np.random.default_rng(seed)
    chosen = [p for p in pickups if p.planned < ALL_BELOW]
    for (low, high), count in per_bin.items():
        inside = [p for p in pickups if low <= p.planned < high or
                  (high >= 1.0 and p.planned >= low)]
        picks = rng.choice(len(inside), size=min(count, len(inside)), replace=False)
        chosen += [inside[i] for i in sorted(picks)]
    return chosen


def by_group(pickups: Sequence[ExecutedPickup], per_group: int, *, by: str,
             seed: int) -> list[ExecutedPickup]:
    """Up to `per_group` pickups drawn without replacement from each group of `by`
    (`group_names`; numpy's default_rng(seed)), in the order of `pickups`."""
    rng = np.random.default_rng(seed)
    chosen: set[int] = set()
    for group in group_names(by):
        inside = [i for i, p in enumerate(pickups) if group_of(p, by) == group]
        picks = rng.choice(len(inside), size=min(per_group, len(inside)), replace=False)
        chosen.update(inside[i] for i in picks)
    return [p for i, p in enumerate(pickups) if i in chosen]


def evaluate(pickup: ExecutedPickup, oracle, *, samples: int, seed: int) -> dict:
    """The oracle's expectation and Monte Carlo at the pickup's planned pose (`oracle`: the
    FeasibilityOracle of the known world at the pickup), and, when the pickup recorded where
    the base landed and the reach error, whether the oracle's test passes there ("landed",
    else None)."""
    from s3o_drake.feasibility.oracle import CROP_CELLS, CROP_SIZE
    from s3o_drake.world.gripper import caught

    x, y, _ = pickup.planned_pose
    cell = CROP_SIZE / CROP_CELLS  # the heatmaps' own cell: the same blur
    expectation = float(oracle.expectation(pickup.dish, np.array([x, x + cell]),
                                           np.array([y, y + cell]))[0, 0])
    monte_carlo = oracle.probability(np.array([x, y]), pickup.dish,
                                     rng=np.random.default_rng(seed), samples=samples)
    landed = None
    if pickup.landed is not None and pickup.reach_noise is not None:
        landed = bool(oracle.landing_success(np.array([pickup.landed]), pickup.dish)[0]
                      and caught(np.array(pickup.reach_noise), pickup.kind,
                                 robot=oracle.checker.scene.robot))
    return {"key": pickup.key, "path": pickup.path, "dish": pickup.dish,
            "planned": pickup.planned, "done": pickup.done, "expectation": expectation,
            "monte_carlo": monte_carlo, "landed": landed,
            **{by: group_of(pickup, by) for by in GROUPINGS}}


def oracle_of(pickup: ExecutedPickup, root: Path):
    """The oracle of the known world at the pickup: the task's true chairs, the dishes the
    run had not yet collected."""
    from s3o_drake.belief.known_world import KnownWorld
    from s3o_drake.feasibility.planning_scene import PlanningScene
    from s3o_drake.world.scenario import load_scenario

    scenario = load_scenario(root / pickup.path)
    left = [d.name for d in KnownWorld.perfect(scenario).dishes if d.name not in pickup.before]
    return PlanningScene(KnownWorld.perfect(scenario, dishes=left)).oracle


def table(rows: Sequence[Mapping]) -> str:
    """Per bin of the plan's Fea^m: pickups, the plan's mean, the oracle's expectation and
    Monte Carlo, the observed success; then the Brier score of each (Markdown)."""
    lines = ["| plan's Fea^m | pickups | plan | oracle, expectation | oracle, Monte Carlo | "
             "observed |", "|---|---|---|---|---|---|"]
    for low, high in BINS:
        inside = [r for r in rows if low <= r["planned"] < high or
                  (high >= 1.0 and r["planned"] >= low)]
        if not inside:
            continue
        means = [np.mean([float(r[k]) for r in inside])
                 for k in ("planned", "expectation", "monte_carlo", "done")]
        lines.append(f"| {low:.1f}-{high:.1f} | {len(inside)} | "
                     + " | ".join(f"{m:.3f}" for m in means) + " |")
    done = np.array([float(r["done"]) for r in rows])
    briers = {k: float(np.mean((np.array([r[k] for r in rows]) - done) ** 2))
              for k in ("planned", "expectation", "monte_carlo")}
    lines += ["", "Brier score against the outcomes: " + ", ".join(
        f"{name} {briers[k]:.4f}" for name, k in
        (("plan", "planned"), ("expectation", "expectation"), ("Monte Carlo", "monte_carlo")))]
    return "\n".join(lines) + "\n"


def group_table(rows: Sequence[Mapping], *, by: str, resamples: int = 2000,
                seed: int = 0) -> str:
    """Per group of `by` (`group_names`): pickups, runs, the plan's mean, the oracle's
    expectation, Monte Carlo and success at the executed landings, the observed success;
    and executed landings less Monte Carlo with a 95 % bootstrap interval over runs (a
    run's pickups share its noise and its world) (Markdown)."""
    title = "stop serves" if by == "stop" else "stop's distance to the dish"
    lines = [f"| {title} | pickups | runs | plan | oracle, expectation | "
             "oracle, Monte Carlo | oracle, executed landings | observed | "
             "executed landings - Monte Carlo (95 %) |", "|---|---|---|---|---|---|---|---|---|"]
    rng = np.random.default_rng(seed)
    for group in group_names(by):
        inside = [r for r in rows if r.get(by) == group and r.get("landed") is not None]
        if not inside:
            continue
        runs: dict[str, list[Mapping]] = {}
        for r in inside:
            runs.setdefault(r["key"].rsplit("#", 1)[0], []).append(r)
        per_run = [(sum(float(r["landed"]) - r["monte_carlo"] for r in rs), len(rs))
                   for rs in runs.values()]
        sums, counts = np.array(per_run).T
        picks = rng.integers(0, len(per_run), (resamples, len(per_run)))
        low, high = np.percentile(sums[picks].sum(axis=1) / counts[picks].sum(axis=1),
                                  [2.5, 97.5])
        means = [np.mean([float(r[k]) for r in inside])
                 for k in ("planned", "expectation", "monte_carlo", "landed", "done")]
        lines.append(f"| {group} | {len(inside)} | {len(runs)} | "
                     + " | ".join(f"{m:.3f}" for m in means)
                     + f" | {means[3] - means[2]:+.3f} [{low:+.3f}, {high:+.3f}] |")
    return "\n".join(lines) + "\n"
