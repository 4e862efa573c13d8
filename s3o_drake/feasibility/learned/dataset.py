"""The FCN's training data: overhead crops of random scenes with Drake-oracle labels. Made
by `s3o build fcn-data`, read by `load_dataset`.

Scene i is task i of `s3o_drake.world.task_generation` drawn with the dataset's seed (the paper's
protocol: the restaurant, 5-7 dishes, one unmapped chair near each). The shipped benchmark
tasks (scenarios/generated) are drawn with seed 0, so use any other seed (default 1000) to
keep the training scenes apart from them. For each scene the world is rendered once from the
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

import io
import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from tqdm import tqdm

from s3o_drake.world.files import write_atomically
from s3o_drake.world.resources import DEFAULT_ROBOT
from s3o_drake.world.scenario import load_scenario, with_overrides
from s3o_drake.world.task_generation import DEFAULT_BASE, generate_task
from s3o_drake.world.worker_processes import worker_pool

MANIFEST = "dataset.json"


def scene_path(out: Path, index: int) -> Path:
    """Where scene `index` is stored."""
    return Path(out) / f"scene_{index:05d}.npz"


def make_scene(base_path: Path, seed: int, index: int, dishes: int | None = None,
               robot: str = DEFAULT_ROBOT) -> dict[str, np.ndarray]:
    """Inputs and oracle labels of every dish of scene `index` for `robot` (arrays for
    np.savez); `dishes`: the generator's, that many instead of the protocol's 5 to 7."""
    from s3o_drake.feasibility.heatmaps import compute_heatmaps
    from s3o_drake.feasibility.learned.fcn import crop_inputs, overhead_view
    from s3o_drake.world.builder import render_overhead
    from s3o_drake.world.camera import overhead_camera

    base = with_overrides(load_scenario(base_path), (f"robot.name={robot}",))
    scenario = generate_task(base, seed, index, dishes=dishes)
    _, depth, label, robot_labels = render_overhead(scenario)
    view = overhead_view(overhead_camera(scenario.room, scenario.camera), depth, label,
                         robot_labels)
    heatmaps = compute_heatmaps(scenario, progress=False)
    inputs = np.stack([crop_inputs(view, np.asarray(d.position[:2]), d.kind)
                       for d in scenario.dishes])
    return {
        "inputs": inputs.astype(np.float32),
        "labels": np.stack([h.values for h in heatmaps]).astype(np.float32),
        "dishes": np.array([d.name for d in scenario.dishes]),
        "kinds": np.array([d.kind for d in scenario.dishes]),
        "positions": np.array([d.position[:2] for d in scenario.dishes], dtype=float),
        "depth": depth.astype(np.float32),
        "label_image": label.astype(np.int16),
        "robot_labels": np.array(sorted(robot_labels), dtype=np.int16),
        "seed": np.array(seed), "index": np.array(index), "oracle_seed": np.array(scenario.seed),
    }


def write_scene(out: Path, base_path: Path, seed: int, index: int,
                dishes: int | None = None, robot: str = DEFAULT_ROBOT) -> int:
    """Computes scene `index` and writes its file atomically; returns its dish count."""
    arrays = make_scene(base_path, seed, index, dishes, robot)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    write_atomically(scene_path(out, index), buffer.getvalue())
    return len(arrays["labels"])


def _job(job: tuple) -> int:
    logging.getLogger("drake").setLevel(logging.WARNING)
    return write_scene(*job)


def build_dataset(out: Path, *, count: int, seed: int, base_path: Path = DEFAULT_BASE,
                  dishes: int | None = None, robot: str = DEFAULT_ROBOT, workers: int = 1,
                  progress: bool = True) -> int:
    """Writes scenes 0..count-1 for `robot` that are not on disk yet; returns how many it
    computed. `dishes`: per scene, instead of the protocol's 5 to 7 (`make_scene`)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    todo = [i for i in range(count) if not scene_path(out, i).exists()]
    jobs = [(out, Path(base_path), seed, i, dishes, robot) for i in todo]
    bar = tqdm(total=count, initial=count - len(todo), desc="scenes", unit="scene",
               disable=not progress)
    if workers <= 1 or len(jobs) <= 1:
        for job in jobs:
            _job(job)
            bar.update()
    else:
        with worker_pool(min(workers, len(jobs)), preload=(__name__,)) as pool:
            for _ in pool.imap_unordered(_job, jobs):
                bar.update()
            # Ended, not terminated (the with's exit): a terminated worker leaves the
            # semaphores it made to the resource tracker, which warns of them at exit.
            pool.close()
            pool.join()
    bar.close()
    return len(jobs)


SCENES_PER_FOLDER = 1_000_000
"""Scene ids of the k-th folder of `load_dataset` start at k times this: scenes of two
folders (two layouts, each numbered from 0) stay apart in the training split."""


def load_dataset(folder: Path | Sequence[Path]) -> dict[str, np.ndarray]:
    """All scenes of a folder, or of several (each its own `s3o build fcn-data`, say one per
    layout): inputs, labels and the scene id of every crop."""
    folders = [Path(folder)] if isinstance(folder, (str, Path)) else [Path(f) for f in folder]
    inputs, labels, scenes = [], [], []
    for k, where in enumerate(folders):
        files = sorted(where.glob("scene_*.npz"))
        if not files:
            raise FileNotFoundError(f"no scene_*.npz in {where}")
        for path in files:
            with np.load(path) as data:
                inputs.append(data["inputs"])
                labels.append(data["labels"])
                scenes.append(np.full(len(data["labels"]),
                                      k * SCENES_PER_FOLDER + int(data["index"])))
    return {"inputs": np.concatenate(inputs), "labels": np.concatenate(labels),
            "scenes": np.concatenate(scenes)}
