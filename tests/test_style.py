"""The code stays ruff-clean and its layers import only downwards (the rules are in
pyproject.toml). Modules are split by what they hold, not by a line count."""

import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def test_ruff_finds_nothing():
    result = subprocess.run([sys.executable, "-m", "ruff", "check", "s3o_drake", "tests"],
                            capture_output=True, text=True, cwd=REPO)
    assert result.returncode == 0, result.stdout + result.stderr


def test_layers_import_only_downwards_and_without_cycles():
    """import-linter's contracts in pyproject.toml: scenario and world at the bottom, then
    perception and feasibility, abstraction, planning and manipulation, execution,
    evaluation, and the commands on top; no cycles between the modules of a package."""
    lint = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) \
        or shutil.which("lint-imports")
    assert lint is not None, "import-linter is in the test extra: pip install -e '.[test]'"
    result = subprocess.run([lint, "--no-cache"], capture_output=True, text=True, cwd=REPO)
    assert result.returncode == 0, result.stdout + result.stderr
