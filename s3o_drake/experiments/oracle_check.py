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
above.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ALL_BELOW = 0.8
"""Every first pickup the plan valued below this is in the sample."""
BINS = ((0.0, 0.7), (0.7, 0.8), (0.8, 0.9), (0.9, 1.0))


@dataclass(frozen=True)
class Pickup:
    """A first pickup attempt of a run: where the plan sent the base, what the plan valued
    it, what happened, and the dishes the run had collected before it."""

    key: str
    path: str
    dish: str
    planned: float
    planned_pose: tuple[float, float, float]
    done: bool
    before: tuple[str, ...]


def first_pickups(rows: Iterable[Mapping]) -> list[Pickup]:
    """The first attempt at each dish of every run that recorded its pickups."""
    out = []
    for row in rows:
        collected: list[str] = []
        for i, p in enumerate(row.get("pickups") or []):
            if p.get("attempt") == 1 and p.get("planned") is not None:
                out.append(Pickup(f"{row['key']}#{i}", row["path"], p["dish"],
                                  float(p["planned"]),
                                  tuple(float(v) for v in p["planned_pose"]),
                                  p["outcome"] == "done", tuple(collected)))
            if p["outcome"] == "done":
                collected.append(p["dish"])
    return out


def stratified(pickups: Sequence[Pickup], per_bin: Mapping[tuple[float, float], int], *,
               seed: int) -> list[Pickup]:
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


def evaluate(pickup: Pickup, oracle, *, samples: int, seed: int) -> dict:
    """The oracle's expectation and Monte Carlo at the pickup's planned pose (`oracle`: the
    FeasibilityOracle of the known world at the pickup)."""
    from s3o_drake.feasibility.oracle import CROP_CELLS, CROP_SIZE

    x, y, _ = pickup.planned_pose
    cell = CROP_SIZE / CROP_CELLS  # the heatmaps' own cell: the same blur
    expectation = float(oracle.expectation(pickup.dish, np.array([x, x + cell]),
                                           np.array([y, y + cell]))[0, 0])
    monte_carlo = oracle.probability(np.array([x, y]), pickup.dish,
                                     rng=np.random.default_rng(seed), samples=samples)
    return {"key": pickup.key, "path": pickup.path, "dish": pickup.dish,
            "planned": pickup.planned, "done": pickup.done, "expectation": expectation,
            "monte_carlo": monte_carlo}


def oracle_of(pickup: Pickup, root: Path):
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
