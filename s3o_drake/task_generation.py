"""Benchmark tasks drawn by the paper's protocol (S3O, section V); the command that writes
them is `python -m s3o_drake.commands.generate`.

Every task keeps the room, the seven tables, the robot's start and the settings of a base
scenario (default: scenarios/restaurant.yaml) and draws anew: 5 to 7 dishes at random
spots on random tables, and one chair that is not on the map near each dish, at a random
position and yaw. Chairs never overlap furniture, walls or each other, and the robot's
start stays free; each task passes the same validation as a hand-written scenario.

Task i depends only on the seed and i, so the same seed gives the same tasks.
"""

import math
from dataclasses import replace

import numpy as np

from s3o_drake.furniture import DISH_SHAPES, RESTAURANT_KINDS, chair_footprint, table_footprint
from s3o_drake.resources import RESTAURANT
from s3o_drake.robot import footprint_polygon
from s3o_drake.scenario import (
    START_CLEARANCE,
    Chair,
    Dish,
    Scenario,
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


class GenerationError(RuntimeError):
    pass


def _sample_dishes(base: Scenario, rng: np.random.Generator) -> list[Dish]:
    count = int(rng.choice(DISH_COUNTS))
    dishes: list[Dish] = []
    placed: list[tuple[np.ndarray, float]] = []
    for _ in range(MAX_TRIES):
        if len(dishes) == count:
            return dishes
        table = base.tables[int(rng.integers(len(base.tables)))]
        kind = RESTAURANT_KINDS[int(rng.integers(len(RESTAURANT_KINDS)))]
        radius = DISH_SHAPES[kind].radius
        half = np.array(table.size[:2]) / 2 - radius - EDGE_MARGIN
        if np.any(half <= 0):
            continue
        p_T = rng.uniform(-half, half)  # in the table frame
        c, s = math.cos(table.yaw), math.sin(table.yaw)
        p_W = np.array(table.center) + np.array([c * p_T[0] - s * p_T[1],
                                                 s * p_T[0] + c * p_T[1]])
        if any(np.linalg.norm(p_W - q) < radius + r + DISH_GAP for q, r in placed):
            continue
        placed.append((p_W, radius))
        name = f"{kind}_{sum(d.kind == kind for d in dishes) + 1}"
        dishes.append(Dish(name=name, table=table.name, kind=kind,
                           position=[round(float(v), 4) for v in p_W]))
    raise GenerationError("could not place the dishes")


def _sample_chairs(base: Scenario, dishes: list[Dish], rng: np.random.Generator) -> list[Chair]:
    room = room_polygon(base).buffer(-CHAIR_GAP)
    obstacles = [table_footprint(t.center, t.yaw, t.size).buffer(CHAIR_GAP)
                 for t in base.tables]
    robot = footprint_polygon(*base.robot.start).buffer(START_CLEARANCE + ROBOT_START_GAP)
    chairs: list[Chair] = []
    for i, dish in enumerate(dishes):
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
            chairs.append(Chair(name=f"chair_{i + 1}", pose=pose, mapped=False))
            obstacles.append(shape.buffer(CHAIR_GAP))
            break
        else:
            raise GenerationError(f"no free spot for a chair near {dish.name}")
    return chairs


def generate_task(base: Scenario, seed: int, index: int) -> Scenario:
    """Task `index` of the set drawn with `seed`; the same arguments give the same task."""
    rng = np.random.default_rng([seed, index])
    for _ in range(100):
        try:
            dishes = _sample_dishes(base, rng)
            chairs = _sample_chairs(base, dishes, rng)
        except GenerationError:
            continue
        task = replace(base, seed=int(rng.integers(2**31)), dishes=dishes, chairs=chairs)
        try:
            validate_scenario(task)
        except ScenarioError:
            continue
        return task
    raise GenerationError(f"could not generate task {index} with seed {seed}")
