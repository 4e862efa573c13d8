"""Generate benchmark tasks by the paper's protocol (S3O, section V).

    python -m s3o_drake.commands.generate --count 100 --seed 0 --out scenarios/generated

Every task keeps the room, the seven tables, the robot's start and the settings of a base
scenario and draws anew: 5 to 7 dishes at random
spots on random tables, and one chair that is not on the map near each dish, at a random
position and yaw. Chairs never overlap furniture, walls or each other, and the robot's
start stays free; each task passes the same validation as a hand-written scenario. Every
dish keeps a candidate stop (free, within the planner's reach, and reached by a drive from
the start): a dish that has none, or a chair that would take its last one, is drawn again,
so that no task holds a dish that no method could pick.

The base is the layout's restaurant (--layout): "spacious" (the default,
scenarios/restaurant.yaml; tasks in scenarios/generated) or "dense" (the same tables packed
as in the paper's Gazebo world, scenarios/restaurant_dense.yaml; tasks in
scenarios/generated_dense), or a scenario of one's own (--base). A task keeps its base's
room and tables, by which the benchmark's result rows name its layout ("custom" for a base
of one's own).

Tasks at scale (the planner's benchmark at 10 to 40 dishes): --dishes N draws N dishes per
task instead of 5 to 7, and --chairs M puts M chairs near M of them drawn at random instead
of one near each. A chair per dish of 30 closes every drive in either restaurant.

Mixed collect-and-place tasks (the tidy-home tasks, docs/planning.md): with --places N, N
cups of each task are to be put down at a random free spot on another table instead of
collected (drawn from a stream of their own: where the task has N cups, it is otherwise
the task --places 0 gives).

--chair-margin M asks the drives of that check on a map whose chairs are grown by M (m),
where perception may put them: a dish whose only way passes a chair within millimetres of
the drives' clearance is drawn again too (the shipped tasks were drawn with 0; dense
task_030 and task_045 hold such dishes, docs/results.md). With --check DIR nothing is
drawn: the tasks of DIR whose dishes have no stop at that margin are listed, with those
dishes.

Files are named task_000.yaml, task_001.yaml, ...; task i depends only on --seed and i,
so the same seed gives the same files, and a larger --count extends a smaller one.
Existing files are overwritten; a file is written whole or not at all.
"""

import sys
from functools import partial
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail, read_base
from s3o_drake.world.files import write_atomically
from s3o_drake.world.resources import LAYOUTS, REPO_DIR


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.generate", description=__doc__,
                            formatter_class=doc_formatter())
    parser.add_argument("--count", type=int, default=100, help="number of tasks (default 100)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--out", metavar="DIR",
                        help="output folder (default: the layout's, scenarios/generated or "
                             "scenarios/generated_dense; with --base, scenarios/generated)")
    parser.add_argument("--layout", choices=tuple(LAYOUTS),
                        help="the restaurant to draw the tasks in (default spacious)")
    parser.add_argument("--base", metavar="YAML",
                        help="instead of a layout, a scenario whose room, tables, robot start "
                             "and settings every task keeps")
    parser.add_argument("--places", type=int, default=0, metavar="N",
                        help="mixed tasks: N cups of each task to be put down on another "
                             "table instead of collected (default 0: collect every dish)")
    parser.add_argument("--dishes", type=int, metavar="N",
                        help="N dishes per task instead of the "
                             "protocol's 5 to 7 (tasks at scale; 1 to 40)")
    parser.add_argument("--chairs", type=int, metavar="M",
                        help="M chairs near M dishes drawn at random, instead of one near "
                             "each dish (0 to the dish count)")
    parser.add_argument("--chair-margin", type=float, default=0.0, metavar="M",
                        help="grow the chairs by M (m) in the stop check's drives, for "
                             "perception's error (default 0; e.g. 0.015)")
    parser.add_argument("--check", metavar="DIR",
                        help="draw nothing: list the tasks of DIR with a dish that has no "
                             "stop at --chair-margin")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if not 0.0 <= args.chair_margin <= 0.2:
        fail(f"--chair-margin: must be 0 to 0.2 m, got {args.chair_margin:g}")
    if args.check is not None:
        return _check(Path(args.check), args.chair_margin, quiet=args.quiet)
    if args.count < 1:
        fail(f"--count: must be at least 1, got {args.count}")
    if args.seed < 0:
        fail(f"--seed: must be a non-negative integer, got {args.seed}")
    if not 0 <= args.places <= 3:
        fail(f"--places: must be 0 to 3 (a task has 5 to 7 dishes), got {args.places}")
    if args.dishes is not None and not 1 <= args.dishes <= 40:
        fail(f"--dishes: must be 1 to 40, got {args.dishes}")
    if args.chairs is not None and not 0 <= args.chairs <= (args.dishes or 5):
        fail(f"--chairs: must be 0 to the dish count ({args.dishes or 5}), got {args.chairs}")
    if args.base is not None and args.layout is not None:
        fail("--base: give a layout or a base scenario, not both")
    base_path, tasks_dir = LAYOUTS[args.layout or "spacious"]
    if args.base is not None:
        base_path = Path(args.base)
    if args.out is None:
        args.out = str(tasks_dir.relative_to(REPO_DIR)) if args.base is None else \
            "scenarios/generated"
    import logging

    from tqdm import tqdm

    from s3o_drake.experiments.generation import dishes_without_stops
    from s3o_drake.world.scenario import dump_scenario
    from s3o_drake.world.task_generation import generate_task

    # The stop check builds a collision checker per chair drawn: one log line each is noise.
    logging.getLogger("drake").setLevel(logging.WARNING)
    base = read_base(str(base_path))
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        fail(f"--out: {out} exists and is not a folder")

    out.mkdir(parents=True, exist_ok=True)
    flags = (f" --layout {args.layout}" if args.layout else "") + (
        f" --places {args.places}" if args.places else "") + (
        f" --dishes {args.dishes}" if args.dishes is not None else "") + (
        f" --chairs {args.chairs}" if args.chairs is not None else "") + (
        f" --chair-margin {args.chair_margin:g}" if args.chair_margin else "")
    header = (f"# Generated by `python -m s3o_drake.commands.generate --seed {args.seed}{flags}` "
              f"from {base_path.name}.\n")
    stops = partial(dishes_without_stops, chair_margin=args.chair_margin, first=True)
    for i in tqdm(range(args.count), desc="tasks", unit="task", disable=args.quiet):
        task = generate_task(base, args.seed, i, places=args.places, stops=stops,
                             dishes=args.dishes, chairs=args.chairs)
        write_atomically(out / f"task_{i:03d}.yaml", header + dump_scenario(task))
    print(f"wrote {args.count} tasks to {out}/")
    return 0


def _check(folder: Path, margin: float, *, quiet: bool) -> int:
    """Lists the tasks of `folder` with a dish that has no stop at `margin` (--check)."""
    if not folder.is_dir():
        fail(f"--check: no folder {folder}")
    files = sorted(folder.glob("task_*.yaml"))
    if not files:
        fail(f"--check: no task_*.yaml in {folder}")
    import logging

    from tqdm import tqdm

    from s3o_drake.experiments.generation import dishes_without_stops

    logging.getLogger("drake").setLevel(logging.WARNING)
    flagged = 0
    for path in tqdm(files, desc="tasks", unit="task", disable=quiet):
        missing = dishes_without_stops(read_base(str(path)), chair_margin=margin)
        if missing:
            flagged += 1
            tqdm.write(f"{path.stem}: {', '.join(missing)}")
    print(f"{flagged} of {len(files)} tasks have a dish without a stop with the chairs "
          f"grown by {margin:g} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
