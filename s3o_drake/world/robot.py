"""The mobile manipulator as a value: `load_robot(name)` gives the `Robot` of a shipped
description (``models/<name>/robot.yaml``, read and checked against its model by
`world/robot_description`): its joint layout, frames, sizes, named configurations, footprint
and built files. Code that needs a robot is given one, as Drake code is given a plant; the
process that has several robots holds several values.

The models are built from primitives (``models/ur5e``: an RMP-110-class base with a UR5e arm
and a Robotiq 2F-140-class gripper; ``models/panda``: a smaller base with a Franka-Panda-class
arm and hand; each URDF's header says why everything is where it is). The base moves on
three actuated joints from the world (``base_x``, ``base_y`` prismatic, ``base_yaw`` revolute
about z; Drake's PlanarJoint cannot be actuated), so the whole robot is one model instance
whose positions, velocities and PD-controlled actuators are all in the order

    ``Robot.joints`` (base, arm, gripper)

(positions, velocities, actuators and the plant's desired-state input alike). The PD gains
are in the URDF (``<drake:controller_gains>``) and are tuned for a
discrete plant (SAP, time step 1e-3..2e-3 s) whose actuators also carry the robot's gravity
as a feed-forward (the world's "gravity_compensation", `world/builder.py`), as the arms' own
controllers do.

Frames (names of bodies in the model):

- ``base_link`` (B): on the floor at the centre of the footprint, x forward, z up. For base
  positions (x, y, yaw), ``X_WB = RigidTransform(RotationMatrix.MakeZRotation(yaw), [x, y, 0])``.
- ``arm_base_link`` (A): the arm's base frame, at ``arm_mount_xyz`` in B (axes parallel to
  B's).
- ``tool_frame``: the tool flange, turned as the hand is mounted.
- ``grasp_frame`` (G): the centre between the fingertip pads, ``grasp_offset`` beyond the tool
  frame along its z axis, which is the approach direction; the fingers open along G's y.
- ``tray_link``: the centre of the tray's inner floor surface (z up), at ``tray_xyz`` in B.
- ``lidar_link``: the centre of the lidar's head.
"""

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from shapely.geometry import Polygon

from s3o_drake.world.resources import (
    DEFAULT_ROBOT,
    PACKAGE_NAME,
    models_dir,
    package_file,
    robot_dir,
)
from s3o_drake.world.robot_description import (
    RobotDescription,
    add_model_instances,
    check_model,
    find_body,
    find_frame,
    find_joint,
    load_robot_description,
    mimic_joints,
)


def _frozen(values, dtype: type = float) -> np.ndarray:
    """An array that may be handed out and kept: it cannot be changed."""
    array = np.array(values, dtype=dtype)
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class RobotFiles:
    """What was built for a robot, in its folder (models/<name>/): each file may be missing
    until `s3o build robot` (or its study) makes it."""

    folder: Path

    @property
    def reachability_map(self) -> Path:
        return self.folder / "reachability_map.npz"

    @property
    def time_model(self) -> Path:
        return self.folder / "time_model.yaml"

    @property
    def fcn_weights(self) -> Path:
        return self.folder / "fcn" / "fcn.pt"

    @property
    def failure_price(self) -> Path:
        return self.folder / "failure_price.yaml"

    @property
    def shared_stop(self) -> Path:
        return self.folder / "shared_stop.yaml"


@dataclass(frozen=True, eq=False, repr=False)
class Robot:
    """A mobile manipulator as the planner and the execution see it: its description
    (checked against its model), the joint layout, frames and sizes read from it, and the
    files built for it. Made by `load_robot`; passed where it is needed, as a plant is.

    Positions, velocities and actuators are in the order ``base_joints + arm_joints +
    gripper_joints`` (`joints`). Compared by identity: `load_robot` returns the same value
    for the same name."""

    description: RobotDescription
    files: RobotFiles
    joints: tuple[str, ...] = field(init=False)
    arm_stow: np.ndarray = field(init=False)
    gripper_open: np.ndarray = field(init=False)
    gripper_closed: np.ndarray = field(init=False)

    def __repr__(self) -> str:
        # Short and stable (cache keys repr what they hold): a name gives one value.
        return f"load_robot({self.name!r})"

    def __reduce__(self):
        # By name: another process (a search or study worker) gets its own loaded value.
        return load_robot, (self.name,)

    def __post_init__(self) -> None:
        d = self.description
        set_ = functools.partial(object.__setattr__, self)
        set_("joints", (*d.base.joints, *d.arm.joints, *d.gripper.joints))
        set_("arm_stow", _frozen(d.configurations.stow))
        # Sliding fingers unless the description says otherwise (a linkage gripper).
        set_("gripper_open", _frozen(d.gripper.open
                                     or [d.gripper.travel] * len(d.gripper.joints)))
        set_("gripper_closed", _frozen(d.gripper.closed or [0.0] * len(d.gripper.joints)))

    # --- names -------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self.description.name

    @property
    def is_of_parts(self) -> bool:
        """Whether the robot is several model instances (its description's parts)."""
        return bool(self.description.parts)

    @property
    def model_url(self) -> str:
        """The model's URL (`package://s3o_drake/...`); a robot of parts has one per part."""
        if self.is_of_parts:
            raise ValueError(f"robot {self.name!r} is made of parts: see model_files")
        return self.description.model

    @property
    def model_file(self) -> Path:
        return package_file(self.model_url)

    @property
    def model_files(self) -> tuple[Path, ...]:
        """The files Drake reads for the robot: its model, or its parts' in order."""
        urls = [p.model for p in self.description.parts] or [self.description.model]
        return tuple(package_file(url) for url in urls)

    # --- joints ------------------------------------------------------------------------
    @property
    def base_joints(self) -> tuple[str, ...]:
        return tuple(self.description.base.joints)

    @property
    def arm_joints(self) -> tuple[str, ...]:
        return tuple(self.description.arm.joints)

    @property
    def gripper_joints(self) -> tuple[str, ...]:
        return tuple(self.description.gripper.joints)

    @property
    def gripper_bodies(self) -> tuple[str, ...]:
        """The bodies that may touch the object being grasped (palm and fingers)."""
        return tuple(self.description.gripper.bodies)

    @property
    def num_positions(self) -> int:
        return len(self.joints)

    @property
    def num_base_joints(self) -> int:
        return len(self.description.base.joints)

    @property
    def num_arm_joints(self) -> int:
        return len(self.description.arm.joints)

    @property
    def arm_positions(self) -> slice:
        """The arm's joints among the robot's positions (and velocities)."""
        return slice(self.num_base_joints, self.num_base_joints + self.num_arm_joints)

    @property
    def gripper_positions(self) -> slice:
        """The fingers' joints among the robot's positions (and velocities)."""
        return slice(self.arm_positions.stop, self.num_positions)

    # --- frames and sizes --------------------------------------------------------------
    @property
    def base_link(self) -> str:
        return self.description.base.link

    @property
    def arm_base_link(self) -> str:
        return self.description.arm.base_link

    @property
    def tool_frame(self) -> str:
        return self.description.tool.frame

    @property
    def grasp_frame(self) -> str:
        return self.description.tool.grasp_frame

    @property
    def tray_link(self) -> str:
        return self.description.tray.link

    @property
    def lidar_link(self) -> str:
        return self.description.lidar_link

    @property
    def base_length(self) -> float:
        """The chassis footprint along the base's x (m): nothing of the robot in its stow
        configuration sticks out of it."""
        return self.description.base.length

    @property
    def base_width(self) -> float:
        """... and along its y (m)."""
        return self.description.base.width

    @property
    def base_radius(self) -> float:
        """The footprint's circumscribed radius (m), for inflating obstacles."""
        return math.hypot(self.base_length / 2, self.base_width / 2)

    @property
    def inscribed_radius(self) -> float:
        """The largest disc inside the footprint, whatever its yaw (m): closer than this to
        an obstacle the base collides at every yaw."""
        return self.base_width / 2

    @property
    def arm_mount_xyz(self) -> tuple[float, float, float]:
        """The arm's base frame in the base link (m)."""
        return tuple(self.description.arm.mount_xyz)

    @property
    def grasp_offset(self) -> float:
        """From the tool frame to the grasp frame along the tool's z (m)."""
        return self.description.tool.grasp_offset

    @property
    def fingertip_offset(self) -> float:
        """The farthest the fingers reach from the tool frame along the tool's z over
        their stroke (m)."""
        return self.description.tool.fingertip_offset

    @property
    def finger_travel(self) -> float:
        """Each finger's travel (m); the opening is the sum of the fingers' positions."""
        return self.description.gripper.travel

    @property
    def finger_joint_per_metre(self) -> np.ndarray:
        """Each gripper joint's motion per metre of its pads' travel (the joint's units per
        m), over the whole stroke: 1 for sliding fingers, whose joints are the pads'
        positions; a linkage gripper's knuckle turns (rad) as its pads close."""
        return np.abs(self.gripper_open - self.gripper_closed) / self.finger_travel

    @property
    def tray_xyz(self) -> tuple[float, float, float]:
        """The centre of the tray's inner floor in the base link (m)."""
        return tuple(self.description.tray.xyz)

    @property
    def reach(self) -> float:
        """How far from the base centre (m) the planner assumes a dish can be picked."""
        return self.description.reach

    # --- values ------------------------------------------------------------------------
    def positions(self, x: float, y: float, yaw: float, arm: np.ndarray | None = None,
                  gripper: np.ndarray | None = None) -> np.ndarray:
        """The robot's positions with its base link at (x, y, yaw) in W: `arm` the arm's
        joint angles (rad; default stowed), `gripper` the fingers' positions (m; default
        open)."""
        arm = self.arm_stow if arm is None else np.asarray(arm, dtype=float).reshape(-1)
        gripper = (self.gripper_open if gripper is None
                   else np.asarray(gripper, dtype=float).reshape(-1))
        if arm.shape != (self.num_arm_joints,):
            raise ValueError(f"arm: expected {self.num_arm_joints} joint angles, "
                             f"got {arm.size}")
        if gripper.shape != (len(self.gripper_joints),):
            raise ValueError(f"gripper: expected {len(self.gripper_joints)} positions, "
                             f"got {gripper.size}")
        return np.concatenate([[x, y, yaw], arm, gripper])

    def desired_state(self, positions: np.ndarray,
                      velocities: np.ndarray | None = None) -> np.ndarray:
        """The value of the plant's desired-state input for this robot: [q_d, v_d]
        (the actuators are in the order of the positions; velocities zero if not given)."""
        n = self.num_positions
        positions = np.asarray(positions, dtype=float).reshape(-1)
        if positions.shape != (n,):
            raise ValueError(f"positions: expected {n} values, got {positions.size}")
        velocities = (np.zeros(n) if velocities is None
                      else np.asarray(velocities, dtype=float).reshape(-1))
        if velocities.shape != (n,):
            raise ValueError(f"velocities: expected {n} values, got {velocities.size}")
        return np.concatenate([positions, velocities])

    def footprint(self, x: float, y: float, yaw: float) -> Polygon:
        """The base's footprint (base_length x base_width) in the world's x-y plane."""
        half_l, half_w = self.base_length / 2, self.base_width / 2
        p_BC = np.array([[half_l, half_w], [-half_l, half_w], [-half_l, -half_w],
                         [half_l, -half_w]])
        c, s = math.cos(yaw), math.sin(yaw)
        p_WC = p_BC @ np.array([[c, -s], [s, c]]).T + np.array([x, y])
        return Polygon(p_WC)

    def add_to(self, parser: Parser, *, name: str = "robot") -> ModelInstanceIndex:
        """Parses the robot into `parser`'s (not yet finalized) plant as model instance
        `name`, registering the ``s3o_drake`` package with its package map if need be, with
        the limits its description overrides. Its positions are in `joints` order. A robot
        of parts is several instances: `add_model_instances`."""
        if self.is_of_parts:
            raise ValueError(f"robot {self.name!r} is made of parts, one model instance "
                             "each: use add_model_instances")
        return self.add_model_instances(parser, name=name).instances[0]

    def add_model_instances(self, parser: Parser, *, name: str = "robot") -> "RobotInstances":
        """Parses the robot into `parser`'s (not yet finalized) plant: one model instance
        `name`, or for a robot of parts one per part (`<name>::<part>`, welded as model
        directives weld them). What is returned finds the robot's joints, bodies and
        frames in the plant, and its positions among the plant's."""
        packages = parser.package_map()
        if not packages.Contains(PACKAGE_NAME):
            packages.Add(PACKAGE_NAME, str(models_dir()))
        instances = add_model_instances(parser, self.description, name)
        return RobotInstances(self, parser.plant(), tuple(instances))

    def model_instance_names(self, name: str = "robot") -> tuple[str, ...]:
        """The names of the model instances `add_model_instances(parser, name=name)` adds:
        `name`, or `<name>::<part>` for each part in order."""
        if not self.is_of_parts:
            return (name,)
        return tuple(f"{name}::{part.name}" for part in self.description.parts)

    def instances_in(self, plant: MultibodyPlant, *, name: str = "robot") -> "RobotInstances":
        """The robot in a plant that holds it as `add_model_instances(..., name=name)` put it
        there (a world diagram's plant, found by its instances' names)."""
        return RobotInstances(self, plant, tuple(
            plant.GetModelInstanceByName(n) for n in self.model_instance_names(name)))


@dataclass(frozen=True)
class RobotInstances:
    """A robot in a plant: its model instances (one, or one per part in the parts'
    order). The robot's positions, velocities and actuators are in `Robot.joints` order
    (base, arm, gripper); a robot of parts has them spread over its instances, and its
    mimic joints (a linkage gripper's) follow the joints they mimic, so they are read and
    set through the joints' indices here. The index methods need a finalized plant."""

    robot: Robot
    plant: MultibodyPlant
    instances: tuple[ModelInstanceIndex, ...]

    def joint(self, name: str):
        """A joint by its name in the description (`part::name`, or `name`)."""
        return find_joint(self.plant, list(self.instances), name)

    def body(self, name: str):
        return find_body(self.plant, list(self.instances), name)

    def frame(self, name: str):
        return find_frame(self.plant, list(self.instances), name)

    def position_indices(self) -> np.ndarray:
        """Where the robot's positions (`Robot.joints` order) are among the plant's."""
        return self._position_indices

    def velocity_indices(self) -> np.ndarray:
        """... and its velocities among the plant's."""
        return self._velocity_indices

    # Found once per robot in a plant: a simulation reads and sets the robot's positions
    # at every step, and the lookups by name (and the URDF's mimic tags) cost more than
    # the step's own arithmetic.
    @functools.cached_property
    def _position_indices(self) -> np.ndarray:
        return _frozen([self.joint(j).position_start() for j in self.robot.joints], int)

    @functools.cached_property
    def _velocity_indices(self) -> np.ndarray:
        return _frozen([self.joint(j).velocity_start() for j in self.robot.joints], int)

    @functools.cached_property
    def _followers(self) -> tuple[tuple[int, int, float, float], ...]:
        """(follower's position index, leader's, multiplier, offset) of the mimic joints."""
        return tuple((self.joint(f).position_start(), self.joint(leader).position_start(),
                      m, b) for f, leader, m, b in mimic_joints(self.robot.description))

    def set_positions(self, context, q: np.ndarray) -> None:
        """Sets the robot's positions (`Robot.joints` order) in a plant context, and its
        mimic joints where they follow them."""
        if self.is_single:
            # One instance: its positions are the robot's, in order (check_model).
            self.plant.SetPositions(context, self.instances[0], q)
            return
        self.plant.SetPositions(context, _lifted(self.plant.GetPositions(context), q,
                                                 self.position_indices(), self._followers))

    def get_positions(self, context) -> np.ndarray:
        if self.is_single:
            return self.plant.GetPositions(context, self.instances[0])
        return self.plant.GetPositions(context)[self.position_indices()]

    @property
    def is_single(self) -> bool:
        """Whether the robot is one model instance (then its positions are that instance's
        and need no selection)."""
        return len(self.instances) == 1

    def body_indices(self) -> list:
        """The robot's bodies in the plant, instance after instance."""
        return [b for instance in self.instances for b in self.plant.GetBodyIndices(instance)]

    def plant_positions(self, q: np.ndarray, context=None) -> np.ndarray:
        """The plant's positions with the robot at `q` (`Robot.joints` order) and its
        mimic joints following, set in `context` (its other positions stay; default: a new
        context): a configuration for a collision checker over the whole plant."""
        context = self.plant.CreateDefaultContext() if context is None else context
        self.set_positions(context, q)
        return self.plant.GetPositions(context).copy()

    def position_map(self) -> "PositionMap":
        """The robot's positions (`Robot.joints` order) among the plant's: how a collision
        checker or a plant context over the whole plant is given them (`PositionMap`). The
        plant's other positions are taken from its default context."""
        plant = self.plant
        indices = self.position_indices()
        rest = plant.GetPositions(plant.CreateDefaultContext()).copy()
        identity = (plant.num_positions() == self.robot.num_positions
                    and np.array_equal(indices, np.arange(self.robot.num_positions)))
        return PositionMap(num_plant=plant.num_positions(), indices=indices,
                           followers=self._followers, rest=_frozen(rest),
                           is_identity=identity)

    def state_selector(self) -> np.ndarray:
        """The matrix that takes the plant's state [q; v] to the robot's [q; v] in
        `Robot.joints` order (a MatrixGain on the plant's state output gives the
        "robot_state" a single-instance robot's state output port gives)."""
        plant, n = self.plant, self.robot.num_positions
        S = np.zeros((2 * n, plant.num_positions() + plant.num_velocities()))
        S[np.arange(n), self.position_indices()] = 1.0
        S[n + np.arange(n), plant.num_positions() + self.velocity_indices()] = 1.0
        return S

    def desired_state_selectors(self) -> dict[ModelInstanceIndex, np.ndarray]:
        """For each of the robot's instances with actuators, the matrix that takes the
        robot's desired state [q_d; v_d] (`Robot.joints` order) to that instance's
        desired-state input (its actuated joints' [q_d; v_d], in actuator order)."""
        plant, n = self.plant, self.robot.num_positions
        index = {int(self.joint(j).index()): k for k, j in enumerate(self.robot.joints)}
        selectors = {}
        for instance in self.instances:
            rows = [index[int(plant.get_joint_actuator(a).joint().index())]
                    for a in plant.GetJointActuatorIndices(instance)]
            if not rows:
                continue
            S = np.zeros((2 * len(rows), 2 * n))
            S[np.arange(len(rows)), rows] = 1.0
            S[len(rows) + np.arange(len(rows)), n + np.array(rows)] = 1.0
            selectors[instance] = S
        return selectors


def _lifted(plant_q: np.ndarray, q: np.ndarray, indices: np.ndarray,
            followers: Sequence[tuple[int, int, float, float]]) -> np.ndarray:
    """A copy of the plant's positions `plant_q` (..., plant's) with the robot's `q`
    (..., robot's) at `indices` and each mimic joint (follower, leader, multiplier,
    offset) following its leader."""
    plant_q = np.array(plant_q, dtype=float)
    plant_q[..., indices] = q
    for follower, leader, multiplier, offset in followers:
        plant_q[..., follower] = multiplier * plant_q[..., leader] + offset
    return plant_q


@dataclass(frozen=True, eq=False)
class PositionMap:
    """The robot's positions (`Robot.joints` order) lifted to a plant's (`to_plant`) and
    read back (`to_robot`): made by `RobotInstances.position_map`.

    The plant's positions are the robot's at `indices`, its mimic joints (`followers`:
    follower's index, leader's index, multiplier, offset) following their leaders, and the
    rest as in `rest`. The map is affine, so a straight line between two robot positions
    lifts to the straight line between their lifts, and a B-spline's lift is the B-spline
    of its lifted control points.

    For a robot that is one model instance alone in its plant the plant's positions are the
    robot's (`is_identity`): then every method returns its argument itself, no copy and no
    arithmetic, so that such a robot's plans are exactly what they were before robots of
    parts."""

    num_plant: int
    indices: np.ndarray
    followers: tuple[tuple[int, int, float, float], ...]
    rest: np.ndarray
    is_identity: bool

    @property
    def num_robot(self) -> int:
        return len(self.indices)

    def to_plant(self, q: np.ndarray) -> np.ndarray:
        """The plant's positions for the robot's `q` (n,) or (k, n) (one per row)."""
        if self.is_identity:
            return q
        q = np.asarray(q, dtype=float)
        return _lifted(np.broadcast_to(self.rest, (*q.shape[:-1], self.num_plant)), q,
                       self.indices, self.followers)

    def to_robot(self, values: np.ndarray) -> np.ndarray:
        """The robot's entries (`Robot.joints` order) of a vector over the plant's
        positions (n_plant,) or (k, n_plant): positions, or their limits."""
        if self.is_identity:
            return values
        return np.asarray(values)[..., self.indices]

    def rate_limits_to_plant(self, limits: np.ndarray) -> np.ndarray:
        """Nonnegative speed or acceleration limits of the robot's positions (n,) as limits
        of the plant's: a mimic joint gets its leader's times |multiplier| (it moves exactly
        that much faster: its limit repeats its leader's, never binds more); the plant's
        other positions, which the robot's motions never move, get +inf."""
        if self.is_identity:
            return limits
        plant_limits = np.full(self.num_plant, np.inf)
        plant_limits[self.indices] = limits
        for follower, leader, multiplier, _ in self.followers:
            plant_limits[follower] = abs(multiplier) * plant_limits[leader]
        return plant_limits


def load_robot(name: str = DEFAULT_ROBOT) -> Robot:
    """The shipped robot `name` (its folder under models/), its description checked for
    shape and values and against its model, once: loading it again returns the same value.
    Raises `RobotDescriptionError` (its field named) for a description that cannot be used."""
    return _load_robot(str(name))


@functools.cache
def _load_robot(name: str) -> Robot:
    description = load_robot_description(name)
    check_model(description)
    return Robot(description, RobotFiles(robot_dir(description.name)))


#: How often (s) the execution systems of the full diagram look at their inputs: commands,
#: reports and grips change a few times a minute, and a 50 ms reaction is invisible next
#: to seconds-long motions, while every periodic event costs a state copy per firing.
#: (Trajectories are evaluated at every plant step regardless.) A property of the robot's
#: controllers, here at the bottom because the time model counts the hand-over between
#: commands.
CONTROL_PERIOD = 0.05
