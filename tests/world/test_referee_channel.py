"""The referee's channel: the simulation's truth about the dishes and the robot's
clearance, as a message and back; and the system that makes one value of it."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw

from s3o_drake.world.dish_messages import DishPoses, DishState, DishStates
from s3o_drake.world.lcmtypes.s3o_lcm import referee_t
from s3o_drake.world.referee_channel import referee_message, referee_of
from s3o_drake.world.robot_lcm import RefereeViewer


def _wire(message):
    return referee_t.decode(message.encode())


def test_states_poses_and_clearance_come_back_as_they_were_sent():
    states = DishStates({"cup": DishState.TRAY, "plate": DishState.TABLE})
    poses = DishPoses({"cup": RigidTransform(RollPitchYaw(0.1, -0.2, 1.3), [1.0, 2.0, 0.8]),
                       "plate": RigidTransform([3.0, 1.0, 0.75])})
    view = referee_of(_wire(referee_message(states, poses, 0.0123, t=4.5)))
    assert dict(view.dish_states) == dict(states)
    for name in states:
        np.testing.assert_allclose(view.dish_poses[name].GetAsMatrix4(),
                                   poses[name].GetAsMatrix4(), atol=1e-12)
    assert view.closest_approach == 0.0123


def test_nothing_before_the_first_message_and_a_bad_state_names_the_field():
    assert referee_of(referee_t()) is None
    message = referee_message(DishStates({"cup": DishState.TRAY}),
                              DishPoses({"cup": RigidTransform()}), 0.1, t=1.0)
    message.state = ["flying"]
    with pytest.raises(ValueError, match=r"state: cup: .*'flying'"):
        referee_of(_wire(message))


def test_the_viewer_makes_one_value_of_the_three_truths():
    viewer = RefereeViewer()
    context = viewer.CreateDefaultContext()
    states = DishStates({"cup": DishState.GRIPPER})
    poses = DishPoses({"cup": RigidTransform([1.0, 1.0, 1.0])})
    viewer.GetInputPort("dish_states").FixValue(context, states)
    viewer.GetInputPort("dish_poses").FixValue(context, poses)
    viewer.GetInputPort("closest_approach").FixValue(context, [0.02])
    view = viewer.get_output_port().Eval(context)
    assert dict(view.dish_states) == dict(states)
    assert view.dish_poses["cup"].IsExactlyEqualTo(poses["cup"])
    assert view.closest_approach == 0.02
