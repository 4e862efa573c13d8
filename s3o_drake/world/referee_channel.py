"""The referee's channel: the simulation's truth about the dishes and the robot's clearance,
for whoever keeps the score of a run whose controllers are in another process.

No robot publishes this, and no controller reads it: a run's report judges what the robot
did by where the dishes really are (`execution.task_monitor`), and across a process
boundary that truth comes from the simulation on REFEREE. On hardware there is none; the
report then has only what the controllers know.

The functions here are plain Python: the TaskMonitor's inputs to a message and back.
"""

import math
from typing import NamedTuple

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform

from s3o_drake.world.dish_messages import DishPoses, DishState, DishStates
from s3o_drake.world.lcmtypes.s3o_lcm import referee_t
from s3o_drake.world.robot_channels import utime

#: simulation -> the scorekeeper, every control period: s3o_lcm.referee_t.
REFEREE = "S3O_REFEREE"


class RefereeView(NamedTuple):
    """What the referee sees: each dish's state and pose, and the closest approach (m)."""

    dish_states: DishStates
    dish_poses: DishPoses
    closest_approach: float


def referee_message(states: DishStates, poses: DishPoses, closest_approach: float, *,
                    t: float) -> referee_t:
    """The dishes' states and poses and the closest approach so far, at time `t`."""
    message = referee_t()
    message.utime = utime(t)
    message.num_dishes = len(states)
    message.dish = list(states)
    message.state = [str(states[d]) for d in states]
    pose = []
    for d in states:
        X_WD = poses[d]
        q = X_WD.rotation().ToQuaternion()
        pose.append([*map(float, X_WD.translation()), q.w(), q.x(), q.y(), q.z()])
    message.pose = pose
    message.closest_approach = float(closest_approach)
    return message


def referee_of(message: referee_t) -> RefereeView | None:
    """The view the message gives; None before the first message came. ValueError, naming
    the field, for a state that is none of DishState's."""
    if not message.utime and not message.num_dishes:
        return None
    states, poses = {}, {}
    for name, state, pose in zip(message.dish, message.state, message.pose, strict=True):
        try:
            states[name] = DishState(state)
        except ValueError:
            raise ValueError(f"state: {name}: expected one of "
                             f"{', '.join(s.value for s in DishState)}, got {state!r}") from None
        w, x, y, z = pose[3:]
        poses[name] = RigidTransform(Quaternion(np.array([w, x, y, z]) / math.hypot(w, x, y, z)),
                                     np.asarray(pose[:3], dtype=float))
    return RefereeView(DishStates(states), DishPoses(poses), float(message.closest_approach))
