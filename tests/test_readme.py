"""The README stays true where it lists what the code has: the modules of the Layout, the
fields of the scenario table, the options of the run usage line."""

import contextlib
import dataclasses
import io
import re
import typing
from pathlib import Path

import pytest

from s3o_drake.world import scenario as schema

REPO = Path(__file__).resolve().parent.parent
README = (REPO / "README.md").read_text()


def _section(title: str) -> str:
    start = README.index(f"\n## {title}\n")
    end = README.find("\n## ", start + 1)
    return README[start:end if end >= 0 else None]


def test_the_layout_names_every_module():
    layout = _section("Layout")
    missing = [str(p.relative_to(REPO)) for p in sorted((REPO / "s3o_drake").rglob("*.py"))
               if p.name != "__init__.py" and not re.search(rf"\b{p.stem}\b", layout)]
    assert missing == []
    packages = {p.parent.name for p in (REPO / "s3o_drake").rglob("__init__.py")} - {"s3o_drake"}
    assert all(f"  {name}/" in layout for name in packages)


def test_the_scenario_table_lists_every_field():
    table = _section("Scenario format")
    rows = {m.group(1): m.group(0) for m in re.finditer(r"^\| `(\w+)(?:\[\])?` \|.*$", table,
                                                         re.MULTILINE)}
    missing = []
    for name, kind in typing.get_type_hints(schema.Scenario).items():
        inner = (typing.get_args(kind) or (kind,))[0]  # list[Table] -> Table
        row = rows.get(name, "")
        assert row, name
        if dataclasses.is_dataclass(inner):
            missing += [f"{name}.{f.name}" for f in dataclasses.fields(inner)
                        if not re.search(rf"`{f.name}\b", row)]  # `bounds: [...]` too
    assert missing == []


def test_the_run_usage_line_has_every_option():
    from s3o_drake.commands.run_scenario import main

    printed = io.StringIO()
    with contextlib.redirect_stdout(printed), pytest.raises(SystemExit):
        main(["--help"])
    usage = printed.getvalue().split("\n\n")[0]
    options = set(re.findall(r"\[(--[a-z-]+)", usage)) - {"--help"}
    line = next(line for line in _section("Usage").splitlines()
                if line.startswith("python -m s3o_drake.run "))
    assert options and [o for o in sorted(options) if o not in line] == []
