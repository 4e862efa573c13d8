"""The feasibility FCN against the Drake oracle on unseen scenes.

    s3o bench fcn [--count 10] [--pictures out/fcn_pictures] [--json FILE]

For every dish of the tasks (the shipped ones: never used in training), the network's
heatmap and the oracle's, computed and timed in the same run. Prints per task and overall
the mean absolute error, the AUROC of "feasible" (oracle above 0.5) and the speed ratio
oracle / FCN per heatmap. Targets: MAE <= 0.06, AUROC >= 0.95, ratio >= 100.
"""

from __future__ import annotations

import json
import logging
import statistics
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

# Light imports only: --help and bad arguments answer before torch and Drake load.
from s3o_drake.commands.common import command_parser, fail, read_scenario
from s3o_drake.commands.options import (
    add_json,
    add_quiet,
    add_tasks,
    at_least,
    json_file,
    one_robot,
    out_folder,
    task_paths,
)
from s3o_drake.world.files import write_atomically

if TYPE_CHECKING:
    from s3o_drake.feasibility.oracle import Heatmap

REPEATS = 5
"""FCN timings are the median of this many runs (an oracle heatmap is timed once)."""
TARGETS = {"mae": 0.06, "auroc": 0.95, "speed_ratio": 100.0}


def save_picture(path: Path, inputs: np.ndarray, predicted: Heatmap, oracle: Heatmap) -> None:
    """Input height crop | predicted | oracle heatmap, side by side, in world coordinates."""
    import matplotlib

    from s3o_drake.feasibility.learned.fcn import CHANNELS

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
    parser = command_parser("bench fcn", __doc__)
    add_tasks(parser, count=10)
    parser.add_argument("--weights", metavar="PT",
                        help="checkpoint (default the tasks' robot's: models/NAME/fcn/fcn.pt)")
    parser.add_argument("--pictures", metavar="DIR", help="write side-by-side pictures here")
    parser.add_argument("--picture-count", type=at_least(0), default=4, metavar="N",
                        help="dishes to picture (default 4)")
    add_json(parser, None)
    parser.add_argument("--threads", type=at_least(1), default=1, metavar="N",
                        help="torch threads for the FCN (default 1)")
    add_quiet(parser)
    args = parser.parse_args(argv)
    tasks = task_paths(args)
    scenarios = [(path.stem, read_scenario(path)) for path in tasks]
    json_path = json_file(args)
    from s3o_drake.world.robot import load_robot

    robot = load_robot(one_robot(zip(tasks, (s for _, s in scenarios), strict=True)))
    if args.weights is None:
        args.weights = str(robot.files.fcn_weights)
    if not Path(args.weights).is_file():
        fail(f"--weights: no such file {args.weights}")
    pictures = out_folder(args.pictures, "--pictures") if args.pictures else None
    import torch
    from tqdm import tqdm

    from s3o_drake.feasibility.heatmaps import compute_heatmaps
    from s3o_drake.feasibility.learned.fcn import (
        CHANNELS,
        FcnFeasibility,
        auroc,
        crop_inputs,
        view_of,
    )
    from s3o_drake.feasibility.oracle_cache import bypassed
    from s3o_drake.feasibility.reachability.map import ReachabilityMap
    try:
        fcn = FcnFeasibility.load(Path(args.weights), robot=robot)
    except Exception as e:  # a corrupt or foreign file: say so in one line
        fail(f"--weights: cannot load {args.weights}: {e}")

    logging.getLogger("drake").setLevel(logging.WARNING)
    torch.set_num_threads(args.threads)
    ReachabilityMap.shared(robot=robot)  # the one-time start-up, out of the timings
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
        with bypassed():  # the oracle's time is measured, not a cached map's
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
    if json_path is not None:
        write_atomically(json_path, json.dumps({"tasks": rows, "summary": summary},
                                               indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
