"""Benchmark tasks drawn by the paper's protocol (S3O, section V); the command that writes
them is `s3o generate`.

Every task keeps the room, the seven tables, the robot's start and the settings of a base
scenario (default: scenarios/restaurant.yaml) and draws anew: 5 to 7 dishes at random
spots on random tables, and one chair that is not on the map near each dish, at a random
position and yaw. Chairs never overlap furniture, walls or each other, and the robot's
start stays free; each task passes the same validation as a hand-written scenario.

With `stops` (the benchmark's tasks: `s3o generate` passes
`experiments.generation.dishes_without_stops`), every dish also keeps a candidate stop that a
drive from the start reaches: dishes drawn where no stop reaches them are drawn again, and
so is a chair that would close the last way to one. In a dense room the chairs of the
protocol otherwise fill the aisles (docs/results_history.md); in the spacious one it redrew
chairs in 5 of the 100 tasks of seed 0. The check lives above this layer (it needs the
navigation map), hence a function passed in.

Task i depends only on the seed and i, so the same seed gives the same tasks.
"""

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from functools import cache

import numpy as np

from s3o_drake.world.furniture import (
    DISH_SHAPES,
    RESTAURANT_KINDS,
    chair_footprint,
    dish_footprint,
    table_footprint,
)
from s3o_drake.world.map import Chair, Table
from s3o_drake.world.objects import Dish, PlaceSpot
from s3o_drake.world.resources import LAYOUTS, RESTAURANT
from s3o_drake.world.scenario import Scenario, load_scenario
from s3o_drake.world.scenario_checks import (
    START_CLEARANCE,
    ScenarioError,
    room_polygon,
    validate_scenario,
)

DEFAULT_BASE = RESTAURANT
DISH_COUNTS = (5, 6, 7)
EDGE_MARGIN = 0.03  # a dish stays this far inside its table's edge (m)
DISH_GAP = 0.05  # free space between two dishes (m)
CHAIR_DISTANCE = (0.45, 1.0)  # a chair's centre is this far from its dish (m)
CHAIR_GAP = 0.05  # free space between a chair and other furniture (m)
ROBOT_START_GAP = 0.3  # chairs leave this much room around the robot's start (m)
MAX_TRIES = 1000
PLACES = 1  # the stream tag of the places' draws (numpy.random.default_rng([seed, i, tag]))


class GenerationError(RuntimeError):
    pass


CUSTOM_LAYOUT = "custom"


@cache
def _layout_bases() -> tuple[tuple[str, Scenario], ...]:
    return tuple((name, load_scenario(base)) for name, (base, _) in LAYOUTS.items())


def layout_of(scenario: Scenario) -> str:
    """The benchmark layout (`resources.LAYOUTS`) that `scenario` stands in: the one whose
    base has the same room and tables (tasks keep their base's), else CUSTOM_LAYOUT."""
    for name, base in _layout_bases():
        if base.room == scenario.room and base.tables == scenario.tables:
            return name
    return CUSTOM_LAYOUT


def spot_on_table(table: Table, radius: float, rng: np.random.Generator) -> np.ndarray | None:
    """A uniform random spot (x, y in the world) on `table`'s top for an object of
    `radius`, EDGE_MARGIN inside its edge; None when the top is too small for it."""
    half = np.array(table.size[:2]) / 2 - radius - EDGE_MARGIN
    if np.any(half <= 0):
        return None
    p_T = rng.uniform(-half, half)  # in the table frame
    c, s = math.cos(table.yaw), math.sin(table.yaw)
    return np.array(table.center) + np.array([c * p_T[0] - s * p_T[1],
                                              s * p_T[0] + c * p_T[1]])


def _sample_dishes(base: Scenario, rng: np.random.Generator,
                   count: int | None = None) -> list[Dish]:
    count = int(rng.choice(DISH_COUNTS)) if count is None else count
    dishes: list[Dish] = []
    placed: list[tuple[np.ndarray, float]] = []
    for _ in range(MAX_TRIES):
        if len(dishes) == count:
            return dishes
        table = base.tables[int(rng.integers(len(base.tables)))]
        kind = RESTAURANT_KINDS[int(rng.integers(len(RESTAURANT_KINDS)))]
        radius = DISH_SHAPES[kind].radius
        p_W = spot_on_table(table, radius, rng)
        if p_W is None:
            continue
        if any(np.linalg.norm(p_W - q) < radius + r + DISH_GAP for q, r in placed):
            continue
        placed.append((p_W, radius))
        name = f"{kind}_{sum(d.kind == kind for d in dishes) + 1}"
        dishes.append(Dish(name=name, table=table.name, kind=kind,
                           position=[round(float(v), 4) for v in p_W]))
    raise GenerationError("could not place the dishes")


StopCheck = Callable[[Scenario], Sequence[str]]
"""The dishes of a scenario that no candidate stop reaches (`generate_task`'s `stops`)."""


def _sample_chairs(base: Scenario, dishes: list[Dish], rng: np.random.Generator,
                   stops: StopCheck | None = None, count: int | None = None) -> list[Chair]:
    """A chair near each dish, or with `count`, near that many dishes drawn at random."""
    near = (list(dishes) if count is None else
            [dishes[i] for i in sorted(rng.choice(len(dishes), size=count, replace=False))])
    room = room_polygon(base).buffer(-CHAIR_GAP)
    obstacles = [table_footprint(t.center, t.yaw, t.size).buffer(CHAIR_GAP)
                 for t in base.tables]
    robot = base.robot_value.footprint(*base.robot.start).buffer(START_CLEARANCE +
                                                                 ROBOT_START_GAP)
    chairs: list[Chair] = []
    for i, dish in enumerate(near):
        for _ in range(MAX_TRIES):
            distance = rng.uniform(*CHAIR_DISTANCE)
            bearing = rng.uniform(-math.pi, math.pi)
            pose = [dish.position[0] + distance * math.cos(bearing),
                    dish.position[1] + distance * math.sin(bearing),
                    rng.uniform(-math.pi, math.pi)]
            pose = [round(float(v), 4) for v in pose]
            shape = chair_footprint(pose)
            if not shape.within(room) or shape.intersects(robot):
                continue
            if any(shape.intersects(o) for o in obstacles):
                continue
            chair = Chair(name=f"chair_{i + 1}", pose=pose, mapped=False)
            if stops is not None and stops(replace(base, dishes=dishes,
                                                   chairs=[*chairs, chair])):
                continue
            chairs.append(chair)
            obstacles.append(shape.buffer(CHAIR_GAP))
            break
        else:
            raise GenerationError(f"no free spot for a chair near {dish.name}")
    return chairs


def _sample_places(task: Scenario, count: int, rng: np.random.Generator) -> Scenario:
    """`task` with `count` of its cups to be put down at random spots on another table's
    top, clear of the objects and of each other, instead of collected."""
    cups = [i for i, d in enumerate(task.dishes) if d.kind == "cup"]
    if len(cups) < count:
        raise GenerationError(f"{len(cups)} cups for {count} places")
    dishes = list(task.dishes)
    taken = [dish_footprint(d.position, d.kind).buffer(DISH_GAP) for d in dishes]
    for i in sorted(rng.choice(cups, size=count, replace=False).tolist()):
        cup = dishes[i]
        for _ in range(MAX_TRIES):
            table = task.tables[int(rng.integers(len(task.tables)))]
            if table.name == cup.table:
                continue
            p_W = spot_on_table(table, DISH_SHAPES["cup"].radius, rng)
            if p_W is None:
                continue
            shape = dish_footprint(list(p_W), "cup")
            if any(shape.intersects(t) for t in taken):
                continue
            taken.append(shape.buffer(DISH_GAP))
            dishes[i] = replace(cup, goal="place", place=PlaceSpot(
                table=table.name, position=[round(float(v), 4) for v in p_W]))
            break
        else:
            raise GenerationError(f"no free place for {cup.name}")
    return replace(task, dishes=dishes)


def generate_task(base: Scenario, seed: int, index: int, places: int = 0,
                  stops: StopCheck | None = None, dishes: int | None = None,
                  chairs: int | None = None) -> Scenario:
    """Task `index` of the set drawn with `seed`; the same arguments give the same task.
    With `places`, that many of its cups are to be put down on another table instead of
    collected (mixed tasks); the rest is the task without places, unless that one has too
    few cups, and another is drawn. With `stops`, no dish (nor place) of the task is one
    that `stops` names (see the module docstring). Tasks at scale: `dishes` instead of 5
    to 7, and `chairs` near as many dishes drawn at random instead of one per dish (a
    chair per dish of 30 fills the aisles of either restaurant, and no drive is left)."""
    if chairs is not None and chairs > (dishes or min(DISH_COUNTS)):
        raise ValueError(f"{chairs} chairs for at most {dishes or min(DISH_COUNTS)} dishes")
    rng = np.random.default_rng([seed, index])
    for _ in range(100):
        try:
            drawn = _sample_dishes(base, rng, dishes)
            if stops is not None and stops(replace(base, dishes=drawn, chairs=[])):
                continue
            seated = _sample_chairs(base, drawn, rng, stops, chairs)
        except GenerationError:
            continue
        task = replace(base, seed=int(rng.integers(2**31)), dishes=drawn, chairs=seated)
        try:
            validate_scenario(task)
        except ScenarioError:
            continue
        if places:
            # Their own stream: where the task has cups enough, it is the task without places.
            try:
                return _with_places(task, places, np.random.default_rng([seed, index, PLACES]),
                                    stops)
            except GenerationError:
                continue
        return task
    raise GenerationError(f"could not generate task {index} with seed {seed}")


def _with_places(task: Scenario, count: int, rng: np.random.Generator,
                 stops: StopCheck | None = None) -> Scenario:
    for _ in range(100):
        try:
            mixed = _sample_places(task, count, rng)
            validate_scenario(mixed)
        except (GenerationError, ScenarioError):
            continue
        if stops is not None and stops(mixed):
            continue
        return mixed
    raise GenerationError(f"could not place {count} cups in this task")
