"""The controllers' side of the LCM boundary: what the robot publishes, read into the
controllers' input ports, and what they command, published (`world.robot_channels`).

`add_controller_lcm` adds, to a diagram of the controllers, a subscriber and a reader per
channel the robot publishes, and a writer and a publisher per channel it obeys; it returns
the ports to wire the controllers to (`ControllerPorts`). Before the robot's first state
the robot is where the briefing starts it; before the first images they are empty.
"""

from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
from drake import lcmt_image_array
from pydrake.systems.framework import DiagramBuilder, InputPort, OutputPort
from pydrake.systems.lcm import LcmInterfaceSystem
from pydrake.systems.sensors import ImageDepth32F, ImageLabel16I, ImageRgba8U

from s3o_drake.world import robot_channels as ch
from s3o_drake.world.lcmtypes import s3o_lcm
from s3o_drake.world.message_systems import add_publisher, add_reader, add_subscriber
from s3o_drake.world.robot import CONTROL_PERIOD, Robot
from s3o_drake.world.robot_messages import GripEvent, GripperStatus, TargetRequest, TargetSighting


@dataclass(frozen=True)
class ControllerPorts:
    """What the controllers read (output ports of the readers) and what they command (input
    ports of the writers), by the name of the world's port each stands for."""

    reads: dict[str, OutputPort]
    commands: dict[str, InputPort]


def add_controller_lcm(builder: DiagramBuilder, *, robot: Robot, lcm: LcmInterfaceSystem,
                       start: Sequence[float], period: float = CONTROL_PERIOD
                       ) -> ControllerPorts:
    """The readers and writers of the controllers' side (module docstring); `start`: the
    base's pose (x, y, yaw) the briefing starts the robot at."""
    joints = tuple(robot.joints)
    n = robot.num_positions
    reads: dict[str, OutputPort] = {}
    commands: dict[str, InputPort] = {}

    def read(name: str, channel: str, message_type: type, decode, *, initial, size=None):
        reads[name] = add_reader(
            builder, add_subscriber(builder, lcm=lcm, channel=channel,
                                    message_type=message_type),
            name=f"from_{channel.lower()}", message_type=message_type, decode=decode,
            initial=initial, size=size)

    def command(name: str, channel: str, message_type: type, encode, *, size=None,
                model=None):
        commands[name] = add_publisher(builder, lcm=lcm, channel=channel,
                                       message_type=message_type, encode=encode,
                                       period=period, size=size, model=model)

    # The robot's positions; no velocities come, and the controllers read none.
    at_start = np.concatenate([robot.positions(*start), np.zeros(n)])
    read("robot_state", ch.ROBOT_STATE, s3o_lcm.robot_state_t,
         lambda m: (np.concatenate([ch.positions_of(m, joints=joints), np.zeros(n)])
                    if m.num_joints else None),
         initial=at_start, size=2 * n)
    read("target_sighting", ch.TARGET_SIGHTING, s3o_lcm.target_sighting_t,
         lambda m: ch.sighting_of(m) if m.utime or m.id else None, initial=TargetSighting())
    read("gripper_status", ch.GRIPPER_STATUS, s3o_lcm.gripper_status_t, ch.gripper_of,
         initial=GripperStatus())
    read("base_bumper", ch.PROTECTIVE_STOP, s3o_lcm.protective_stop_t, ch.bumper_of,
         initial=np.array([0.0, np.nan, np.nan]), size=3)
    # Drake's LcmImageArrayToImages gave a depth image with zeros and other labels than
    # were sent: the images are read here, by their frame names.
    images = add_subscriber(builder, lcm=lcm, channel=ch.OVERHEAD_IMAGES,
                            message_type=lcmt_image_array)
    for frame, image_type, dtype, channels in zip(
            ch.IMAGE_FRAMES, (ImageRgba8U, ImageDepth32F, ImageLabel16I),
            (np.uint8, np.float32, np.int16), (4, 1, 1), strict=True):
        reads[f"{frame}_image"] = add_reader(
            builder, images, name=f"from_{frame}", message_type=lcmt_image_array,
            decode=partial(_image, frame=frame, image_type=image_type, dtype=dtype,
                           channels=channels),
            initial=image_type())

    command("robot_desired_state", ch.ROBOT_COMMAND, s3o_lcm.robot_command_t,
            lambda x, t: ch.command_message(x, joints=joints, t=t), size=2 * n)
    command("grip", ch.GRIP, s3o_lcm.grip_t, lambda g, t: ch.grip_message(g, t=t),
            model=GripEvent())
    command("target_request", ch.TARGET_REQUEST, s3o_lcm.target_request_t,
            lambda r, t: ch.request_message(r, t=t), model=TargetRequest())
    return ControllerPorts(reads=reads, commands=commands)


def _image(message, *, frame: str, image_type: type, dtype: type, channels: int):
    """The image of `frame` in `message` as a Drake image of `image_type`; None before any
    came."""
    pixels = ch.image_of(message, frame, dtype=dtype, channels=channels)
    if pixels is None:
        return None
    height, width = pixels.shape[:2]
    image = image_type(width, height)
    image.mutable_data[:] = pixels
    return image
