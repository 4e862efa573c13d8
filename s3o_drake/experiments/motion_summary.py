"""How the robot moved in a study's runs: its closest approach to the true world, the plan's
predicted time against the simulated one, and where the base landed against its stop.

Per method and motion (`execution.motion`, recorded in every row):

- the closest approach (m): the smallest distance between the robot and the true world's
  walls, tables and chairs over each run, measured in the simulation; its minimum, 5th
  percentile and median over the runs (below zero: a collision);
- the plan's predicted execution time against the simulated one, |predicted - simulated| /
  simulated, its median and the mean signed error, on the runs that collected every dish
  (a run that lost a dish did less than the plan); the same for the time the plan expected
  with the noise (`run_rows.expected_time`: recorded, or for older rows computed from the
  robot's shipped time model), where it has one;
- the landings: for each stop's first executed pickup, the distance between the base's
  position when the pickup was commanded and the stop as planned (the landing noise, and
  whatever the navigator made of it), its median and 90th percentile;
- where the time went (`time_by_motion_table`): the mean seconds of a complete run in each
  kind of motion (`execution.activity.Activity.by_motion`), for the rows that record it.
"""

from collections.abc import Mapping, Sequence

import numpy as np

from s3o_drake.experiments.run_rows import expected_time, has_time, motion_of
from s3o_drake.experiments.store import robot_of

MOTION_HEADER = ("| method | motion | runs | closest approach (m): min | 5th percentile | median "
                  "| complete runs | \\|predicted - simulated\\| / simulated: median | mean "
                  "signed | with an expected time | \\|expected - simulated\\| / simulated: "
                  "median | mean signed | landings | landing offset (m): median "
                  "| 90th percentile |")


def closest_approaches(runs: Sequence[Mapping]) -> np.ndarray:
    """The runs' closest approaches (m), where they were measured."""
    return np.asarray([r["closest_approach"] for r in runs
                       if r.get("closest_approach") is not None], dtype=float)


def time_errors(runs: Sequence[Mapping]) -> np.ndarray:
    """(predicted - simulated) / simulated of the runs that collected every dish."""
    return np.asarray([(r["predicted_time"] - r["execution_time"]) / r["execution_time"]
                       for r in runs if r.get("complete") and has_time(r)
                       and r.get("predicted_time") and r["execution_time"] > 0], dtype=float)


def expected_errors(runs: Sequence[Mapping]) -> np.ndarray:
    """(expected - simulated) / simulated of the runs that collected every dish and have an
    expected time (`run_rows.expected_time`, older rows on their robot's shipped model)."""
    from s3o_drake.planning.time_model import TimeModel
    from s3o_drake.world.robot import load_robot

    out = []
    for r in runs:
        if not (r.get("complete") and has_time(r) and r["execution_time"] > 0):
            continue
        expected = expected_time(r, TimeModel.load(load_robot(robot_of(r)).files.time_model))
        if expected:
            out.append((expected - r["execution_time"]) / r["execution_time"])
    return np.asarray(out, dtype=float)


def landing_offsets(runs: Sequence[Mapping]) -> np.ndarray:
    """For each stop's first executed pickup (the plan's own, attempt 1, at a planned pose
    not seen before in its run): the base's distance from the planned stop (m)."""
    offsets = []
    for run in runs:
        seen = set()
        for record in run.get("pickups") or ():
            planned = tuple(record["planned_pose"])
            if record.get("attempt", 1) != 1 or planned in seen:
                continue
            seen.add(planned)
            actual = record["actual_pose"]
            offsets.append(float(np.hypot(actual[0] - planned[0], actual[1] - planned[1])))
    return np.asarray(offsets, dtype=float)


def motion_table(runs: Sequence[Mapping], methods: Sequence[str]) -> str:
    """The Markdown table of the module docstring, a row per method and motion present."""
    lines = [MOTION_HEADER, "|---" * 15 + "|"]
    for method in methods:
        mine = [r for r in runs if r["method"] == method and "error" not in r]
        for motion in sorted({motion_of(r) for r in mine}):
            these = [r for r in mine if motion_of(r) == motion]
            near, errors = closest_approaches(these), time_errors(these)
            offsets, expected = landing_offsets(these), expected_errors(these)
            cells = [method, motion, str(len(these))]
            cells += ([f"{near.min():.3f}", f"{np.percentile(near, 5):.3f}",
                       f"{np.median(near):.3f}"] if near.size else ["–"] * 3)
            cells += [str(errors.size)] + ([f"{np.median(np.abs(errors)):.1%}",
                                            f"{errors.mean():+.1%}"] if errors.size
                                           else ["–"] * 2)
            cells += [str(expected.size)] + ([f"{np.median(np.abs(expected)):.1%}",
                                              f"{expected.mean():+.1%}"] if expected.size
                                             else ["–"] * 2)
            cells += [str(offsets.size)] + ([f"{np.median(offsets):.3f}",
                                             f"{np.percentile(offsets, 90):.3f}"]
                                            if offsets.size else ["–"] * 2)
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


MOTION_KINDS = ("drive", "turn", "together", "arm", "still")
"""`Activity.by_motion`'s kinds, in the order the table shows them."""


def time_by_motion_table(runs: Sequence[Mapping], methods: Sequence[str]) -> str:
    """Per method and motion, the mean seconds of a complete run in each kind of motion
    (the base driving, turning in place, the base and the arm together, the arm alone,
    neither), over the complete runs whose rows record them; "" when none does."""
    lines = ["| method | motion | complete runs | " + " | ".join(MOTION_KINDS) + " | total |",
             "|---" * (4 + len(MOTION_KINDS)) + "|"]
    for method in methods:
        mine = [r for r in runs if r["method"] == method and r.get("complete")
                and r.get("time_by_motion")]
        for motion in sorted({motion_of(r) for r in mine}):
            these = [r["time_by_motion"] for r in mine if motion_of(r) == motion]
            means = [float(np.mean([t[k] for t in these])) for k in MOTION_KINDS]
            lines.append(f"| {method} | {motion} | {len(these)} | "
                         + " | ".join(f"{m:.1f}" for m in means) + f" | {sum(means):.1f} |")
    return "\n".join(lines) + "\n" if len(lines) > 2 else ""

