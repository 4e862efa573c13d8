"""The commands answer --help and bad arguments before the heavy imports: the arguments are
parsed first, and Drake, torch, OpenCV, matplotlib, shapely, scipy and clingo are imported
only after."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from s3o_drake.commands import cli

REPO = Path(__file__).resolve().parents[2]
HEAVY = ("pydrake", "torch", "cv2", "matplotlib", "shapely", "scipy", "clingo")
# Every command, by the module that `python -m` runs (its first address; `s3o NAME` runs
# the same main): the card's, and each of the `s3o` command table.
COMMANDS = ["s3o_drake.run"] + [command.module for command in cli.COMMANDS]


def _python(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env,
                          cwd=REPO, timeout=120)


def _imported(importtime_log: str) -> set[str]:
    """Top-level packages named in `python -X importtime`'s log."""
    names = set()
    for line in importtime_log.splitlines():
        if line.startswith("import time:") and "|" in line:
            names.add(line.rsplit("|", 1)[1].strip().split(".")[0])
    return names


@pytest.mark.parametrize("module", COMMANDS)
def test_help_imports_nothing_heavy(module):
    result = _python("-X", "importtime", "-m", module, "--help")
    assert result.returncode == 0, result.stderr[-2000:]
    assert "usage:" in result.stdout
    heavy = _imported(result.stderr) & set(HEAVY)
    assert not heavy, f"{module} --help imported {sorted(heavy)} before parsing its arguments"


@pytest.mark.parametrize("module", COMMANDS)
def test_a_bad_argument_is_one_line_and_status_2_before_heavy_imports(module):
    result = _python("-X", "importtime", "-m", module, "--no-such-option")
    assert result.returncode == 2
    lines = [line for line in result.stderr.splitlines() if not line.startswith("import time:")]
    assert len(lines) == 1 and "error:" in lines[0]
    assert not _imported(result.stderr) & set(HEAVY)


def test_run_help_is_the_module_docstring():
    from s3o_drake.commands import run_scenario as run

    result = _python("-m", "s3o_drake.run", "--help")
    assert run.__doc__.splitlines()[0] in result.stdout
