"""Make the FCN's training data: overhead crops with Drake-oracle labels.

    s3o build fcn-data --count 300 --seed 1000 --out out/fcn_data --workers 2

Scene i is task i of the task generator drawn with --seed (the shipped benchmark tasks use
seed 0: keep them apart). Each scene is rendered once from the overhead camera and, per
dish, the network's input crop and the oracle's heatmap are stored in scene_00000.npz, ...
A rerun skips the scenes on disk; a folder made with another seed or base is refused.
"""

import json
import sys
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, fail, read_base
from s3o_drake.commands.options import (
    add_out,
    add_quiet,
    add_robot,
    add_seed,
    add_workers,
    at_least,
    out_folder,
)
from s3o_drake.world.files import write_atomically
from s3o_drake.world.resources import DEFAULT_ROBOT, REPO_DIR, RESTAURANT


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("build fcn-data", __doc__)
    parser.add_argument("--count", type=at_least(1), required=True, metavar="N",
                        help="the first N scenes of the seed")
    add_seed(parser, 1000, "scene seed (the benchmark tasks use 0)")
    add_out(parser, file=False, required=True)
    add_workers(parser, 1)
    parser.add_argument("--base", metavar="YAML", default=str(RESTAURANT),
                        help="base scenario of the generator (default "
                             f"{RESTAURANT.relative_to(REPO_DIR)})")
    parser.add_argument("--dishes", type=at_least(1), metavar="N",
                        help="dishes per scene (default: the protocol's 5 to 7)")
    add_robot(parser, "the robot the oracle labels for", default=None,
              shown="the base scenario's")
    add_quiet(parser)
    args = parser.parse_args(argv)
    base = read_base(args.base)
    robot = args.robot or base.robot_value.name
    out = out_folder(args.out)
    from s3o_drake.feasibility.learned.dataset import MANIFEST, build_dataset

    manifest = {"seed": args.seed, "base": Path(args.base).resolve().name}
    if args.dishes is not None:  # a folder made without it stays valid
        manifest["dishes"] = args.dishes
    if robot != DEFAULT_ROBOT:  # the same: folders of the UR5e's scenes name none
        manifest["robot"] = robot
    if (out / MANIFEST).exists():
        known = json.loads((out / MANIFEST).read_text())
        if known != manifest:
            fail(f"--seed/--base/--dishes/--robot: {out} holds scenes made with {known}, "
                 f"not {manifest}")
    out.mkdir(parents=True, exist_ok=True)
    write_atomically(out / MANIFEST, json.dumps(manifest) + "\n")
    done = build_dataset(out, count=args.count, seed=args.seed, base_path=Path(args.base),
                         dishes=args.dishes, robot=robot, workers=args.workers,
                         progress=not args.quiet)
    print(f"{done} scenes computed, {args.count - done} already on disk, in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
