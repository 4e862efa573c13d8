"""The FCN training's hyper-parameters (TrainConfig): a plain dataclass, apart from the
training (s3o_drake.feasibility.learned.training, which needs torch), so that the train command can
show the defaults in its --help without importing torch."""

from dataclasses import dataclass


@dataclass
class TrainConfig:
    """Hyper-parameters of one training run."""

    seed: int = 0
    epochs: int = 60
    patience: int = 6
    batch: int = 32
    lr: float = 3e-3
    width: int = 8
    val_fraction: float = 0.15
    rotate: bool = True
