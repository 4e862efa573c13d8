"""The state-space abstraction: candidates counted and time taken.

    s3o bench abstraction [--counts 5 7 15 30] [--dense 7 10] [--cache FILE.npz]

The restaurant (--base) cut to its first dishes or extended with dishes drawn on its tables;
dense rows put every dish on one table (--dense-table). Times everything build_abstraction
does (free space, Voronoi cells, candidates, Fea^t, ranking) on heatmaps computed before.
Targets: 7 dishes fully enumerated and ranked in <= 1 s; 30 dishes give a top-K in <= 5 s.
Exit status: 0 when the targets are met, 1 when one is missed, 2 on bad input.
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

# Light imports only: --help and bad arguments answer before Drake and shapely load.
from s3o_drake.commands.common import command_parser, fail, read_scenario
from s3o_drake.commands.options import add_seed, add_workers, at_least
from s3o_drake.world.resources import REPO_DIR, RESTAURANT

if TYPE_CHECKING:
    from s3o_drake.feasibility.oracle import Heatmap
    from s3o_drake.world.scenario import Scenario

TARGETS = {7: 1.0, 30: 5.0}  # dishes -> seconds
MAX_TRIES = 10_000


def with_dish_count(base: Scenario, count: int, seed: int, *,
                    table: str | None = None) -> Scenario:
    """The base scene with its first `count` dishes, or more drawn on its tables.

    With `table`, all `count` dishes are drawn on that one table instead (a dense scene:
    many mutually adjacent cells, the enumeration's worst case).
    """
    from s3o_drake.world.furniture import DISH_SHAPES, RESTAURANT_KINDS
    from s3o_drake.world.objects import Dish
    from s3o_drake.world.scenario_checks import ScenarioError, validate_scenario
    from s3o_drake.world.task_generation import DISH_GAP, spot_on_table

    dishes = [] if table else list(base.dishes[:count])
    tables = [t for t in base.tables if t.name == table] if table else base.tables
    placed = [(np.array(d.position), DISH_SHAPES[d.kind].radius) for d in dishes]
    names = {d.name for d in dishes}
    rng = np.random.default_rng([seed, count])
    for _ in range(MAX_TRIES):
        if len(dishes) >= count:
            break
        top = tables[int(rng.integers(len(tables)))]
        kind = RESTAURANT_KINDS[int(rng.integers(len(RESTAURANT_KINDS)))]
        radius = DISH_SHAPES[kind].radius
        p_W = spot_on_table(top, radius, rng)
        if p_W is None:
            continue
        if any(np.linalg.norm(p_W - q) < radius + r + DISH_GAP for q, r in placed):
            continue
        k = 1
        while f"{kind}_x{k}" in names:
            k += 1
        names.add(f"{kind}_x{k}")
        placed.append((p_W, radius))
        dishes.append(Dish(name=f"{kind}_x{k}", table=top.name, kind=kind,
                           position=[round(float(v), 4) for v in p_W]))
    if len(dishes) < count:
        raise ScenarioError("--counts", f"could not place {count} dishes on the tables")
    scene = replace(base, dishes=dishes)
    validate_scenario(scene)
    return scene


def _cache_key(scene: Scenario, cells: int) -> str:
    dishes = ";".join(f"{d.name}@{d.position[0]:.4f},{d.position[1]:.4f}" for d in scene.dishes)
    chairs = ";".join(f"{c.pose}" for c in scene.chairs)
    # The oracle's version: heatmaps of an older success test must not be reused.
    return f"{dishes}|{chairs}|{cells}|executed-pickup|{scene.seed}"


def _load_cache(path: Path, key: str) -> list[Heatmap] | None:
    """The cached heatmaps if the file exists and was made for the same scene."""
    from s3o_drake.feasibility.oracle import Heatmap

    if not path.is_file():
        return None
    with np.load(path) as data:
        if str(data["key"]) != key:
            return None
        return [Heatmap(str(d), v, float(x0), float(y0), float(c)) for d, v, x0, y0, c in
                zip(data["dish"], data["values"], data["x0"], data["y0"], data["cell"],
                    strict=True)]


def _save_cache(path: Path, key: str, heatmaps: list[Heatmap]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        np.savez_compressed(f, key=key, dish=[h.dish for h in heatmaps],
                            values=np.stack([h.values for h in heatmaps]),
                            x0=[h.x0 for h in heatmaps], y0=[h.y0 for h in heatmaps],
                            cell=[h.cell for h in heatmaps])


def _synthetic_row(label: str, scene: Scenario, perceived: list, heatmaps: dict,
                   adjacency: list[set[int]], target: float | None, note: str) -> bool:
    """Times the abstraction with the cells' adjacency replaced; prints one row."""
    from s3o_drake.abstraction.location_grid import LocationGrid
    from s3o_drake.abstraction.ranking import rank
    from s3o_drake.abstraction.task_feasibility import TaskFeasibility
    from s3o_drake.abstraction.voronoi import voronoi_partition
    from s3o_drake.belief.known_world import KnownWorld

    t0 = time.perf_counter()
    partition = voronoi_partition(KnownWorld.of(scene, perceived_chairs=perceived))
    partition.adjacency = adjacency
    task = TaskFeasibility(LocationGrid.of(partition, heatmaps),
                           samples=scene.planner.location_samples, seed=scene.seed)
    planner = scene.planner
    abstraction = rank(partition, task, top_k=planner.top_k,
                       location_cost=planner.gamma / planner.reward)
    elapsed = time.perf_counter() - t0
    ok = target is None or elapsed <= target
    edges = sum(len(a) for a in adjacency) // 2
    verdict = f"<= {target:g} {'ok' if ok else 'MISSED'}" if target else ""
    print(f"{label:>9} {edges:>5} {abstraction.count:>10} "
          f"{'enumerate' if abstraction.exhaustive else 'beam':>10} "
          f"{'yes' if abstraction.complete else 'no':>8} {elapsed:>8.3f} {verdict:>8}  "
          f"{note}; best: {len(abstraction.best.groups)} locations, "
          f"score {abstraction.best.score:.2f}")
    return ok


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench abstraction", __doc__)
    parser.add_argument("--base", metavar="YAML", default=str(RESTAURANT),
                        help=f"base scene (default {RESTAURANT.relative_to(REPO_DIR)})")
    parser.add_argument("--counts", type=at_least(1), nargs="+", default=[5, 7, 15, 30],
                        metavar="N", help="dish counts to time (default: 5 7 15 30)")
    parser.add_argument("--dense", type=at_least(1), nargs="*", default=[7, 10], metavar="N",
                        help="dish counts of dense rows, all on --dense-table (default: 7 10)")
    parser.add_argument("--dense-table", default="mid_1", metavar="NAME",
                        help="the table of the dense rows (default: mid_1, free all round)")
    parser.add_argument("--cells", type=at_least(1), default=64, metavar="N",
                        help="heatmap cells per side (default: 64)")
    add_workers(parser, 1, "processes computing the heatmaps")
    add_seed(parser, 0, "seed of the extra dishes")
    parser.add_argument("--cache", metavar="FILE.npz",
                        help="keep the heatmaps in this file and reuse them for the same scene")
    args = parser.parse_args(argv)
    from s3o_drake.abstraction.ranking import build_abstraction
    from s3o_drake.belief.known_world import KnownWorld
    from s3o_drake.feasibility.heatmaps import compute_heatmaps
    from s3o_drake.world.scenario_checks import ScenarioError

    base = read_scenario(args.base, "--base")
    try:
        largest = with_dish_count(base, max(args.counts), args.seed)
        if args.dense_table not in {t.name for t in base.tables}:
            raise ScenarioError("--dense-table", f"no table named {args.dense_table!r}")
        longest = args.dense_table
        dense = with_dish_count(replace(base, chairs=[]), max(args.dense), args.seed,
                                table=longest) if args.dense else None
    except ScenarioError as e:
        fail(str(e) if e.path.startswith("--") else f"--base: {args.base}: {e}")
    scenes = [(n, "", largest) for n in args.counts]
    scenes += [(n, f" ({longest})", dense) for n in args.dense]
    perceived = [c.pose for c in base.chairs if not c.mapped]

    start = time.perf_counter()
    by_scene: dict[int, dict[str, Heatmap]] = {}
    for index, scene in enumerate(s for s in (largest, dense) if s is not None):
        key = _cache_key(scene, args.cells)
        cache = Path(args.cache).with_suffix(f".{index}.npz") if args.cache else None
        heatmaps = _load_cache(cache, key) if cache else None
        if heatmaps is None:
            heatmaps = compute_heatmaps(scene, workers=args.workers, cells=args.cells)
            if cache:
                _save_cache(cache, key, heatmaps)
        by_scene[id(scene)] = {h.dish: h for h in heatmaps}
    print(f"Fea^m heatmaps: {time.perf_counter() - start:.1f} s (not timed below)")

    print(f"{'dishes':>9} {'edges':>5} {'candidates':>10} {'search':>10} {'complete':>8} "
          f"{'time (s)':>8} {'target':>8}  best state space")
    met = True
    for count, label, full in scenes:
        scene = replace(full, dishes=full.dishes[:count])
        t0 = time.perf_counter()
        chairs = [] if label else perceived
        abstraction = build_abstraction(KnownWorld.of(scene, perceived_chairs=chairs),
                                        by_scene[id(full)])
        elapsed = time.perf_counter() - t0
        target = TARGETS.get(count) if not label or count == 7 else None
        ok = target is None or elapsed <= target
        met &= ok
        best = abstraction.best
        merged = [g for g in best.groups if len(g) > 1]
        print(f"{f'{count}{label}':>9} {len(abstraction.partition.edges()):>5} "
              f"{abstraction.count:>10} "
              f"{'enumerate' if abstraction.exhaustive else 'beam':>10} "
              f"{'yes' if abstraction.complete else 'no':>8} {elapsed:>8.3f} "
              f"{(f'<= {target:g}' + (' ok' if ok else ' MISSED')) if target else '':>8}  "
              f"{len(best.groups)} locations, score {best.score:.2f}, merged "
              f"{', '.join('+'.join(g) for g in merged) or 'none'}")
    # Worst cases on real Fea^t, with the adjacency overridden: 7 dishes all adjacent
    # (877 partitions, all enumerated), and the 30 dishes on one chain (2^29 partitions:
    # one component above the enumeration limit, so the beam search runs).
    if dense is not None and len(dense.dishes) >= 7:
        complete7 = [set(range(7)) - {i} for i in range(7)]
        met &= _synthetic_row("7 (K7)", replace(dense, dishes=dense.dishes[:7]), [],
                              by_scene[id(dense)], complete7, TARGETS[7],
                              "every cell made adjacent to every other")
    n = len(largest.dishes)
    if n >= 2:
        chain = [{j for j in (i - 1, i + 1) if 0 <= j < n} for i in range(n)]
        met &= _synthetic_row(f"{n} (chain)", largest, perceived, by_scene[id(largest)], chain,
                              TARGETS.get(n), "cells made a chain: beam search")
    return 0 if met else 1


if __name__ == "__main__":
    sys.exit(main())
