"""What a study's result rows say beyond their fields: whether a run has an execution time,
the completion its plan predicted, and the commit the rows were made at."""

from collections import Counter
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from s3o_drake.experiments.store import robot_of
from s3o_drake.world.choices import Motion

if TYPE_CHECKING:
    from s3o_drake.planning.time_model import TimeModel

MOTION_FIELD = "execution.motion"
"""The scenario field of the motion, as `--set` names it."""


def has_time(run: Mapping) -> bool:
    """Whether a run has an execution time: it made a plan (one without has none, not 0 s)."""
    return bool(run.get("planned", True))


def predicted_completion(run: Mapping) -> float:
    """The chance the run's plan gave itself of collecting every dish: the product of the
    plan's Fea^m of its pickups, 0 with a dish left out or without a plan. Rows made before
    it was recorded (`predicted_completion`) give it from their pickup records (each dish's
    first, as planned), a dish without one counting 0."""
    if "predicted_completion" in run:
        return float(run["predicted_completion"])
    if not has_time(run):
        return 0.0
    first: dict[str, float] = {}
    for p in run.get("pickups", ()):
        first.setdefault(p["dish"], p.get("planned") if p.get("planned") is not None
                         else p["predicted"])
    if len(first) < run.get("dishes", len(first)):
        return 0.0
    return float(np.prod(list(first.values()))) if first else 1.0


def expected_time(run: Mapping, model: "TimeModel") -> float | None:
    """The execution time the run's plan expected with the noise (s): its `expected_time`,
    or for rows made before that was recorded, its predicted time plus what `model`'s noise
    terms add to its gotos and pickups, counted from its outcomes, where those are its plan's
    (no recovery) and the noise was the default one; None otherwise."""
    if "expected_time" in run:
        return run["expected_time"]
    if (not run.get("predicted_time") or run.get("recoveries")
            or any(o.startswith("uncertainty.") for o in run.get("overrides") or ())):
        return None
    outcomes = run.get("outcomes") or ()
    return _expected(model, motion_of(run), float(run["predicted_time"]),
                     gotos=sum(o.startswith("goto ") for o in outcomes),
                     pickups=sum(o.startswith("pickup ") for o in outcomes))


def _expected(model: "TimeModel", motion: str, predicted: float, *, gotos: int,
              pickups: int) -> float | None:
    from s3o_drake.world.settings import Uncertainty

    extra = model.noise_time(motion, Uncertainty(), gotos=gotos, pickups=pickups)
    return None if extra is None else predicted + extra


def code_of(runs: Sequence[Mapping]) -> str:
    """The commit the runs were made at ("a (n), b (m)" when several)."""
    return _recorded(runs, "code", separator=", ")


def packages_of(runs: Sequence[Mapping]) -> str:
    """The packages' versions the runs were made with (`store.packages_version`), as
    `code_of` says the commits ("a (n); b (m)" when several)."""
    return _recorded(runs, "packages", separator="; ")


def machine_of(runs: Sequence[Mapping]) -> str:
    """The processors the runs were made on (`store.machine_version`), as `packages_of`
    says the packages."""
    return _recorded(runs, "machine", separator="; ")


def _recorded(runs: Sequence[Mapping], field: str, *, separator: str) -> str:
    """The runs' value of a bookkeeping `field`, or each value with its count, the most
    common first ("not recorded" for rows written before the field was)."""
    counts = Counter(r.get(field, "not recorded") for r in runs)
    if len(counts) == 1:
        return next(iter(counts))
    return separator.join(f"{c} ({n})" for c, n in counts.most_common())


BOOKKEEPING = frozenset({"code", "packages", "machine", "schema", "job_seconds",
                         "planning_time", "realtime_rate", "key", "path", "digest"})
"""Fields of a run's row that say when, where and how fast it ran, not what it did."""


def motion_of(run: Mapping) -> str:
    """The motion a run ran with (`execution.motion`): rows from before it was recorded
    stopped and went."""
    return str(run.get("motion", Motion.STOP_AND_GO.value))


def _what_it_did(value: object, top: bool = True) -> object:
    """`value` without bookkeeping and wall-clock timings, at any depth; a run's robot and
    motion always named (rows from before they were recorded ran the UR5e, stopping and
    going), the motion not among the fields a study replaced."""
    if isinstance(value, Mapping):
        kept = {k: _what_it_did(v, False) for k, v in value.items()
                if k not in BOOKKEEPING and "wall" not in k and k != "timing"}
        if not top:
            return kept
        if "overrides" in kept:
            kept["overrides"] = [o for o in kept["overrides"]
                                 if not str(o).startswith(f"{MOTION_FIELD}=")]
        return {**kept, "robot": robot_of(value), "motion": motion_of(value)}
    if isinstance(value, list | tuple):
        return [_what_it_did(v, False) for v in value]
    return value


def same_values(x, y, tolerance: float = 0.0) -> bool:
    """Whether two row values are the same: equal, or numbers (within lists and mappings
    alike) that differ by at most `tolerance` times the larger of 1 and their size."""
    if isinstance(x, Mapping) and isinstance(y, Mapping):
        return x.keys() == y.keys() and all(same_values(x[k], y[k], tolerance) for k in x)
    if isinstance(x, (list, tuple)) and isinstance(y, (list, tuple)):
        return len(x) == len(y) and all(same_values(u, v, tolerance)
                                        for u, v in zip(x, y, strict=True))
    if (isinstance(x, float) or isinstance(y, float)) and not isinstance(x, bool) and \
            not isinstance(y, bool) and isinstance(x, (int, float)) and \
            isinstance(y, (int, float)):
        return x == y or abs(x - y) <= tolerance * max(1.0, abs(x), abs(y))
    return x == y


def run_differences(before: Sequence[Mapping], after: Sequence[Mapping],
                    tolerance: float = 0.0) -> tuple[int, list[str]]:
    """The runs that both sets hold (by task, method, run seed and recovery), and one line
    per field where a run did something else: plans, outcomes, pickups, recoveries,
    simulated times (numbers the same within `tolerance`: `same_values`). Timings of the
    machine and bookkeeping are left out, and so are fields that only one of the versions
    records."""
    def keyed(rows):
        return {(r["task"], r["method"], r.get("run_seed"), r.get("recovery", "none")): r
                for r in rows if "error" not in r}
    a, b = keyed(before), keyed(after)
    common = sorted(set(a) & set(b))
    lines = []
    for key in common:
        x, y = _what_it_did(a[key]), _what_it_did(b[key])
        # A field one version does not record yet is no difference in what the run did.
        for field in sorted(set(x) & set(y)):
            if not same_values(x[field], y[field], tolerance):
                lines.append(f"{'/'.join(map(str, key))}: {field}: {str(x[field])[:80]} "
                             f"-> {str(y[field])[:80]}")
    return len(common), lines
