"""What a pickup at a stop that serves several dishes is worth, against its Fea^m.

Fea^m(y_r, y_o) models a base that drives to y_r to face o. At a stop that serves several
dishes the base arrives facing one of them and turns in place to face each next one: it
stands where the approach to the first dish left it, a chair can cut a turn short, and the
motion search puts the stop where every dish's Fea^m is high at once, at the edges of their
regions, where the model's small errors can add up. Measured over executed pickups, those
at such stops succeed less often than their Fea^m says, where those at one-dish stops are
calibrated (docs/results_7bf8489.md); no one of those causes accounts for it alone. The planner
therefore rates a pickup at a stop serving k dishes at s_k Fea^m, with the share

    s_k = Σ success / Σ Fea^m

over the first attempts of the pickups at stops serving k dishes (k = 2, and 3 or more) of
recorded open-loop runs: a ratio estimator, 1 where Fea^m is calibrated. One-dish stops
keep s_1 = 1. `derive_shares` computes it; `s3o shared-stop` derives it from studies and
records it in the robot's folder (shared_stop.yaml); `stop_shares` reads it for the
planner's utility and its ranking under `planner.shared_stop: execution`, in open loop,
where a failed pickup loses its dish (`uses_recorded_shares`).
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from s3o_drake.world.choices import Recovery, SharedStop
from s3o_drake.world.robot import Robot
from s3o_drake.world.settings import PlanningSettings, Settings

FORMAT = "s3o_drake.SharedStop/1"
SIZES = ("2", "3+")
"""The stop sizes with a share of their own: two dishes, and three or more."""


def size_key(size: int) -> str | None:
    """The key of SIZES that a stop serving `size` dishes falls under (None: one dish)."""
    return None if size < 2 else SIZES[min(size, 3) - 2]


@dataclass(frozen=True)
class StopShares:
    """s_k of the module docstring, by stop size; 1 for a stop that serves one dish."""

    shares: Mapping[str, float]
    provenance: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for key in SIZES:
            value = self.shares.get(key)
            if value is None or not 0 < value <= 1.5:
                raise ValueError(f"shares.{key}: must be a number in (0, 1.5], got {value!r}")

    def of(self, size: int) -> float:
        """The share of a pickup at a stop serving `size` dishes."""
        key = size_key(size)
        return 1.0 if key is None else float(self.shares[key])

    def to_dict(self) -> dict[str, Any]:
        return {"format": FORMAT, "shares": {k: float(self.shares[k]) for k in SIZES},
                **dict(self.provenance)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> StopShares:
        if data.get("format") != FORMAT:
            raise ValueError(f"not a shared-stop record (format {data.get('format')!r}, "
                             f"expected {FORMAT!r})")
        shares = data.get("shares")
        if not isinstance(shares, Mapping):
            raise ValueError("shares: must map the stop sizes 2 and 3+ to numbers")
        return cls({str(k): float(v) for k, v in shares.items()},
                   {k: v for k, v in data.items() if k not in ("format", "shares")})

    @classmethod
    def load(cls, path: str | Path) -> StopShares:
        """The recorded shares at `path` (a robot's: `Robot.files.shared_stop`; cached per
        path)."""
        return _load(str(Path(path).resolve()))


NONE = StopShares({key: 1.0 for key in SIZES})
"""Every pickup at its Fea^m: the paper's rating."""


@functools.lru_cache(maxsize=4)
def _load(path: str) -> StopShares:
    if not Path(path).is_file():
        raise FileNotFoundError(f"{path}: no shared-stop shares; make them with "
                                "`s3o shared-stop`")
    return StopShares.from_dict(yaml.safe_load(Path(path).read_text()))


def uses_recorded_shares(settings: Settings) -> bool:
    """Whether `settings` rate pickups at shared stops by the recorded shares:
    `shared_stop: execution` in open loop. With recovery a failed pickup costs the
    recovery's time, and its recorded price per expected failure (planning/failure_price.py)
    comes from runs whose recoveries at shared stops it already holds."""
    return (settings.planner.shared_stop != SharedStop.PAPER.value
            and settings.execution.recovery == Recovery.NONE.value)


def stop_shares(planner: PlanningSettings, *, robot: Robot | None) -> StopShares:
    """The shares the planner's utility and ranking use: those recorded for `robot` with
    `shared_stop: execution`, NONE with `shared_stop: paper` (which the planner's
    settings say with recovery: `failure_price.priced_planner`; no robot is needed then)."""
    if planner.shared_stop == SharedStop.PAPER.value:
        return NONE
    if robot is None:
        raise ValueError("shared_stop: execution rates pickups by the robot's recorded "
                         "shares, and no robot was given")
    return StopShares.load(robot.files.shared_stop)


@dataclass(frozen=True)
class StopPickup:
    """The first attempt of an executed pickup, and how many dishes its stop served."""

    predicted: float
    """Fea^m of the pickup as planned."""
    succeeded: bool
    stop_size: int


def derive_shares(records: Iterable[StopPickup], *, resamples: int = 2000,
                  seed: int = 0, partial: bool = False) -> dict[str, dict[str, float]]:
    """Per key of SIZES, and for one-dish stops ("1", which the planner keeps at 1, as a
    check of Fea^m's calibration): s_k with a 95 % bootstrap interval over its pickups,
    their count, successes and summed Fea^m. A size without pickups rated above 0 is an
    error, or with `partial` (one study of several, whose sizes the others may hold) left
    out."""
    data = np.array([(r.predicted, float(r.succeeded), r.stop_size) for r in records],
                    dtype=float).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    found: dict[str, dict[str, float]] = {}
    for key in ("1", *SIZES):
        rows = data[[(size_key(int(s)) or "1") == key for s in data[:, 2]]]
        predicted = np.clip(rows[:, 0], 0.0, 1.0)
        if len(rows) == 0 or predicted.sum() <= 0:
            if partial:
                continue
            raise ValueError(f"no pickups with Fea^m > 0 at stops serving {key} "
                             f"dish{'es' if key != '1' else ''}")
        picks = rng.integers(0, len(rows), (resamples, len(rows)))
        ratios = rows[picks, 1].sum(axis=1) / np.maximum(predicted[picks].sum(axis=1), 1e-12)
        low, high = np.percentile(ratios, [2.5, 97.5])
        found[key] = {"share": float(rows[:, 1].sum() / predicted.sum()), "low": float(low),
                      "high": float(high), "pickups": len(rows),
                      "successes": int(rows[:, 1].sum()), "predicted": float(predicted.sum())}
    return found
