"""The learned feasibility: the network, its training loop, the dataset command, the shipped
weights, and the CLIs' bad-input handling."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from s3o_drake.commands import dataset as dataset_command
from s3o_drake.commands import fcn_benchmark
from s3o_drake.commands import train as train_command
from s3o_drake.feasibility.heatmaps import compute_heatmaps
from s3o_drake.feasibility.learned import dataset, training
from s3o_drake.feasibility.learned.fcn import (
    CHANNELS,
    FEA_FLOOR,
    LABEL_REACH_STD,
    FcnFeasibility,
    FeasibilityUNet,
    auroc,
    crop_inputs,
    view_of,
)
from s3o_drake.feasibility.oracle import CROP_CELLS, CROP_SIZE
from s3o_drake.feasibility.pickup_geometry import place_probability
from s3o_drake.world.goals import with_place_targets
from s3o_drake.world.scenario import load_scenario

REPO = Path(__file__).resolve().parents[2]
WEIGHTS = REPO / "models" / "ur5e" / "fcn" / "fcn.pt"


def _synthetic(count: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Crops with a random box obstacle; label: a reach ring minus the obstacle."""
    rng = np.random.default_rng(seed)
    n = CROP_CELLS
    inputs = np.zeros((count, len(CHANNELS), n, n), np.float32)
    c = (np.arange(n) + 0.5) * CROP_SIZE / n - CROP_SIZE / 2
    dx, dy = np.meshgrid(c, c)
    ring = ((np.hypot(dx, dy) > 0.5) & (np.hypot(dx, dy) < 1.0)).astype(np.float32)
    labels = np.zeros((count, n, n), np.float32)
    for k in range(count):
        i, j = rng.integers(0, n - 16, 2)
        inputs[k, 0, i:i + 16, j:j + 16] = 0.45
        inputs[k, 3], inputs[k, 4] = dx, dy
        labels[k] = ring * (inputs[k, 0] == 0)
    return inputs, labels, np.arange(count) // 2


def test_network_maps_a_crop_to_a_heatmap_of_the_same_grid():
    model = FeasibilityUNet(width=4)
    import torch

    out = model(torch.zeros(2, len(CHANNELS), CROP_CELLS, CROP_CELLS))
    assert out.shape == (2, CROP_CELLS, CROP_CELLS)


@pytest.fixture
def one_thread():
    """One torch thread: on a shared 2-core machine more threads only wait for each other."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def test_training_lowers_the_loss_on_a_tiny_dataset(one_thread):
    inputs, labels, scenes = _synthetic(8, seed=0)
    config = training.TrainConfig(seed=0, epochs=6, patience=6, batch=4, lr=5e-3, width=4,
                               val_fraction=0.25)
    result = training.train(inputs, labels, scenes, config, progress=False)
    assert result.train_loss[-1] < 0.8 * result.train_loss[0]
    assert min(result.val_loss) < result.val_loss[0]
    assert 0 <= result.val_mae <= 1


def test_auroc_is_the_rank_statistic():
    scores = np.array([0.1, 0.4, 0.35, 0.8, 0.4])
    positive = np.array([False, False, True, True, True])
    # Pairs (positive, negative) ordered right, ties count a half: (0.35 > 0.1) + (0.8 > both)
    # + (0.4 > 0.1) + (0.4 = 0.4) / 2 = 4.5 of 6.
    assert auroc(scores, positive) == pytest.approx(4.5 / 6)
    assert np.isnan(auroc(scores, np.zeros(5, bool)))


def test_dataset_writes_scenes_and_a_rerun_resumes(tmp_path, monkeypatch):
    out = tmp_path / "data"
    # One dish a scene: the oracle's labels are most of a scene's time.
    argv = ["--count", "1", "--seed", "1000", "--dishes", "1", "--out", str(out), "--quiet"]
    assert dataset_command.main(argv) == 0
    first = dataset.scene_path(out, 0)
    with np.load(first) as data:
        n = len(data["dishes"])
        assert n == 1
        assert data["inputs"].shape == (n, len(CHANNELS), CROP_CELLS, CROP_CELLS)
        assert data["labels"].shape == (n, CROP_CELLS, CROP_CELLS)
        assert data["labels"].min() >= 0 and data["labels"].max() <= 1
        assert data["labels"].max() > 0
    stamp = first.stat().st_mtime_ns
    # A run killed while writing scene 1 leaves only a temporary file: not a done scene.
    (out / ".scene_00001.npz.abc.tmp").write_bytes(b"partial")
    computed = []

    def fake_scene(base_path, seed, index, dishes, robot):
        computed.append((index, robot))
        n = CROP_CELLS
        return {"inputs": np.zeros((1, len(CHANNELS), n, n)), "labels": np.zeros((1, n, n)),
                "index": np.array(index)}

    monkeypatch.setattr(dataset, "make_scene", fake_scene)
    argv = ["--count", "2", "--seed", "1000", "--dishes", "1", "--out", str(out), "--quiet"]
    assert dataset_command.main(argv) == 0
    assert computed == [(1, "ur5e")]  # the base scenario's robot
    assert first.stat().st_mtime_ns == stamp
    loaded = dataset.load_dataset(out)
    assert list(loaded["scenes"]) == [0] * n + [1]
    # The folder is the UR5e's: another robot's scenes go to a folder of their own.
    with pytest.raises(SystemExit) as info:
        dataset_command.main([*argv, "--robot", "panda"])
    assert info.value.code == 2 and computed == [(1, "ur5e")]


@pytest.mark.parametrize(("module", "argv", "field"), [
    (dataset_command, ["--count", "0", "--out", "x"], "--count"),
    (dataset_command, ["--count", "2", "--out", "x", "--workers", "0"], "--workers"),
    (dataset_command, ["--count", "2"], "--out"),
    (train_command, ["--data", "/nonexistent/fcn"], "--data"),
    (train_command, ["--data", "x", "--lr", "-1"], "--lr"),
    (fcn_benchmark, ["--count", "0"], "--count"),
    (fcn_benchmark, ["--tasks", "10"], "--count 10"),  # a count was --tasks before
    (fcn_benchmark, ["--weights", "/nonexistent.pt"], "--weights"),
])
def test_bad_arguments_are_one_line_and_exit_2(module, argv, field, capsys, tmp_path,
                                                monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_info:
        module.main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and field in err
    assert not any(tmp_path.iterdir())  # nothing written


@pytest.mark.skipif(not WEIGHTS.is_file(), reason="no shipped weights")
def test_shipped_weights_predict_a_held_out_dish():
    """A benchmark task's dish (the network trains on another seed's scenes). task_003's
    first dish: its oracle map is the one test_oracle_pinning.py checks against Monte
    Carlo, computed once for both (the second reads the oracle's cache)."""
    scenario = load_scenario(REPO / "scenarios" / "generated" / "task_003.yaml")
    fcn = FcnFeasibility.load(WEIGHTS, robot=scenario.contents.robot)
    view = view_of(scenario)
    dish = scenario.dishes[0]
    predicted = fcn.heatmap(view, dish)
    assert predicted.values.shape == (CROP_CELLS, CROP_CELLS)
    assert predicted.values.min() >= 0 and predicted.values.max() <= 1
    (oracle,) = compute_heatmaps(scenario, [dish.name], progress=False)
    assert (predicted.x0, predicted.y0, predicted.cell) == pytest.approx(
        (oracle.x0, oracle.y0, oracle.cell))
    assert np.abs(predicted.values - oracle.values).mean() < 0.15
    # Out of reach reads 0, as the oracle's does, not the sigmoid's small positive tail:
    # the free-stop rule checks every cell above 0.
    values = predicted.values
    assert np.all((values == 0) | (values >= FEA_FLOOR))
    assert np.mean(values == 0) > 0.5 and np.mean(oracle.values == 0) > 0.5
    # The crop is the network's input for that dish.
    assert crop_inputs(view, np.asarray(dish.position), dish.kind).shape[0] == len(CHANNELS)


@pytest.mark.parametrize("kind", ["can", "apple"])
def test_objects_it_was_not_trained_on_are_seen_as_what_they_are_held_like(kind):
    """A can and an apple (the tidy-home objects) are shown to the network as cups, the
    kind they are held like (furniture.NETWORK_KIND): the heatmap stays close to the
    oracle's for the object itself."""
    scenario = load_scenario(REPO / "scenarios" / "small" / "two_dishes.yaml")
    dish = dataclasses.replace(scenario.dishes[1], kind=kind)
    scenario = dataclasses.replace(scenario, dishes=[dish])
    predicted = FcnFeasibility.load(WEIGHTS, robot=scenario.contents.robot).heatmap(
        view_of(scenario), dish)
    (oracle,) = compute_heatmaps(scenario, [dish.name], progress=False)
    assert oracle.values.max() > 0.9
    assert np.abs(predicted.values - oracle.values).mean() < 0.08


def test_the_labels_reach_noise_is_the_restaurants():
    """The network's heatmaps are rescaled by factors of the labels' reach noise: the noise
    of the scenes the dataset draws (scenarios/restaurant.yaml's)."""
    restaurant = load_scenario(REPO / "scenarios" / "restaurant.yaml")
    assert restaurant.uncertainty.reach_std == LABEL_REACH_STD


def test_a_place_target_is_rated_as_the_oracle_rates_it():
    """tidy_home's apple put down on the plate: shown to the network as a cup standing on
    the plate, its heatmap rescaled from a cup's catch to the apple's chance of standing
    within tolerance, it is close to the oracle's, and no higher than that chance."""
    tidy = with_place_targets(load_scenario(REPO / "scenarios" / "tidy_home.yaml"))
    (target,) = [d for d in tidy.dishes if d.name == "apple__place"]
    predicted = FcnFeasibility.load(WEIGHTS, robot=tidy.contents.robot).heatmap(
        view_of(tidy), target)
    (oracle,) = compute_heatmaps(tidy, [target.name], progress=False)
    ceiling = place_probability("apple", tidy.uncertainty.reach_std, robot=tidy.robot_value)
    assert oracle.values.max() > 0.85 and predicted.values.max() <= ceiling + 1e-9
    assert np.abs(predicted.values - oracle.values).mean() < 0.05


def test_two_datasets_train_as_one_with_their_scenes_kept_apart(tmp_path):
    """One folder per layout, both numbered from scene 0: loaded together, a scene of one
    is never mistaken for the other's in the training split."""
    n = CROP_CELLS
    for name, count in (("spacious", 2), ("dense", 3)):
        folder = tmp_path / name
        folder.mkdir()
        for index in range(count):
            np.savez(dataset.scene_path(folder, index),
                     inputs=np.zeros((1, len(CHANNELS), n, n)), labels=np.zeros((1, n, n)),
                     index=np.array(index))
    loaded = dataset.load_dataset([tmp_path / "spacious", tmp_path / "dense"])
    assert len(loaded["labels"]) == 5 and len(np.unique(loaded["scenes"])) == 5
    assert dataset.load_dataset(tmp_path / "dense")["scenes"].tolist() == [0, 1, 2]


def test_the_weights_record_their_data_from_the_repository_root(tmp_path, monkeypatch):
    """The weights ship with the folders they were trained on: named as every checkout
    names them, not by the path of the machine that trained them."""
    from s3o_drake.world import resources

    monkeypatch.setattr(resources, "REPO_DIR", tmp_path)
    n = CROP_CELLS
    folder = tmp_path / "out" / "robot" / "fcn_data"
    folder.mkdir(parents=True)
    for index in range(4):
        labels = np.zeros((1, n, n))
        labels[0, : n // 2] = 1.0
        np.savez(dataset.scene_path(folder, index), inputs=np.zeros((1, len(CHANNELS), n, n)),
                 labels=labels, index=np.array(index))
    out = tmp_path / "weights"
    argv = ["--data", str(folder), "--out", str(out), "--epochs", "1", "--batch", "2",
            "--width", "4", "--threads", "1", "--quiet"]
    assert train_command.main(argv) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert list(metrics["dataset"]) == ["out/robot/fcn_data"]
    assert metrics["data"] == ["out/robot/fcn_data"]
