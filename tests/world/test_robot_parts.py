"""A robot of parts (models/gen3): the makers' files composed as model directives, its
description checked against them, and the robot's positions and ports in a plant where it
is several model instances."""

import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from pydrake.geometry import Role
from pydrake.math import RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from s3o_drake.commands.build_robot import checksum
from s3o_drake.world.maker_models import (
    Gains,
    _add_transmissions,
    _visuals_from_collisions,
    convert_mesh,
    expand_xacro,
    ros_packages,
)
from s3o_drake.world.resources import MODELS_DIR, robot_dir
from s3o_drake.world.robot import load_robot
from s3o_drake.world.robot_description import (
    RobotDescriptionError,
    load_robot_description,
    parse_robot_description,
    robot_names,
)

ARM_Q = [0.3, 0.5, -0.4, 1.2, 0.2, -0.7, 0.9]


@pytest.fixture(scope="module")
def gen3():
    return load_robot("gen3")


def _plant(robot, time_step=1e-3):
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(
        time_step=time_step, discrete_contact_approximation="sap"), builder)
    placed = robot.add_model_instances(Parser(plant, scene_graph))
    return builder, plant, scene_graph, placed


def test_gen3_is_built_and_offered(gen3):
    # Built (`s3o build robot gen3`): its description lacks nothing, it is offered beside
    # the others, it loads by name, checked against its parts, and a scenario may name it.
    from s3o_drake.world.scenario import parse_scenario

    assert gen3.is_of_parts and not gen3.description.missing
    assert {"ur5e", "panda", "gen3"} <= set(robot_names())
    assert parse_scenario("robot: {name: gen3}").robot_value is gen3
    for built in (gen3.files.reachability_map, gen3.files.time_model, gen3.files.fcn_weights):
        assert built.is_file()
    assert gen3.joints == ("base_x", "base_y", "base_yaw", *(f"joint_{i}" for i in range(1, 8)),
                           "robotiq_85_left_knuckle_joint")
    assert [p.name for p in gen3.description.parts] == ["base", "arm", "gripper"]
    # The linkage gripper: open and closed in its knuckle's angle, not its fingers' travel.
    assert gen3.gripper_open.tolist() == [0.0] and gen3.gripper_closed.tolist() == [0.8]
    with pytest.raises(ValueError, match="made of parts"):
        gen3.model_file  # noqa: B018
    assert len(gen3.model_files) == 3 and all(f.is_file() for f in gen3.model_files)


def test_composed_plant(gen3):
    _, plant, scene_graph, placed = _plant(gen3)
    plant.Finalize()
    names = [plant.GetModelInstanceName(i) for i in placed.instances]
    assert names == ["robot::base", "robot::arm", "robot::gripper"]
    # 3 base + 7 arm + 6 gripper joints, of which 5 mimic the knuckle (coupler
    # constraints); the robot's own positions are its 11 actuated joints.
    assert plant.num_positions() == 16 and gen3.num_positions == 11
    assert plant.num_actuators() == 11 and plant.num_constraints() == 5
    assert scene_graph.model_inspector().NumGeometriesWithRole(Role.kProximity) == 26

    # Limits: speeds and joint 2's positions the model's; accelerations, and the positions
    # of the joints the model leaves without limit (1, 3, 5, 7), the description's.
    v = placed.velocity_indices()
    assert plant.GetVelocityUpperLimits()[v[3:10]].tolist() == [1.3963] * 4 + [1.2218] * 3
    assert plant.GetAccelerationUpperLimits()[v[3:10]].tolist() == [1.0] * 4 + [10.0] * 3
    assert plant.GetPositionUpperLimits()[placed.position_indices()[3]] == 2 * math.pi
    assert plant.GetPositionUpperLimits()[placed.position_indices()[4]] == 2.24

    context = plant.CreateDefaultContext()
    q = gen3.positions(1.0, 2.0, 0.5, arm=ARM_Q, gripper=[0.4])
    placed.set_positions(context, q)
    np.testing.assert_array_equal(placed.get_positions(context), q)
    # The mimic joints follow the knuckle.
    tip = placed.joint("gripper::robotiq_85_left_finger_tip_joint")
    right = placed.joint("robotiq_85_right_knuckle_joint")
    assert tip.get_angle(context) == -0.4 and right.get_angle(context) == -0.4

    # The grasp frame in the base link at this configuration (Kinova's joint origins, the
    # 2F-85 on the flange, our tool frame a quarter turn about the approach axis).
    X_BG = plant.CalcRelativeTransform(context, placed.frame(gen3.base_link),
                                       placed.frame(gen3.grasp_frame))
    np.testing.assert_allclose(X_BG.translation(), [0.906, -0.0408, 1.4519], atol=1e-4)
    np.testing.assert_allclose(RollPitchYaw(X_BG.rotation()).vector(),
                               [0.7222, 0.7085, 1.0166], atol=1e-4)
    # The pads open 0.085 m across the tool frame's y.
    set_open = gen3.positions(0, 0, 0, arm=ARM_Q, gripper=gen3.gripper_open)
    placed.set_positions(context, set_open)
    tool = placed.frame(gen3.tool_frame)
    y = [plant.CalcRelativeTransform(context, tool, placed.frame(f"robotiq_85_{s}_finger_tip_link"))
         .translation()[1] for s in ("left", "right")]
    assert abs(y[0] - y[1]) == pytest.approx(0.1355, abs=1e-4)  # tip origins: pads 0.025 in


def test_shipped_generated_files_are_the_recorded_build():
    # models/gen3/generated/ is what `s3o build robot gen3 --steps model` wrote (its
    # record: command, the inputs' and outputs' checksums).
    record = json.loads((robot_dir("gen3") / "build.json").read_text())["steps"]["model"]
    assert record["command"] == "s3o build model gen3"
    assert record["writes"]["models/gen3/generated"] == checksum(robot_dir("gen3") / "generated")
    assert record["reads"]["models/parts"] == checksum(MODELS_DIR / "parts")


def test_makers_files_carry_license_and_source():
    for maker in ("kinova_gen3", "robotiq_2f_85"):
        folder = MODELS_DIR / "parts" / maker
        assert "BSD" in (folder / "LICENSE").read_text() or "Redistribution" in \
            (folder / "LICENSE").read_text()
        source = (folder / "SOURCE.md").read_text()
        for file in folder.rglob("*"):
            if file.is_file() and file.name != "SOURCE.md":
                assert file.relative_to(folder).as_posix() in source, file
    assert set(ros_packages()) == {"kortex_description", "robotiq_description"}


def test_build_part_from_a_xacro(tmp_path):
    # A package of its own, with an STL mesh (which Drake refuses) and a mimic joint.
    import trimesh

    package = tmp_path / "toy_description"
    (package / "meshes").mkdir(parents=True)
    (package / "package.xml").write_text("<package><name>toy_description</name></package>")
    trimesh.creation.box([0.1, 0.2, 0.3]).export(package / "meshes" / "box.stl")
    xacro = tmp_path / "toy.urdf.xacro"
    xacro.write_text("""<?xml version="1.0"?>
<robot name="toy" xmlns:xacro="http://ros.org/wiki/xacro">
  <xacro:property name="mesh" value="package://toy_description/meshes/box.stl"/>
  <link name="root"><visual><geometry><sphere radius="0.1"/></geometry></visual>
    <collision><geometry><mesh filename="${mesh}"/></geometry></collision></link>
  <link name="a"/><link name="b"/>
  <joint name="j" type="revolute"><parent link="root"/><child link="a"/>
    <limit lower="-1" upper="1" effort="5" velocity="1"/></joint>
  <joint name="k" type="revolute"><parent link="a"/><child link="b"/><mimic joint="j"/>
    <limit lower="-1" upper="1" effort="5" velocity="1"/></joint>
</robot>""")
    mesh = tmp_path / "box.obj"
    convert_mesh(package / "meshes" / "box.stl", mesh)
    assert trimesh.load(mesh, force="mesh").volume == pytest.approx(0.006)
    # (build_part writes package://s3o_drake URLs, so only into models/: it is checked on
    # the real parts by the recorded build above.)
    text = expand_xacro(xacro, {"toy_description": package})
    assert "package://toy_description/meshes/box.stl" in text
    robot = ET.fromstring(text)
    _visuals_from_collisions(robot)
    (visual,) = robot.find("link").findall("visual")
    assert visual.find("geometry/mesh") is not None
    with pytest.raises(ValueError, match="mimics"):
        _add_transmissions(robot, [Gains("k", 1.0, 0.1)])
    _add_transmissions(robot, [Gains("j", 1.0, 0.1)])
    (transmission,) = robot.findall("transmission")
    assert transmission.find("joint").get("name") == "j"


@pytest.mark.parametrize("change, path", [
    ("model: package://s3o_drake/ur5e/mobile_manipulator.urdf\n", "model"),
    ("parts: []\n", "model"),
])
def test_model_or_parts(change, path):
    text = (MODELS_DIR / "gen3" / "robot.yaml").read_text()
    if change.startswith("parts"):
        # Without parts and their frames (and without a model) it names no model.
        text = text.split("\nparts:\n")[0] + "\nbase:" + text.split("\nbase:")[1]
    else:
        text = change + text
    with pytest.raises(RobotDescriptionError, match=path):
        parse_robot_description(text)


@pytest.mark.parametrize("old, new, path", [
    ("mount: {parent: base::arm_mount", "mount: {parent: gripper::arm_mount",
     r"parts\[1\].mount.parent"),
    ("parent: gripper::robotiq_85_base_link", "parent: arm::end_effector_link",
     r"frames\[0\].parent"),
    ("  - name: gripper\n", "  - name: arm\n", r"parts\[2\].name"),
])
def test_parts_errors_name_the_field(old, new, path):
    text = (MODELS_DIR / "gen3" / "robot.yaml").read_text()
    assert old in text
    with pytest.raises(RobotDescriptionError, match=path):
        parse_robot_description(text.replace(old, new, 1))


def test_description_checks_against_the_parts():
    from s3o_drake.world.robot_description import check_model

    description = load_robot_description("gen3")
    description.tool.grasp_frame = "arm::grasp_frame"
    with pytest.raises(RobotDescriptionError, match=r"tool\.grasp_frame"):
        check_model(description)
    # The model has no acceleration limits: without the description's, none is in force.
    description = load_robot_description("gen3")
    (joint_5,) = [o for o in description.arm.limit_overrides if o.joint == "joint_5"]
    joint_5.acceleration = None
    with pytest.raises(RobotDescriptionError, match=r"arm\.joints\[4\].*acceleration limit"):
        check_model(description)


def test_gen3_stows_inside_its_footprint_clear_of_the_base_and_tray(gen3):
    from pydrake.planning import RobotDiagramBuilder, SceneGraphCollisionChecker

    from s3o_drake.feasibility.clearance import robot_plan_extent
    from s3o_drake.world.resources import make_parser

    builder = RobotDiagramBuilder(time_step=0.0)
    placed = gen3.add_model_instances(make_parser(builder.plant(), builder.scene_graph()))
    builder.plant().Finalize()
    diagram = builder.Build()
    plant = diagram.plant()
    extent = robot_plan_extent(plant, diagram.scene_graph().model_inspector(), placed,
                               plant.CreateDefaultContext())
    half_l, half_w = gen3.base_length / 2, gen3.base_width / 2
    assert extent[0] >= -half_l - 1e-9 and extent[1] <= half_l + 1e-9
    assert extent[2] >= -half_w - 1e-9 and extent[3] <= half_w + 1e-9
    checker = SceneGraphCollisionChecker(model=diagram,
                                         robot_model_instances=list(placed.instances),
                                         edge_step_size=0.05)
    q = placed.plant_positions(gen3.positions(0.0, 0.0, 0.0))  # arm stowed, gripper open
    clearance = checker.CalcRobotClearance(q, 0.1)
    assert min(clearance.distances()) >= 0.03
    # The tray is among what it is clear of: a body of the base's part.
    assert placed.body(gen3.tray_link).model_instance() == placed.instances[0]
