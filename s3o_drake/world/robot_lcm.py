"""The simulated robot on an LCM bus: the world's diagram, publishing what a robot and its
sensors publish and obeying the commands a robot obeys, on the channels of
`robot_channels`.

`add_robot_lcm` wires a world diagram (`builder.build_world_diagram`, with its dishes
tracked) to Drake's LCM systems: publishers of the robot's joint state, the gripper's report,
the sensor's sightings, the protective stop's report (every control period) and the overhead
camera's images (every IMAGE_PERIOD); subscribers of the desired state, the grip and the
sighting requests. A `CommandWatchdog` holds the robot where it stands until the first
command, and whenever no new command came for COMMAND_TIMEOUT of the robot's time, as a
robot's driver stops a robot whose controller went quiet.

`add_referee_publisher` adds what no robot publishes: the simulation's truth about the
dishes and the robot's clearance, on the referee's channel (`referee_channel`), so that a
run whose controllers are in another process is judged as a run in one process is.
"""

import numpy as np
from drake import lcmt_image_array
from pydrake.common.value import AbstractValue
from pydrake.lcm import DrakeLcm
from pydrake.systems.framework import (
    BasicVector,
    Context,
    Diagram,
    DiagramBuilder,
    DiscreteValues,
    EventStatus,
    LeafSystem,
)
from pydrake.systems.lcm import LcmInterfaceSystem, LcmPublisherSystem
from pydrake.systems.primitives import MatrixGain
from pydrake.systems.sensors import ImageToLcmImageArrayT

from s3o_drake.world import robot_channels as ch
from s3o_drake.world.builder import build_world_diagram
from s3o_drake.world.clearance_monitor import REACH, add_clearance_monitor
from s3o_drake.world.dish_messages import DishPoses, DishStates
from s3o_drake.world.lcmtypes import s3o_lcm
from s3o_drake.world.message_systems import add_publisher, add_reader, add_subscriber
from s3o_drake.world.referee_channel import REFEREE, RefereeView, referee_message
from s3o_drake.world.robot import CONTROL_PERIOD, Robot
from s3o_drake.world.robot_messages import GripEvent, GripperStatus, TargetRequest, TargetSighting
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.system_lifetime import weak_callback

COMMAND_TIMEOUT = 0.5
"""How long (s of the robot's time) the robot goes on without a command before it holds."""
COMMAND_FRESH = 2 * CONTROL_PERIOD
"""How long (s) a command's velocities are followed: after that, until COMMAND_TIMEOUT, the
robot goes to the command's positions and stops there, which the controllers checked, and
does not run on along a motion that its controllers stopped following."""


class CommandWatchdog(LeafSystem):
    """The robot's desired state: the last command's while commands come, else where it
    stands.

    A command counts for `timeout` s of the robot's time after it arrived, as a robot's
    driver judges it: by when a new one came, not by the controllers' clock, which need not
    be the robot's (its stamp only tells one command from the next). Its velocities count
    for `fresh` s only: a late command's positions are held, with zero velocities.

    Input ports:
        desired_state: vector (2 num_positions), the last command's desired state.
        command_stamp: vector 1, that command's own stamp (s; negative: no command yet).
        true_state: vector (2 num_positions), the robot's state.
    Output ports:
        desired_state: vector (2 num_positions): the command's; its positions with zero
            velocities once it is older than `fresh` s; before the first command and once
            none came for `timeout` s, the robot's positions with zero velocities (it
            holds where it stands).

    State: the latest stamp seen and the robot's time it came (s), updated every `period`.
    """

    def __init__(self, *, num_positions: int, timeout: float = COMMAND_TIMEOUT,
                 fresh: float = COMMAND_FRESH, period: float = CONTROL_PERIOD) -> None:
        super().__init__()
        if not 0 < fresh <= timeout:
            raise ValueError(f"fresh, timeout: expected 0 < fresh <= timeout, got {fresh}, "
                             f"{timeout}")
        self._n, self._timeout, self._fresh = num_positions, timeout, fresh
        self._desired = self.DeclareVectorInputPort("desired_state", 2 * num_positions)
        self._stamp = self.DeclareVectorInputPort("command_stamp", 1)
        self._true = self.DeclareVectorInputPort("true_state", 2 * num_positions)
        self._seen = self.DeclareDiscreteState([-1.0, -np.inf])
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, weak_callback(self._hear))
        self.DeclareForcedDiscreteUpdateEvent(weak_callback(self._hear))
        self.DeclareVectorOutputPort("desired_state", 2 * num_positions,
                                     weak_callback(self._calc_desired_state))

    def _hear(self, context: Context, state: DiscreteValues) -> EventStatus:
        stamp = float(self._stamp.Eval(context)[0])
        seen = context.get_discrete_state(self._seen).get_value()
        if stamp >= 0.0 and stamp != seen[0]:
            state.get_mutable_vector(self._seen).SetFromVector([stamp, context.get_time()])
            return EventStatus.Succeeded()
        return EventStatus.DidNothing()

    def _age(self, context: Context) -> float:
        """How long ago (s) the latest command came (inf: none came)."""
        return context.get_time() - float(context.get_discrete_state(self._seen).GetAtIndex(1))

    def commanded(self, context: Context) -> bool:
        """Whether a command came within the timeout."""
        return self._age(context) <= self._timeout

    def _calc_desired_state(self, context: Context, output: BasicVector) -> None:
        age = self._age(context)
        if age <= self._fresh:
            output.SetFromVector(self._desired.Eval(context))
            return
        if age <= self._timeout:
            late = np.array(self._desired.Eval(context), dtype=float)
            late[self._n:] = 0.0
            output.SetFromVector(late)
            return
        held = np.array(self._true.Eval(context), dtype=float)
        held[self._n:] = 0.0
        output.SetFromVector(held)


class RefereeViewer(LeafSystem):
    """The referee's view, one value of the simulation's three truths.

    Input ports:
        dish_states: abstract DishStates.
        dish_poses: abstract DishPoses.
        closest_approach: vector 1 (m).
    Output ports:
        view: abstract RefereeView.
    """

    def __init__(self) -> None:
        super().__init__()
        self._states = self.DeclareAbstractInputPort("dish_states",
                                                     AbstractValue.Make(DishStates()))
        self._poses = self.DeclareAbstractInputPort("dish_poses", AbstractValue.Make(DishPoses()))
        self._closest = self.DeclareVectorInputPort("closest_approach", 1)
        self.DeclareAbstractOutputPort(
            "view", lambda: AbstractValue.Make(RefereeView(DishStates(), DishPoses(), REACH)),
            weak_callback(self._calc_view))

    def _calc_view(self, context: Context, output: AbstractValue) -> None:
        output.set_value(RefereeView(self._states.Eval(context), self._poses.Eval(context),
                                     float(self._closest.Eval(context)[0])))


def add_referee_publisher(builder: DiagramBuilder, world: Diagram, *, robot: Robot,
                          furniture: list[str], lcm: LcmInterfaceSystem,
                          period: float = CONTROL_PERIOD) -> None:
    """Publishes on REFEREE (`referee_channel`) what the simulation knows of the dishes and
    of the robot's clearance to `furniture` and the walls, every `period`: for the report of
    a run whose controllers are elsewhere; no robot publishes it."""
    viewer = builder.AddNamedSystem("referee_view", RefereeViewer())
    builder.Connect(world.GetOutputPort("dish_states"), viewer.GetInputPort("dish_states"))
    builder.Connect(world.GetOutputPort("dish_poses"), viewer.GetInputPort("dish_poses"))
    builder.Connect(add_clearance_monitor(builder, world, robot=robot, furniture=furniture,
                                          period=period),
                    viewer.GetInputPort("closest_approach"))
    builder.Connect(viewer.get_output_port(), add_publisher(
        builder, lcm=lcm, channel=REFEREE, message_type=s3o_lcm.referee_t,
        encode=lambda view, t: referee_message(*view, t=t), period=period,
        model=RefereeView(DishStates(), DishPoses(), REACH)))


def add_robot_lcm(builder: DiagramBuilder, world: Diagram, *, robot: Robot,
                  lcm: LcmInterfaceSystem, period: float = CONTROL_PERIOD) -> None:
    """Wires `world` (in `builder`, with tracked dishes) to `lcm` (module docstring)."""
    joints = tuple(robot.joints)
    n = robot.num_positions

    def publish(port, channel: str, message_type: type, encode, *, size=None,
                model=None) -> None:
        builder.Connect(port, add_publisher(
            builder, lcm=lcm, channel=channel, message_type=message_type, encode=encode,
            period=period, size=size, model=model))

    commands = add_subscriber(builder, lcm=lcm, channel=ch.ROBOT_COMMAND,
                              message_type=s3o_lcm.robot_command_t)

    def subscribe(channel: str, message_type: type, decode, *, initial, size=None,
                  reading: str = ""):
        message = (commands if channel == ch.ROBOT_COMMAND else add_subscriber(
            builder, lcm=lcm, channel=channel, message_type=message_type))
        return add_reader(builder, message, name=f"from_{channel.lower()}{reading}",
                          message_type=message_type, decode=decode, initial=initial,
                          size=size)

    # The joint state: positions only (the controllers read no velocities).
    positions = builder.AddNamedSystem("robot_positions", MatrixGain(np.eye(n, 2 * n)))
    builder.Connect(world.GetOutputPort("robot_state"), positions.get_input_port())
    publish(positions.get_output_port(), ch.ROBOT_STATE, s3o_lcm.robot_state_t,
            lambda q, t: ch.robot_state_message(q, joints=joints, t=t), size=n)
    publish(world.GetOutputPort("gripper_status"), ch.GRIPPER_STATUS, s3o_lcm.gripper_status_t,
            lambda s, t: ch.gripper_message(s, t=t), model=GripperStatus())
    publish(world.GetOutputPort("target_sighting"), ch.TARGET_SIGHTING, s3o_lcm.target_sighting_t,
            lambda s, t: ch.sighting_message(s, t=t), model=TargetSighting())
    publish(world.GetOutputPort("base_bumper"), ch.PROTECTIVE_STOP, s3o_lcm.protective_stop_t,
            lambda b, t: ch.stop_message(b, t=t), size=3)
    images = builder.AddNamedSystem("overhead_images_to_lcm",
                                    ImageToLcmImageArrayT(*ch.IMAGE_FRAMES))
    for frame in ch.IMAGE_FRAMES:
        builder.Connect(world.GetOutputPort(f"{frame}_image"), images.GetInputPort(frame))
    image_publisher = builder.AddNamedSystem("publish_overhead_images", LcmPublisherSystem.Make(
        channel=ch.OVERHEAD_IMAGES, lcm_type=lcmt_image_array, lcm=lcm,
        publish_period=ch.IMAGE_PERIOD, use_cpp_serializer=True))
    builder.Connect(images.image_array_t_msg_output_port(), image_publisher.get_input_port())

    desired = subscribe(ch.ROBOT_COMMAND, s3o_lcm.robot_command_t,
                        lambda m: ch.desired_of(m, joints=joints) if m.num_positions else None,
                        initial=np.zeros(2 * n), size=2 * n)
    stamp = subscribe(ch.ROBOT_COMMAND, s3o_lcm.robot_command_t,
                      lambda m: [ch.seconds(m.utime)] if m.num_positions else None,
                      initial=[-1.0], size=1, reading="_stamp")
    watchdog = builder.AddNamedSystem("command_watchdog", CommandWatchdog(num_positions=n))
    builder.Connect(desired, watchdog.GetInputPort("desired_state"))
    builder.Connect(stamp, watchdog.GetInputPort("command_stamp"))
    builder.Connect(world.GetOutputPort("robot_state"), watchdog.GetInputPort("true_state"))
    builder.Connect(watchdog.get_output_port(), world.GetInputPort("robot_desired_state"))
    builder.Connect(subscribe(ch.GRIP, s3o_lcm.grip_t, ch.grip_of, initial=GripEvent()),
                    world.GetInputPort("grip"))
    builder.Connect(subscribe(ch.TARGET_REQUEST, s3o_lcm.target_request_t, ch.request_of,
                              initial=TargetRequest()),
                    world.GetInputPort("target_request"))



def render_once(diagram: Diagram, context: Context) -> None:
    """Renders the overhead camera's images of `diagram` (`build_robot_diagram`) once, in
    its root `context`. Before the simulator's initialisation: it publishes the robot's
    first state and then renders, and a renderer's first frame (its GL context, the
    meshes) can take longer than the controllers wait between two states."""
    world = diagram.GetSubsystemByName("world")
    world_context = world.GetMyContextFromRoot(context)
    for frame in ch.IMAGE_FRAMES:
        world.GetOutputPort(f"{frame}_image").Eval(world_context)


def build_robot_diagram(scenario: Scenario, *, lcm: DrakeLcm, seed: int | None = None,
                        noise: bool = True) -> Diagram:
    """The simulated robot alone, on `lcm`: the world's diagram (the true chairs, the
    dishes tracked, the overhead camera; the scenario's noise unless `noise` is off, drawn
    from `seed`, default the scenario's) wired by `add_robot_lcm`, and the referee's
    channel (`add_referee_publisher`). Named "s3o_robot"."""
    builder = DiagramBuilder()
    interface = builder.AddNamedSystem("lcm", LcmInterfaceSystem(lcm))
    world = builder.AddNamedSystem("world", build_world_diagram(
        scenario, track_dishes=True, seed=seed, noise=noise, show_collisions=False))
    add_robot_lcm(builder, world, robot=scenario.robot_value, lcm=interface)
    add_referee_publisher(builder, world, robot=scenario.robot_value, lcm=interface,
                          furniture=[f.name for f in (*scenario.tables, *scenario.chairs)])
    diagram = builder.Build()
    diagram.set_name("s3o_robot")
    return diagram
