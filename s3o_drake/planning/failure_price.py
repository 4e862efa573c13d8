"""What a pickup's chance of failing costs the utility, in the execution's mode.

The utility rewards a pickup with λ Fea^m: a plan loses λ (1 - Fea^m) in expectation for the
chance that the pickup fails. That is the paper's price, and it is the right one in open loop,
where a failed pickup loses the dish. With recovery the dish is not lost: the robot checks the
stop from where it landed, corrects it by a short move and retries, so a pickup that may fail
costs the time those recoveries take. Its price is then that time per expected failure,

    c = Σ recovery time / Σ (1 - Fea^m),

over the first pickup attempt of every dish of recorded runs with recovery (Fea^m as planned,
the recoveries the corrections and retries of that dish). It is a ratio estimator: with a
calibrated Fea^m the expected number of failures is Σ (1 - Fea^m), and recoveries that Fea^m
does not foresee (a correction after a poor landing) are priced in too. `derive_price` computes
it; `s3o failure-price` derives it from studies and records it in
models/ur5e/failure_price.yaml; `priced_planner` applies it.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from s3o_drake.abstraction.shared_stop import uses_recorded_shares
from s3o_drake.world.choices import Recovery, SharedStop
from s3o_drake.world.robot import Robot
from s3o_drake.world.settings import PlanningSettings, Settings

FORMAT = "s3o_drake.FailurePrice/1"
RECOVERY_KINDS = ("correction", "retry")
"""The recoveries a pickup that may fail costs: moves to a better stop, and tries again."""


@dataclass(frozen=True)
class FailurePrice:
    """The recorded price (s per expected failure) of a pickup under recovery."""

    seconds: float
    provenance: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"format": FORMAT, "seconds": float(self.seconds), **dict(self.provenance)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> FailurePrice:
        if data.get("format") != FORMAT:
            raise ValueError(f"not a failure price (format {data.get('format')!r}, expected "
                             f"{FORMAT!r})")
        seconds = float(data["seconds"])
        if not seconds > 0:
            raise ValueError(f"seconds: must be positive, got {seconds:g}")
        return cls(seconds, {k: v for k, v in data.items() if k not in ("format", "seconds")})

    @classmethod
    def load(cls, path: str | Path) -> FailurePrice:
        """The recorded price at `path` (a robot's: `Robot.files.failure_price`; cached per
        path)."""
        return _load(str(Path(path).resolve()))


@functools.lru_cache(maxsize=4)
def _load(path: str) -> FailurePrice:
    if not Path(path).is_file():
        raise FileNotFoundError(f"{path}: no failure price; make it with "
                                "`s3o failure-price`")
    return FailurePrice.from_dict(yaml.safe_load(Path(path).read_text()))


@dataclass(frozen=True)
class PricedPickup:
    """A dish's first planned pickup in a run with recovery, and what recovering it cost."""

    predicted: float
    """Fea^m of the pickup as planned."""
    recovery_time: float
    """Simulated time (s) of the corrections and retries of the dish in that plan."""


def derive_price(records: Iterable[PricedPickup], *, resamples: int = 2000,
                 seed: int = 0) -> dict[str, float]:
    """c of the module docstring, with a 95 % bootstrap interval over the records, and the
    totals it is made of."""
    data = np.array([(r.predicted, r.recovery_time) for r in records], dtype=float)
    if len(data) == 0:
        raise ValueError("no pickups to derive a failure price from")
    expected = 1.0 - np.clip(data[:, 0], 0.0, 1.0)
    if expected.sum() <= 0:
        raise ValueError("every pickup was planned at Fea^m 1: no failure was expected")
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, len(data), (resamples, len(data)))
    ratios = data[picks, 1].sum(axis=1) / np.maximum(expected[picks].sum(axis=1), 1e-12)
    low, high = np.percentile(ratios, [2.5, 97.5])
    return {"seconds": float(data[:, 1].sum() / expected.sum()), "low": float(low),
            "high": float(high), "pickups": len(data),
            "expected_failures": float(expected.sum()),
            "recovery_time": float(data[:, 1].sum())}


def uses_recorded_price(settings: Settings) -> bool:
    """Whether `settings` price a failure with the robot's recorded recovery price:
    `failure_price: execution` with recovery on."""
    return (settings.planner.failure_price != "paper"
            and settings.execution.recovery != Recovery.NONE.value)


def failure_reward(settings: Settings, price: FailurePrice | None = None, *,
                   robot: Robot) -> float:
    """λ as the utility prices a pickup's failure under `settings`: the planner's λ, or with
    `failure_price: execution` and recovery on, the recovery price recorded for `robot`
    (or `price`)."""
    if not uses_recorded_price(settings):
        return settings.planner.reward
    return (price or FailurePrice.load(robot.files.failure_price)).seconds


def priced_planner(settings: Settings, price: FailurePrice | None = None, *,
                   robot: Robot) -> PlanningSettings:
    """The planner settings as the execution's mode prices a pickup: λ replaced by
    `failure_reward`, and a shared stop's pickups at their Fea^m where the recorded shares
    do not apply (`shared_stop.uses_recorded_shares`: with recovery, whose price holds
    them). The same object when nothing changes."""
    planner = settings.planner
    changes: dict[str, object] = {}
    reward = failure_reward(settings, price, robot=robot)
    if reward != planner.reward:
        changes["reward"] = reward
    if planner.shared_stop != SharedStop.PAPER.value and not uses_recorded_shares(settings):
        changes["shared_stop"] = SharedStop.PAPER.value
    return dataclasses.replace(planner, **changes) if changes else planner
