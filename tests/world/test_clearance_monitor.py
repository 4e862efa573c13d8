"""ClearanceMonitor: the robot's closest approach to the true world, from the simulation's
SceneGraph; alone (a forced update on a world at rest) and in a short simulation."""

import math

import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from shapely import affinity
from shapely.geometry import box

from s3o_drake.world.builder import build_world_diagram
from s3o_drake.world.clearance_monitor import REACH, ClearanceMonitor, proximity_geometries
from s3o_drake.world.directives import ROBOT_INSTANCE
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import with_overrides

UR5E = load_robot("ur5e")


def _world_and_monitor(scenario, start):
    scenario = with_overrides(scenario, (f"robot.start={list(start)}",))
    builder = DiagramBuilder()
    world = builder.AddNamedSystem("world", build_world_diagram(scenario))
    plant = world.GetSubsystemByName("plant")
    scene_graph = world.GetSubsystemByName("scene_graph")
    furniture = [plant.GetModelInstanceByName(f.name)
                 for f in (*scenario.tables, *scenario.chairs)]
    monitor = builder.AddNamedSystem("clearance", ClearanceMonitor(
        robot=proximity_geometries(plant, scene_graph,
                                   [plant.GetModelInstanceByName(ROBOT_INSTANCE)]),
        world=proximity_geometries(plant, scene_graph, furniture, world_names=("wall",)),
        period=0.05))
    builder.Connect(world.GetOutputPort("query_object"), monitor.GetInputPort("query_object"))
    return builder.Build(), monitor


def _reading(diagram, monitor, context) -> float:
    return float(monitor.GetOutputPort("closest_approach").Eval(
        monitor.GetMyContextFromRoot(context))[0])


def _measured(scenario, start) -> float:
    diagram, monitor = _world_and_monitor(scenario, start)
    context = diagram.CreateDefaultContext()
    assert _reading(diagram, monitor, context) == REACH  # nothing measured yet
    mine = monitor.GetMyMutableContextFromRoot(context)
    monitor.CalcForcedDiscreteVariableUpdate(mine, mine.get_mutable_discrete_state())
    return _reading(diagram, monitor, context)


def _plan_view_gap(scenario, start) -> float:
    half_l, half_w = UR5E.base_length / 2, UR5E.base_width / 2
    footprint = affinity.rotate(box(-half_l, -half_w, half_l, half_w), start[2],
                                use_radians=True)
    footprint = affinity.translate(footprint, *start[:2])
    (table,) = scenario.tables
    x, y = table.center
    w, d = table.size[:2]
    return footprint.distance(box(x - w / 2, y - d / 2, x + w / 2, y + d / 2))


def test_measures_the_gap_between_the_robot_and_the_table(scenario):
    """The base before the table, its arm stowed over its footprint: the reading is the gap
    in 3D, at least the plan view's (the base's top is below the table's), and it shrinks
    as the base comes closer; the dishes on the table, which the gripper may touch, and the
    floor under the wheels are not measured."""
    near, nearer = (1.85, 1.55, math.pi / 2), (1.85, 1.60, math.pi / 2)
    gap = _plan_view_gap(scenario, near)
    assert gap == pytest.approx(0.24, abs=0.005)
    reading = _measured(scenario, near)
    assert gap - 1e-3 <= reading <= gap + 0.05
    closer = _measured(scenario, nearer)
    assert reading - closer == pytest.approx(0.05, abs=0.01)


def test_keeps_the_smallest_distance_of_a_simulation(scenario):
    """Simulated for a second, the robot holding its pose (its PD actuators settle it by
    millimetres), the reading is the least of the measurements: at most that of the pose
    it started in, and within a centimetre of it."""
    start = (1.85, 1.55, math.pi / 2)
    diagram, monitor = _world_and_monitor(scenario, start)
    simulator = Simulator(diagram)
    simulator.AdvanceTo(1.0)
    reading = _reading(diagram, monitor, simulator.get_context())
    initial = _measured(scenario, start)
    assert initial - 0.01 < reading <= initial


def test_the_room_is_furniture_welded_to_the_world():
    """The monitor reads the room's poses once: a piece of furniture that could move is
    refused, by name."""
    from pydrake.geometry import Box
    from pydrake.math import RigidTransform
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, CoulombFriction
    from pydrake.multibody.tree import SpatialInertia

    from s3o_drake.world.clearance_monitor import room_geometries

    plant, scene_graph = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.0)
    for name in ("welded", "loose"):
        instance = plant.AddModelInstance(name)
        body = plant.AddRigidBody("leg", instance, SpatialInertia.SolidBoxWithMass(
            1.0, 0.1, 0.1, 0.1))
        plant.RegisterCollisionGeometry(body, RigidTransform(), Box(0.1, 0.1, 0.1), "leg",
                                        CoulombFriction(0.5, 0.5))
        if name == "welded":
            plant.WeldFrames(plant.world_frame(), body.body_frame())
    plant.Finalize()
    assert len(room_geometries(plant, scene_graph, ["welded"])) == 1
    with pytest.raises(ValueError, match=r"^loose: furniture must be welded to the world$"):
        room_geometries(plant, scene_graph, ["welded", "loose"])


@pytest.mark.parametrize("robot_name", ["ur5e", "gen3"])
def test_near_pairs_keep_every_pair_that_comes_within_reach(robot_name):
    """NearPairs leaves out only what cannot come within its reach: in the dense
    restaurant, at random base poses by its tables and random arm configurations, every
    (robot, room) pair that Drake's pairwise query measures within the reach is among its
    pairs, and most pairs are left out: for a robot of primitives (the UR5e) and one of
    its makers' meshes (the Gen3), whose bounds are their convex hulls'."""
    import numpy as np

    from s3o_drake.world.clearance_monitor import NearPairs, room_geometries
    from s3o_drake.world.resources import REPO_DIR
    from s3o_drake.world.scenario import load_scenario

    scenario = with_overrides(load_scenario(REPO_DIR / "scenarios" / "restaurant_dense.yaml"),
                              (f"robot.name={robot_name}",))
    world = build_world_diagram(scenario, noise=False)
    context = world.CreateDefaultContext()
    plant, scene_graph = (world.GetSubsystemByName(n) for n in ("plant", "scene_graph"))
    robot = proximity_geometries(plant, scene_graph, list(
        load_robot(robot_name).instances_in(plant).instances))
    room = room_geometries(plant, scene_graph,
                           [f.name for f in (*scenario.tables, *scenario.chairs)])
    plant_context = world.GetMutableSubsystemContext(plant, context)
    lower, upper = plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits()
    rng = np.random.default_rng(0)
    for reach in (0.1, REACH):
        near = NearPairs(robot=robot, world=room, reach=reach)
        measured = 0
        for _ in range(40):
            q = plant.GetPositions(plant_context)
            table = scenario.tables[rng.integers(len(scenario.tables))]
            q[:2] = np.asarray(table.center) + rng.normal(0.0, 0.6, 2)
            q[2] = rng.uniform(-math.pi, math.pi)
            q[3:] = rng.uniform(np.maximum(lower[3:], -math.pi), np.minimum(upper[3:], math.pi))
            plant.SetPositions(plant_context, q)
            query = world.GetOutputPort("query_object").Eval(context)
            found = set(near.pairs(query))
            within = {(p.id_A, p.id_B)
                      for p in query.ComputeSignedDistancePairwiseClosestPoints(reach)
                      if {p.id_A, p.id_B} & robot and {p.id_A, p.id_B} & room}
            assert within <= found
            assert len(found) < len(robot) * len(room) / 4
            measured += len(within)
        assert measured > 0  # the poses came near the tables
