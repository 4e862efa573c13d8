"""Make the FCN's training data: overhead crops of random scenes with Drake-oracle labels.

    python -m s3o_drake.commands.dataset --count 300 --seed 1000 --out data/fcn --workers 2

Scene i is task i of `s3o_drake.world.task_generation` drawn with --seed (the paper's protocol: the
restaurant, 5-7 dishes, one unmapped chair near each). The shipped benchmark tasks
(scenarios/generated) are drawn with seed 0, so use any other seed (default 1000) to keep
the training scenes apart from them. For each scene the world is rendered once from the
overhead camera (robot at its start pose) and, for every dish, the input crop
(`fcn.crop_inputs`) and the label, the oracle's 4 m x 4 m, 64 x 64 heatmap
(`compute_heatmaps` with the scene's own seed, chairs included), are stored.

One file per scene, scene_00000.npz, ...: inputs (n, C, 64, 64), labels (n, 64, 64), the
dishes' names, kinds and positions, and the depth and label images (to rebuild other
inputs without rerunning the oracle). Scene i depends only on (--seed, i), whatever the
worker count. Each file is written whole as soon as its scene is done, so an interrupted
run loses nothing, and a rerun skips the scenes already on disk (a larger --count extends
a smaller one). The folder remembers its seed; a rerun with another seed is refused.
"""

import json
import sys
from pathlib import Path

from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail, read_base
from s3o_drake.feasibility.dataset import (
    MANIFEST,
    build_dataset,
)
from s3o_drake.world.files import write_atomically
from s3o_drake.world.task_generation import DEFAULT_BASE


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.dataset",
                            description=__doc__, formatter_class=doc_formatter())
    parser.add_argument("--count", type=int, required=True, help="number of scenes")
    parser.add_argument("--seed", type=int, default=1000,
                        help="scene seed (default 1000; the benchmark tasks use 0)")
    parser.add_argument("--out", metavar="DIR", required=True, help="output folder")
    parser.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    parser.add_argument("--base", metavar="YAML", default=str(DEFAULT_BASE),
                        help="base scenario of the generator (default scenarios/restaurant.yaml)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if args.count < 1:
        fail(f"--count: must be at least 1, got {args.count}")
    if args.seed < 0:
        fail(f"--seed: must be a non-negative integer, got {args.seed}")
    if args.workers < 1:
        fail(f"--workers: must be at least 1, got {args.workers}")
    read_base(args.base)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        fail(f"--out: {out} exists and is not a folder")
    manifest = {"seed": args.seed, "base": Path(args.base).resolve().name}
    if (out / MANIFEST).exists():
        known = json.loads((out / MANIFEST).read_text())
        if known != manifest:
            fail(f"--seed/--base: {out} holds scenes made with {known}, not {manifest}")
    out.mkdir(parents=True, exist_ok=True)
    write_atomically(out / MANIFEST, json.dumps(manifest) + "\n")
    done = build_dataset(out, count=args.count, seed=args.seed, base_path=Path(args.base),
                         workers=args.workers, progress=not args.quiet)
    print(f"{done} scenes computed, {args.count - done} already on disk, in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
