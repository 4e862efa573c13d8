"""Random valid scenes, unlike the benchmark's: for the property tests and the soak.

Where `task_generation` keeps the restaurant and draws dishes and chairs by the paper's
protocol, `random_scene` draws the whole world: a room of random size, tables of random
size anywhere and at any yaw (some so deep that a dish in the middle is out of reach),
0 to `max_dishes` dishes anywhere on them (at the edge of reach or out of it), chairs
crowding the dishes, and sometimes a robot boxed in by chairs. Every scene passes
`validate_scenario`, as a user's file would; what cannot be placed is left out, so a scene
may hold fewer dishes or chairs than drawn.

Scene `(seed, index)` depends only on those two numbers.
"""

import math
from dataclasses import dataclass, replace

import numpy as np
from shapely.geometry import box

from s3o_drake.world.furniture import (
    DISH_SHAPES,
    RESTAURANT_KINDS,
    chair_footprint,
    table_footprint,
)
from s3o_drake.world.map import Chair, Room, Table
from s3o_drake.world.objects import Dish
from s3o_drake.world.robot import Robot, load_robot
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.scenario_checks import START_CLEARANCE, ScenarioError, validate_scenario
from s3o_drake.world.settings import PlanningSettings, RobotSection

TRIES = 200  # draws per table, dish or chair before it is left out
GAP = 0.03  # free space kept between pieces of furniture (m)


@dataclass(frozen=True)
class SceneShape:
    """What a random scene may hold (upper bounds; drawn below them)."""

    max_tables: int = 5
    max_dishes: int = 30
    max_chairs: int = 12
    boxed_in: float = 0.2
    """Probability that chairs surround the robot's start."""


def _table(rng: np.random.Generator, room: list[float], i: int) -> Table:
    length, width = rng.uniform(0.5, 2.6), rng.uniform(0.5, 2.0)
    margin = math.hypot(length, width) / 2
    x = rng.uniform(room[0] + margin, room[2] - margin) if room[2] - room[0] > 2 * margin else 0.0
    y = rng.uniform(room[1] + margin, room[3] - margin) if room[3] - room[1] > 2 * margin else 0.0
    return Table(name=f"table_{i + 1}", center=[round(x, 4), round(y, 4)],
                 yaw=round(float(rng.uniform(-math.pi, math.pi)), 4),
                 size=[round(length, 3), round(width, 3), 0.04],
                 height=round(float(rng.uniform(0.6, 0.9)), 3))


def _dish_on(table: Table, kind: str, rng: np.random.Generator) -> list[float] | None:
    half = np.array(table.size[:2]) / 2 - DISH_SHAPES[kind].radius - 0.005
    if np.any(half <= 0):
        return None
    # Half the dishes near an edge (within reach from outside), the others anywhere.
    p = rng.uniform(-half, half)
    if rng.random() < 0.5:
        axis = int(rng.integers(2))
        p[axis] = math.copysign(half[axis] * rng.uniform(0.85, 1.0), p[axis])
    c, s = math.cos(table.yaw), math.sin(table.yaw)
    return [round(table.center[0] + c * p[0] - s * p[1], 4),
            round(table.center[1] + s * p[0] + c * p[1], 4)]


def random_scene(seed: int, index: int = 0, shape: SceneShape = SceneShape(),
                 planner: PlanningSettings | None = None, *,
                 robot: Robot | None = None) -> Scenario:
    """Scene `index` of the set drawn with `seed` (see the module docstring) for `robot`
    (None: the robot a scenario that names none has); `planner` replaces the default planner
    settings."""
    robot_ = load_robot() if robot is None else robot
    rng = np.random.default_rng([int(seed), int(index)])
    room = [0.0, 0.0, round(float(rng.uniform(3.0, 10.0)), 3),
            round(float(rng.uniform(3.0, 8.0)), 3)]
    start = [round(float(rng.uniform(room[0] + 0.6, room[2] - 0.6)), 4),
             round(float(rng.uniform(room[1] + 0.6, room[3] - 0.6)), 4),
             round(float(rng.uniform(-math.pi, math.pi)), 4)]
    at_start = robot_.footprint(*start).buffer(START_CLEARANCE + GAP)
    room_box = box(*room)
    taken = [at_start]

    def fits(shape_) -> bool:
        return shape_.within(room_box) and not any(shape_.intersects(t) for t in taken)

    tables: list[Table] = []
    for i in range(int(rng.integers(1, shape.max_tables + 1))):
        for _ in range(TRIES):
            table = _table(rng, room, i)
            top = table_footprint(table.center, table.yaw, table.size)
            if fits(top.buffer(GAP)):
                tables.append(table)
                taken.append(top.buffer(GAP))
                break

    dishes: list[Dish] = []
    placed: list = []
    for _ in range(int(rng.integers(0, shape.max_dishes + 1)) if tables else 0):
        for _ in range(TRIES):
            table = tables[int(rng.integers(len(tables)))]
            kind = RESTAURANT_KINDS[int(rng.integers(len(RESTAURANT_KINDS)))]
            p = _dish_on(table, kind, rng)
            if p is None:
                continue
            disc = np.array(p), DISH_SHAPES[kind].radius
            if any(np.linalg.norm(disc[0] - q) < disc[1] + r + 0.01 for q, r in placed):
                continue
            placed.append(disc)
            dishes.append(Dish(name=f"dish_{len(dishes) + 1}", table=table.name, kind=kind,
                               position=p))
            break

    chairs: list[Chair] = []

    def chair_near(x: float, y: float, distance: tuple[float, float]) -> None:
        for _ in range(TRIES):
            d, bearing = rng.uniform(*distance), rng.uniform(-math.pi, math.pi)
            pose = [round(x + d * math.cos(bearing), 4), round(y + d * math.sin(bearing), 4),
                    round(float(rng.uniform(-math.pi, math.pi)), 4)]
            footprint = chair_footprint(pose)
            if fits(footprint.buffer(GAP)):
                chairs.append(Chair(name=f"chair_{len(chairs) + 1}", pose=pose,
                                    mapped=bool(rng.random() < 0.2)))
                taken.append(footprint.buffer(GAP))
                return

    if rng.random() < shape.boxed_in:  # a ring of chairs around the start
        taken.remove(at_start)
        taken.append(robot_.footprint(*start).buffer(START_CLEARANCE + 0.01))
        for _ in range(8):
            chair_near(start[0], start[1], (robot_.base_radius + 0.3, robot_.base_radius + 0.5))
    for _ in range(int(rng.integers(0, shape.max_chairs + 1))):
        if dishes:
            dish = dishes[int(rng.integers(len(dishes)))]
            chair_near(dish.position[0], dish.position[1], (0.3, 0.9))
        else:
            chair_near(*rng.uniform(room[:2], room[2:]), (0.0, 0.1))

    section = RobotSection(name="" if robot is None else robot.name, start=start)
    scene = Scenario(seed=int(rng.integers(2**31)), room=Room(bounds=room), tables=tables,
                     chairs=chairs, dishes=dishes, robot=section)
    if planner is not None:
        scene = replace(scene, planner=planner)
    try:
        validate_scenario(scene)
    except ScenarioError as e:  # a bug here, not a bad draw: every piece was checked
        raise AssertionError(f"random scene ({seed}, {index}) is invalid: {e}") from e
    return scene
