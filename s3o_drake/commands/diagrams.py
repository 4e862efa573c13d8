"""Regenerate the Graphviz pictures of the Drake diagrams.

    s3o diagrams [--check]

Writes diagrams/execution.dot (the execution diagram, one level deep) and diagrams/world.dot
(the simulated restaurant in it), and an .svg of each where Graphviz's `dot` is installed.
--check writes nothing and exits 1 when a committed .dot file is stale.
"""

import re
import shutil
import subprocess
import sys
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser
from s3o_drake.world.resources import DIAGRAMS_DIR, SCENARIOS_DIR

SCENARIO = SCENARIOS_DIR / "small" / "two_dishes.yaml"
"""The structure does not depend on the scene; a small one builds fastest."""

# A system id: "_17" (a diagram), "s17" (a block), "cluster17..." / "clusters17in" (their
# boxes); not the "s3" of "s3o_drake" in a class name.
_ID = re.compile(r"(?<![A-Za-z0-9])(_|s|clusters|cluster)(\d+)(?![0-9]|o_)")


def normalize(dot: str) -> str:
    """Drake's system ids replaced by their order of first appearance, the connections
    sorted."""
    seen: dict[str, int] = {}

    def renumber(match: re.Match) -> str:
        number = seen.setdefault(match.group(2), len(seen) + 1)
        return f"{match.group(1)}{number}"

    lines = _ID.sub(renumber, dot).split("\n")
    # Drake lists the connections in no fixed order: sort them where they stand.
    edges = [i for i, line in enumerate(lines) if " -> " in line]
    for i, line in zip(edges, sorted(lines[i] for i in edges), strict=True):
        lines[i] = line
    return "\n".join(lines)


def render() -> dict[str, str]:
    """{file name: normalized Graphviz text} of the project's diagrams."""
    from s3o_drake.execution.diagram import build_execution_diagram
    from s3o_drake.world.scenario import load_scenario

    diagram = build_execution_diagram(load_scenario(SCENARIO))
    world = diagram.GetSubsystemByName("world")
    return {"execution.dot": normalize(diagram.GetGraphvizString(max_depth=1)),
            "world.dot": normalize(world.GetGraphvizString(max_depth=1))}


def stale(directory: Path = DIAGRAMS_DIR) -> list[str]:
    """The .dot files in `directory` that are missing or differ from `render()`."""
    return [name for name, text in render().items()
            if not (directory / name).is_file() or (directory / name).read_text() != text]


def write(directory: Path = DIAGRAMS_DIR) -> list[Path]:
    """Writes every .dot, and its .svg when `dot` is installed."""
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for name, text in render().items():
        path = directory / name
        path.write_text(text)
        written.append(path)
        if shutil.which("dot"):
            svg = path.with_suffix(".svg")
            subprocess.run(["dot", "-Tsvg", str(path), "-o", str(svg)], check=True)
            written.append(svg)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("diagrams", __doc__)
    parser.add_argument("--check", action="store_true",
                        help="compare with the committed files instead of writing them")
    args = parser.parse_args(argv)
    if args.check:
        names = stale()
        for name in names:
            print(f"{DIAGRAMS_DIR.name}/{name} is stale; run s3o diagrams")
        return 1 if names else 0
    for path in write():
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
