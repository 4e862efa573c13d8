"""Benchmark the feasibility FCN against the Drake oracle on scenes never used in training.

    python -m s3o_drake.commands.fcn_benchmark --tasks 10 --pictures out/fcn_pictures

The scenes are the first N shipped benchmark tasks (scenarios/generated, drawn with seed 0;
the training scenes come from another seed, 1000 by default). Each task is rendered once
from the overhead camera; then, for every dish, the FCN's heatmap (crop + network) and the
oracle's (`compute_heatmaps`, in this process, the task's own seed, chairs included) are
computed and timed in the same run. The reachability map is loaded
and prepared before the first task; that one-time start-up is left out.

Prints per task and overall: mean absolute error of the FCN against the oracle over all
cells, AUROC of the FCN's value as a score for "feasible" (oracle above 0.5), and the speed
ratio oracle time / FCN time per heatmap, rendering excluded (the render, shared by all the
dishes of a scene, is reported apart, and the ratio with it included too). The FCN's time
is that of one batched call for all the dishes of a task (as a planner asks), divided by
their number, on --threads torch threads (default 1); one call per dish is timed too and
reported beside it; each FCN time is the median of 5 runs. The oracle's collision checker
spreads its batches over the cores; it is timed once.
Targets: MAE <= 0.06, AUROC >= 0.95, ratio >= 100.

--pictures DIR writes, for the first --picture-count dishes, the input height crop, the
predicted and the oracle heatmap side by side (dish_<task>_<dish>.png). --json FILE also
writes the figures.
"""

import json
import logging
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from s3o_drake.commands.common import (
    ArgumentParser,
    doc_formatter,
    fail,
    first_tasks,
    read_scenario,
)
from s3o_drake.feasibility.fcn import (
    CHANNELS,
    FcnFeasibility,
    auroc,
    crop_inputs,
    view_of,
)
from s3o_drake.feasibility.heatmaps import compute_heatmaps
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.feasibility.reachability import ReachabilityMap
from s3o_drake.world.files import write_atomically
from s3o_drake.world.resources import FCN_WEIGHTS

WEIGHTS = FCN_WEIGHTS
REPEATS = 5
"""FCN timings are the median of this many runs (an oracle heatmap is timed once)."""
TARGETS = {"mae": 0.06, "auroc": 0.95, "speed_ratio": 100.0}


def save_picture(path: Path, inputs: np.ndarray, predicted: Heatmap, oracle: Heatmap) -> None:
    """Input height crop | predicted | oracle heatmap, side by side, in world coordinates."""
    import matplotlib

    matplotlib.use("Agg")  # files only; never a window
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(12, 4), constrained_layout=True)
    extent = predicted.extent
    panels = [(inputs[CHANNELS.index("height")], "input: height (m)", "viridis", 0.0, 1.2),
              (predicted.values, "FCN Fea^m", "magma", 0.0, 1.0),
              (oracle.values, "oracle Fea^m", "magma", 0.0, 1.0)]
    for ax, (image, title, cmap, lo, hi) in zip(axes, panels, strict=True):
        shown = ax.imshow(image, origin="lower", extent=extent, cmap=cmap, vmin=lo, vmax=hi)
        ax.set_title(title)
        ax.set_xlabel("x (m)")
        fig.colorbar(shown, ax=ax, shrink=0.8)
    axes[0].set_ylabel("y (m)")
    fig.suptitle(f"{path.stem}: MAE {np.abs(predicted.values - oracle.values).mean():.3f}")
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.fcn_benchmark",
                            description=__doc__, formatter_class=doc_formatter())
    parser.add_argument("--tasks", type=int, default=10, help="number of tasks (default 10)")
    parser.add_argument("--weights", metavar="PT", default=str(WEIGHTS),
                        help="checkpoint (default models/fcn/fcn.pt)")
    parser.add_argument("--pictures", metavar="DIR", help="write side-by-side pictures here")
    parser.add_argument("--picture-count", type=int, default=4,
                        help="dishes to picture (default 4)")
    parser.add_argument("--json", metavar="FILE", help="also write the figures to this file")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch threads for the FCN (default 1)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    tasks = first_tasks(args.tasks)
    if args.picture_count < 0:
        fail(f"--picture-count: must be non-negative, got {args.picture_count}")
    if args.threads < 1:
        fail(f"--threads: must be at least 1, got {args.threads}")
    if not Path(args.weights).is_file():
        fail(f"--weights: no such file {args.weights}")
    try:
        fcn = FcnFeasibility.load(Path(args.weights))
    except Exception as e:  # a corrupt or foreign file: say so in one line
        fail(f"--weights: cannot load {args.weights}: {e}")
    pictures = Path(args.pictures) if args.pictures else None
    if pictures is not None and pictures.exists() and not pictures.is_dir():
        fail(f"--pictures: {pictures} exists and is not a folder")
    scenarios = [(path.stem, read_scenario(path)) for path in tasks]

    logging.getLogger("drake").setLevel(logging.WARNING)
    torch.set_num_threads(args.threads)
    ReachabilityMap.shared()  # the one-time start-up, out of the timings
    fcn.predict(np.zeros((1, len(CHANNELS), 64, 64), np.float32))  # torch's first call
    if pictures is not None:
        pictures.mkdir(parents=True, exist_ok=True)
    rows, predicted_all, oracle_all = [], [], []
    render_s = fcn_s = oracle_s = single_s = 0.0
    drawn = 0
    for name, scenario in tqdm(scenarios, desc="tasks", unit="task", disable=args.quiet):
        start = time.perf_counter()
        view = view_of(scenario)
        render_s += time.perf_counter() - start
        # A few ms are at the mercy of the scheduler: the median of REPEATS runs.
        single = []
        for _ in range(REPEATS):
            start = time.perf_counter()
            for dish in scenario.dishes:
                fcn.heatmap(view, dish)
            single.append(time.perf_counter() - start)
        single_s += statistics.median(single)
        batched = []
        for _ in range(REPEATS):
            start = time.perf_counter()
            predicted = fcn.heatmaps(view, scenario.dishes)
            batched.append(time.perf_counter() - start)
        task_fcn = statistics.median(batched)
        start = time.perf_counter()
        oracle = compute_heatmaps(scenario, progress=False)
        task_oracle = time.perf_counter() - start
        fcn_s, oracle_s = fcn_s + task_fcn, oracle_s + task_oracle
        p = np.stack([h.values for h in predicted])
        o = np.stack([h.values for h in oracle])
        predicted_all.append(p)
        oracle_all.append(o)
        rows.append({"task": name, "dishes": len(p), "mae": float(np.abs(p - o).mean()),
                     "auroc": auroc(p, o > 0.5), "fcn_s": task_fcn, "oracle_s": task_oracle})
        for dish, pred, orac in zip(scenario.dishes, predicted, oracle, strict=True):
            if pictures is not None and drawn < args.picture_count:
                inputs = crop_inputs(view, np.asarray(dish.position[:2]), dish.kind)
                save_picture(pictures / f"dish_{name}_{dish.name}.png", inputs, pred, orac)
                drawn += 1

    p, o = np.concatenate(predicted_all), np.concatenate(oracle_all)
    dishes = len(p)
    summary = {
        "tasks": len(rows), "dishes": dishes, "mae": float(np.abs(p - o).mean()),
        "auroc": auroc(p, o > 0.5),
        "worst_dish_mae": float(np.abs(p - o).mean(axis=(1, 2)).max()),
        "fcn_s_per_heatmap": fcn_s / dishes, "oracle_s_per_heatmap": oracle_s / dishes,
        "fcn_s_per_heatmap_one_at_a_time": single_s / dishes,
        "speed_ratio_one_at_a_time": oracle_s / single_s,
        "render_s_per_task": render_s / len(rows),
        "speed_ratio": oracle_s / fcn_s,
        "speed_ratio_render_included": oracle_s / (fcn_s + render_s),
        "weights": str(args.weights), "targets": TARGETS,
    }
    print(f"{'task':<10} {'dishes':>6} {'MAE':>7} {'AUROC':>7} {'FCN s':>8} {'oracle s':>9}")
    for r in rows:
        print(f"{r['task']:<10} {r['dishes']:>6} {r['mae']:>7.4f} {r['auroc']:>7.4f} "
              f"{r['fcn_s']:>8.4f} {r['oracle_s']:>9.3f}")
    print(f"\n{dishes} dishes on {len(rows)} held-out tasks:")
    print(f"  MAE           {summary['mae']:.4f}  (target <= {TARGETS['mae']}; "
          f"worst dish {summary['worst_dish_mae']:.4f})")
    print(f"  AUROC         {summary['auroc']:.4f}  (target >= {TARGETS['auroc']})")
    print(f"  per heatmap   FCN {1000 * summary['fcn_s_per_heatmap']:.2f} ms, oracle "
          f"{1000 * summary['oracle_s_per_heatmap']:.0f} ms: ratio {summary['speed_ratio']:.0f}x "
          f"rendering excluded (target >= {TARGETS['speed_ratio']:.0f}x)")
    print(f"  one at a time FCN {1000 * summary['fcn_s_per_heatmap_one_at_a_time']:.2f} ms: "
          f"ratio {summary['speed_ratio_one_at_a_time']:.0f}x")
    print(f"  rendering     {summary['render_s_per_task']:.3f} s per task (once for all its "
          f"dishes): ratio {summary['speed_ratio_render_included']:.0f}x rendering included")
    if args.json:
        write_atomically(Path(args.json), json.dumps({"tasks": rows, "summary": summary},
                                                     indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
