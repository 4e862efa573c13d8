"""Train the feasibility FCN on oracle-labelled crops.

    s3o build fcn --data out/fcn_data [out/fcn_data_dense ...] [--out out/fcn] [--seed 0]

Trains on the crops of `s3o build fcn-data` (scenes split at random into training and
validation, random quarter turns, binary cross entropy against the oracle's probabilities,
Adam; the epoch with the least validation loss is kept). Writes fcn.pt and metrics.json to
--out; `--out models/ur5e/fcn` replaces the weights the planner reads. CPU only.
"""

import json
import sys
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, fail
from s3o_drake.commands.options import add_out, add_quiet, out_folder
from s3o_drake.feasibility.learned.train_config import TrainConfig
from s3o_drake.world.resources import repo_path

DEFAULT_OUT = Path("out") / "fcn"
"""Where the weights go unless --out says otherwise: not over a shipped models/NAME/fcn/."""


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("build fcn", __doc__)
    parser.add_argument("--data", metavar="DIR", nargs="+", required=True,
                        help="dataset folders (one per layout, say)")
    add_out(parser, file=False, default=str(DEFAULT_OUT),
            note="the shipped weights are replaced only when told: --out "
                 "models/NAME/fcn")
    defaults = TrainConfig()
    for name, kind, metavar, what in (
            ("seed", int, "N", "seed of the split, the turns and torch"),
            ("epochs", int, "N", "most epochs"),
            ("patience", int, "N", "epochs without a better one before stopping"),
            ("batch", int, "N", "crops per batch"),
            ("lr", float, "X", "Adam's step size"),
            ("width", int, "N", "channels of the network's first layer"),
            ("val_fraction", float, "X", "share of the scenes held out for validation")):
        parser.add_argument(f"--{name.replace('_', '-')}", type=kind, metavar=metavar,
                            default=getattr(defaults, name),
                            help=f"{what} (default {getattr(defaults, name)})")
    parser.add_argument("--threads", type=int, default=2, metavar="N",
                        help="torch threads (default 2)")
    add_quiet(parser)
    args = parser.parse_args(argv)
    for name in ("epochs", "patience", "batch", "width", "threads"):
        if getattr(args, name) < 1:
            fail(f"--{name}: must be at least 1, got {getattr(args, name)}")
    if args.seed < 0:
        fail(f"--seed: must be a non-negative integer, got {args.seed}")
    if not args.lr > 0:
        fail(f"--lr: must be positive, got {args.lr}")
    if not 0 <= args.val_fraction < 1:
        fail(f"--val-fraction: must be in [0, 1), got {args.val_fraction}")
    out = out_folder(args.out)
    import numpy as np
    import torch

    from s3o_drake.feasibility.learned.dataset import load_dataset
    from s3o_drake.feasibility.learned.fcn import CHANNELS
    from s3o_drake.feasibility.learned.training import save, train

    try:
        data = load_dataset([Path(d) for d in args.data])
    except (FileNotFoundError, OSError, KeyError, ValueError) as e:
        fail(f"--data: {e}")
    if data["inputs"].shape[1] != len(CHANNELS):
        fail(f"--data: crops have {data['inputs'].shape[1]} channels, expected {len(CHANNELS)}")
    torch.set_num_threads(args.threads)
    config = TrainConfig(seed=args.seed, epochs=args.epochs, patience=args.patience,
                         batch=args.batch, lr=args.lr, width=args.width,
                         val_fraction=args.val_fraction)
    result = train(data["inputs"], data["labels"], data["scenes"], config,
                   progress=not args.quiet)
    # Named from the repository's root: the provenance ships with the weights.
    manifests = {repo_path(d): Path(d) / "dataset.json" for d in args.data}
    provenance = {"data": list(manifests), "scenes": len(np.unique(data["scenes"])),
                  "crops": len(data["labels"]),
                  "dataset": {d: json.loads(m.read_text()) if m.exists() else {}
                              for d, m in manifests.items()}}
    save(result, config, out, provenance)
    print(f"best epoch {result.best_epoch + 1} of {len(result.val_loss)}: val loss "
          f"{result.val_loss[result.best_epoch]:.4f}, val MAE {result.val_mae:.4f}, "
          f"val AUROC {result.val_auroc:.4f}; wrote {out / 'fcn.pt'}, {out / 'metrics.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
