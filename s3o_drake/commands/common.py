"""Shared command-line plumbing: each command's parser, one-line errors with exit status 2,
the scenario files read for a command, and the Meshcat it starts."""

import argparse
import functools
import sys
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

if TYPE_CHECKING:
    from pydrake.geometry import Meshcat

    from s3o_drake.world.robot_description import RobotDescription
    from s3o_drake.world.scenario import Scenario

EXIT_BAD_INPUT = 2
PROG = "s3o"
"""The console script; every command is `s3o NAME` (commands/cli.py)."""
DOCS = "docs/commands.md"
"""Where each command's long explanation is: its --help fits a screen."""
MESHCAT_HOST = "localhost"
"""Where the commands' Meshcat listens: this machine only, unless --host says otherwise."""


class ArgumentParser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line on stderr and exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see --help)\n")


def command_parser(name: str, doc: str | None, prog: str | None = None) -> ArgumentParser:
    """The parser of `s3o NAME`: the module docstring (short) as its description, and where
    the details are (DOCS, the section named after the command)."""
    # No abbreviations: --seed must not be taken for --seeds where only that one exists.
    return ArgumentParser(prog=prog or f"{PROG} {name}", description=doc,
                          epilog=f"Details: {DOCS}, section \"{PROG} {name}\".",
                          formatter_class=_HelpFormatter, allow_abbrev=False)


class _HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """The docstring's line breaks kept; an option with a list (--tasks PATH [PATH ...])
    still has its help beside it, so that --help fits a screen."""

    def __init__(self, prog: str) -> None:
        super().__init__(prog, max_help_position=30)


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


def add_robot_name(parser: argparse.ArgumentParser) -> None:
    """NAME: the robot a build command builds (a folder of models/ with its robot.yaml)."""
    parser.add_argument("name", help="the robot: a folder of models/ with its robot.yaml")


def read_robot_description(name: str) -> "RobotDescription":
    """Robot `name`'s description, read and checked for shape and values; one that cannot
    be used is one line naming the robot and the field, and exit status 2."""
    from s3o_drake.world.robot_description import RobotDescriptionError, load_robot_description

    try:
        return load_robot_description(name)
    except RobotDescriptionError as e:
        fail(f"{name}: {e}")


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
    and the recording are not served to the network), emptied of what an earlier run of
    this process showed; a host it cannot listen on is one line (--host) and exit status 2.

    One server per host, kept until the process ends. Drake aborts the process when a
    Meshcat is destroyed on another thread than the one that made it, and a finished run's
    diagram holds its Meshcat in reference cycles that the garbage collector frees on
    whichever thread it runs next (clingo's search calls Python on its own): a server never
    freed cannot be freed on the wrong thread."""
    meshcat = _meshcat_server(host)
    meshcat.Delete()
    meshcat.DeleteAddedControls()
    meshcat.DeleteRecording()
    return meshcat


@functools.cache
def _meshcat_server(host: str) -> "Meshcat":
    """The process's Meshcat server on `host` (`start_meshcat`); a failure is not kept."""
    from pydrake.geometry import Meshcat, MeshcatParams

    try:
        return Meshcat(MeshcatParams(host=host))
    except RuntimeError as e:
        fail(f"--host: cannot listen on {host!r}: {str(e).splitlines()[0]}")
