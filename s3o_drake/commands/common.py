"""Shared command-line plumbing: one-line errors with exit status 2."""

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

if TYPE_CHECKING:
    from pydrake.geometry import Meshcat

    from s3o_drake.world.scenario import Scenario

EXIT_BAD_INPUT = 2
MESHCAT_HOST = "localhost"
"""Where the commands' Meshcat listens: this machine only, unless --host says otherwise."""


class ArgumentParser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line on stderr and exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see --help)\n")


def fail(message: str) -> NoReturn:
    """Reports bad input as one line on stderr and exits with status 2."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(EXIT_BAD_INPUT)


def read_scenario(path: str | Path, option: str = "") -> "Scenario":
    """Loads a scenario file for a command. A bad one (missing, a folder, not YAML, a bad
    field) is one line on stderr naming the file once and the field, and exit status 2
    (`option`, such as "--base", says which argument gave the file). An empty or
    comment-only file is all defaults."""
    from s3o_drake.world.scenario import load_scenario
    from s3o_drake.world.scenario_checks import ScenarioError

    try:
        return load_scenario(path)
    except ScenarioError as e:
        fail(f"{option}: {e}" if option else str(e))


def read_base(path: str | Path) -> "Scenario":
    """The base scenario of generated tasks (--base): a scenario file with tables to put the
    dishes on; anything else is one line and exit status 2."""
    base = read_scenario(path, "--base")
    if not base.tables:
        fail(f"--base: {path}: tables: none to put dishes on (an empty file is all defaults: "
             "a room without tables)")
    return base


def start_meshcat(host: str = MESHCAT_HOST) -> "Meshcat":
    """A Meshcat server that listens on `host` only (by default localhost: the live view
    and the recording are not served to the network); a host it cannot listen on is one
    line (--host) and exit status 2."""
    from pydrake.geometry import Meshcat, MeshcatParams

    try:
        return Meshcat(MeshcatParams(host=host))
    except RuntimeError as e:
        fail(f"--host: cannot listen on {host!r}: {str(e).splitlines()[0]}")


def first_tasks(count: int) -> list[Path]:
    """The first `count` shipped tasks; a bad count (--tasks) is one line and exit 2."""
    from s3o_drake.world.resources import shipped_tasks

    available = shipped_tasks()
    if not 1 <= count <= len(available):
        fail(f"--tasks: must be between 1 and {len(available)}, got {count}")
    return available[:count]


def task_scenarios(files: list[str] | None, count: int) -> list[tuple[str, "Scenario"]]:
    """(name, scenario) of a benchmark's tasks: the scenario `files` when given, else the
    first `count` shipped tasks; a bad count (--tasks) or file is one line and exit 2."""
    paths = [Path(p) for p in files] if files else first_tasks(count)
    return [(path.stem, read_scenario(path)) for path in paths]


def task_files(items: list[str], count: int | None) -> list[Path]:
    """The task files that --tasks names (folders: their task_*.yaml, sorted; files as
    given), the first `count` (--count) of them; a missing one, a bad count or none at all
    is one line and exit 2."""
    paths: list[Path] = []
    for item in map(Path, items):
        if item.is_dir():
            paths += sorted(item.glob("task_*.yaml"))
        elif item.is_file():
            paths.append(item)
        else:
            fail(f"--tasks: no such folder or file {item}")
    if count is not None:
        if not 1 <= count <= len(paths):
            fail(f"--count: must be between 1 and {len(paths)}, got {count}")
        paths = paths[:count]
    if not paths:
        fail("--tasks: no task_*.yaml found")
    return paths


def finished_rows(path: Path, settings: dict) -> dict[str, dict]:
    """The task rows already in a benchmark's --json file (a JSON line each, keyed "task")
    that were made with these settings, by task: what a resumed run reads back. A line
    cut short by an interruption is skipped."""
    import json

    rows: dict[str, dict] = {}
    if not path.is_file():
        return rows
    for line in path.read_text().splitlines():
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            continue
        if "task" in record and all(record.get(k) == v for k, v in settings.items()):
            rows[record["task"]] = record
    return rows


def doc_formatter() -> type[argparse.HelpFormatter]:
    """Keeps the module docstring's line breaks in --help."""
    return argparse.RawDescriptionHelpFormatter
