"""Where the project's shipped files live (models, scenarios, the diagrams' pictures), and a
Drake parser that finds the models. Every path to a shipped file is made here."""

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pydrake is imported where a parser is made, so that the paths are light
    from pydrake.multibody.parsing import Parser

PACKAGE_NAME = "s3o_drake"
REPO_DIR = Path(__file__).resolve().parents[2]
"""The checkout the package is installed from (`pip install -e .`)."""
MODELS_DIR = REPO_DIR / "models"
SCENARIOS_DIR = REPO_DIR / "scenarios"
RESTAURANT = SCENARIOS_DIR / "restaurant.yaml"
"""The default scenario: the restaurant of the paper's benchmark (the spacious layout)."""
RESTAURANT_DENSE = SCENARIOS_DIR / "restaurant_dense.yaml"
"""The same seven tables packed as in the paper's Gazebo world (the dense layout)."""
TASKS_DIR = SCENARIOS_DIR / "generated"
"""The shipped benchmark tasks (`s3o generate --count 100 --seed 0`)."""
LAYOUTS = {"spacious": (RESTAURANT, TASKS_DIR),
           "dense": (RESTAURANT_DENSE, SCENARIOS_DIR / "generated_dense")}
"""Each benchmark layout (its `room.layout`): its base scenario and its shipped tasks."""
DIAGRAMS_DIR = REPO_DIR / "diagrams"
DEFAULT_ROBOT = "ur5e"
"""The robot a scenario names when it names none: its folder under models/."""
DESCRIPTION_FILE = "robot.yaml"
"""A robot's description, in its folder under models/ (`world/robot_description.py`)."""


def repo_path(path: str | Path) -> str:
    """`path` as the repository names it: from its root when it lies inside (the same on
    every checkout, so fit for rows and records that ship), else as given."""
    resolved = Path(path).resolve()
    if resolved.is_relative_to(REPO_DIR):
        return resolved.relative_to(REPO_DIR).as_posix()
    return str(path)


def robot_dir(name: str) -> Path:
    """A robot's folder: its description (robot.yaml), its model, and what was built for
    it (reachability map, time model, failure price, shared-stop shares, the network's
    weights)."""
    return MODELS_DIR / name



def package_file(url: str) -> Path:
    """The file of a `package://s3o_drake/...` URL."""
    prefix = f"package://{PACKAGE_NAME}/"
    if not url.startswith(prefix):
        raise ValueError(f"{url!r} is not a {prefix} URL")
    return MODELS_DIR / url[len(prefix):]


def models_dir() -> Path:
    """The `models/` folder (with its package.xml) of this checkout."""
    if not (MODELS_DIR / "package.xml").is_file():
        raise FileNotFoundError(
            f"models/package.xml not found at {MODELS_DIR}; install s3o_drake from its "
            "repository with `pip install -e .` so that the model files are next to the package"
        )
    return MODELS_DIR


def shipped_tasks() -> list[Path]:
    """The shipped benchmark tasks, in name order."""
    return sorted(TASKS_DIR.glob("task_*.yaml"))


def make_parser(plant, scene_graph=None) -> "Parser":
    """A Parser for `plant` that resolves package://s3o_drake/... URLs."""
    from pydrake.multibody.parsing import Parser

    parser = Parser(plant, scene_graph) if scene_graph is not None else Parser(plant)
    packages = parser.package_map()
    if not packages.Contains(PACKAGE_NAME):
        packages.Add(PACKAGE_NAME, str(models_dir()))
    return parser
