"""The mobile manipulator: its model file, joint layout, named configurations and footprint.

The values come from the description of this process's robot (``models/<name>/robot.yaml``,
`resources.ROBOT_NAME`: the UR5e unless S3O_ROBOT names another; read and checked against
its model by `world/robot_description`); the names below are the package's view of it, and
no module below the commands assumes more of the robot than they say.

The models are built from primitives (``models/ur5e``: an RMP-110-class base with a UR5e arm
and a Robotiq 2F-140-class gripper; ``models/panda``: a smaller base with a Franka-Panda-class
arm and hand; each URDF's header says why everything is where it is). The base moves on
three actuated joints from the world (``base_x``, ``base_y`` prismatic, ``base_yaw`` revolute
about z; Drake's PlanarJoint cannot be actuated), so the whole robot is one model instance
whose positions, velocities and PD-controlled actuators are all in the order

    ``BASE_JOINTS + ARM_JOINTS + GRIPPER_JOINTS``

(positions, velocities, actuators and the plant's desired-state input alike; NUM_POSITIONS of
each). The PD gains are in the URDF (``<drake:controller_gains>``) and are tuned for a
discrete plant (SAP, time step 1e-3..2e-3 s) whose actuators also carry the robot's gravity
as a feed-forward (the world's "gravity_compensation", `world/builder.py`), as the arms' own
controllers do.

Frames (names of bodies in the model):

- ``base_link`` (B): on the floor at the centre of the footprint, x forward, z up. For base
  positions (x, y, yaw), ``X_WB = RigidTransform(RotationMatrix.MakeZRotation(yaw), [x, y, 0])``.
- ``ARM_BASE_LINK`` (A): the arm's DH base frame, at ``ARM_MOUNT_XYZ`` in B (axes parallel to
  B's).
- ``TOOL_FRAME``: the tool flange, turned as the hand is mounted.
- ``GRASP_FRAME`` (G): the centre between the fingertip pads, ``GRASP_OFFSET`` beyond the tool
  frame along its z axis, which is the approach direction; the fingers open along G's y.
- ``TRAY_LINK``: the centre of the tray's inner floor surface (z up), at ``TRAY_XYZ`` in B.
- ``LIDAR_LINK``: the centre of the lidar's head.
"""

import math

import numpy as np
from pydrake.multibody.parsing import Parser
from pydrake.multibody.tree import ModelInstanceIndex
from shapely.geometry import Polygon

from s3o_drake.world.resources import PACKAGE_NAME, ROBOT_NAME, models_dir, package_file
from s3o_drake.world.robot_description import load_robot_description

ROBOT = load_robot_description(ROBOT_NAME)
"""The description of the robot this process plans and executes for
(`resources.ROBOT_NAME`)."""
ROBOT_URL = ROBOT.model
ROBOT_URDF = package_file(ROBOT_URL)
"""The robot's model file."""

BASE_JOINTS = tuple(ROBOT.base.joints)
ARM_JOINTS = tuple(ROBOT.arm.joints)
GRIPPER_JOINTS = tuple(ROBOT.gripper.joints)
#: All joints, in the order of the model instance's positions, velocities and actuators.
ROBOT_JOINTS = BASE_JOINTS + ARM_JOINTS + GRIPPER_JOINTS
NUM_POSITIONS = len(ROBOT_JOINTS)
NUM_BASE_JOINTS = len(BASE_JOINTS)
NUM_ARM_JOINTS = len(ARM_JOINTS)
#: The arm's joints among the robot's positions (and velocities), and the gripper's.
ARM_POSITIONS = slice(NUM_BASE_JOINTS, NUM_BASE_JOINTS + NUM_ARM_JOINTS)
GRIPPER_POSITIONS = slice(ARM_POSITIONS.stop, NUM_POSITIONS)

BASE_LINK = ROBOT.base.link
ARM_BASE_LINK = ROBOT.arm.base_link
TOOL_FRAME = ROBOT.tool.frame
GRASP_FRAME = ROBOT.tool.grasp_frame
TRAY_LINK = ROBOT.tray.link
LIDAR_LINK = ROBOT.lidar_link

#: Chassis footprint (m) along the base's x (forward) and y axes. Nothing of the robot in its
#: stow configuration sticks out of it.
BASE_LENGTH = ROBOT.base.length
BASE_WIDTH = ROBOT.base.width
#: Circumscribed radius of the footprint (m), for inflating obstacles.
BASE_RADIUS = math.hypot(BASE_LENGTH / 2, BASE_WIDTH / 2)
#: Inscribed radius (m): the largest disc inside the footprint, whatever its yaw. Closer than
#: this to an obstacle the base collides at every yaw, so standing spots keep at least this.
INSCRIBED_RADIUS = BASE_WIDTH / 2

#: Position of the arm's base frame in base_link (m); see the URDF's header for the reasons.
ARM_MOUNT_XYZ = tuple(ROBOT.arm.mount_xyz)
#: Distance (m) from the tool frame to the grasp frame along the tool's z axis.
GRASP_OFFSET = ROBOT.tool.grasp_offset
#: Distance (m) from the tool frame to the fingertips along its z axis.
FINGERTIP_OFFSET = ROBOT.tool.fingertip_offset
#: Travel of each finger (m); the opening between the fingers is the sum of both positions.
FINGER_TRAVEL = ROBOT.gripper.travel

#: Position of tray_link (centre of the tray's inner floor) in base_link (m).
TRAY_XYZ = tuple(ROBOT.tray.xyz)
#: Inner floor of the tray (m): along the base's x, along its y; height of the rim above it.
TRAY_INNER_LENGTH = ROBOT.tray.inner_length
TRAY_INNER_WIDTH = ROBOT.tray.inner_width
TRAY_RIM_HEIGHT = ROBOT.tray.rim_height


def _frozen(values) -> np.ndarray:
    array = np.array(values, dtype=float)
    array.flags.writeable = False
    return array


#: The arm's stow configuration (rad), in ARM_JOINTS order: the arm folded in the base's x-z
#: plane, upper arm leaning slightly back from vertical (shoulder lift -1.3), elbow folded
#: (2.7), wrist 1 chosen so that the gripper points straight down (q2 + q3 + q4 = -pi/2),
#: wrist 2 at -pi/2, wrist 3 turning the gripper so that its fingers open across the robot.
#: The grasp frame is then above the right half of the tray, at about (-0.13, -0.13, 0.61) m
#: in base_link (fingertips 0.19 m above the tray's floor); the arm and gripper stay inside
#: x in [-0.18, 0.21] m, y in [-0.24, 0.06] m of the footprint and below 1.39 m, at least
#: 0.019 m from any self-collision.
ARM_STOW = _frozen(ROBOT.configurations.stow)
#: Finger positions (m): fully open (opening 0.14 m) and closed (fingers touching).
GRIPPER_OPEN = _frozen([FINGER_TRAVEL, FINGER_TRAVEL])
GRIPPER_CLOSED = _frozen([0.0, 0.0])


def add_robot(parser: Parser, *, name: str = "robot") -> ModelInstanceIndex:
    """Parses the robot into `parser`'s (not yet finalized) plant as model instance `name`.

    The ``s3o_drake`` package is registered with `parser`'s package map if it is not already
    (as ``resources.make_parser`` does). Returns the new model instance; its positions are
    in ``ROBOT_JOINTS`` order (see ``robot_positions``).
    """
    packages = parser.package_map()
    if not packages.Contains(PACKAGE_NAME):
        packages.Add(PACKAGE_NAME, str(models_dir()))
    plant = parser.plant()
    if plant.HasModelInstanceNamed(name):
        raise ValueError(f"the plant already has a model instance named {name!r}")
    (model,) = parser.AddModels(url=ROBOT_URL)
    plant.RenameModelInstance(model, name)
    return model


def robot_positions(
    x: float,
    y: float,
    yaw: float,
    arm: np.ndarray = ARM_STOW,
    gripper: np.ndarray = GRIPPER_OPEN,
) -> np.ndarray:
    """The robot's positions (model instance order) with base_link at (x, y, yaw) in W.

    `arm` holds the 6 arm joint angles (rad) in ``ARM_JOINTS`` order, `gripper` the 2 finger
    positions (m) in ``GRIPPER_JOINTS`` order.
    """
    arm = np.asarray(arm, dtype=float).reshape(-1)
    gripper = np.asarray(gripper, dtype=float).reshape(-1)
    if arm.shape != (len(ARM_JOINTS),):
        raise ValueError(f"arm: expected {len(ARM_JOINTS)} joint angles, got {arm.size}")
    if gripper.shape != (len(GRIPPER_JOINTS),):
        raise ValueError(f"gripper: expected {len(GRIPPER_JOINTS)} positions, got {gripper.size}")
    return np.concatenate([[x, y, yaw], arm, gripper])


def robot_desired_state(positions: np.ndarray, velocities: np.ndarray | None = None) -> np.ndarray:
    """The value for ``plant.get_desired_state_input_port(model)``: [q_d, v_d]
    (2 NUM_POSITIONS values).

    The actuators are in the order of the positions, so this is ``positions`` followed by
    ``velocities`` (zero if not given).
    """
    positions = np.asarray(positions, dtype=float).reshape(-1)
    if positions.shape != (NUM_POSITIONS,):
        raise ValueError(f"positions: expected {NUM_POSITIONS} values, got {positions.size}")
    if velocities is None:
        velocities = np.zeros(NUM_POSITIONS)
    velocities = np.asarray(velocities, dtype=float).reshape(-1)
    if velocities.shape != (NUM_POSITIONS,):
        raise ValueError(f"velocities: expected {NUM_POSITIONS} values, got {velocities.size}")
    return np.concatenate([positions, velocities])


def footprint_polygon(x: float, y: float, yaw: float) -> Polygon:
    """The base's footprint (BASE_LENGTH x BASE_WIDTH rectangle) in the world's x-y plane."""
    half_l, half_w = BASE_LENGTH / 2, BASE_WIDTH / 2
    p_BC = np.array([[half_l, half_w], [-half_l, half_w], [-half_l, -half_w], [half_l, -half_w]])
    c, s = math.cos(yaw), math.sin(yaw)
    R_WB = np.array([[c, -s], [s, c]])
    p_WC = p_BC @ R_WB.T + np.array([x, y])
    return Polygon(p_WC)


#: How often (s) the execution systems of the full diagram look at their inputs: commands,
#: reports and grips change a few times a minute, and a 50 ms reaction is invisible next
#: to seconds-long motions, while every periodic event costs a state copy per firing.
#: (Trajectories are evaluated at every plant step regardless.) A property of the robot's
#: controllers, here at the bottom because the time model counts the hand-over between
#: commands.
CONTROL_PERIOD = 0.05
