"""A scenario's or a description's error raised in a worker process crosses back to the
caller whole: the pool pickles it. One that could not be unpickled stopped the pool's
result thread, and the map waited for good."""

import pickle

from s3o_drake.world.robot_description import RobotDescriptionError
from s3o_drake.world.scenario_checks import ScenarioError


def test_errors_cross_processes_whole():
    for error in (ScenarioError("robot.name", "no robot named 'x'", "task.yaml"),
                  RobotDescriptionError("tool.grasp_offset", "must be positive")):
        again = pickle.loads(pickle.dumps(error))
        assert type(again) is type(error) and str(again) == str(error)
        assert (again.path, again.message) == (error.path, error.message)
