"""Calibration of Fea^m against executed pickups: the figures and the reliability diagram.

Fea^m is a probability: of the pickups it rates p, a share p should succeed. The records
(`PickupRecord`, one per executed pickup, written by `run` into report.json and by
`evaluate` into each row of results.jsonl) pair the plan's prediction with the outcome.
From them:

- the reliability diagram: the predictions in equal-width bins of [0, 1], each bin's mean
  prediction against its observed success (with a 95 % Clopper-Pearson interval and the
  count); a calibrated model lies on the diagonal;
- the expected calibration error, ECE = Σ_b (n_b / N) |mean predicted_b - observed_b|;
- the Brier score, mean (p - y)² with y = 1 for a success, 0 for a failure;
- the observed success of the pickups predicted at or above `HIGH` (0.9), with its count
  and 95 % interval: the pickups a planner counts on.

Records of runs from before they were recorded do not exist: such rows are refused, not
guessed (`RecordsError`).
"""

from __future__ import annotations

import functools
import json
import math
from collections import Counter
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; never a window
import numpy as np
from scipy.stats import beta

from s3o_drake.execution.messages import PickupRecord
from s3o_drake.experiments.store import ResultStore
from s3o_drake.world.angles import facing_yaw, wrap
from s3o_drake.world.choices import CALIBRATION_GROUPINGS
from s3o_drake.world.goals import placed_object
from s3o_drake.world.resources import REPO_DIR

HIGH = 0.9
"""Pickups predicted at or above this are the ones a plan counts on."""
LEVEL = 0.95
"""Confidence level of the binomial intervals."""
TURNED_AWAY = 0.15
"""Angle (rad) between the base's yaw and the bearing to its dish beyond which a pickup was
made turned away from the dish. The execution turns to face the dish exactly (half the
study pickups within 0.001 rad), so a larger angle is a turn in place cut short."""
TURN_EDGES = (TURNED_AWAY, 1.0)
"""Edges (rad) of the groups by "turn": facing the dish, turned a little, turned beside or
behind it."""
STOP_SIZES = ("1 dish", "2 dishes", "3+ dishes")
"""The groups by "stop": how many dishes a pickup's stop served (`stop_size_group`)."""
DISTANCE_EDGES = (0.8, 0.9, 0.95, 1.0)
"""Edges (m) of the groups by the planned stop's distance to its dish: Fea^m falls and its
errors grow towards the edge of the arm's reach, where an optimiser that maximises it
tends to stop."""
RESULTS_FILE = "results.jsonl"
REPORT_FILE = "report.json"


class RecordsError(ValueError):
    """The input holds no usable pickup records; the message names the file and why."""


@dataclass(frozen=True)
class Bin:
    """Predictions in [low, high) (the last bin includes 1): how many, their mean, and the
    share that succeeded with its 95 % interval (NaN and None for an empty bin)."""

    low: float
    high: float
    count: int
    successes: int
    mean_predicted: float
    interval: tuple[float, float] | None

    @property
    def observed(self) -> float:
        return self.successes / self.count if self.count else math.nan


@dataclass(frozen=True)
class Calibration:
    """The calibration figures of one set of pickups (see the module docstring)."""

    count: int
    successes: int
    mean_predicted: float
    ece: float
    brier: float
    high_count: int
    """Pickups predicted >= HIGH."""
    high_successes: int
    high_interval: tuple[float, float] | None
    """95 % interval of their success rate (None when there are none)."""
    bins: tuple[Bin, ...]

    @property
    def success_rate(self) -> float:
        return self.successes / self.count if self.count else math.nan

    @property
    def high_success(self) -> float:
        return self.high_successes / self.high_count if self.high_count else math.nan

    def to_dict(self) -> dict:
        """Plain JSON data (None for what is undefined)."""
        def number(v: float) -> float | None:
            return None if math.isnan(v) else v

        return {"pickups": self.count, "successes": self.successes,
                "success_rate": number(self.success_rate),
                "mean_predicted": number(self.mean_predicted), "ece": number(self.ece),
                "brier": number(self.brier), "high_threshold": HIGH,
                "high_pickups": self.high_count, "high_successes": self.high_successes,
                "high_success": number(self.high_success),
                "high_interval": None if self.high_interval is None
                else list(self.high_interval),
                "bins": [{"low": b.low, "high": b.high, "pickups": b.count,
                          "successes": b.successes,
                          "mean_predicted": number(b.mean_predicted),
                          "observed": number(b.observed),
                          "interval": None if b.interval is None else list(b.interval)}
                         for b in self.bins]}


def binomial_interval(successes: int, count: int, level: float = LEVEL) -> tuple[float, float]:
    """Clopper-Pearson (exact) interval of a success rate: conservative, and meaningful for
    the few pickups of a sparse bin and for rates near 1, where the normal one is not."""
    if count <= 0 or not 0 <= successes <= count:
        raise ValueError(f"need 0 <= successes <= count and count > 0, got {successes}/{count}")
    alpha = 1.0 - level
    low = 0.0 if successes == 0 else float(beta.ppf(alpha / 2, successes,
                                                    count - successes + 1))
    high = 1.0 if successes == count else float(beta.ppf(1 - alpha / 2, successes + 1,
                                                         count - successes))
    return low, high


def calibrate(predicted: Sequence[float], succeeded: Sequence[bool], *,
              bins: int = 10) -> Calibration:
    """The figures of pickups predicted `predicted` (each in [0, 1]) with outcomes
    `succeeded`, over `bins` equal-width bins."""
    p = np.asarray(predicted, dtype=float)
    y = np.asarray(succeeded, dtype=bool)
    if p.shape != y.shape or p.ndim != 1:
        raise ValueError("predicted and succeeded must be two sequences of one length")
    if bins < 1:
        raise ValueError(f"bins: expected at least 1, got {bins}")
    if np.any((p < 0) | (p > 1) | ~np.isfinite(p)):
        raise ValueError("predictions must lie in [0, 1]")
    n = len(p)
    index = np.minimum((p * bins).astype(int), bins - 1)  # 1.0 falls in the last bin
    table = []
    ece = 0.0
    for b in range(bins):
        inside = index == b
        count, wins = int(inside.sum()), int(y[inside].sum())
        mean = float(p[inside].mean()) if count else math.nan
        if count:
            ece += count / n * abs(mean - wins / count)
        table.append(Bin(low=b / bins, high=(b + 1) / bins, count=count, successes=wins,
                         mean_predicted=mean,
                         interval=binomial_interval(wins, count) if count else None))
    high = p >= HIGH
    high_count, high_wins = int(high.sum()), int(y[high].sum())
    return Calibration(
        count=n, successes=int(y.sum()), mean_predicted=float(p.mean()) if n else math.nan,
        ece=ece if n else math.nan,
        brier=float(np.mean((p - y) ** 2)) if n else math.nan,
        high_count=high_count, high_successes=high_wins,
        high_interval=binomial_interval(high_wins, high_count) if high_count else None,
        bins=tuple(table))


def calibrate_records(records: Iterable[PickupRecord], *, bins: int = 10) -> Calibration:
    records = list(records)
    return calibrate([r.predicted for r in records], [r.succeeded for r in records],
                     bins=bins)


# --------------------------------------------------------------------------- reading

@dataclass(frozen=True)
class Records:
    """The pickups read from some results, and how many runs they came from."""

    pickups: tuple[PickupRecord, ...]
    runs: int
    files: tuple[Path, ...]
    stops: tuple[int, ...] = ()
    """For each pickup, how many dishes its stop served (`stop_sizes`)."""
    orders: tuple[int, ...] = ()
    """For each pickup, its place among the pickups made from its stop (`stop_orders`)."""
    facing: tuple[float | None, ...] = ()
    """For each pickup, the angle (rad) between the base's yaw and the bearing to its dish
    from where the base stood (`facing_error`); None where the dish's position is not
    known (a run's report, a task file not found, a place target)."""
    distances: tuple[float | None, ...] = ()
    """For each pickup, the distance (m) from its planned stop to its dish; None where the
    dish's position is not known (as for `facing`)."""

    def of_methods(self, methods: Collection[str]) -> Records:
        """These records with only the pickups planned by `methods` (runs and files kept)."""
        kept = [i for i, p in enumerate(self.pickups) if p.method in methods]

        def pick(values: tuple) -> tuple:
            return tuple(values[i] for i in kept) if values else values

        return replace(self, pickups=pick(self.pickups), stops=pick(self.stops),
                       orders=pick(self.orders), facing=pick(self.facing),
                       distances=pick(self.distances))


def read_records(paths: Sequence[str | Path]) -> Records:
    """The pickup records of `paths`: results.jsonl files of `evaluate`, folders holding one
    (else the report.json files below them), report.json files of `run`. RecordsError
    names the first file that holds none or a bad one."""
    pickups: list[PickupRecord] = []
    stops: list[int] = []
    orders: list[int] = []
    facing: list[float | None] = []
    distances: list[float | None] = []
    runs = 0
    files: list[Path] = []
    for path in map(Path, paths):
        for file in _result_files(path):
            if any(file.resolve() == seen.resolve() for seen in files):
                continue  # named twice (a folder and its file): its runs count once
            runs_found = (_read_results(file) if file.suffix == ".jsonl"
                          else [(_read_report(file), None)])
            for found, task in runs_found:
                pickups += found
                poses = [(r.attempt, r.planned_pose) for r in found]
                stops += stop_sizes(poses)
                orders += stop_orders(poses)
                dishes = dish_positions(task)
                facing += [facing_error(r.actual_pose, dishes[r.dish])
                           if r.dish in dishes else None for r in found]
                distances += [stop_distance(r.planned_pose, r.dish, dishes) for r in found]
            runs += len(runs_found)
            files.append(file)
    return Records(pickups=tuple(pickups), runs=runs, files=tuple(files), stops=tuple(stops),
                   orders=tuple(orders), facing=tuple(facing), distances=tuple(distances))


def facing_error(X_WB: Sequence[float], p_WO: Sequence[float]) -> float:
    """The angle (rad, in [0, π]) between the yaw of the base pose `X_WB` (x, y, yaw) and
    the bearing from it to the dish at `p_WO` (x, y)."""
    return abs(wrap(float(X_WB[2]) - facing_yaw(X_WB[:2], p_WO[:2])))


def stop_distance(planned_pose: Sequence[float], dish: str,
                  dishes: Mapping[str, Sequence[float]]) -> float | None:
    """The distance (m) from a pickup's planned stop to its dish, None when `dishes` (as
    `dish_positions` gives them) does not hold it."""
    return math.dist(planned_pose[:2], dishes[dish]) if dish in dishes else None


@functools.cache
def dish_positions(task: str | None) -> dict[str, tuple[float, float]]:
    """The dishes' positions of a study row's task file (its `path`, from the repository
    or the working folder); none when there is no such file."""
    if not task:
        return {}
    from s3o_drake.world.scenario import load_scenario

    for root in (REPO_DIR, Path.cwd()):
        if (root / task).is_file():
            scenario = load_scenario(root / task)
            return {d.name: (float(d.position[0]), float(d.position[1]))
                    for d in scenario.dishes}
    return {}


def stop_sizes(run: Sequence[tuple[int, Sequence[float]]]) -> list[int]:
    """For each pickup of one run, given as (attempt, planned_pose) in the run's order, how
    many dishes the stop it was made from served: the run's first attempts planned at the
    same pose (a merged location's stop serves several; a stop moved by a correction counts
    as its own)."""
    served = Counter(_stop_key(pose) for attempt, pose in run if attempt == 1)
    return [max(1, served[_stop_key(pose)]) for _, pose in run]


def stop_orders(run: Sequence[tuple[int, Sequence[float]]]) -> list[int]:
    """For each pickup of one run, given as in `stop_sizes`, its place among the first
    attempts planned at the same pose: 1 for the first, made as the base arrived; 2, 3, ...
    for those made after a turn in place at the stop (a retry keeps the place of the
    pickup it retries)."""
    seen: Counter[tuple[float, ...]] = Counter()
    orders = []
    for attempt, pose in run:
        key = _stop_key(pose)
        if attempt == 1:
            seen[key] += 1
        orders.append(max(1, seen[key]))
    return orders


def _stop_key(pose: Sequence[float]) -> tuple[float, ...]:
    """A planned pose as the key of its stop: the pickups planned at one stop share it."""
    return tuple(round(float(v), 6) for v in pose)


def _result_files(path: Path) -> list[Path]:
    if path.is_dir():
        if (path / RESULTS_FILE).is_file():
            return [path / RESULTS_FILE]
        reports = sorted(p for p in path.rglob(REPORT_FILE) if p.is_file())
        if not reports:
            raise RecordsError(f"{path}: no {RESULTS_FILE} in it and no {REPORT_FILE} "
                               "below it")
        return reports
    if not path.is_file():
        raise RecordsError(f"{path}: no such file or folder")
    return [path]


def _read_results(path: Path) -> list[tuple[list[PickupRecord], str | None]]:
    """A study's results (JSON lines, as ResultStore reads them: the last row of a key):
    each run's records and its task file."""
    rows = [r for r in ResultStore(path, read_only=True).rows()
            if r.get("kind") == "run" and "error" not in r]
    if not rows:
        raise RecordsError(f"{path}: no finished runs (not a results.jsonl of evaluate?)")
    old = [r for r in rows if "pickups" not in r]
    if old:
        raise RecordsError(
            f"{path}: {len(old)} of {len(rows)} runs have no per-pickup records (written "
            "before they were recorded: their predicted Fea^m is not in the file)")
    return [(_parse(row["pickups"], f"{path}: run {row['key']}"), row.get("path"))
            for row in rows]


def _read_report(path: Path) -> list[PickupRecord]:
    try:
        report = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise RecordsError(f"{path}: not a JSON report ({str(e).splitlines()[0]})") from e
    if not isinstance(report, dict) or "outcomes" not in report:
        raise RecordsError(f"{path}: not a run report (no outcomes)")
    if "pickups" not in report:
        raise RecordsError(f"{path}: a run report without per-pickup records (written "
                           "before they were recorded)")
    return _parse(report["pickups"], str(path))


def _parse(data: object, where: str) -> list[PickupRecord]:
    if not isinstance(data, list):
        raise RecordsError(f"{where}: pickups: expected a list, got {data!r:.60}")
    records = []
    for i, item in enumerate(data):
        try:
            records.append(PickupRecord.from_dict(item))
        except ValueError as e:
            raise RecordsError(f"{where}: pickups[{i}]: {e}") from e
    return records


# ------------------------------------------------------------------------- reporting

def action_of(record: PickupRecord) -> str:
    """"place" for the record of putting an object down (its dish is a place target),
    else "pickup"."""
    return "pickup" if placed_object(record.dish) is None else "place"


def grouped(records: Sequence[PickupRecord], by: str, *,
            stops: Sequence[int] | None = None, orders: Sequence[int] | None = None,
            facing: Sequence[float | None] | None = None,
            distances: Sequence[float | None] | None = None) -> dict[str, list[PickupRecord]]:
    """The records by "method", "source", "action" (`action_of`), "stop" (how many dishes
    the record's stop served, `stops[i]` for `records[i]`: "1 dish", "2 dishes", "3+
    dishes"), "facing" (that, and whether the base faced the dish, `facing[i]` within
    TURNED_AWAY: "1 dish, facing", "1 dish, turned away", "..., position unknown"), "turn"
    (that angle alone, between TURN_EDGES: "0.00-0.15 rad", ..., "1.00 rad or more",
    "position unknown") or "order" (the record's place at its stop, `orders[i]`:
    "1st at its stop", "2nd at its stop", "3rd+ at its stop") or "distance" (from the
    planned stop to the dish, `distances[i]`, between DISTANCE_EDGES: "0.00-0.80 m", ...,
    "1.00 m or more", "position unknown"), keys sorted; or all under "all" (by "all")."""
    if by == "all":
        return {"all": list(records)}
    if by not in CALIBRATION_GROUPINGS:
        raise ValueError(f"by: expected one of {', '.join(CALIBRATION_GROUPINGS)}, got {by!r}")
    if by in ("stop", "facing") and (stops is None or len(stops) != len(records)):
        raise ValueError(f"by {by}: needs how many dishes each record's stop served")
    if by in ("facing", "turn") and (facing is None or len(facing) != len(records)):
        raise ValueError(f"by {by}: needs each record's angle to its dish")
    if by == "order" and (orders is None or len(orders) != len(records)):
        raise ValueError("by order: needs each record's place at its stop")
    if by == "distance" and (distances is None or len(distances) != len(records)):
        raise ValueError("by distance: needs each record's distance to its dish")
    groups: dict[str, list[PickupRecord]] = {}
    for i, record in enumerate(records):
        if by in ("stop", "facing"):
            key = stop_size_group(stops[i])
            if by == "facing":
                key += (", position unknown" if facing[i] is None else
                        ", turned away" if facing[i] > TURNED_AWAY else ", facing")
        elif by == "order":
            key = ("1st", "2nd", "3rd+")[min(orders[i], 3) - 1] + " at its stop"
        elif by == "distance":
            key = distance_group(distances[i])
        elif by == "turn":
            key = binned(facing[i], TURN_EDGES, "rad")
        else:
            key = action_of(record) if by == "action" else getattr(record, by)
        groups.setdefault(key, []).append(record)
    return dict(sorted(groups.items()))


def stop_size_group(size: int) -> str:
    """The name of the group (by "stop") of a stop that served `size` dishes."""
    return STOP_SIZES[min(size, len(STOP_SIZES)) - 1]


def distance_group(distance: float | None) -> str:
    """The name of the group (by "distance") of a stop `distance` (m) from its dish."""
    return binned(distance, DISTANCE_EDGES, "m")


def binned(value: float | None, edges: Sequence[float], unit: str) -> str:
    """The name of the bin between `edges` (from 0) that holds `value`: "0.00-0.80 m", ...,
    "1.00 m or more"; "position unknown" for None."""
    if value is None:
        return "position unknown"
    k = int(np.searchsorted(edges, value, side="right"))
    if k == len(edges):
        return f"{edges[-1]:.2f} {unit} or more"
    low = 0.0 if k == 0 else edges[k - 1]
    return f"{low:.2f}-{edges[k]:.2f} {unit}"


def figures_table(figures: Mapping[str, Calibration]) -> str:
    """One line per group: pickups, success, mean prediction, ECE, Brier, and the success
    of those predicted >= HIGH with its count and 95 % interval."""
    name_width = max(12, *(len(name) for name in figures))
    lines = [f"{'':<{name_width}}  pickups  success  mean Fea^m    ECE   Brier   "
             f"Fea^m >= {HIGH:g}: success (n) [95 % interval]"]
    for name, f in figures.items():
        if f.high_count:
            low, high = f.high_interval
            top = f"{f.high_success:.3f} ({f.high_count}) [{low:.3f}, {high:.3f}]"
        else:
            top = "none"
        lines.append(f"{name:<{name_width}}  {f.count:7d}  {f.success_rate:7.3f}  "
                     f"{f.mean_predicted:10.3f}  {f.ece:5.3f}  {f.brier:6.3f}   {top}")
    return "\n".join(lines)


