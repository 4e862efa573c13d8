"""Build the arm's inverse reachability map with Drake IK.

    s3o build reachability [--robot NAME] [--out out/reachability_map.npz] [--workers 2]

The inverse reachability map stores, per grasp kind, arm configurations on a grid over the
grasp point's horizontal distance and height from the arm base; the feasibility check
looks them up in microseconds. The build is deterministic (the same file, whatever
--workers), about 6 minutes on two cores; the shipped map, models/NAME/reachability_map.npz,
is replaced only when --out names it.
"""

import argparse
import math
import sys
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, fail
from s3o_drake.commands.options import add_out, add_quiet, add_robot, add_workers, out_file
from s3o_drake.world.files import write_atomically

DEFAULT_OUT = Path("out") / "reachability_map.npz"
"""Where the map goes unless --out says otherwise: not over the shipped one."""


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"expected a positive number of metres, got {text!r}")
    return value


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("build reachability", __doc__)
    add_robot(parser, "the robot whose arm is mapped")
    add_out(parser, file=True, default=str(DEFAULT_OUT),
            note="the shipped map is replaced only when told: --out "
                 "models/NAME/reachability_map.npz")
    add_workers(parser, 2)
    parser.add_argument("--resolution", type=_positive, metavar="M",
                        help="grid step in metres (default: the shipped map's)")
    add_quiet(parser)
    if argv is None:
        argv = sys.argv[1:]
    # Its first address had a subcommand: `python -m s3o_drake.commands.build_reachability
    # build ...`, in the project's records; it is still understood.
    if argv[:1] == ["build"]:
        argv = argv[1:]
    args = parser.parse_args(argv)
    from s3o_drake.feasibility.reachability.build import RESOLUTION, build_map
    from s3o_drake.world.robot import load_robot

    if args.resolution is None:
        args.resolution = RESOLUTION
    if not 0.002 <= args.resolution <= 0.1:
        fail(f"--resolution: must be between 0.002 and 0.1 m, got {args.resolution}")
    out = out_file(args.out)
    reach_map = build_map(robot=load_robot(args.robot), resolution=args.resolution,
                          workers=args.workers, progress=not args.quiet)
    data = reach_map.to_bytes()
    out.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(out, data)
    s = reach_map.settings
    print(f"wrote {out} ({len(data) / 1e6:.2f} MB): nodes {s['nodes']}, configurations "
          f"{s['configurations']}, {s['build_seconds']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
