"""The arm's inverse reachability map: stored grasp configurations, looked up in microseconds.

A grasp's frame depends only on its kind ("top", "side"), the bearing from the arm base A to
the dish and a wrist turn about the approach axis (see `grasps`). Turning the shoulder-pan
joint by Δ turns the whole arm about A's z axis, and turning wrist 3 turns the gripper about
the approach axis, so one arm configuration that grasps at bearing 0 with wrist turn 0 serves
every bearing and turn. The map therefore stores, for each kind, configurations on a grid
over the grasp point's horizontal distance ρ from A and its height h above A.

Built once with Drake IK on a plant that holds the robot alone: at each grid node the
closed-form solutions of the UR5e (all eight shoulder/wrist/elbow branches) seed
`InverseKinematics` with the grasp-frame constraints and a self-collision clearance of 1 cm
(SNOPT, capped iterations), and each verified solution is kept in its branch's slot (at most
K = 8 per node). The environment is left to query time, where the configurations are moved to
the query's bearing and checked against the scene with the collision checker
(`s3o_drake.feasibility.check`).

A query between nodes takes each branch from the grid cell's corners (bilinear interpolation
of the joint angles), verifies it by forward kinematics and, where it is not yet within
tolerance, moves it onto the target with a few Newton steps; so the answer does not depend on
the grid's resolution, and a target beyond the arm's reach has no candidates.

    python -m s3o_drake.commands.build_reachability build [--out out/reachability_map.npz]
                                                       [--workers 2] [--resolution 0.01]

builds the map deterministically with worker processes (a few minutes on two cores) and writes
it atomically, with its settings, as a compressed .npz; `ReachabilityMap.load()` reads the
shipped one, models/reachability_map.npz, which only `--out models/reachability_map.npz`
replaces.
"""

import math
import sys
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail
from s3o_drake.world.files import write_atomically
from s3o_drake.world.resources import REACHABILITY_MAP, REPO_DIR

DEFAULT_OUT = Path("out") / REACHABILITY_MAP.name
"""Where the map goes unless --out says otherwise: not over the shipped one."""


def _positive(text: str) -> float:
    value = float(text)
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(text)
    return value


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.build_reachability",
                            description=__doc__, formatter_class=doc_formatter())
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                parser_class=ArgumentParser)
    build = sub.add_parser("build", help="build the map with Drake IK and write it",
                           description="Builds the reachability map with Drake IK and writes "
                                       "it atomically with its settings: deterministic "
                                       "(the same file content, build time and date aside, "
                                       "whatever --workers), about 6 minutes on two cores "
                                       "at the default resolution.")
    build.add_argument("--out", metavar="NPZ", default=str(DEFAULT_OUT),
                       help=f"output file (default {DEFAULT_OUT}; the shipped map is replaced "
                            f"only when told: --out {REACHABILITY_MAP.relative_to(REPO_DIR)})")
    build.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    build.add_argument("--resolution", type=_positive,
                       help="grid step in metres (default: the shipped map's, "
                            "reachability_build.RESOLUTION)")
    build.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    from s3o_drake.feasibility.reachability_build import RESOLUTION, build_map

    if args.resolution is None:
        args.resolution = RESOLUTION
    if args.workers < 1:
        fail(f"--workers: must be at least 1, got {args.workers}")
    if not 0.002 <= args.resolution <= 0.1:
        fail(f"--resolution: must be between 0.002 and 0.1 m, got {args.resolution}")
    out = Path(args.out)
    if out.is_dir():
        fail(f"--out: {out} is a folder")
    if any(folder.exists() and not folder.is_dir() for folder in out.parents):
        fail(f"--out: {out.parent} is not a folder")
    reach_map = build_map(resolution=args.resolution, workers=args.workers,
                          progress=not args.quiet)
    data = reach_map.to_bytes()
    out.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(out, data)
    s = reach_map.settings
    print(f"wrote {out} ({len(data) / 1e6:.2f} MB): nodes {s['nodes']}, configurations "
          f"{s['configurations']}, {s['build_seconds']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
