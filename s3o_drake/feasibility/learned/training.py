"""Training of the feasibility FCN on the oracle-labelled crops of
`s3o_drake.feasibility.learned.dataset`; the command is `s3o build fcn`.

The scenes (not the crops: the dishes of one scene share a room) are split at random into
training and validation (--val-fraction). Inputs are normalised per channel with the
training set's mean and standard deviation (stored with the weights). Every batch is turned
by a random multiple of 90 degrees about the dish, crop and label together (the offset
planes, which say where each cell is, are put back unturned). The loss is binary cross
entropy against the oracle's probabilities (see `fcn`); Adam, its step halved after 2
epochs without progress; the epoch with the lowest validation loss is kept, and training
stops after --patience epochs without a better one.

`save` writes, each file whole or not at all, into the output folder:
- fcn.pt: the state_dict, the model's config, the input normalisation, and the data, seed,
  split and epochs used;
- metrics.json: training and validation loss per epoch, the best epoch, and on the
  validation crops the mean absolute error and the AUROC (feasible: oracle above 0.5).
torch.manual_seed comes from --seed; CPU only.
"""

import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch
from torch import nn
from tqdm import tqdm

from s3o_drake.feasibility.learned.fcn import CHANNELS, FeasibilityUNet, auroc
from s3o_drake.feasibility.learned.train_config import TrainConfig
from s3o_drake.world.files import write_atomically

OFFSET_CHANNELS = [CHANNELS.index("dx"), CHANNELS.index("dy")]


@dataclass
class TrainResult:
    """The best model, its normalisation, and what happened on the way."""

    model: FeasibilityUNet
    mean: np.ndarray
    std: np.ndarray
    train_loss: list[float] = field(default_factory=list)
    val_loss: list[float] = field(default_factory=list)
    best_epoch: int = 0
    val_scenes: list[int] = field(default_factory=list)
    val_mae: float = math.nan
    val_auroc: float = math.nan


def split_scenes(scenes: np.ndarray, fraction: float, seed: int) -> np.ndarray:
    """Boolean mask of the validation crops: whole scenes drawn at random, at least one."""
    unique = np.unique(scenes)
    rng = np.random.default_rng([seed, 1])
    count = max(1, round(fraction * len(unique))) if len(unique) > 1 else 0
    val = rng.permutation(unique)[:count]
    return np.isin(scenes, val)


def _predict(model: nn.Module, x: torch.Tensor, batch: int) -> torch.Tensor:
    model.eval()
    with torch.inference_mode():
        return torch.cat([model(x[k:k + batch]) for k in range(0, len(x), batch)])


def train(inputs: np.ndarray, labels: np.ndarray, scenes: np.ndarray, config: TrainConfig,
          progress: bool = True) -> TrainResult:
    """Trains a FeasibilityUNet on crops (N, C, 64, 64) and labels (N, 64, 64)."""
    torch.manual_seed(config.seed)
    rng = np.random.default_rng([config.seed, 2])
    val = split_scenes(scenes, config.val_fraction, config.seed)
    train_rows = ~val if val.any() else np.ones(len(scenes), dtype=bool)
    mean = inputs[train_rows].mean(axis=(0, 2, 3)).astype(np.float32)
    std = inputs[train_rows].std(axis=(0, 2, 3)).astype(np.float32)
    std[std < 1e-6] = 1.0  # a constant channel (a dish kind absent) stays as it is

    def tensor(rows: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
        x = (inputs[rows] - mean[:, None, None]) / std[:, None, None]
        return torch.from_numpy(x.astype(np.float32)), torch.from_numpy(labels[rows].astype(
            np.float32))

    x_train, y_train = tensor(train_rows)
    x_val, y_val = tensor(val) if val.any() else (x_train, y_train)
    offsets = x_train[:1, OFFSET_CHANNELS].clone()
    model = FeasibilityUNet(in_channels=inputs.shape[1], width=config.width)
    optimiser = torch.optim.Adam(model.parameters(), lr=config.lr)
    # Halving the step when validation stalls lets the heatmaps' edges settle.
    schedule = torch.optim.lr_scheduler.ReduceLROnPlateau(optimiser, factor=0.5, patience=2)
    loss_fn = nn.BCEWithLogitsLoss()
    result = TrainResult(model, mean, std, val_scenes=sorted(set(scenes[val].tolist())))
    best, best_state, waited = math.inf, None, 0
    bar = tqdm(range(config.epochs), desc="epochs", unit="epoch", disable=not progress)
    for epoch in bar:
        model.train()
        order = torch.from_numpy(rng.permutation(len(x_train)))
        total = 0.0
        for k in range(0, len(order), config.batch):
            rows = order[k:k + config.batch]
            x, y = x_train[rows], y_train[rows]
            if config.rotate:
                turns = int(rng.integers(4))
                x = torch.rot90(x, turns, dims=(-2, -1)).clone()
                y = torch.rot90(y, turns, dims=(-2, -1))
                x[:, OFFSET_CHANNELS] = offsets  # where a cell is does not turn
            loss = loss_fn(model(x), y)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            total += loss.item() * len(rows)
        result.train_loss.append(total / len(x_train))
        val_loss = float(loss_fn(_predict(model, x_val, 256), y_val))
        result.val_loss.append(val_loss)
        schedule.step(val_loss)
        bar.set_postfix(train=f"{result.train_loss[-1]:.4f}", val=f"{val_loss:.4f}")
        if val_loss < best:
            best, waited, result.best_epoch = val_loss, 0, epoch
            best_state = {k: v.clone() for k, v in model.state_dict().items()}
        else:
            waited += 1
            if waited >= config.patience:
                break
    bar.close()
    model.load_state_dict(best_state)
    model.eval()
    predicted = torch.sigmoid(_predict(model, x_val, 256)).numpy()
    truth = y_val.numpy()
    result.val_mae = float(np.abs(predicted - truth).mean())
    result.val_auroc = auroc(predicted, truth > 0.5)
    return result


def save(result: TrainResult, config: TrainConfig, out: Path, provenance: dict) -> None:
    """Writes fcn.pt and metrics.json into `out`."""
    out.mkdir(parents=True, exist_ok=True)
    checkpoint = {"state_dict": result.model.state_dict(), "config": result.model.config,
                  "mean": result.mean.tolist(), "std": result.std.tolist(),
                  "channels": list(CHANNELS), "train_config": vars(config),
                  "best_epoch": result.best_epoch, "epochs_run": len(result.val_loss),
                  "val_scenes": result.val_scenes, **provenance}
    buffer = io.BytesIO()
    torch.save(checkpoint, buffer)
    metrics = {"train_loss": result.train_loss, "val_loss": result.val_loss,
               "best_epoch": result.best_epoch, "val_mae": result.val_mae,
               "val_auroc": result.val_auroc, "train_config": vars(config), **provenance}
    write_atomically(out / "fcn.pt", buffer.getvalue())
    write_atomically(out / "metrics.json", json.dumps(metrics, indent=1) + "\n")
