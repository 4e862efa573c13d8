"""The messages between the robot and its controllers: every port value comes back from its
message as it was, a message of another robot is refused by name, and the generated Python
of the project's own types is what lcm-gen makes of their definitions."""

import filecmp
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from s3o_drake.world import robot_channels as ch
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

JOINTS = ("x", "y", "yaw", "shoulder", "elbow")
LCMTYPES = Path(ch.__file__).parent / "lcmtypes"


def _wire(message, message_type):
    """The message as the other side decodes it."""
    return message_type.decode(message.encode())


def test_the_state_and_the_command_come_back_as_they_went():
    q = np.array([1.0, 2.0, 0.5, -1.2, 0.3])
    state = _wire(ch.robot_state_message(q, joints=JOINTS, t=1.23), robot_state_t)
    assert state.utime == 1_230_000 and ch.seconds(state.utime) == pytest.approx(1.23)
    np.testing.assert_array_equal(ch.positions_of(state, joints=JOINTS), q)
    desired = np.concatenate([q, q / 10])
    command = _wire(ch.command_message(desired, joints=JOINTS, t=2.0), robot_command_t)
    np.testing.assert_array_equal(ch.desired_of(command, joints=JOINTS), desired)


def test_a_message_of_other_joints_is_refused_by_name():
    state = ch.robot_state_message([0.0, 0.0, 0.0], joints=("x", "y", "theta"), t=0.0)
    with pytest.raises(ValueError, match="joint_name"):
        ch.positions_of(state, joints=("x", "y", "yaw"))
    command = ch.command_message(np.zeros(6), joints=("x", "y", "theta"), t=0.0)
    with pytest.raises(ValueError, match="position_name"):
        ch.desired_of(command, joints=("x", "y", "yaw"))
    with pytest.raises(ValueError, match="desired"):
        ch.command_message(np.zeros(5), joints=("x", "y", "yaw"), t=0.0)


def test_the_robot_messages_come_back_as_they_went():
    grip = GripEvent("plate_a", ("cup_b",), ("apple",))
    assert ch.grip_of(_wire(ch.grip_message(grip, t=0.5), grip_t)) == grip
    request = TargetRequest(7, "plate_a")
    assert ch.request_of(_wire(ch.request_message(request, t=0.5), target_request_t)) == request
    for sighting in (TargetSighting(7, "plate_a", (1.5, 2.25)), TargetSighting(8, "teapot")):
        assert ch.sighting_of(_wire(ch.sighting_message(sighting, t=0.5),
                                    target_sighting_t)) == sighting
    for status in (GripperStatus(True), GripperStatus(False)):
        assert ch.gripper_of(_wire(ch.gripper_message(status, t=0.5),
                                   gripper_status_t)) == status
    stopped = ch.bumper_of(_wire(ch.stop_message([1.0, 1.6, 1.05], t=0.5), protective_stop_t))
    np.testing.assert_array_equal(stopped, [1.0, 1.6, 1.05])
    free = ch.bumper_of(_wire(ch.stop_message([0.0, np.nan, np.nan], t=0.5),
                              protective_stop_t))
    assert free[0] == 0.0 and np.isnan(free[1:]).all()


def test_the_generated_types_are_lcm_gen_s_of_their_definitions(tmp_path):
    lcm_gen = shutil.which("lcm-gen")
    if lcm_gen is None:
        pytest.skip("lcm-gen (pip install lcm) is not installed")
    subprocess.run([lcm_gen, "-p", "--ppath", str(tmp_path), str(LCMTYPES / "s3o_lcm.lcm")],
                   check=True)
    made = sorted(p.name for p in (tmp_path / "s3o_lcm").glob("*.py"))
    shipped = sorted(p.name for p in (LCMTYPES / "s3o_lcm").glob("*.py"))
    assert made == shipped
    _, mismatch, errors = filecmp.cmpfiles(tmp_path / "s3o_lcm", LCMTYPES / "s3o_lcm", made,
                                           shallow=False)
    assert mismatch == [] and errors == []
