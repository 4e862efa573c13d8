"""Builds the restaurant of a Scenario in Drake: plant, scene graph, overhead camera.

`populate_plant` adds the room, tables, chairs, dishes and the robot to a MultibodyPlant;
`build_world_diagram` wraps that in the simulation diagram with the overhead RgbdSensor
and, when a Meshcat is passed in, its visualizers. Furniture and dishes are instances of
the SDFormat templates in `models/furniture/`, welded to the world.
"""

import copy
from dataclasses import dataclass, field
from string import Template

import numpy as np
from pydrake.geometry import (
    Box,
    ClippingRange,
    ColorRenderCamera,
    DepthRange,
    DepthRenderCamera,
    GeometryInstance,
    IllustrationProperties,
    MakeRenderEngineVtk,
    Meshcat,
    PerceptionProperties,
    RenderCameraCore,
    RenderEngineVtkParams,
    Role,
    SceneGraph,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlant,
)
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.controllers import InverseDynamics
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.lcm import ApplyLcmBusConfig
from pydrake.systems.primitives import MatrixGain
from pydrake.systems.sensors import RgbdSensor
from pydrake.visualization import ApplyVisualizationConfig

from s3o_drake.world import furniture as fu
from s3o_drake.world.base_scanner import (
    SCAN_RANGE,
    BaseScanner,
    scanner_info,
    scanner_mounts,
)
from s3o_drake.world.camera import overhead_camera
from s3o_drake.world.choices import Localization
from s3o_drake.world.clearance_monitor import proximity_geometries, room_geometries
from s3o_drake.world.contents import SceneContents
from s3o_drake.world.geometry_mirror import AddGeometryMirror
from s3o_drake.world.goals import place_targets
from s3o_drake.world.localisation import Localisation, LocalisationError
from s3o_drake.world.map import Chair, Room, Table
from s3o_drake.world.object_tracker import AddObjectTracker, ObjectTracker
from s3o_drake.world.objects import Dish, surface_height
from s3o_drake.world.protective_stop import WATCH_PERIOD, ProtectiveStop
from s3o_drake.world.resources import make_parser, models_dir
from s3o_drake.world.robot import CONTROL_PERIOD, Robot, RobotInstances
from s3o_drake.world.robot_ports import connect_robot_desired_state, robot_state_output
from s3o_drake.world.scan_matching import RoomSection
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.target_sensor import TargetSensor

RENDERER = "vtk"
ILLUSTRATION = "meshcat_visualizer(illustration)"
"""The Meshcat visualizer of the illustration geometry, by the name Drake gives it."""
FLOOR_RGBA = np.array([0.82, 0.80, 0.76, 1.0])
WALL_RGBA = np.array([0.90, 0.90, 0.88, 1.0])


@dataclass
class WorldModels:
    """The model instances a world holds, by scenario name (the robot's: one, or one per
    part)."""

    robot: RobotInstances
    tables: dict[str, ModelInstanceIndex] = field(default_factory=dict)
    chairs: dict[str, ModelInstanceIndex] = field(default_factory=dict)
    dishes: dict[str, ModelInstanceIndex] = field(default_factory=dict)


def _template(name: str) -> Template:
    return Template((models_dir() / "furniture" / f"{name}.sdf.template").read_text())


def _weld(plant: MultibodyPlant, model: ModelInstanceIndex, body: str, X_WB: RigidTransform):
    plant.WeldFrames(plant.world_frame(), plant.GetBodyByName(body, model).body_frame(), X_WB)


def _planar_pose(x: float, y: float, yaw: float, z: float = 0.0) -> RigidTransform:
    return RigidTransform(RotationMatrix.MakeZRotation(yaw), [x, y, z])


def table_sdf(table: Table) -> str:
    size_x, size_y, thickness = table.size
    leg_len = table.height - thickness
    dx, dy = fu.table_leg_offsets(table.size)[-1]
    return _template("table").substitute(
        name=table.name, mass=10.0 + 20.0 * size_x * size_y, size_x=size_x, size_y=size_y,
        thickness=thickness, top_z=table.height - thickness / 2, leg_w=fu.TABLE_LEG_WIDTH,
        leg_len=leg_len, leg_z=leg_len / 2, leg_dx=dx, leg_dy=dy)


def chair_sdf(chair: Chair, rgba: str = "0.55 0.16 0.12 1") -> str:
    back_x, back_z = fu.chair_back_offset()
    leg_len = fu.CHAIR_SEAT_HEIGHT - fu.CHAIR_SEAT_THICKNESS
    return _template("chair").substitute(
        name=chair.name, rgba=rgba,
        seat_z=fu.CHAIR_SEAT_HEIGHT - fu.CHAIR_SEAT_THICKNESS / 2, seat_d=fu.CHAIR_SEAT_DEPTH,
        seat_w=fu.CHAIR_SEAT_WIDTH, seat_t=fu.CHAIR_SEAT_THICKNESS,
        back_x=back_x, back_z=fu.CHAIR_SEAT_HEIGHT + back_z, back_pitch=-fu.CHAIR_BACK_TILT,
        back_t=fu.CHAIR_BACK_THICKNESS, back_w=fu.CHAIR_BACK_WIDTH, back_h=fu.CHAIR_BACK_HEIGHT,
        leg_w=fu.CHAIR_LEG_WIDTH, leg_len=leg_len, leg_z=leg_len / 2,
        leg_dx=fu.chair_leg_offsets()[-1][0], leg_dy=fu.chair_leg_offsets()[-1][1])


def dish_sdf(dish: Dish) -> str:
    shape = fu.DISH_SHAPES[dish.kind]
    mass = fu.DISH_MASS[dish.kind]
    r, h = shape.radius, shape.height
    return _template("dish").substitute(
        name=dish.name, radius=r, height=h, half_h=h / 2, mass=mass,
        ixx=mass * (3 * r * r + h * h) / 12, izz=mass * r * r / 2,
        rgba=" ".join(f"{c:g}" for c in shape.rgba))


def room_boxes(room: Room, margin: float) -> dict[str, tuple[list[float], list[float]]]:
    """{name: (centre p_WB, size)} of the room's boxes in W: the floor ("floor", its top at
    z = 0, reaching `margin` beyond the walls) and the four walls."""
    x_min, y_min, x_max, y_max = room.bounds
    cx, cy = (x_min + x_max) / 2, (y_min + y_max) / 2
    size_x, size_y = x_max - x_min, y_max - y_min
    t, h = room.wall_thickness, room.wall_height
    floor_margin = 2 * t + 2 * margin
    return {
        "floor": ([cx, cy, -0.005], [size_x + floor_margin, size_y + floor_margin, 0.01]),
        "wall_south": ([cx, y_min - t / 2, h / 2], [size_x + 2 * t, t, h]),
        "wall_north": ([cx, y_max + t / 2, h / 2], [size_x + 2 * t, t, h]),
        "wall_west": ([x_min - t / 2, cy, h / 2], [t, size_y, h]),
        "wall_east": ([x_max + t / 2, cy, h / 2], [t, size_y, h]),
    }


def _add_room(plant: MultibodyPlant, room: Room, margin: float) -> None:
    """Floor (seen, not collided with; `margin` beyond the walls) and four walls, on the
    world body."""
    world = plant.world_body()
    for name, (p_WB, size) in room_boxes(room, margin).items():
        X = RigidTransform(p_WB)
        rgba = FLOOR_RGBA if name == "floor" else WALL_RGBA
        plant.RegisterVisualGeometry(world, X, Box(*size), name, rgba)
        if name != "floor":
            plant.RegisterCollisionGeometry(world, X, Box(*size), name,
                                            CoulombFriction(0.5, 0.5))


def _add_gravity_compensation(builder: DiagramBuilder, plant: MultibodyPlant) -> None:
    """Feeds the actuators, as feed-forward to their PD control, the torques that cancel
    gravity at the current state ("gravity_compensation", Drake's InverseDynamics), as the
    arms' own controllers do.

    The PD gains were tuned without gravity, and compensated the dynamics are the same. The
    robot's gravity was at first disabled in the plant instead, but then a robot holding
    still asks SAP for impulses that are all exactly zero: its relative convergence
    tolerance has nothing to scale with, and the solver failed to converge on a robot at
    rest (task_089 with V-PETLON: at t = 21.44 s, and again after each of the five restarts
    from zero velocity). With gravity carried by the actuators the impulses are never all
    zero, and that run goes on.
    """
    compensation = builder.AddNamedSystem(
        "gravity_compensation",
        InverseDynamics(plant, InverseDynamics.InverseDynamicsMode.kGravityCompensation))
    # Generalized forces (velocity order) to actuator order: B^T, B the actuation matrix.
    to_actuators = builder.AddNamedSystem("gravity_to_actuators",
                                          MatrixGain(plant.MakeActuationMatrix().T))
    builder.Connect(plant.get_state_output_port(), compensation.get_input_port_estimated_state())
    builder.Connect(compensation.get_output_port_generalized_force(),
                    to_actuators.get_input_port())
    builder.Connect(to_actuators.get_output_port(), plant.get_actuation_input_port())


@dataclass(frozen=True)
class FixedModel:
    """A model welded in the room: a table, a chair or a dish."""

    name: str
    """The model instance's name (the scenario's name of the thing)."""
    body: str
    """Its one body's name: "table", "chair" or "dish"."""
    sdf: str
    X_WB: RigidTransform


def fixed_models(contents: SceneContents, *, dishes: bool = True) -> list[FixedModel]:
    """The tables, chairs and (with `dishes`) dishes of `contents`, as SDFormat models and
    where their bodies are welded."""
    fixed = [FixedModel(t.name, "table", table_sdf(t), _planar_pose(*t.center, t.yaw))
             for t in contents.tables]
    fixed += [FixedModel(c.name, "chair", chair_sdf(c), _planar_pose(*c.pose))
              for c in contents.chairs]
    if dishes:
        fixed += [FixedModel(d.name, "dish", dish_sdf(d), _planar_pose(
            d.position[0], d.position[1], 0.0, surface_height(contents.tables, d)))
            for d in contents.dishes]
    return fixed


def populate_plant(plant: MultibodyPlant, scene_graph: SceneGraph | None,
                   contents: SceneContents, *, dishes: bool = True) -> WorldModels:
    """Adds a room, its furniture, its objects and the robot to an unfinalized plant: the
    true world's (`Scenario.contents`) or a belief's (`KnownWorld.contents`).
    `dishes=False` leaves out the objects (for systems that own them)."""
    parser = make_parser(plant, scene_graph)
    _add_room(plant, contents.room, contents.floor_margin)
    robot = contents.robot
    models = WorldModels(robot=robot.add_model_instances(parser))
    q0 = robot.positions(*contents.start)
    for name, q in zip(robot.joints, q0, strict=True):
        models.robot.joint(name).set_default_positions([q])

    kinds = {"table": models.tables, "chair": models.chairs, "dish": models.dishes}
    for fixed in fixed_models(contents, dishes=dishes):
        (model,) = parser.AddModelsFromString(fixed.sdf, "sdf")
        _weld(plant, model, fixed.body, fixed.X_WB)
        kinds[fixed.body][fixed.name] = model
    return models


def _add_overhead_camera(builder: DiagramBuilder, plant: MultibodyPlant,
                         scene_graph: SceneGraph, tracker: ObjectTracker | None,
                         scenario: Scenario) -> RgbdSensor:
    """The overhead RgbdSensor, looking at a perception-only mirror of `scene_graph`
    (world/geometry_mirror.py): the mirror's poses, and the renderer's, are updated only
    when an image is evaluated, not at every plant step."""
    camera_scene_graph = builder.AddNamedSystem("camera_scene_graph", SceneGraph())
    camera_scene_graph.AddRenderer(RENDERER, MakeRenderEngineVtk(RenderEngineVtkParams()))
    sources = [plant.get_source_id()] + ([] if tracker is None else [tracker.source_id])
    mirror = AddGeometryMirror(builder, original=scene_graph, copy=camera_scene_graph,
                               sources=sources)
    builder.Connect(plant.get_geometry_pose_output_port(), mirror.get_input_port(0))
    if tracker is not None:
        builder.Connect(tracker.GetOutputPort("geometry_pose"), mirror.get_input_port(1))
    camera = overhead_camera(scenario.room, scenario.camera)
    far = scenario.camera.height + 1.0
    core = RenderCameraCore(RENDERER, camera.info(), ClippingRange(0.05, far), RigidTransform())
    sensor = builder.AddNamedSystem("overhead_camera", RgbdSensor(
        parent_id=camera_scene_graph.world_frame_id(), X_PB=camera.X_WC,
        color_camera=ColorRenderCamera(core, show_window=False),
        depth_camera=DepthRenderCamera(core, DepthRange(0.05, far))))
    builder.Connect(camera_scene_graph.get_query_output_port(), sensor.query_object_input_port())
    return sensor


def _add_base_scanner(builder: DiagramBuilder, plant: MultibodyPlant,
                      robot: RobotInstances) -> BaseScanner:
    """The base's scanner ("base_scanner", world/base_scanner.py): its cameras ride the
    base's twin in the overhead camera's mirror; its scan exported as base_scan."""
    camera_scene_graph = builder.GetSubsystemByName("camera_scene_graph")
    mirror = builder.GetSubsystemByName("geometry_mirror")
    base = mirror.twin(plant.GetBodyFrameIdOrThrow(robot.body(robot.robot.base_link).index()))
    r = robot.robot
    mounts = scanner_mounts(base_length=r.base_length, base_width=r.base_width)
    info = scanner_info()
    core = RenderCameraCore(RENDERER, info, ClippingRange(*SCAN_RANGE), RigidTransform())
    scanner = builder.AddNamedSystem("base_scanner", BaseScanner(mounts=mounts, info=info))
    for i, X_BC in enumerate(mounts):
        camera = builder.AddNamedSystem(f"base_scanner_{i}", RgbdSensor(
            parent_id=base, X_PB=X_BC, depth_camera=DepthRenderCamera(core, DepthRange(
                *SCAN_RANGE))))
        builder.Connect(camera_scene_graph.get_query_output_port(),
                        camera.query_object_input_port())
        builder.Connect(camera.depth_image_32F_output_port(),
                        scanner.GetInputPort(f"depth_{i}"))
    builder.ExportOutput(scanner.GetOutputPort("base_scan"), "base_scan")
    return scanner


def _add_object_tracker(builder: DiagramBuilder, plant: MultibodyPlant, scene_graph: SceneGraph,
                        scenario: Scenario, robot: RobotInstances, *, seed: int,
                        reach_std: float, localisation: Localisation | None) -> ObjectTracker:
    tracker = AddObjectTracker(builder, scenario=scenario, plant=plant, robot=robot,
                               scene_graph=scene_graph, period=CONTROL_PERIOD)
    sensor = builder.AddNamedSystem("target_sensor", TargetSensor(
        places={t.target: t.position for t in place_targets(scenario)}, seed=seed,
        reach_std=reach_std))
    if localisation is not None:  # the sensor sees from the base, placed as localised
        n = robot.robot.num_positions
        base_pose = builder.AddNamedSystem("true_base_pose", MatrixGain(np.eye(3, 2 * n)))
        builder.Connect(robot_state_output(builder, robot), base_pose.get_input_port())
        builder.Connect(base_pose.get_output_port(), sensor.GetInputPort("base_pose"))
        builder.Connect(localisation.GetOutputPort("error"),
                        sensor.GetInputPort("localisation_error"))
    builder.Connect(tracker.GetOutputPort("dish_poses"), sensor.GetInputPort("dish_poses"))
    builder.Connect(sensor.GetOutputPort("sensing_error"), tracker.GetInputPort("sensing_error"))
    builder.ExportInput(tracker.GetInputPort("grip"), "grip")
    builder.ExportInput(sensor.GetInputPort("target_request"), "target_request")
    builder.ExportOutput(sensor.GetOutputPort("target_sighting"), "target_sighting")
    builder.ExportOutput(tracker.GetOutputPort("gripper_status"), "gripper_status")
    builder.ExportOutput(tracker.GetOutputPort("dish_poses"), "dish_poses")
    builder.ExportOutput(tracker.GetOutputPort("dish_states"), "dish_states")
    return tracker


def _anchor_fixed_geometry(plant: MultibodyPlant, scene_graph: SceneGraph,
                           models: WorldModels) -> None:
    """Hands the welded furniture's and dishes' visual geometry (illustration and
    perception roles) to anchored copies.

    The plant reports a pose for every body's frame at every step, welded or not: the render
    engine then moves each of those geometries (for the restaurant that tripled the cost of
    a simulation step) and a Meshcat recording keeps a track per frame (three quarters of
    the playback's size). These bodies never move, so their visual roles go to anchored
    copies (same shape, pose and properties, render label included): camera and Meshcat show
    exactly what they showed, and only the robot and the tracked dishes are moved. Their
    collision geometry stays with the plant's bodies.
    """
    inspector = scene_graph.model_inspector()
    source = scene_graph.RegisterSource("fixed_visuals")
    context = plant.CreateDefaultContext()
    fixed = [*models.tables.values(), *models.chairs.values(), *models.dishes.values()]
    for instance in fixed:
        for body_index in plant.GetBodyIndices(instance):
            X_WB = plant.EvalBodyPoseInWorld(context, plant.get_body(body_index))
            frame = plant.GetBodyFrameIdOrThrow(body_index)
            visuals = set(inspector.GetGeometries(frame, Role.kPerception)) | set(
                inspector.GetGeometries(frame, Role.kIllustration))
            for geometry in sorted(visuals, key=lambda g: g.get_value()):
                copy = GeometryInstance(X_WB @ inspector.GetPoseInFrame(geometry),
                                        inspector.GetShape(geometry),
                                        inspector.GetName(geometry))
                perception = inspector.GetPerceptionProperties(geometry)
                if perception is not None:
                    copy.set_perception_properties(PerceptionProperties(perception))
                    scene_graph.RemoveRole(plant.get_source_id(), geometry, Role.kPerception)
                illustration = inspector.GetIllustrationProperties(geometry)
                if illustration is not None:
                    copy.set_illustration_properties(IllustrationProperties(illustration))
                    scene_graph.RemoveRole(plant.get_source_id(), geometry, Role.kIllustration)
                scene_graph.RegisterAnchoredGeometry(source, copy)


def build_world_diagram(scenario: Scenario, *, meshcat: Meshcat | None = None,
                        track_dishes: bool = False, show_collisions: bool = True,
                        seed: int | None = None, noise: bool = True) -> Diagram:
    """The simulated restaurant as one named Diagram ("s3o_world").

    Input ports:  robot_desired_state (positions then velocities of the robot's joints,
                  `Robot.joints` order, tracked by the joints' PD actuators; a
                  ProtectiveStop ("protective_stop") holds the base short of what it would
                  run into; unconnected: the robot holds where it stands)
    Output ports: robot_state (the same order), base_bumper (the protective stop's
                  report), overhead_color_image, overhead_depth_image, overhead_label_image,
                  query_object, body_poses

    Where the robot reports its pose as localised (`uncertainty.localization`
    "reported"), a Localisation ("localisation", world/localisation.py) stands between
    these ports and the plant: robot_state's base pose is the localisation's, and the
    base drives to robot_desired_state's as it estimates it. Its error is drawn from
    `seed`, and is none without `noise`.

    With `track_dishes`, the dishes are not welded into the plant: an ObjectTracker
    ("object_tracker") owns their geometry and moves them with the gripper and the tray by
    its grasp rules, a TargetSensor ("target_sensor") sees what the arm reaches for with
    the sensing error (the scenario's `reach_std`, none without `noise`, from `seed`,
    default the scenario's), and the diagram also has
    Input ports:  grip (abstract GripEvent; unconnected: the gripper holds nothing),
                  target_request (abstract TargetRequest)
    Output ports: target_sighting (abstract TargetSighting), gripper_status (abstract
                  GripperStatus) (world/robot_messages.py: what the robot's controllers
                  see), dish_poses (abstract DishPoses, X_WD), dish_states (abstract
                  DishStates) (world/dish_messages.py: the simulation's truth).

    With a Meshcat, adds Drake's visualizers as `scenario.visualization` says
    (`ApplyVisualizationConfig`): the illustration (`ILLUSTRATION`, which records for
    playback) and, with `show_collisions`, the proximity geometry (for a person watching
    live; it is not in a recording and costs a quarter of a step's time).
    """
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(scenario.plant, builder)
    plant.set_name("plant")
    models = populate_plant(plant, scene_graph, scenario.contents, dishes=not track_dishes)
    plant.Finalize()
    _anchor_fixed_geometry(plant, scene_graph, models)
    seed = scenario.seed if seed is None else int(seed)
    localisation = _add_localisation(builder, scenario, models.robot, seed=seed, noise=noise)
    tracker = None
    if track_dishes:
        tracker = _add_object_tracker(
            builder, plant, scene_graph, scenario, models.robot, seed=seed,
            reach_std=scenario.uncertainty.reach_std if noise else 0.0,
            localisation=localisation)

    sensor = _add_overhead_camera(builder, plant, scene_graph, tracker, scenario)
    if localisation is not None:  # what the robot localises by
        scanner = _add_base_scanner(builder, plant, models.robot)
        builder.Connect(scanner.GetOutputPort("base_scan"),
                        localisation.GetInputPort("base_scan"))
    _add_gravity_compensation(builder, plant)
    # A single-instance robot's are the plant's own ports; a robot of parts', MatrixGains.
    builder.ExportOutput(robot_state_output(builder, models.robot) if localisation is None
                         else localisation.GetOutputPort("reported_state"), "robot_state")
    _add_protective_stop(builder, plant, scene_graph, scenario, models.robot, localisation)
    builder.ExportOutput(sensor.color_image_output_port(), "overhead_color_image")
    builder.ExportOutput(sensor.depth_image_32F_output_port(), "overhead_depth_image")
    builder.ExportOutput(sensor.label_image_output_port(), "overhead_label_image")
    builder.ExportOutput(scene_graph.get_query_output_port(), "query_object")
    builder.ExportOutput(plant.get_body_poses_output_port(), "body_poses")

    if meshcat is not None:
        config = copy.copy(scenario.visualization)
        config.publish_proximity = config.publish_proximity and show_collisions
        # Drake adds its LCM visualizers with Meshcat's: their bus is one that publishes
        # nowhere (owned by the diagram), as the project's views are Meshcat's.
        buses = ApplyLcmBusConfig({config.lcm_bus: None}, builder)
        ApplyVisualizationConfig(config, builder, lcm_buses=buses, plant=plant,
                                 scene_graph=scene_graph, meshcat=meshcat)

    diagram = builder.Build()
    diagram.set_name("s3o_world")
    return diagram


def _add_localisation(builder: DiagramBuilder, scenario: Scenario, robot: RobotInstances, *,
                      seed: int, noise: bool) -> Localisation | None:
    """The robot's localisation ("localisation"), fed the plant's true state, when the
    robot reports its pose as localised (`uncertainty.localization`); its error is none
    without `noise`."""
    u = scenario.uncertainty
    if u.localization != Localization.REPORTED:
        return None
    localisation = builder.AddNamedSystem("localisation", Localisation(
        num_positions=robot.robot.num_positions, num_base=robot.robot.num_base_joints,
        error=(LocalisationError(u.localization_xy_std, u.localization_yaw_std) if noise
               else LocalisationError.exact()),
        seed=seed, period=CONTROL_PERIOD,
        # What the robot was given of the room: no unmapped chair.
        section=RoomSection(scenario.room, scenario.tables,
                            [c.pose for c in scenario.chairs if c.mapped])))
    builder.Connect(robot_state_output(builder, robot), localisation.GetInputPort("true_state"))
    return localisation


def _add_protective_stop(builder: DiagramBuilder, plant: MultibodyPlant,
                         scene_graph: SceneGraph, scenario: Scenario,
                         robot: RobotInstances, localisation: Localisation | None) -> None:
    """The base's protective stop between the exported robot_desired_state (through the
    robot's `localisation`, where it has one) and the plant; its report exported as
    base_bumper."""
    # The robot's geometry but the hand's, which touches what it grasps.
    hand = {robot.body(name).index() for name in robot.robot.gripper_bodies}
    stop = builder.AddNamedSystem("protective_stop", ProtectiveStop(
        base=proximity_geometries(plant, scene_graph, (), bodies=[
            plant.get_body(b) for b in robot.body_indices() if b not in hand]),
        world=room_geometries(plant, scene_graph,
                              [f.name for f in (*scenario.tables, *scenario.chairs)]),
        num_positions=robot.robot.num_positions, num_base=robot.robot.num_base_joints,
        period=WATCH_PERIOD))
    builder.Connect(robot_state_output(builder, robot), stop.GetInputPort("true_state"))
    builder.Connect(scene_graph.get_query_output_port(), stop.GetInputPort("query_object"))
    connect_robot_desired_state(builder, robot, stop.GetOutputPort("plant_desired_state"))
    if localisation is None:
        builder.ExportInput(stop.GetInputPort("desired_state"), "robot_desired_state")
    else:
        builder.Connect(localisation.GetOutputPort("plant_desired_state"),
                        stop.GetInputPort("desired_state"))
        builder.ExportInput(localisation.GetInputPort("desired_state"), "robot_desired_state")
    builder.ExportOutput(stop.GetOutputPort("bumper"), "base_bumper")


def overhead_images(world: Diagram, context) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The overhead camera's colour (H, W, 4) RGBA, depth (H, W) m and label (H, W) images,
    from a world diagram and its context."""
    color = world.GetOutputPort("overhead_color_image").Eval(context).data
    depth = world.GetOutputPort("overhead_depth_image").Eval(context).data
    label = world.GetOutputPort("overhead_label_image").Eval(context).data
    return np.array(color, copy=True), np.array(depth[:, :, 0]), np.array(label[:, :, 0])


def robot_render_labels(world: Diagram, robot: Robot) -> frozenset[int]:
    """The render labels of `robot`'s geometry (all its model instances') in a world
    diagram: the robot knows its own body when it sees it."""
    plant = world.GetSubsystemByName("plant")
    inspector = world.GetSubsystemByName("scene_graph").model_inspector()
    labels = set()
    for body in robot.instances_in(plant).body_indices():
        for g in inspector.GetGeometries(plant.GetBodyFrameIdOrThrow(body), Role.kPerception):
            labels.add(int(inspector.GetPerceptionProperties(g).GetProperty("label", "id")))
    return frozenset(labels)


def render_overhead(scenario: Scenario) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                 frozenset[int]]:
    """One render of the scenario's world with the robot holding its start pose:
    `overhead_images` and the robot's render labels."""
    world = build_world_diagram(scenario)
    context = world.CreateDefaultContext()
    world.GetInputPort("robot_desired_state").FixValue(context, robot_hold_state(scenario))
    return (*overhead_images(world, context), robot_render_labels(world, scenario.robot_value))


def robot_hold_state(scenario: Scenario) -> np.ndarray:
    """The robot's desired state that holds its start pose (positions, zero velocities)."""
    robot = scenario.robot_value
    return robot.desired_state(robot.positions(*scenario.robot.start))
