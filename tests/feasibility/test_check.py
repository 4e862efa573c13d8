"""Motion-level feasibility: the one check, the reachability map, exhaustive IK.

The scene (tests/conftest.py) is scenarios/small/two_dishes.yaml: a 1.2 m x 0.8 m table (x
1.4..2.6, y 2.1..2.9, top at 0.75 m) with a plate and a cup 0.2 m inside its free south edge
(y = 2.1) and a chair at its north side.
"""

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pydrake.geometry import Role

from s3o_drake.experiments.reachability_agreement import sample_queries
from s3o_drake.feasibility import kinematics as kin
from s3o_drake.feasibility.check import CheckResult, FeasibilityChecker
from s3o_drake.feasibility.grasp_targets import arm_base_positions, grasp_specs
from s3o_drake.feasibility.grasps import grasps_for
from s3o_drake.feasibility.ik import grasp_error, solve_grasp_ik, verify
from s3o_drake.feasibility.reachability import map as reach
from s3o_drake.feasibility.reachability.build import build_map
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.furniture import DISH_KINDS
from s3o_drake.world.map import Chair
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import load_scenario

UR5E = load_robot("ur5e")

REPO = Path(__file__).resolve().parents[2]
# In front of the plate, facing it (north), 0.34 m from the table's edge.
FRONT_OF_PLATE = np.array([1.85, 1.45, math.pi / 2])
# The check's tolerance on the grasp frame.
POSITION_TOLERANCE = 0.01
ANGLE_TOLERANCE = math.radians(3.0)


@pytest.fixture(scope="module")
def reachability(scene):
    return reach.ReachabilityMap.load(robot=scene.robot)


@pytest.fixture(scope="module")
def by_map(scene, reachability):
    return FeasibilityChecker(scene, reachability)


@pytest.fixture(scope="module")
def by_ik(scene):
    return FeasibilityChecker(scene, method="ik")


# ------------------------------------------------------------------------------- the check

@pytest.mark.parametrize("method", ["map", "ik"])
def test_dish_near_a_free_edge_is_feasible_from_in_front(method, by_map, by_ik):
    checker = by_map if method == "map" else by_ik
    for dish in ("plate_a", "cup_b"):
        base = FRONT_OF_PLATE.copy()
        base[0] = checker.scene.dish_p_WD(dish)[0][0]
        result = checker.check(base, dish)
        assert isinstance(result, CheckResult)
        assert result.feasible, (dish, result.reason)
        assert result.reason == "ok"
        assert result.grasp in ("top", "side")
        assert result.q.shape == (11,)
        np.testing.assert_allclose(result.q[:3], base)


@pytest.mark.parametrize("method", ["map", "ik"])
def test_far_away_and_under_the_table_are_infeasible(method, by_map, by_ik):
    checker = by_map if method == "map" else by_ik
    far = np.array([0.65, 0.70, 0.0])  # 2 m from the plate, in the open
    far[2] = facing_yaw(far[:2], checker.scene.dish_p_WD("plate_a")[0])
    result = checker.check(far, "plate_a")
    assert not result.feasible and result.reason == "out_of_reach"
    assert result.q is None and result.grasp is None
    under = np.array([1.85, 2.45, math.pi / 2])
    result = checker.check(under, "plate_a")
    assert not result.feasible and result.reason == "base_collision"


def test_a_chair_on_the_feasible_spot_makes_it_infeasible(scene, reachability):
    blocker = Chair(name="blocker", pose=[FRONT_OF_PLATE[0], FRONT_OF_PLATE[1], 0.0])
    contents = dataclasses.replace(scene.contents, chairs=(*scene.contents.chairs, blocker))
    cluttered = FeasibilityScene(contents)
    assert FeasibilityChecker(scene, reachability).check(FRONT_OF_PLATE, "plate_a").feasible
    result = FeasibilityChecker(cluttered, reachability).check(FRONT_OF_PLATE, "plate_a")
    assert not result.feasible and result.reason == "base_collision"


@pytest.fixture(scope="module")
def reference(scene):
    """A second scene of the same contents, for checks independent of the checkers'."""
    return FeasibilityScene(scene.contents)


def _min_robot_environment_distance(world, q, dish) -> float:
    """Smallest distance between the robot and the rest, by a scene graph query on a fresh
    context of `world`.

    The gripper's distance to the grasped dish does not count (it touches it).
    """
    plant = world.plant
    context = world.diagram.CreateDefaultContext()
    world.robot_instances.set_positions(plant.GetMyMutableContextFromRoot(context), q)
    scene_graph = world.diagram.scene_graph()
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
    inspector = query.inspector()

    def body(geometry_id):
        return plant.GetBodyFromFrameId(inspector.GetFrameId(geometry_id))

    dish_body = world.dish_body(dish)
    gripper = {world.robot_instances.body(name).index()
               for name in world.robot.gripper_bodies}
    smallest = np.inf
    for pair in query.ComputeSignedDistancePairwiseClosestPoints(max_distance=0.05):
        a, b = body(pair.id_A), body(pair.id_B)
        robot_a = a.model_instance() in world.robot_instances.instances
        robot_b = b.model_instance() in world.robot_instances.instances
        if robot_a == robot_b:
            continue  # robot-robot (self) or environment-environment
        other = b if robot_a else a
        mine = a if robot_a else b
        if other.index() == dish_body.index() and mine.index() in gripper:
            continue
        assert inspector.GetProperties(pair.id_A, Role.kProximity) is not None
        smallest = min(smallest, pair.distance)
    return smallest


@pytest.mark.parametrize("method", ["map", "ik"])
def test_returned_configuration_is_free_and_grasps_the_target(method, scene, by_map, by_ik,
                                                              reference):
    checker = by_map if method == "map" else by_ik
    rng = np.random.default_rng(3)
    found = 0
    for dish in ("plate_a", "cup_b"):
        for _ in range(6):
            base = FRONT_OF_PLATE + np.array([rng.uniform(-0.3, 0.3), rng.uniform(-0.15, 0.1), 0])
            base[2] = facing_yaw(base[:2], scene.dish_p_WD(dish)[0])
            offset = np.array([*rng.normal(0.0, 0.01, 2), 0.0])
            result = checker.check(base, dish, offset)
            if not result.feasible:
                continue
            found += 1
            # Independently: another scene's checker, and a scene graph distance query.
            with reference.grasping(dish):
                assert reference.checker.CheckConfigCollisionFree(result.q)
            assert _min_robot_environment_distance(reference, result.q, dish) >= 0.0099
            grasp = next(g for g in checker.grasps(base, dish, offset) if g.kind == result.grasp)
            angle, distance = grasp_error(reference, result.q, grasp.X_WG)
            assert distance <= POSITION_TOLERANCE and angle <= ANGLE_TOLERANCE
            assert np.all(result.q >= reference.plant.GetPositionLowerLimits())
            assert np.all(result.q <= reference.plant.GetPositionUpperLimits())
    assert found >= 6


def test_map_and_exhaustive_ik_agree_on_a_fixed_sample(scene, by_map, by_ik):
    queries = sample_queries(scene, 36, np.random.default_rng(7), max_distance=1.1)
    agree = informative = 0
    for dish, base, offset in zip(queries.dishes, queries.bases, queries.offsets, strict=True):
        a, b = by_map.check(base, dish, offset), by_ik.check(base, dish, offset)
        agree += a.feasible == b.feasible
        informative += b.reason != "base_collision"
    assert informative >= 10  # the sample is not all base collisions
    assert agree / len(queries.dishes) >= 0.9


def test_check_many_gives_the_answers_of_check(scene, by_map):
    queries = sample_queries(scene, 150, np.random.default_rng(11), max_distance=1.6)
    for dish in ("plate_a", "cup_b"):
        many = by_map.check_many(queries.bases, dish, queries.offsets)
        one = [by_map.check(b, dish, o).feasible
               for b, o in zip(queries.bases, queries.offsets, strict=True)]
        assert many.dtype == bool and many.shape == (150,)
        np.testing.assert_array_equal(many, one)
        assert 0 < many.sum() < len(many)
    assert by_map.check_many(np.zeros((0, 3)), "plate_a").shape == (0,)


def test_vectorised_grasp_geometry_follows_grasps_for(scene):
    rng = np.random.default_rng(5)
    bases = np.column_stack([rng.uniform(0, 4, 20), rng.uniform(0, 4, 20), rng.uniform(-3, 3, 20)])
    p_WA = arm_base_positions(bases, robot=scene.robot)
    for base, p in zip(bases, p_WA, strict=True):
        np.testing.assert_allclose(p, scene.p_WA(base), atol=1e-12)
    for kind in DISH_KINDS:
        specs = grasp_specs(kind, robot=scene.robot)
        for p in p_WA:
            p_WD = rng.uniform(0, 4, 2)
            grasps = grasps_for(kind, p_WD, 0.75, p, robot=scene.robot)
            assert [g.kind for g in grasps] == [s.kind for s in specs]
            for g, s in zip(grasps, specs, strict=True):
                assert g.rho == pytest.approx(np.hypot(*(p_WD - p[:2])) - s.inset)
                assert g.height == pytest.approx(0.75 + s.z_offset - p[2])
                assert g.wrist_turn == s.wrist_turn


def test_full_ik_solves_a_reachable_grasp_and_gives_up_on_a_far_one(scene, by_map):
    grasp = by_map.grasps(FRONT_OF_PLATE, "plate_a")[0]
    seed = by_map.check(FRONT_OF_PLATE, "plate_a").q[3:9]
    q = solve_grasp_ik(scene, FRONT_OF_PLATE, grasp, dish="plate_a", seeds=seed[None])
    assert q is not None and verify(scene, q, "plate_a", grasp.X_WG)
    np.testing.assert_allclose(q[:3], FRONT_OF_PLATE)
    far = np.array([1.85, 0.9, math.pi / 2])  # 1.4 m: beyond the arm's reach
    assert solve_grasp_ik(scene, far, by_map.grasps(far, "plate_a")[0], dish="plate_a",
                          max_major_iterations=20) is None


def test_reach_offsets_may_be_horizontal(by_map):
    bases = np.tile(FRONT_OF_PLATE, (4, 1))
    flat = np.array([[0.0, 0.0], [0.05, 0.0], [0.0, 0.4], [-0.01, 0.01]])
    padded = np.column_stack([flat, np.zeros(4)])
    np.testing.assert_array_equal(by_map.check_many(bases, "cup_b", flat),
                                  by_map.check_many(bases, "cup_b", padded))
    for two, three in zip(flat, padded, strict=True):
        a = by_map.check(FRONT_OF_PLATE, "cup_b", two)
        b = by_map.check(FRONT_OF_PLATE, "cup_b", three)
        assert (a.feasible, a.reason, a.grasp) == (b.feasible, b.reason, b.grasp)
    with pytest.raises(ValueError, match="reach offsets"):
        by_map.check_many(bases, "cup_b", np.zeros((3, 3)))


# ------------------------------------------------------------------- kinematics and the map

def test_numpy_kinematics_match_the_plant(scene):
    from pydrake.planning import RobotDiagramBuilder

    robot = scene.robot
    arm = kin.arm_kinematics(robot)
    builder = RobotDiagramBuilder(time_step=0.0)
    robot.add_to(builder.parser())
    builder.plant().Finalize()
    plant = builder.plant()
    context = plant.CreateDefaultContext()
    A, G = plant.GetFrameByName(robot.arm_base_link), plant.GetFrameByName(robot.grasp_frame)
    q = np.random.default_rng(0).uniform(-math.pi, math.pi, (30, 6))
    R, p = arm.forward(q)
    for i in range(len(q)):
        plant.SetPositions(context, robot.positions(0.4, -0.3, 1.0, q[i]))
        X_AG = plant.CalcRelativeTransform(context, A, G)
        np.testing.assert_allclose(X_AG.rotation().matrix(), R[i], atol=1e-12)
        np.testing.assert_allclose(X_AG.translation(), p[i], atol=1e-12)
    # Closed-form IK returns every configuration among its eight branches.
    solutions = arm.inverse(R, p)
    gap = np.abs(kin.wrap(solutions - q[:, None])).max(axis=-1)
    assert np.nanmin(gap, axis=1).max() < 1e-8


def test_shipped_map_loads_and_records_its_settings(reachability):
    s = reachability.settings
    assert s["robot_urdf_sha256"] == reach.robot_model_sha256(reachability.robot)
    assert set(s["kinds"]) == {"top", "side"}
    assert s["resolution"] <= 0.02 and s["max_per_node"] == 8
    assert s["min_distance"] == pytest.approx(0.01)
    assert s["rho_range"][1] >= 0.95 and s["height_range"][0] <= -0.15
    assert s["height_range"][1] >= 0.4
    for key in ("seeds", "built", "build_seconds", "max_major_iterations"):
        assert key in s
    assert reachability.robot.files.reachability_map.stat().st_size < 5e6
    # A top grasp 0.6 m ahead at table height has several branches, all exact.
    q = reachability.candidates("top", 0.6, 0.03)
    assert 2 <= len(q) <= 8
    R, p = reachability.arm.forward(q)
    angle, distance = kin.pose_error(R, p, reach.R_KIND["top"], np.array([0.6, 0.0, 0.03]))
    assert distance.max() <= 0.002 and angle.max() <= math.radians(2)
    assert len(reachability.candidates("top", 1.15, 0.03)) == 0  # beyond the arm's reach
    assert len(reachability.candidates("side", 2.0, 0.0)) == 0  # beyond the map
    # Tilted targets (the side grasp's second try) are solved exactly too.
    pitch = math.radians(1.8)
    q, valid = reachability.candidates_many("side", np.array([0.7]), np.array([0.05]),
                                            pitch=pitch)
    R, p = reachability.arm.forward(q[valid])
    R_tilted = np.array([[math.cos(pitch), 0, math.sin(pitch)], [0, 1, 0],
                         [-math.sin(pitch), 0, math.cos(pitch)]]) @ reach.R_KIND["side"]
    angle, distance = kin.pose_error(R, p, R_tilted, np.array([0.7, 0.0, 0.05]))
    assert valid.sum() >= 2 and distance.max() < 1e-3 and angle.max() < 1e-3


def test_lookups_do_not_depend_on_the_order_cells_are_first_asked_in(scene):
    """A cell's trust is worked out when a lookup first needs it: a map asked in one
    order gives, bit for bit, what a map asked in another gives, every cell at once
    included."""
    rng = np.random.default_rng(7)
    rho = rng.uniform(0.2, 1.1, 400)
    height = rng.uniform(-0.15, 0.4, 400)
    for kind in ("top", "side"):
        one_go, piecewise = (reach.ReachabilityMap.load(robot=scene.robot) for _ in range(2))
        everything = one_go._cells(kind)
        n_i, n_j, _ = everything.full.shape
        i, j = np.meshgrid(np.arange(n_i), np.arange(n_j), indexing="ij")
        everything.trusted(i.ravel(), j.ravel())
        want = one_go.candidates_many(kind, rho, height)
        order = rng.permutation(len(rho))
        got = [piecewise.candidates_many(kind, rho[part], height[part])
               for part in np.array_split(order, 9)]
        for part, (q, valid) in zip(np.array_split(order, 9), got, strict=True):
            assert np.array_equal(valid, want[1][part])
            assert np.array_equal(q, want[0][part], equal_nan=True)


def test_missing_map_names_the_build_command(tmp_path, scene):
    with pytest.raises(reach.ReachabilityMapError, match="s3o build reachability"):
        reach.ReachabilityMap.load(tmp_path / "none.npz", robot=scene.robot)


def test_small_build_round_trips_through_its_file(tmp_path, scene):
    built = build_map(robot=scene.robot, resolution=0.1, rho_range=(0.5, 0.7),
                      height_range=(0.0, 0.1), workers=1, progress=False)
    path = tmp_path / "map.npz"
    path.write_bytes(built.to_bytes())
    loaded = reach.ReachabilityMap.load(path, robot=scene.robot)
    assert loaded.settings["resolution"] == 0.1 and loaded.configs["top"].shape == (3, 2, 8, 6)
    assert loaded.settings["nodes"]["top"] == 6
    np.testing.assert_array_equal(loaded.configs["side"], built.configs["side"])
    assert len(loaded.candidates("top", 0.55, 0.05)) >= 2


def test_build_command_rejects_bad_arguments_in_one_line(capsys):
    run = subprocess.run(
        [sys.executable, "-m", "s3o_drake.commands.build_reachability", "build",
         "--resolution", "0.5"], capture_output=True, text=True, cwd=REPO)
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1 and "--resolution" in run.stderr
    # The module's own address is run above; its help comes from the same parser.
    from s3o_drake.commands.build_reachability import main as build_main

    with pytest.raises(SystemExit) as info:
        build_main(["--help"])
    assert info.value.code == 0
    help_text = capsys.readouterr().out
    assert "inverse reachability map" in help_text and "build" in help_text


@pytest.fixture(scope="module")
def scene_of():
    """The feasibility scene of a scenario file, built once for the tests that ask for it."""
    scenes = {}

    def of(path: Path) -> FeasibilityScene:
        if path not in scenes:
            scenes[path] = FeasibilityScene(load_scenario(path).contents)
        return scenes[path]

    return of


@pytest.mark.parametrize("scenario_path", [REPO / "scenarios" / "restaurant.yaml",
                                           REPO / "scenarios" / "generated" / "task_003.yaml"])
def test_plan_view_shortcuts_agree_with_drake(scenario_path, scene_of):
    """The base check's shortcuts (far from everything: free; prisms overlapping: collides)
    never contradict the Drake collision checker, and settle most random poses."""

    scenario = load_scenario(scenario_path)
    scene = scene_of(scenario_path)
    rng = np.random.default_rng(5)
    x0, y0, x1, y1 = scenario.room.bounds
    n = 3000
    bases = np.stack([rng.uniform(x0, x1, n), rng.uniform(y0, y1, n),
                      rng.uniform(-math.pi, math.pi, n)], axis=1)
    free = np.array(scene.checker.CheckConfigsCollisionFree(
        [np.concatenate([b, UR5E.arm_stow, UR5E.gripper_open]) for b in bases]), dtype=bool)
    certainly_free = scene.clearance.certainly_free(bases[:, :2])
    certainly_colliding = scene.collision.certainly_colliding(bases)
    assert not (certainly_free & ~free).any()
    assert not (certainly_colliding & free).any()
    assert (certainly_free | certainly_colliding).mean() > 0.6
    assert 0.4 < scene.robot_radius < 0.5  # the base's half diagonal is 0.418 m


@pytest.mark.parametrize("scenario_path", [REPO / "scenarios" / "restaurant.yaml",
                                           REPO / "scenarios" / "restaurant_dense.yaml"])
def test_the_posed_shortcut_agrees_with_drake_next_to_furniture(scenario_path, scene_of):
    """Where stops stand, 0.25-0.6 m from a table or chair at any yaw, the turned robot
    extent never calls a pose free that Drake finds colliding, and it settles poses that
    the radius test leaves to Drake."""
    import shapely

    from s3o_drake.world.obstacles import Obstacles

    scenario = load_scenario(scenario_path)
    scene = scene_of(scenario_path)
    rng = np.random.default_rng(7)
    rings = Obstacles.of_contents(scenario.contents).union.buffer(0.25).boundary
    n = 3000
    on_ring = shapely.get_coordinates(shapely.line_interpolate_point(
        rings, rng.uniform(0, 1, n), normalized=True))
    xy = on_ring + rng.uniform(-0.35, 0.35, (n, 2))
    bases = np.column_stack([xy, rng.uniform(-math.pi, math.pi, n)])
    free = np.array(scene.checker.CheckConfigsCollisionFree(
        [np.concatenate([b, UR5E.arm_stow, UR5E.gripper_open]) for b in bases]), dtype=bool)
    posed = scene.clearance.certainly_free_posed(bases)
    assert not (posed & ~free).any()
    # Of the free poses that the radius and prism tests leave to Drake (measured: 730 and
    # 682), the posed test settles 51 % and 39 %.
    left = ~scene.clearance.certainly_free(bases[:, :2]) \
        & ~scene.collision.certainly_colliding(bases) & scene.clearance.in_room(bases[:, :2])
    assert (posed & left).sum() > (left & free).sum() / 3

