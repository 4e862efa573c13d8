"""Claims in the Voronoi partition: a dish that its own cell serves poorly takes the positions
that serve it better (s3o_drake/abstraction/voronoi.py), and every method then plans it."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Point

from s3o_drake.abstraction import LocationGrid, voronoi_partition
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.planning.methods import plan_task
from s3o_drake.planning.task.check import check_plan
from s3o_drake.planning.task.planner import TaskProblem
from s3o_drake.world.choices import METHODS
from s3o_drake.world.deadline import Deadline
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import parse_scenario

UR5E = load_robot("ur5e")

# A cup on the left of a table and a plate on its right: the line x = 3 splits their cells.
SCENE = """
seed: 2
room: {bounds: [0.0, 0.0, 6.0, 4.0]}
tables:
  - {name: table, center: [3.0, 2.0], yaw: 0.0, size: [1.0, 0.6, 0.04], height: 0.75}
dishes:
  - {name: cup, table: table, position: [2.7, 2.0], kind: cup}
  - {name: plate, table: table, position: [3.3, 2.0], kind: plate}
robot: {start: [1.0, 3.5, 0.0]}
"""
# Right of the table, in the plate's cell: the only positions that pick the cup.
BAND = (3.85, 4.25, 1.7, 2.3)
# Below the table, also in the plate's cell.
BELOW = (3.05, 3.6, 1.0, 1.4)


def _heatmap(dish: str, *boxes: tuple[float, float, float, float], value: float = 0.9,
             low: tuple[float, float, float, float] | None = None) -> Heatmap:
    """Fea^m `value` inside the boxes (x0, x1, y0, y1), 0.2 inside `low`, 0 elsewhere, on a
    grid over the room."""
    grid = Heatmap(dish, np.zeros((80, 120)), 0.0, 0.0, 0.05)
    c = grid.centers()

    def inside(*boxes):
        mask = np.zeros(grid.values.shape, dtype=bool)
        for x0, x1, y0, y1 in boxes:
            mask |= (c[..., 0] > x0) & (c[..., 0] < x1) & (c[..., 1] > y0) & (c[..., 1] < y1)
        return mask

    values = np.where(inside(*boxes), value, 0.0)
    if low is not None:
        values = np.where(inside(low) & (values == 0.0), 0.2, values)
    return Heatmap(dish, values, grid.x0, grid.y0, grid.cell)


@pytest.fixture(scope="module")
def known():
    return KnownWorld.perfect(parse_scenario(SCENE))


def test_a_dish_its_cell_cannot_serve_claims_the_positions_that_can(known):
    maps = [_heatmap("cup", BAND), _heatmap("plate", BAND, BELOW)]
    plain = voronoi_partition(known)
    partition = voronoi_partition(known, feasibility=maps)
    cup, plate = partition.dishes.index("cup"), partition.dishes.index("plate")
    assert [i for i, _ in partition.claims] == [cup]
    p_band = np.array([[4.05, 2.0]])
    assert plain.sym_many(p_band)[0] == plate  # by distance alone, the plate's
    assert partition.sym_many(p_band)[0] == cup
    assert partition.sym((4.05, 2.0)) == cup  # Sym and its vectorised form agree
    assert partition.sym_many(np.array([[3.3, 1.2]]))[0] == plate  # the plate keeps the rest
    p_left = np.array([[2.1, 1.6]])  # in the cup's Voronoi cell, which picks it from nowhere
    assert plain.sym_many(p_left)[0] == cup
    assert partition.sym_many(p_left)[0] == -1 and partition.sym(p_left[0]) is None
    assert not partition.cells[plate].buffer(-1e-6).intersects(partition.claims[0][1])
    grid = LocationGrid.of(partition, maps)
    assert grid.location(("cup",)).fea.max() == pytest.approx(0.9)
    assert grid.location(("plate",)).fea.max() == pytest.approx(0.9)
    # Without Fea^m nothing is claimed: the cup's cell picks it from nowhere.
    assert LocationGrid.of(plain, maps).location(("cup",)).fea.max() == 0.0


def test_a_claim_leaves_a_neighbour_its_only_good_positions(known):
    """Where the plate too is picked only from the band, the band stays the plate's (S3O can
    merge the two; a plain Voronoi state space picks the cup at long odds or not at all)."""
    maps = [_heatmap("cup", BAND), _heatmap("plate", (3.9, 4.2, 1.75, 2.25))]
    partition = voronoi_partition(known, feasibility=maps)
    assert partition.claims == []
    assert partition.sym_many(np.array([[4.05, 2.0]]))[0] == partition.dishes.index("plate")


def test_positions_the_robot_cannot_drive_to_do_not_count(known):
    """A cell whose positions that pick its dish are all out of the robot's way (here: every
    position left of x = 2 by `drivable`) serves it no better than one that picks it from
    nowhere: the dish claims positions it can be driven to."""
    maps = [_heatmap("cup", (1.6, 1.95, 1.7, 2.3), BAND), _heatmap("plate", BAND, BELOW)]
    assert voronoi_partition(known, feasibility=maps).claims == []  # it serves the cup
    partition = voronoi_partition(known, feasibility=maps, drivable=lambda P: P[:, 0] > 2.0)
    assert [partition.dishes[i] for i, _ in partition.claims] == ["cup"]


@pytest.mark.parametrize("method", METHODS)
def test_every_method_plans_a_dish_whose_own_cell_cannot_pick_it(known, method):
    maps = [_heatmap("cup", BAND), _heatmap("plate", BAND, BELOW)]
    plan = plan_task(known, method=method, heatmaps=maps, seed=0).plan
    assert plan.unreachable == ()
    assert {a.dish for a in plan.pickups} == {"cup", "plate"}
    # From where it claimed (V-PETLON's goals, drawn with no regard to Fea^m, may stand
    # where the plate is out of reach: it is the baseline that ignores feasibility).
    assert next(a.feasibility for a in plan.pickups if a.dish == "cup") == pytest.approx(0.9)
    dishes = {d: name for name, group in zip(plan.locations, plan.groups, strict=True)
              for d in group}
    check_plan(TaskProblem(locations=plan.locations, dishes=dishes, costs=lambda a, b: 0.0),
               plan.task_actions)


def test_petlon_finds_the_one_free_spot_of_a_sliver_cell():
    """task_017's bowl_2: one free, drivable lattice point in sixteen, in a cell 1/50 of its
    bounding box. Rejection rounds in the box miss it; the draw then comes from the lattice."""
    from shapely.geometry import box

    from s3o_drake.planning.motion.petlon import random_position
    from s3o_drake.planning.navigation.map import NavigationMap
    from s3o_drake.world.obstacles import Obstacles

    nav = NavigationMap(Obstacles(room=box(0.0, 0.0, 6.0, 4.0), footprints=()), robot=UR5E)
    # An L of two thin strips; free only within 5 mm of one lattice point of it.
    region = box(0.5, 0.5, 5.5, 0.55).union(box(0.5, 0.5, 0.55, 3.5))
    spot = np.array([3.025, 0.525])

    def free(points: np.ndarray) -> np.ndarray:
        return np.linalg.norm(points - spot, axis=1) < 0.005

    p = random_position(region, nav, np.array([3.0, 2.0]), np.random.default_rng(0), free)
    assert p is not None and free(p[None])[0]
    assert random_position(region, nav, np.array([3.0, 2.0]), np.random.default_rng(0),
                           lambda P: np.zeros(len(P), dtype=bool)) is None


def test_no_claim_starts_after_the_deadline(known):
    """A planner out of time plans on the cells as they are (the claims are uninterruptible
    work that a small budget must not pay for)."""
    maps = [_heatmap("cup", BAND), _heatmap("plate", BAND, BELOW)]
    # A clock that stands still: passed or not whatever the machine's speed.
    late = voronoi_partition(known, feasibility=maps, deadline=Deadline(0.0, lambda: 1.0))
    assert late.claims == []
    assert len(voronoi_partition(known, feasibility=maps,
                                 deadline=Deadline(1.0, lambda: 0.0)).claims) == 1


def test_a_claim_takes_the_positions_that_pick_at_odds_like_the_best(known):
    """Not every position with some chance: below the table the cup is picked at 0.2, right
    of it at 0.9, and only the band is claimed (V-PETLON's goals are drawn from the claim)."""
    maps = [_heatmap("cup", BAND, low=BELOW), _heatmap("plate", BAND, BELOW)]
    (_, claimed), = voronoi_partition(known, feasibility=maps).claims
    assert claimed.contains(Point(4.05, 2.0)) and not claimed.intersects(Point(3.3, 1.2))


def test_petlon_gives_up_a_cell_without_a_free_spot_early():
    """A cell with no free point cost all the rejection rounds (seconds in a crowded scene:
    the soak's V-PETLON ran out of its budget on them); its lattice now tells early."""
    from shapely.geometry import box

    from s3o_drake.planning.motion.petlon import DRAWS_PER_POSITION, LATTICE_AFTER, random_position
    from s3o_drake.planning.navigation.map import NavigationMap
    from s3o_drake.world.obstacles import Obstacles

    nav = NavigationMap(Obstacles(room=box(0.0, 0.0, 6.0, 4.0), footprints=()), robot=UR5E)
    calls = []

    def nowhere(points: np.ndarray) -> np.ndarray:
        calls.append(len(points))
        return np.zeros(len(points), dtype=bool)

    assert random_position(box(1.0, 1.0, 2.0, 2.0), nav, np.array([3.0, 3.0]),
                           np.random.default_rng(0), nowhere) is None
    assert len(calls) == LATTICE_AFTER + 1 < DRAWS_PER_POSITION  # the rounds, then the lattice
