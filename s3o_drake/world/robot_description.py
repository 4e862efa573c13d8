"""A mobile manipulator as data: its description file (models/<name>/robot.yaml) next to
its model.

The description names what the planner and the execution need to know of a robot: the
model file, the base's joints and footprint, the arm's joints (where their limits come
from, and any limit it overrides), its inverse kinematics family, the tool, grasp and tray
frames, the gripper, the stow configuration and the reach the planner assumes. The model
(URDF) holds the geometry and the joint limits and is what Drake simulates; the arm's
kinematics and limits are read from it (feasibility/kinematics.py), so no kinematic
parameters or limits are typed here unless they override the model's
(`apply_limit_overrides`, where the robot is parsed). `check_model` confirms that the model
has every joint and frame the description names, of the right kind, with finite limits
that hold the stow configuration.

Vectors are lists (pydrake's `yaml_load_typed` reads no tuples); SI units.
"""

import math
from dataclasses import dataclass, field
from pathlib import Path

from pydrake.common.yaml import yaml_load_typed

from s3o_drake.world.resources import DEFAULT_ROBOT, DESCRIPTION_FILE, MODELS_DIR, robot_dir
from s3o_drake.world.yaml_checks import FieldError, check_structure, load_yaml

IK_FAMILIES = ("ur", "numeric")
"""How the arm's inverse kinematics is solved (feasibility/kinematics.py): "ur", the
closed-form solutions of the UR family's geometry (three parallel axes between a shoulder
and a wrist offset; eight branches), its lengths read from the model and checked against
it; "numeric", damped least squares from seeds, for any
serial arm (a redundant one too)."""
BASE_DRIVES = ("differential", "holonomic")
"""How a base moves: where it faces only, or sideways too (`BaseDescription.drive`)."""


@dataclass
class BaseDescription:
    joints: list[str] = field(default_factory=list)
    """The base's three actuated joints: x and y (prismatic), yaw (revolute)."""
    link: str = ""
    length: float = 0.0
    """The chassis footprint along the base's x (forward) (m)."""
    width: float = 0.0
    """... and along its y (m)."""
    drive: str = "differential"
    """"differential": the base drives where it faces (or backs straight away), as the
    paper's does; "holonomic": it can move sideways, and turns while it translates."""

    @property
    def holonomic(self) -> bool:
        return self.drive == "holonomic"


@dataclass
class LimitOverride:
    """One arm joint's limits that replace its model's; those not given stay the model's."""

    joint: str = ""
    position_lower: float | None = None
    """rad."""
    position_upper: float | None = None
    velocity: float | None = None
    """rad/s, either way."""
    acceleration: float | None = None
    """rad/s², either way."""
    source: str = ""
    """Where these values come from (must be given)."""


@dataclass
class ArmDescription:
    base_link: str = ""
    mount_xyz: list[float] = field(default_factory=list)
    """The arm's base frame in the base link (m); its axes are the base link's."""
    joints: list[str] = field(default_factory=list)
    limits_source: str = ""
    """Where the model's joint limits (position, velocity, acceleration) come from."""
    limit_overrides: list[LimitOverride] = field(default_factory=list)
    """Limits that replace the model's wherever the robot is parsed."""
    kinematics_source: str = ""
    """Where the model's joint origins and axes come from (the arm's kinematics are read
    from the model)."""
    inverse_kinematics: str = "numeric"
    """One of IK_FAMILIES."""


@dataclass
class ToolDescription:
    frame: str = ""
    """The tool flange."""
    grasp_frame: str = ""
    """Between the fingertip pads; its z is the approach, the fingers open along its y."""
    grasp_offset: float = 0.0
    """From the tool frame to the grasp frame along the tool's z (m)."""
    fingertip_offset: float = 0.0
    """The farthest the fingers reach from the tool frame along the tool's z (m), over
    their stroke: where sliding fingers' tips are; a linkage gripper's swing further out as
    they close. A grasp leaves that much above the table."""
    wrist_radius: float = 0.0
    """The radius (m) about the approach axis of what follows the grasp point along it (the
    hand and the wrist): in a side grasp it passes over the table, so it sets the lowest
    side grasp."""


@dataclass
class GripperDescription:
    joints: list[str] = field(default_factory=list)
    bodies: list[str] = field(default_factory=list)
    """The bodies that may touch the object being grasped (palm and fingers)."""
    travel: float = 0.0
    """Travel of each finger (m); for sliding fingers the opening is the sum of the
    fingers' positions."""
    open: list[float] = field(default_factory=list)
    """The joints' positions when open; default each at `travel` (sliding fingers). A
    linkage gripper (its fingers turn, and its other joints mimic the one actuated) gives
    its own, in its joints' units (rad)."""
    closed: list[float] = field(default_factory=list)
    """... and closed on nothing; default all zero (sliding fingers)."""


@dataclass
class TrayDescription:
    link: str = ""
    xyz: list[float] = field(default_factory=list)
    """The centre of the tray's inner floor in the base link (m)."""
    inner_length: float = 0.0
    inner_width: float = 0.0
    rim_height: float = 0.0


@dataclass
class MountDescription:
    """Where a part is welded, as a model directive's `add_weld` says it: the parent frame
    (of a part listed before, `part::frame`), the child frame of this part, and the child
    in the parent (X_PC: m, and roll-pitch-yaw in rad)."""

    parent: str = ""
    child: str = ""
    xyz: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])


@dataclass
class ActuatorGains:
    """A joint the robot actuates that its maker's model leaves to a ROS controller: the
    build adds its actuator with these PD gains (Drake's `controller_gains`)."""

    joint: str = ""
    p: float = 0.0
    """N m/rad or N/m."""
    d: float = 0.0
    """N m s/rad or N s/m."""


@dataclass
class PartDescription:
    """One part of a robot as its maker ships it (the arm, the gripper) or as we make it
    (the base with its tray), and where it mounts."""

    name: str = ""
    """The part's model instance is `<robot>::<name>` (a model directive's namespace)."""
    model: str = ""
    """The file Drake reads (`package://s3o_drake/...`; URDF, SDFormat or MJCF)."""
    mount: MountDescription = field(default_factory=MountDescription)
    """Where it is welded; none for the part that joins the world by its own joints (the
    base, listed first)."""
    xacro: str = ""
    """The xacro `model` is generated from, if any (`s3o build robot NAME --steps model`:
    world/maker_models.py), with the maker's meshes converted for Drake."""
    actuators: list[ActuatorGains] = field(default_factory=list)
    """Actuators the generated model gets, in this order (with `xacro`)."""
    visuals_from_collision: bool = False
    """Draw each link with its collision geometry (with `xacro`, for a part whose visual
    meshes are not shipped)."""


@dataclass
class FrameDescription:
    """A frame of ours on a part (a model directive's `add_frame`): the tool or grasp
    frame that the maker's model does not have."""

    name: str = ""
    """`part::name`."""
    parent: str = ""
    """`part::frame`."""
    xyz: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])


@dataclass
class Configurations:
    stow: list[float] = field(default_factory=list)
    """The arm's joint angles (rad) while the base drives."""


@dataclass
class RobotDescription:
    """One robot's description file (see the module docstring)."""

    name: str = ""
    missing: str = ""
    """What the robot still lacks to plan and execute, if anything: a robot that lacks
    something is not offered (`robot_names`; `s3o run` and `s3o evaluate` refuse it), but
    loads by its name, and a scenario may name it (its build's steps do)."""
    model: str = ""
    """The model's URL (`package://s3o_drake/...`), one model instance; or none, and ..."""
    parts: list[PartDescription] = field(default_factory=list)
    """... the robot's parts, each a model instance, welded as model directives weld them.
    Names of joints, bodies and frames are then `part::name`, or only `name` where one
    part alone has it."""
    frames: list[FrameDescription] = field(default_factory=list)
    """Frames of ours on the parts (a robot of parts only)."""
    base: BaseDescription = field(default_factory=BaseDescription)
    arm: ArmDescription = field(default_factory=ArmDescription)
    tool: ToolDescription = field(default_factory=ToolDescription)
    gripper: GripperDescription = field(default_factory=GripperDescription)
    tray: TrayDescription = field(default_factory=TrayDescription)
    lidar_link: str = ""
    configurations: Configurations = field(default_factory=Configurations)
    reach: float = 0.0
    """How far from the base centre (m) the planner assumes a dish can be picked."""

    @property
    def joints(self) -> list[str]:
        """All joints, in the order of the model instance's positions and actuators."""
        return [*self.base.joints, *self.arm.joints, *self.gripper.joints]


class RobotDescriptionError(FieldError):
    """A description that cannot be used, located by its field path; one line."""


def described_robots() -> list[str]:
    """Every robot with a description: the folders of models/ with a robot.yaml, those
    still being built among them."""
    return sorted(p.parent.name for p in MODELS_DIR.glob(f"*/{DESCRIPTION_FILE}"))


def robot_names() -> list[str]:
    """The shipped robots: the described ones that lack nothing (`missing` empty)."""
    return [name for name in described_robots()
            if not (load_yaml((robot_dir(name) / DESCRIPTION_FILE).read_text()) or {})
            .get("missing")]


def robot_description_path(name: str) -> Path:
    """The shipped description of robot `name`."""
    path = robot_dir(name) / DESCRIPTION_FILE
    if not path.is_file():
        known = ", ".join(described_robots())
        raise RobotDescriptionError("robot", f"no robot named {name!r} (known: {known})")
    return path


def load_robot_description(name_or_path: str | Path = DEFAULT_ROBOT) -> RobotDescription:
    """The description of a shipped robot (by name) or in a file; checked for shape and
    values, not yet against its model (`check_model`). Raises RobotDescriptionError."""
    path = Path(name_or_path)
    if path.suffix not in (".yaml", ".yml"):
        path = robot_description_path(str(name_or_path))
    return parse_robot_description(path.read_text())


def parse_robot_description(text: str) -> RobotDescription:
    """A description from YAML text (see `load_robot_description`)."""
    try:
        raw = load_yaml(text)
        if not isinstance(raw, dict):
            raise FieldError("", "expected a mapping of fields")
        check_structure(raw, RobotDescription, "")
    except FieldError as e:
        raise RobotDescriptionError(e.path, e.message) from None
    description = yaml_load_typed(schema=RobotDescription, data=text)
    _check_values(description)
    return description


def _check_values(d: RobotDescription) -> None:
    def fail(path: str, message: str) -> None:
        raise RobotDescriptionError(path, message)

    if bool(d.model) == bool(d.parts):
        fail("model", "give either a model or parts")
    if d.parts:
        _check_parts(d)
    elif d.frames:
        fail("frames", "only a robot of parts adds frames (a model holds its own)")
    for path, value in (("name", d.name), ("base.link", d.base.link),
                        ("arm.base_link", d.arm.base_link), ("tool.frame", d.tool.frame),
                        ("tool.grasp_frame", d.tool.grasp_frame), ("tray.link", d.tray.link),
                        ("arm.limits_source", d.arm.limits_source)):
        if not value.strip():
            fail(path, "must be given")
    if d.arm.inverse_kinematics not in IK_FAMILIES:
        fail("arm.inverse_kinematics",
             f"expected one of {', '.join(IK_FAMILIES)}, got {d.arm.inverse_kinematics!r}")
    if d.arm.inverse_kinematics == "ur" and len(d.arm.joints) != 6:
        fail("arm.inverse_kinematics", "the UR family's closed form is for 6 joints")
    if not d.gripper.bodies:
        fail("gripper.bodies", "must name the bodies that touch a grasped object")
    if len(d.base.joints) != 3:
        fail("base.joints", f"expected 3 joints (x, y, yaw), got {len(d.base.joints)}")
    n = len(d.arm.joints)
    if n == 0:
        fail("arm.joints", "must name the arm's joints")
    if len(d.configurations.stow) != n:
        fail("configurations.stow",
             f"expected {n} values (one per arm joint), got {len(d.configurations.stow)}")
    for path, values in (("arm.mount_xyz", d.arm.mount_xyz), ("tray.xyz", d.tray.xyz)):
        if len(values) != 3:
            fail(path, f"expected 3 values (x, y, z), got {len(values)}")
    overridden = set()
    for i, o in enumerate(d.arm.limit_overrides):
        path = f"arm.limit_overrides[{i}]"
        if o.joint not in d.arm.joints:
            fail(f"{path}.joint", f"{o.joint!r} is not one of arm.joints")
        if o.joint in overridden:
            fail(f"{path}.joint", f"{o.joint!r} is overridden twice")
        overridden.add(o.joint)
        if not o.source.strip():
            fail(f"{path}.source", "must say where the values come from")
        values = {"position_lower": o.position_lower, "position_upper": o.position_upper,
                  "velocity": o.velocity, "acceleration": o.acceleration}
        if all(v is None for v in values.values()):
            fail(path, "overrides no limit")
        for name, v in values.items():
            if v is not None and not math.isfinite(v):
                fail(f"{path}.{name}", f"must be finite, got {v}")
            if v is not None and name in ("velocity", "acceleration") and v <= 0:
                fail(f"{path}.{name}", f"must be positive, got {v}")
    for path, v in (("base.length", d.base.length), ("base.width", d.base.width),
                    ("gripper.travel", d.gripper.travel), ("reach", d.reach),
                    ("tool.wrist_radius", d.tool.wrist_radius),
                    ("tray.inner_length", d.tray.inner_length),
                    ("tray.inner_width", d.tray.inner_width),
                    ("tray.rim_height", d.tray.rim_height)):
        if not (math.isfinite(v) and v > 0):
            fail(path, f"must be positive, got {v}")
    if d.base.width > d.base.length:
        fail("base.width", "the base's x is its long side: width must not exceed length")
    for path, values in (("gripper.open", d.gripper.open),
                         ("gripper.closed", d.gripper.closed)):
        if values and len(values) != len(d.gripper.joints):
            fail(path, f"expected {len(d.gripper.joints)} values (one per gripper joint), "
                 f"got {len(values)}")
    if d.base.drive not in BASE_DRIVES:
        fail("base.drive", f"expected one of {', '.join(BASE_DRIVES)}, got {d.base.drive!r}")
    names = d.joints
    for i, joint in enumerate(names):
        if names.index(joint) != i:
            fail("joints", f"{joint!r} is named twice")


def _check_parts(d: RobotDescription) -> None:
    def fail(path: str, message: str) -> None:
        raise RobotDescriptionError(path, message)

    def scoped(path: str, value: str, parts: list[str]) -> None:
        part, sep, local = value.partition("::")
        if not sep or part not in parts or not local or "::" in local:
            fail(path, f"expected 'part::name' of a part listed before, got {value!r}")

    names = [p.name for p in d.parts]
    for i, part in enumerate(d.parts):
        path = f"parts[{i}]"
        if not part.name.strip() or "::" in part.name:
            fail(f"{path}.name", f"must be given, without '::', got {part.name!r}")
        if names.index(part.name) != i:
            fail(f"{path}.name", f"{part.name!r} is named twice")
        if not part.model.strip():
            fail(f"{path}.model", "must be given")
        if i == 0 and (part.mount.parent or part.mount.child):
            fail(f"{path}.mount", "the first part (the base) joins the world by its own "
                 "joints: no mount")
        if i > 0:
            scoped(f"{path}.mount.parent", part.mount.parent, names[:i])
            if not part.mount.child.strip():
                fail(f"{path}.mount.child", "must be given")
        for key in ("xyz", "rpy"):
            if len(getattr(part.mount, key)) != 3:
                fail(f"{path}.mount.{key}", "expected 3 values")
        if (part.actuators or part.visuals_from_collision) and not part.xacro:
            fail(f"{path}.xacro", "must be given: only a model built from a xacro gets "
                 "actuators or visuals from its collision geometry")
    for i, frame in enumerate(d.frames):
        scoped(f"frames[{i}].name", frame.name, names)
        scoped(f"frames[{i}].parent", frame.parent, names)
        if frame.name.partition("::")[0] != frame.parent.partition("::")[0]:
            fail(f"frames[{i}].parent", "must be on the frame's own part")
        for key in ("xyz", "rpy"):
            if len(getattr(frame, key)) != 3:
                fail(f"frames[{i}].{key}", "expected 3 values")


def _transform(xyz: list[float], rpy: list[float], base_frame: str | None = None):
    from pydrake.common.schema import Transform
    from pydrake.math import RigidTransform, RollPitchYaw

    transform = Transform(RigidTransform(RollPitchYaw(rpy), xyz))
    if base_frame is not None:
        transform.base_frame = base_frame
    return transform


def part_directives(description: RobotDescription, name: str = "robot"):
    """A robot of parts as Drake's model directives: each part a model instance
    `<name>::<part>`, welded where its mount says, then the frames of ours."""
    from pydrake.multibody.parsing import (
        AddFrame,
        AddModel,
        AddWeld,
        ModelDirective,
        ModelDirectives,
    )

    directives = []
    for part in description.parts:
        directives.append(ModelDirective(add_model=AddModel(name=f"{name}::{part.name}",
                                                            file=part.model)))
        mount = part.mount
        if mount.parent:
            directives.append(ModelDirective(add_weld=AddWeld(
                parent=f"{name}::{mount.parent}", child=f"{name}::{part.name}::{mount.child}",
                X_PC=_transform(mount.xyz, mount.rpy))))
    for frame in description.frames:
        directives.append(ModelDirective(add_frame=AddFrame(
            name=f"{name}::{frame.name}",
            X_PF=_transform(frame.xyz, frame.rpy, base_frame=f"{name}::{frame.parent}"))))
    return ModelDirectives(directives=directives)


def add_model_instances(parser, description: RobotDescription, name: str = "robot") -> list:
    """Adds the robot to `parser`'s unfinalized plant: one model instance `name`, or one per
    part (`<name>::<part>`, in the parts' order), with the limits its description overrides
    (`apply_limit_overrides`). Returns the instances."""
    from pydrake.multibody.parsing import ProcessModelDirectives

    plant = parser.plant()
    if not description.parts:
        if plant.HasModelInstanceNamed(name):
            raise ValueError(f"the plant already has a model instance named {name!r}")
        (model,) = parser.AddModels(url=description.model)
        plant.RenameModelInstance(model, name)
        instances = [model]
    else:
        infos = ProcessModelDirectives(part_directives(description, name), parser)
        instances = [i.model_instance for i in infos]
        _filter_gripper_self_collisions(parser, instances, description)
    apply_limit_overrides(plant, instances, description)
    return instances


def _filter_gripper_self_collisions(parser, instances: list, description) -> None:
    """No collisions among the bodies of the part that holds the gripper's joints: a
    linkage gripper's links (the Robotiq 2F-85's knuckles, inner knuckles and finger tips)
    overlap at the pins of its closed chain by design, and Drake filters only parent and
    child, so otherwise every configuration of the robot would be in collision."""
    from pydrake.geometry import CollisionFilterDeclaration

    plant, scene_graph = parser.plant(), parser.scene_graph()
    if not description.gripper.joints or scene_graph is None:
        return
    part = find_joint(plant, instances, description.gripper.joints[0]).model_instance()
    geometries = plant.CollectRegisteredGeometries(
        [plant.get_body(b) for b in plant.GetBodyIndices(part)])
    scene_graph.collision_filter_manager().Apply(
        CollisionFilterDeclaration().ExcludeWithin(geometries))


def _find(plant, instances: list, name: str, has, get, kind: str):
    """The element `name` (`part::name`, or `name` where one instance alone has it) of the
    robot's `instances`; ValueError if there is none or more than one."""
    scope, _, local = name.rpartition("::")
    candidates = [i for i in instances
                  if not scope or plant.GetModelInstanceName(i).endswith(f"::{scope}")]
    found = [i for i in candidates if has(local, i)]
    if len(found) != 1:
        where = ", ".join(plant.GetModelInstanceName(i) for i in found) or "none"
        raise ValueError(f"{kind} {name!r}: expected in one of the robot's parts, found in "
                         f"{where}")
    return get(local, found[0])


def find_joint(plant, instances: list, name: str):
    return _find(plant, instances, name, plant.HasJointNamed, plant.GetJointByName, "joint")


def find_body(plant, instances: list, name: str):
    return _find(plant, instances, name, plant.HasBodyNamed, plant.GetBodyByName, "body")


def find_frame(plant, instances: list, name: str):
    return _find(plant, instances, name, plant.HasFrameNamed, plant.GetFrameByName, "frame")


def mimic_joints(description: RobotDescription) -> list[tuple[str, str, float, float]]:
    """The joints of the robot's URDF parts that follow another (URDF `<mimic>`: Drake
    makes each a coupler constraint, which only a discrete SAP plant enforces):
    (`part::follower`, `part::leader`, multiplier, offset), q_f = m q_l + offset."""
    import xml.etree.ElementTree as ET

    from s3o_drake.world.resources import package_file

    mimics = []
    for part in description.parts:
        if not part.model.endswith(".urdf"):
            continue
        for joint in ET.parse(package_file(part.model)).getroot().iter("joint"):
            mimic = joint.find("mimic")
            if mimic is not None:
                mimics.append((f"{part.name}::{joint.get('name')}",
                               f"{part.name}::{mimic.get('joint')}",
                               float(mimic.get("multiplier", 1.0)),
                               float(mimic.get("offset", 0.0))))
    return mimics


def apply_limit_overrides(plant, instances: list, description: RobotDescription) -> None:
    """Gives the arm's joints among the robot's `instances` in `plant` (parsed, not yet
    finalized) the limits that `description` overrides (`ArmDescription.limit_overrides`)."""
    for i, o in enumerate(description.arm.limit_overrides):
        try:
            joint = find_joint(plant, instances, o.joint)
        except ValueError:
            raise RobotDescriptionError(f"arm.limit_overrides[{i}].joint",
                                        f"the model has no joint {o.joint!r}") from None
        if o.position_lower is not None or o.position_upper is not None:
            lower, upper = joint.position_lower_limits(), joint.position_upper_limits()
            joint.set_position_limits(
                lower if o.position_lower is None else [o.position_lower],
                upper if o.position_upper is None else [o.position_upper])
        if o.velocity is not None:
            joint.set_velocity_limits([-o.velocity], [o.velocity])
        if o.acceleration is not None:
            joint.set_acceleration_limits([-o.acceleration], [o.acceleration])


def check_model(description: RobotDescription) -> None:
    """Parses the description's model (or its parts) and checks that it agrees with the
    description: every joint named, of the right kind (base x and y prismatic, the rest
    revolute or prismatic as the model has them), in the order of the model instance's
    positions (a robot of parts: of its actuators, which the plant's inputs follow); every
    frame and body named; the arm's position, speed and acceleration limits (the model's, or
    the description's overrides) finite, the stow and the gripper's open and closed
    positions within them. Raises RobotDescriptionError."""
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import JointActuatorIndex, PrismaticJoint, RevoluteJoint

    from s3o_drake.world.resources import make_parser

    plant = MultibodyPlant(0.0)
    parser = make_parser(plant)
    for i, override in enumerate(description.arm.limit_overrides):
        if not override.joint.strip():
            raise RobotDescriptionError(f"arm.limit_overrides[{i}].joint", "must be given")
    try:
        instances = add_model_instances(parser, description)
    except RuntimeError as e:  # Drake's parser or directives, in its words
        raise RobotDescriptionError("parts" if description.parts else "model",
                                    str(e).splitlines()[0]) from None
    plant.Finalize()

    def found(find, name: str):
        try:
            return find(plant, instances, name)
        except ValueError:
            return None

    for path, frame in (("base.link", description.base.link),
                        ("arm.base_link", description.arm.base_link),
                        ("tool.frame", description.tool.frame),
                        ("tool.grasp_frame", description.tool.grasp_frame),
                        ("tray.link", description.tray.link),
                        ("lidar_link", description.lidar_link)):
        if frame and found(find_frame, frame) is None:
            raise RobotDescriptionError(path, f"the model has no frame {frame!r}")
    for body in description.gripper.bodies:
        if found(find_body, body) is None:
            raise RobotDescriptionError("gripper.bodies", f"the model has no body {body!r}")
    kinds = {description.base.joints[0]: PrismaticJoint,
             description.base.joints[1]: PrismaticJoint,
             description.base.joints[2]: RevoluteJoint}
    joints = []
    for name in description.joints:
        joint = found(find_joint, name)
        if joint is None:
            raise RobotDescriptionError("joints", f"the model has no joint {name!r}")
        if name in kinds and not isinstance(joint, kinds[name]):
            raise RobotDescriptionError("base.joints", f"{name!r} is a {joint.type_name()} "
                                        f"joint, expected {kinds[name].__name__}")
        joints.append(joint)
    if description.parts:
        actuated = [plant.get_joint_actuator(JointActuatorIndex(a)).joint().index()
                    for a in range(plant.num_actuators())]
        if [j.index() for j in joints] != actuated:
            raise RobotDescriptionError("joints", "the joints must be all of the parts' "
                                        "actuated joints, in the order of their actuators")
    else:
        order = [j.position_start() for j in joints]
        if order != sorted(order) or len(order) != plant.num_positions(instances[0]):
            raise RobotDescriptionError("joints", "the joints must be all of the model's, in "
                                        "the order of its positions")
    velocity = plant.GetVelocityUpperLimits()
    acceleration = plant.GetAccelerationUpperLimits()
    lower, upper = plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits()
    arm = description.arm
    for i, name in enumerate(arm.joints):
        joint = joints[len(description.base.joints) + i]
        index, position = joint.velocity_start(), joint.position_start()
        lo, hi = lower[position], upper[position]
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise RobotDescriptionError(f"arm.joints[{i}]", f"{name}'s position limits "
                                        f"[{lo}, {hi}] must be finite, the lower below")
        for kind, limit in (("velocity", velocity[index]),
                            ("acceleration", acceleration[index])):
            if not (math.isfinite(limit) and limit > 0):
                raise RobotDescriptionError(f"arm.joints[{i}]", f"{name}'s {kind} limit "
                                            f"must be finite and positive, got {limit}")
        stow = description.configurations.stow[i]
        if not lo <= stow <= hi:
            raise RobotDescriptionError(f"configurations.stow[{i}]", f"{stow} is outside "
                                        f"{name}'s limits [{lo}, {hi}]")
    gripper = joints[len(description.base.joints) + len(arm.joints):]
    for path, values in (("gripper.open", description.gripper.open),
                         ("gripper.closed", description.gripper.closed)):
        for i, (joint, q) in enumerate(zip(gripper, values, strict=False)):
            lo, hi = joint.position_lower_limits()[0], joint.position_upper_limits()[0]
            if not lo <= q <= hi:
                raise RobotDescriptionError(f"{path}[{i}]", f"{q} is outside the joint's "
                                            f"limits [{lo}, {hi}]")
