"""Train the feasibility FCN on the oracle-labelled crops of `s3o_drake.feasibility.dataset`.

    python -m s3o_drake.commands.train --data out/fcn_data [--out out/fcn] --seed 0

writes the weights to out/fcn/ unless --out says otherwise; `--out models/fcn` replaces the
shipped ones that the planner reads.

The scenes (not the crops: the dishes of one scene share a room) are split at random into
training and validation (--val-fraction). Inputs are normalised per channel with the
training set's mean and standard deviation (stored with the weights). Every batch is turned
by a random multiple of 90 degrees about the dish, crop and label together (the offset
planes, which say where each cell is, are put back unturned). The loss is binary cross
entropy against the oracle's probabilities (see `fcn`); Adam, its step halved after 2
epochs without progress; the epoch with the lowest validation loss is kept, and training
stops after --patience epochs without a better one.

Writes, each file whole or not at all, into --out:
- fcn.pt: the state_dict, the model's config, the input normalisation, and the data, seed,
  split and epochs used;
- metrics.json: training and validation loss per epoch, the best epoch, and on the
  validation crops the mean absolute error and the AUROC (feasible: oracle above 0.5).
torch.manual_seed comes from --seed; CPU only.
"""

import json
import sys
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail
from s3o_drake.feasibility.train_config import TrainConfig
from s3o_drake.world.resources import FCN_WEIGHTS, REPO_DIR

DEFAULT_OUT = Path("out") / "fcn"
"""Where the weights go unless --out says otherwise: not over the shipped models/fcn/."""


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.train", description=__doc__,
                            formatter_class=doc_formatter())
    parser.add_argument("--data", metavar="DIR", required=True, help="dataset folder")
    parser.add_argument("--out", metavar="DIR", default=str(DEFAULT_OUT),
                        help=f"output folder (default {DEFAULT_OUT}; the shipped weights are "
                             f"replaced only when told: --out "
                             f"{FCN_WEIGHTS.parent.relative_to(REPO_DIR)})")
    defaults = TrainConfig()
    for name, kind in (("seed", int), ("epochs", int), ("patience", int), ("batch", int),
                       ("lr", float), ("width", int), ("val_fraction", float)):
        parser.add_argument(f"--{name.replace('_', '-')}", type=kind,
                            default=getattr(defaults, name),
                            help=f"default {getattr(defaults, name)}")
    parser.add_argument("--threads", type=int, default=2, help="torch threads (default 2)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
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
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        fail(f"--out: {out} exists and is not a folder")
    import numpy as np
    import torch

    from s3o_drake.feasibility.dataset import load_dataset
    from s3o_drake.feasibility.fcn import CHANNELS
    from s3o_drake.feasibility.training import save, train

    try:
        data = load_dataset(Path(args.data))
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
    manifest = Path(args.data) / "dataset.json"
    provenance = {"data": str(args.data), "scenes": len(np.unique(data["scenes"])),
                  "crops": len(data["labels"]),
                  "dataset": json.loads(manifest.read_text()) if manifest.exists() else {}}
    save(result, config, out, provenance)
    print(f"best epoch {result.best_epoch + 1} of {len(result.val_loss)}: val loss "
          f"{result.val_loss[result.best_epoch]:.4f}, val MAE {result.val_mae:.4f}, "
          f"val AUROC {result.val_auroc:.4f}; wrote {out / 'fcn.pt'}, {out / 'metrics.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
