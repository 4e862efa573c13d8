"""How closely each robot's arm follows a planned pickup in simulation.

    s3o bench tracking [--robot NAME ...]

For each robot (default: every robot in models/, those still being built too), plans a
pickup of scenarios/small/two_dishes.yaml's plate from a stop the feasibility check accepts,
plays the plan as the world's desired state and prints the arm joints' largest error and
the grasp point's, over the pickup and where the fingers close. A robot's gains
(robot.yaml's `actuators`) are adequate when it follows as closely as the shipped ones.
"""

from __future__ import annotations

import logging

# Light imports only: --help and bad arguments answer before Drake loads.
from s3o_drake.commands.common import command_parser
from s3o_drake.commands.options import robot_name


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench tracking", __doc__)
    parser.add_argument("--robot", type=robot_name, nargs="+", metavar="NAME",
                        help="the robots (default every robot in models/)")
    args = parser.parse_args(argv)
    from s3o_drake.experiments.tracking import pickup_tracking
    from s3o_drake.world.resources import SCENARIOS_DIR
    from s3o_drake.world.robot_description import described_robots
    from s3o_drake.world.scenario import load_scenario, with_overrides

    logging.getLogger("drake").setLevel(logging.WARNING)
    scene = load_scenario(SCENARIOS_DIR / "small" / "two_dishes.yaml")
    print("| robot | pickup (s) | arm joints: max error (rad) | grasp point: max error (mm) "
          "| where the fingers close (mm) |")
    print("|---|---|---|---|---|")
    for name in args.robot or described_robots():
        result = pickup_tracking(with_overrides(scene, (f"robot.name={name}",)))
        print(f"| {name} | {result.duration:.1f} | {result.joint_error:.4f} | "
              f"{result.grasp_error * 1000:.1f} | {result.error_at_grasp * 1000:.2f} |",
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
