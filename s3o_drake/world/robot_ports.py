"""The robot's state and desired state as ports of a diagram, in `Robot.joints` order,
whatever the robot's model instances.

A robot of one model instance has them as the plant's ports of that instance, and they are
used as they are (no system in between: a diagram of such a robot is what it always was).
A robot of parts (several instances, and mimic joints that only follow) gets them through
`MatrixGain` systems built from `RobotInstances.state_selector` and
`desired_state_selectors`.
"""

from pydrake.systems.framework import DiagramBuilder, OutputPort
from pydrake.systems.primitives import MatrixGain

from s3o_drake.world.robot import RobotInstances

STATE_SELECTOR = "robot_state_selector"
"""The MatrixGain of a robot of parts: the plant's state to the robot's [q; v]."""
DESIRED_STATE_SELECTOR = "robot_desired_state_to_{instance}"
"""... and the robot's [q_d; v_d] to one instance's desired-state input."""


def robot_state_output(builder: DiagramBuilder, robot: RobotInstances) -> OutputPort:
    """The output port of the robot's state [q; v] (`Robot.joints` order) in `builder`:
    the plant's port of a single-instance robot, else the output of one MatrixGain on the
    plant's state (added on first use, shared after)."""
    plant = robot.plant
    if robot.is_single:
        return plant.get_state_output_port(robot.instances[0])
    if builder.HasSubsystemNamed(STATE_SELECTOR):
        return builder.GetSubsystemByName(STATE_SELECTOR).get_output_port()
    gain = builder.AddNamedSystem(STATE_SELECTOR, MatrixGain(robot.state_selector()))
    builder.Connect(plant.get_state_output_port(), gain.get_input_port())
    return gain.get_output_port()


def connect_robot_desired_state(builder: DiagramBuilder, robot: RobotInstances,
                                source: OutputPort) -> None:
    """Connects `source`, the robot's desired state [q_d; v_d] (`Robot.joints` order), to
    the plant in `builder`: to the plant's input of a single-instance robot, else to one
    MatrixGain per instance with actuators, each feeding that instance's desired-state
    input."""
    plant = robot.plant
    if robot.is_single:
        builder.Connect(source, plant.get_desired_state_input_port(robot.instances[0]))
        return
    for instance, selector in robot.desired_state_selectors().items():
        gain = builder.AddNamedSystem(
            DESIRED_STATE_SELECTOR.format(instance=plant.GetModelInstanceName(instance)),
            MatrixGain(selector))
        builder.Connect(gain.get_output_port(), plant.get_desired_state_input_port(instance))
        builder.Connect(source, gain.get_input_port())
