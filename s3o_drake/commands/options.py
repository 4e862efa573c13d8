"""The options that several commands share, defined and checked in one place, so that one
name means one thing in every command (docs/commands.md, "Shared options"):

  --tasks PATH ...  task scenario files, or folders of them (every *.yaml, by name)
  --count N         only the first N of --tasks
  --seed N          one seed;  --seeds N: the seeds 0 to N-1
  --workers N       worker processes
  --out DIR|FILE    where the command writes (its --help says a folder or a file)
  --json FILE       the results as JSON: a line per task or run where the command makes
                    such rows (appended as each is done, resumed from; --fresh starts over),
                    else the figures as one JSON document
  --method NAME     one planning method;  --quiet: no progress bars
  --set PATH=VALUE  replace a scenario field (repeatable), validated like the file

A bad value is refused while the arguments are parsed: one line naming the option, exit
status 2, nothing written.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from s3o_drake.commands.common import fail
from s3o_drake.world.choices import METHODS
from s3o_drake.world.resources import DEFAULT_ROBOT, TASKS_DIR, repo_path

if TYPE_CHECKING:
    from s3o_drake.experiments.store import ResultStore
    from s3o_drake.world.scenario import Scenario


def at_least(low: int) -> Callable[[str], int]:
    """An argparse type: an integer of at least `low`."""
    def integer(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be at least {low}, got {value}")
        return value
    return integer


def seconds(text: str) -> float:
    """An argparse type: a positive, finite number of seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text}")
    return value


def method(text: str) -> str:
    """An argparse type: one of the planning methods."""
    if text not in METHODS:
        raise argparse.ArgumentTypeError(f"unknown method {text!r}; one of {', '.join(METHODS)}")
    return text


def add_pickup_methods(parser: argparse.ArgumentParser) -> None:
    """--methods NAME ...: only these methods' executed pickups (None: every method's)."""
    parser.add_argument("--methods", nargs="+", type=method, metavar="NAME",
                        help=f"only these methods' pickups, some of: {', '.join(METHODS)}")


def add_tasks(parser: argparse.ArgumentParser, *, default: Sequence[Path] = (TASKS_DIR,),
              count: int | None = None, required: str = "required") -> None:
    """--tasks PATH ... and --count N; `task_paths` reads them. `count`: how many of the
    tasks the command takes when --count is not given (None: all); `required`: what the
    help says of --tasks without a default."""
    shown = f"default {' '.join(repo_path(p) for p in default)}" if default else required
    parser.add_argument("--tasks", nargs="+", metavar="PATH",
                        help=f"task files or folders of them (every *.yaml, by name; {shown})")
    parser.add_argument("--count", type=at_least(1), metavar="N",
                        help=f"only the first N tasks (default {count or 'all'})")
    parser.set_defaults(task_defaults=(tuple(default), count))


def task_paths(args: argparse.Namespace) -> list[Path]:
    """The task files --tasks and --count name, in order; a missing file or folder, an empty
    folder, two tasks of one name (rows are keyed by it) or too few tasks for --count is one
    line and exit status 2."""
    default, count = args.task_defaults
    if not (args.tasks or default):
        fail("--tasks: required (task files or folders of them)")
    paths: list[Path] = []
    for item in map(Path, args.tasks or default):
        if item.is_dir():
            found = sorted(item.glob("*.yaml"))
            if not found:
                fail(f"--tasks: no *.yaml task in {item}")
            paths += found
        elif item.is_file():
            paths.append(item)
        else:
            hint = f" (the first {item} tasks: --count {item})" if str(item).isdigit() else ""
            fail(f"--tasks: no such folder or file {item}{hint}")
    names: dict[str, Path] = {}
    for path in paths:
        if names.setdefault(path.stem, path) != path:
            fail(f"--tasks: two tasks named {path.stem} ({names[path.stem]}, {path})")
    if args.count is not None:
        if args.count > len(paths):
            fail(f"--count: --tasks holds {len(paths)} tasks, {args.count} asked")
        return paths[:args.count]
    return paths if count is None else paths[:count]


def realtime_rate(text: str) -> float:
    """An argparse type: a real-time rate, 0 (as fast as it can) or more."""
    try:
        rate = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not rate >= 0.0:
        raise argparse.ArgumentTypeError(f"expected 0 (as fast as it can) or more, got {text}")
    return rate


def add_seed(parser: argparse.ArgumentParser, default: int | None = 0,
             what: str = "random seed") -> None:
    """--seed N: one seed (None: the scenario's own)."""
    shown = "the scenario's own" if default is None else default
    parser.add_argument("--seed", type=at_least(0), default=default, metavar="N",
                        help=f"{what} (default {shown})")


def add_seeds(parser: argparse.ArgumentParser, default: int) -> None:
    """--seeds N: the seeds 0 to N-1."""
    parser.add_argument("--seeds", type=at_least(1), default=default, metavar="N",
                        help=f"seeds 0 to N-1 (default {default})")


def robot_name(text: str) -> str:
    """An argparse type: a shipped robot's name (a folder of models/ with its robot.yaml;
    the description is read and checked where the robot is loaded, after the arguments)."""
    from s3o_drake.world.resources import DESCRIPTION_FILE, robot_dir

    if not text or "/" in text or not (robot_dir(text) / DESCRIPTION_FILE).is_file():
        raise argparse.ArgumentTypeError(f"no robot named {text!r} (no models/{text}/"
                                         f"{DESCRIPTION_FILE})")
    return text


def add_robot(parser: argparse.ArgumentParser, what: str = "the robot",
              default: str | None = DEFAULT_ROBOT, shown: str | None = None) -> None:
    """--robot NAME: for a command that works for a robot rather than on a scenario's
    (`default` None: the command's scenario's, as `shown` says)."""
    parser.add_argument("--robot", type=robot_name, default=default, metavar="NAME",
                        help=f"{what}: a folder of models/ with its robot.yaml (default "
                             f"{shown or default})")


def add_workers(parser: argparse.ArgumentParser, default: int,
                what: str = "worker processes") -> None:
    parser.add_argument("--workers", type=at_least(1), default=default, metavar="N",
                        help=f"{what} (default {default})")


def add_quiet(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quiet", action="store_true", help="no progress bars")


def add_overrides(parser: argparse.ArgumentParser, text: str) -> None:
    """--set PATH=VALUE (repeatable), as `args.overrides`: a list of the strings."""
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                        dest="overrides", help=text)


def with_overrides_or_fail(scenario: Scenario, overrides: Sequence[str]) -> Scenario:
    """The scenario with --set's fields replaced; a bad path or value is one line naming
    the field, and exit 2."""
    if not overrides:
        return scenario
    from s3o_drake.world.scenario import with_overrides
    from s3o_drake.world.scenario_checks import ScenarioError

    try:
        return with_overrides(scenario, overrides)
    except ScenarioError as e:
        fail(str(e) if str(e).startswith("--set") else f"--set {e}")


def add_method(parser: argparse.ArgumentParser, default: str | None = "S3O-GROP*",
               shown: str | None = None) -> None:
    """--method NAME, checked against the planning methods."""
    parser.add_argument("--method", type=method, default=default, metavar="NAME",
                        help=f"planning method, one of {', '.join(METHODS)} (default "
                             f"{shown or default})")


def add_out(parser: argparse.ArgumentParser, *, file: bool, default: str | None = None,
            required: bool = False, text: str = "", note: str = "") -> None:
    """--out DIR (a folder) or --out FILE; `note` follows the default."""
    said = [f"default {default}"] if default is not None else []
    said += [note] if note else []
    parser.add_argument("--out", metavar="FILE" if file else "DIR", default=default,
                        required=required,
                        help=(text or ("output file" if file else "output folder"))
                        + (f" ({'; '.join(said)})" if said else ""))


def out_folder(path: str | Path, option: str = "--out") -> Path:
    """A folder to write into: anything else in its place is one line and exit 2."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        fail(f"{option}: {path} exists and is not a folder")
    return path


def out_file(path: str | Path, option: str = "--out") -> Path:
    """A file to write: a folder in its place, or a file where a folder of its path should
    be, is one line and exit 2."""
    path = Path(path)
    if path.is_dir():
        fail(f"{option}: {path} is a folder")
    if any(folder.exists() and not folder.is_dir() for folder in path.parents):
        fail(f"{option}: {path.parent} is not a folder")
    return path


def add_json(parser: argparse.ArgumentParser, rows: str | None) -> None:
    """--json FILE: with `rows` (what a line holds, e.g. "task"), JSON lines appended as
    each is done and resumed from, and --fresh; without, one JSON document of figures."""
    if rows is None:
        parser.add_argument("--json", metavar="FILE",
                            help="also write the figures to FILE (one JSON document)")
        return
    parser.add_argument("--json", metavar="FILE",
                        help=f"append a JSON line per {rows} to FILE as each is done; the "
                             "same command resumes from them")
    parser.add_argument("--fresh", action="store_true", help="start the --json file over")


def json_file(args: argparse.Namespace) -> Path | None:
    """The --json file, if any; its folder must exist (one line and exit 2)."""
    if not args.json:
        return None
    path = Path(args.json)
    if not path.parent.is_dir():
        fail(f"--json: no folder {path.parent}")
    if path.is_dir():
        fail(f"--json: {path} is a folder")
    return path


def one_robot(scenarios: Iterable[tuple[Path, Scenario]], option: str = "--tasks") -> str:
    """The robot that every scenario (with the file it came from) is for; scenarios for two
    robots are one line naming `option` and exit status 2 (a result file holds one robot's
    rows)."""
    robots: dict[str, Path] = {}
    for path, scenario in scenarios:
        robots.setdefault(scenario.robot_value.name, path)
    if len(robots) > 1:
        (a, path_a), (b, path_b) = list(robots.items())[:2]
        fail(f"{option}: {path_a} is for robot {a!r} and {path_b} for {b!r}: one command "
             "runs one robot")
    return next(iter(robots), DEFAULT_ROBOT)


def json_store(args: argparse.Namespace, key: Callable[[dict], str] | None = None, *,
               robot: str = DEFAULT_ROBOT) -> ResultStore | None:
    """The result store of --json (None without it), emptied first with --fresh, for the
    rows of `robot`'s runs. `key` keys the lines written before the command used the
    store."""
    path = json_file(args)
    if path is None:
        return None
    from s3o_drake.experiments.store import ResultStore

    if getattr(args, "fresh", False):
        path.unlink(missing_ok=True)
    return ResultStore(path, robot=robot, key=key)


def study_robot(folders: Sequence[Path]) -> str:
    """The robot whose runs the study folders hold (their rows say; one robot, or one line
    naming DIR and exit status 2)."""
    from s3o_drake.experiments.store import ResultStore, robot_of

    robots: dict[str, Path] = {}
    for folder in folders:
        for row in ResultStore(folder / "results.jsonl", read_only=True).rows():
            robots.setdefault(robot_of(row), folder)
    if len(robots) > 1:
        (a, folder_a), (b, folder_b) = list(robots.items())[:2]
        fail(f"DIR: {folder_a} holds runs of robot {a!r} and {folder_b} of {b!r}: the "
             "studies must be one robot's")
    return next(iter(robots), DEFAULT_ROBOT)


def add_studies(parser: argparse.ArgumentParser, text: str) -> None:
    """DIR ...: study folders of `s3o evaluate`, each holding its results.jsonl."""
    parser.add_argument("studies", nargs="+", metavar="DIR", help=text)


def study_folders(args: argparse.Namespace) -> list[Path]:
    """The folders of `add_studies`; one without a results.jsonl is one line and exit
    status 2."""
    folders = [Path(d) for d in args.studies]
    for folder in folders:
        if not (folder / "results.jsonl").is_file():
            fail(f"DIR: no results.jsonl in {folder}")
    return folders


def write_record(out: Path, header: str, record: dict) -> None:
    """A derived record (a price, shares) as YAML under its comment `header`, written whole
    or not at all; a file that cannot be written is one line and exit status 2."""
    import yaml

    from s3o_drake.world.files import write_atomically

    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        write_atomically(out, header + yaml.safe_dump(record, sort_keys=False))
    except OSError as e:
        fail(f"--out: cannot write {out}: {e.strerror or e}")
