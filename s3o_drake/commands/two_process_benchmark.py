"""One process against two: the robot beside its controllers, or on a bus.

    s3o bench two-process [--tasks PATH ...] [--count N] [--seed N] [--realtime-rate R]
                          [--loss P] [--set PATH=VALUE] [--json FILE]

Runs each task (default: the first 10 generated tasks and scenarios/tidy_home.yaml) with
--recovery replan three times: in one process twice (`s3o run`'s execution; the second must
repeat the first, timings aside), then in two, `s3o sim` in a process of its own on a bus of
this machine and the controllers in this one (`s3o run --robot lcm`'s). The two agree when
they collect the same dishes with as many stops, within 2 % of execution time (the robot's
time while the controllers planned left out, as one process's plans take no simulated
time). Prints a line per task and how many agree; each task takes its robot time in real
time (`--realtime-rate`, as `s3o sim`'s). `--loss P`: the two processes talk through a relay
that drops each message with probability P, as a lossy network would. Exit status 0 when
every task agrees and the one process repeats itself, 1 when not, 2 on bad input.
"""

from __future__ import annotations

import argparse
import sys

from s3o_drake.commands.common import command_parser
from s3o_drake.commands.options import (
    add_json,
    add_overrides,
    add_seed,
    add_tasks,
    json_store,
    realtime_rate,
    task_paths,
)
from s3o_drake.world.resources import REPO_DIR

DEFAULT_TASKS = (REPO_DIR / "scenarios" / "generated", REPO_DIR / "scenarios" / "tidy_home.yaml")
RECOVERY = "execution.recovery=replan"


def share(text: str) -> float:
    """An argparse type: a share in [0, 1)."""
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0.0 <= value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a share from 0 below 1, got {text!r}")
    return value


def _line(row: dict) -> str:
    one, two = row["one"], row["two"]
    got = f"{len(one['collected_dishes'])}/{len(two['collected_dishes'])}"
    times = (f"{one['execution_time']:6.1f} / {two['execution_time']:6.1f} s "
             f"({100 * (two['execution_time'] / one['execution_time'] - 1):+5.1f} %)"
             if one["execution_time"] else "-")
    said = "agree" if not row["differences"] else "; ".join(row["differences"])
    again = "" if row["repeats"] else "; one process did not repeat itself"
    if "messages_dropped" in two:
        again += (f"; {two['messages_dropped']} of "
                  f"{two['messages_dropped'] + two['messages_passed']} messages lost")
    return (f"{row['task']:<12} dishes {got:<5} stops {one['stops']}/{two['stops']}  "
            f"time {times}  waited {two.get('waited', 0.0):5.1f} s: {said}{again}")


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench two-process", __doc__)
    add_tasks(parser, default=DEFAULT_TASKS)
    add_seed(parser, 0, "the runs' seed")
    parser.add_argument("--realtime-rate", type=realtime_rate, default=1.0, metavar="R",
                        help="the robot's simulated seconds per second (default 1)")
    parser.add_argument("--loss", type=share, default=0.0, metavar="P",
                        help="drop each message between the processes with probability P "
                             "(default 0)")
    add_overrides(parser, "replace a field of every task (after --recovery replan)")
    add_json(parser, "task")
    args = parser.parse_args(argv)
    paths = task_paths(args)
    if args.tasks is None:  # the first 10 generated tasks, and tidy-home
        paths = [p for p in paths if p.parent.name == "generated"][:10] + [
            p for p in paths if p.parent.name != "generated"]
    store = json_store(args)

    from s3o_drake.experiments.two_process import compare_processes

    overrides = [RECOVERY, *args.overrides]
    rows = []
    for i, path in enumerate(paths, 1):
        key = f"{path.stem}:{args.seed}:{args.loss:g}"
        if store is not None and store.finished(key):
            row = next(r for r in store.rows() if r["key"] == key)
        else:
            print(f"[{i}/{len(paths)}] {path.stem}: one process twice, then two",
                  file=sys.stderr, flush=True)
            row = compare_processes(path, seed=args.seed, overrides=overrides,
                                    realtime_rate=args.realtime_rate, loss=args.loss)
            if store is not None:
                store.append(row)
        rows.append(row)
        print(_line(row), flush=True)
    agree = sum(not r["differences"] for r in rows)
    repeats = sum(r["repeats"] for r in rows)
    print(f"two processes agree with one on {agree} of {len(rows)} tasks (the same dishes, "
          f"as many stops, execution time within 2 %); one process repeated itself on "
          f"{repeats} of {len(rows)}")
    return 0 if agree == repeats == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
