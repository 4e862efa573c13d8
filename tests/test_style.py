"""The code stays ruff-clean, its layers import only downwards, and no module grows past
500 lines (the rules are in pyproject.toml)."""

import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
MAX_MODULE_LINES = 500


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


def test_no_module_is_longer_than_500_lines():
    long = {str(p.relative_to(REPO)): n for p in sorted((REPO / "s3o_drake").rglob("*.py"))
            if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES}
    assert long == {}
