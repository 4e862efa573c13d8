"""The simulated robot alone on an LCM bus, for controllers elsewhere.

    s3o sim SCENARIO [--lcm URL] [--realtime-rate R] [--time-limit S] [--seed N] [--set F=V]

The robot and the room, as a robot's controllers meet them: the plant with the true chairs
and the dishes, the overhead camera, the grasp's rules and the base's protective stop. It
publishes what a robot and its sensors publish and obeys the commands a robot obeys, on the
channels docs/hardware.md names; it holds where it stands until commands come, and when they
stop for 0.5 s. With --set uncertainty.localization=reported it localises on its own side
(odometry and a planar scan matched to its map) and publishes its pose as it estimates it.
Ctrl-C (or `kill`) ends it; it then says what is on its tray.
The bus stays on this machine unless --lcm says otherwise.
Exit status: 0, 2 on bad input, 130 when interrupted.
"""

import argparse
import signal
import sys
from typing import TYPE_CHECKING

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, fail, read_scenario
from s3o_drake.commands.options import (
    add_overrides,
    add_seed,
    realtime_rate,
    seconds,
    with_overrides_or_fail,
)
from s3o_drake.world.robot_channels import LOCAL_BUS

if TYPE_CHECKING:
    from s3o_drake.world.scenario import Scenario

SIGNAL_STEP = 0.1
"""How often (s of the robot's clock) the robot looks whether it was told to end."""


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("sim", __doc__)
    parser.add_argument("scenario", help="the scenario file (the room, the task, the robot)")
    parser.add_argument("--lcm", default=LOCAL_BUS, metavar="URL",
                        help=f"the LCM bus (default {LOCAL_BUS}: this machine only)")
    parser.add_argument("--realtime-rate", type=realtime_rate, default=1.0, metavar="R",
                        help="simulated seconds per second (default 1, as hardware; 0: as "
                             "fast as it can)")
    parser.add_argument("--time-limit", type=seconds, default=1800.0, metavar="S",
                        help="simulated seconds after which it ends (default 1800)")
    add_seed(parser, None, "the noise's seed")
    add_overrides(parser, "replace a field of the scenario, e.g. uncertainty.reach_std=0")
    args = parser.parse_args(argv)
    if not args.lcm.startswith("udpm://"):
        fail(f"--lcm: expected a udpm:// URL, got {args.lcm!r} (memq:// stays inside one "
             "process; the controllers run in another)")
    scenario = with_overrides_or_fail(read_scenario(args.scenario), args.overrides)
    # Ctrl-C and `kill` end it alike, even where it was started with SIGINT ignored (as a
    # shell's background jobs are): the robot then says what is on its tray. The signal is
    # noted, from before the robot is built, and looked at between steps: raised as
    # KeyboardInterrupt, it could land inside a Python callback that Drake calls (a
    # message's decoding, a system's output) and be lost there, and the robot run on.
    signals: list[int] = []

    def note(signum: int, _frame: object) -> None:
        signals.append(signum)

    signal.signal(signal.SIGINT, note)
    previous = signal.signal(signal.SIGTERM, note)
    try:
        return _run(args, scenario, signals)
    finally:
        signal.signal(signal.SIGTERM, previous)


def _run(args: argparse.Namespace, scenario: "Scenario", signals: list[int]) -> int:
    """Builds the robot, runs it until a signal is noted in `signals` or the time limit,
    and says what is on its tray."""
    from pydrake.lcm import DrakeLcm
    from pydrake.systems.analysis import Simulator

    from s3o_drake.world.dish_messages import DishState
    from s3o_drake.world.robot_channels import ROBOT_COMMAND, ROBOT_STATE
    from s3o_drake.world.robot_lcm import build_robot_diagram, render_once

    try:
        lcm = DrakeLcm(args.lcm)
    except RuntimeError as e:
        fail(f"--lcm: {e}")
    diagram = build_robot_diagram(scenario, lcm=lcm, seed=args.seed)
    simulator = Simulator(diagram)
    simulator.set_target_realtime_rate(args.realtime_rate)
    render_once(diagram, simulator.get_context())
    simulator.Initialize()
    print(f"the robot is on {args.lcm}: publishing {ROBOT_STATE} and its sensors, obeying "
          f"{ROBOT_COMMAND}; Ctrl-C ends it", file=sys.stderr, flush=True)
    context = simulator.get_context()
    while not signals and context.get_time() < args.time_limit:
        simulator.AdvanceTo(min(context.get_time() + SIGNAL_STEP, args.time_limit))
    code = 130 if signals else 0
    # A second Ctrl-C must not cut short what the robot says it holds.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    world = diagram.GetSubsystemByName("world")
    states = world.GetOutputPort("dish_states").Eval(world.GetMyContextFromRoot(context))
    tray = states.named(DishState.TRAY)
    print(f"ended at {context.get_time():.2f} s: on the tray {', '.join(tray) or 'nothing'}",
          flush=True)
    return code


if __name__ == "__main__":
    sys.exit(main())
