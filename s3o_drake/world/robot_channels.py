"""The LCM channels between the robot and its controllers, and how their messages are made
and read.

What passes is what a robot and its sensors publish and what a robot obeys
(`robot_messages`): the robot's joint state with its base pose as the robot's localisation
reports it, the gripper's report, the sensor's sightings, the protective stop's report and
the overhead camera's images; and the desired state, the grip and the sighting requests.
Drake's lcmtypes carry what they fit (`lcmt_image_array`); the rest are the project's own
(`lcmtypes/s3o_lcm.lcm`: Drake's `lcmt_robot_state` is single precision). Each message
carries `utime`, the robot's clock (microseconds of simulated time), which the controllers
follow.

The functions here are plain Python: a port's value to its message and back, each reading
checked, with a ValueError that names the field.
"""

from collections.abc import Sequence

import numpy as np

from s3o_drake.world.lcmtypes.s3o_lcm import (
    grip_t,
    gripper_status_t,
    protective_stop_t,
    robot_command_t,
    robot_state_t,
    target_request_t,
    target_sighting_t,
)
from s3o_drake.world.robot_messages import (
    GripEvent,
    GripperStatus,
    TargetRequest,
    TargetSighting,
)

#: robot -> controllers, every control period: s3o_lcm.robot_state_t, the robot's joints
#: in `Robot.joints` order, the base's x, y, yaw as its localisation reports them.
ROBOT_STATE = "S3O_ROBOT_STATE"
#: robot -> controllers: lcmt_image_array, the overhead camera's colour, depth and label.
OVERHEAD_IMAGES = "S3O_OVERHEAD_IMAGES"
#: robot -> controllers, every control period: s3o_lcm.gripper_status_t.
GRIPPER_STATUS = "S3O_GRIPPER_STATUS"
#: robot -> controllers, every control period: s3o_lcm.target_sighting_t.
TARGET_SIGHTING = "S3O_TARGET_SIGHTING"
#: robot -> controllers, every control period: s3o_lcm.protective_stop_t.
PROTECTIVE_STOP = "S3O_PROTECTIVE_STOP"
#: controllers -> robot, every control period: s3o_lcm.robot_command_t.
ROBOT_COMMAND = "S3O_ROBOT_COMMAND"
#: controllers -> robot, every control period: s3o_lcm.grip_t.
GRIP = "S3O_GRIP"
#: controllers -> robot, every control period: s3o_lcm.target_request_t.
TARGET_REQUEST = "S3O_TARGET_REQUEST"

RECEIVE_BUFFER = 2 ** 21
"""The socket's receive buffer (bytes) the bus asks for: an overhead image message is about
340 kB, and the kernel's default (about 200 kB) drops its fragments and the messages around
them. The kernel grants at most net.core.rmem_max (LCM warns when it gets less)."""


def local_bus(port: int = 7667) -> str:
    """A bus between processes that never leaves this machine: UDP multicast with a time to
    live of 0, on `port`."""
    return f"udpm://239.255.76.67:{port}?ttl=0&recv_buf_size={RECEIVE_BUFFER}"


LOCAL_BUS = local_bus()
"""The default bus between processes (`local_bus`)."""

FIRST_STATE_WAIT = 30.0
"""How long (s) the controllers wait for the robot's first state, by default."""

IMAGE_FRAMES = ("overhead_color", "overhead_depth", "overhead_label")
"""The frame names of the overhead camera's images in their lcmt_image_array, in the order
colour, depth, label."""

IMAGE_PERIOD = 0.5
"""How often (s) the robot publishes the overhead camera's images: the controllers read them
only when they plan."""


def utime(t: float) -> int:
    """Simulated time `t` (s) as a message's `utime` (microseconds)."""
    return round(t * 1e6)


def seconds(message_utime: int) -> float:
    """A message's `utime` as simulated time (s)."""
    return message_utime * 1e-6


def robot_state_message(positions: Sequence[float], *, joints: Sequence[str],
                        t: float) -> robot_state_t:
    """The robot's positions (`joints` order) at time `t`."""
    if len(positions) != len(joints):
        raise ValueError(f"positions: expected {len(joints)} (one per joint), "
                         f"got {len(positions)}")
    message = robot_state_t()
    message.utime = utime(t)
    message.num_joints = len(joints)
    message.joint_name = list(joints)
    message.joint_position = [float(q) for q in positions]
    return message


def positions_of(message: robot_state_t, *, joints: Sequence[str]) -> np.ndarray:
    """The positions (`joints` order) that `message` reports; ValueError when it reports
    other joints."""
    names = list(message.joint_name)
    if names != list(joints):
        missing = [j for j in joints if j not in names]
        raise ValueError(f"joint_name: expected the robot's {len(joints)} joints in order, "
                         f"got {len(names)}" + (f" without {missing[0]!r}" if missing else ""))
    return np.asarray(message.joint_position, dtype=float)


def command_message(desired: Sequence[float], *, joints: Sequence[str],
                    t: float) -> robot_command_t:
    """The desired state [positions, velocities] (`joints` order) at time `t`."""
    n = len(joints)
    if len(desired) != 2 * n:
        raise ValueError(f"desired: expected {2 * n} values (positions then velocities), "
                         f"got {len(desired)}")
    message = robot_command_t()
    message.utime = utime(t)
    message.num_positions = n
    message.position_name = list(joints)
    message.position = [float(v) for v in desired[:n]]
    message.velocity = [float(v) for v in desired[n:]]
    return message


def desired_of(message: robot_command_t, *, joints: Sequence[str]) -> np.ndarray:
    """The desired state [positions, velocities] (`joints` order) that `message` commands;
    ValueError when it commands other joints."""
    if list(message.position_name) != list(joints):
        raise ValueError(f"position_name: expected the robot's {len(joints)} joints in "
                         f"order, got {list(message.position_name)[:3]}...")
    return np.concatenate([np.asarray(message.position, dtype=float),
                           np.asarray(message.velocity, dtype=float)])


def grip_message(grip: GripEvent, *, t: float) -> grip_t:
    message = grip_t()
    message.utime = utime(t)
    message.dish = grip.dish
    message.num_placed, message.placed = len(grip.placed), list(grip.placed)
    message.num_put, message.put = len(grip.put), list(grip.put)
    return message


def grip_of(message: grip_t) -> GripEvent:
    return GripEvent(message.dish, tuple(message.placed), tuple(message.put))


def request_message(request: TargetRequest, *, t: float) -> target_request_t:
    message = target_request_t()
    message.utime = utime(t)
    message.id, message.target = int(request.id), request.target
    return message


def request_of(message: target_request_t) -> TargetRequest:
    return TargetRequest(int(message.id), message.target)


def sighting_message(sighting: TargetSighting, *, t: float) -> target_sighting_t:
    message = target_sighting_t()
    message.utime = utime(t)
    message.id, message.target = int(sighting.id), sighting.target
    message.seen = sighting.p_WT is not None
    message.position = list(sighting.p_WT) if sighting.p_WT is not None else [0.0, 0.0]
    return message


def sighting_of(message: target_sighting_t) -> TargetSighting:
    p_WT = (float(message.position[0]), float(message.position[1])) if message.seen else None
    return TargetSighting(int(message.id), message.target, p_WT)


def gripper_message(status: GripperStatus, *, t: float) -> gripper_status_t:
    message = gripper_status_t()
    message.utime = utime(t)
    message.object_detected = bool(status.object_detected)
    return message


def gripper_of(message: gripper_status_t) -> GripperStatus:
    return GripperStatus(bool(message.object_detected))


def stop_message(bumper: Sequence[float], *, t: float) -> protective_stop_t:
    """The protective stop's report [stopped (1/0), x, y] at time `t`."""
    message = protective_stop_t()
    message.utime = utime(t)
    message.stopped = bool(bumper[0])
    message.position = [float(bumper[1]), float(bumper[2])] if bumper[0] else [0.0, 0.0]
    return message


def bumper_of(message: protective_stop_t) -> np.ndarray:
    """The report as the navigator's `bumper` input reads it: [stopped, x, y] (NaN when
    not stopped)."""
    if not message.stopped:
        return np.array([0.0, np.nan, np.nan])
    return np.array([1.0, float(message.position[0]), float(message.position[1])])


def image_of(message, frame: str, *, dtype: type, channels: int) -> np.ndarray | None:
    """The uncompressed image of `frame` in an lcmt_image_array `message`, as an array
    (height, width, channels) of `dtype`; None when the message has none of that frame (no
    images came yet). ValueError when it is compressed or its size does not fit."""
    for image in message.images:
        if image.header.frame_name != frame:
            continue
        if image.compression_method != image.COMPRESSION_METHOD_NOT_COMPRESSED:
            raise ValueError(f"{frame}: compression_method: expected none, got "
                             f"{image.compression_method}")
        item = np.dtype(dtype).itemsize
        data = np.frombuffer(bytes(image.data), dtype=dtype)
        if image.row_stride * image.height != data.size * item:
            raise ValueError(f"{frame}: size: {data.size * item} bytes for {image.height} "
                             f"rows of {image.row_stride}")
        rows = data.reshape(image.height, image.row_stride // item)
        return rows[:, :image.width * channels].reshape(image.height, image.width, channels)
    return None
