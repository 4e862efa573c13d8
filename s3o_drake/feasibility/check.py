"""The motion-level feasibility check: can the robot, standing here, pick that dish?

For a base pose (x, y, yaw) where the robot really stands and a dish, feasible means

(a) the base stands inside the room and is collision-free: the robot with its arm in
    stow passes the scene's collision checker (tables, chairs, walls and the other
    dishes, 1 cm padding; `check_many` settles most poses from plan-view geometry first,
    see `clearance`, with the same answers), and
(b) for one of the dish's grasps (`grasps.grasps_for`, in order: top, then side) an arm
    configuration exists within the joint limits, at least 1 cm from every obstacle (the
    grasped dish excepted: the gripper touches it) and without self-collision, that puts the
    grasp frame within 2 mm and 2° of the grasp pose (IK's tolerances; the returned
    configuration is always within 1 cm and 3°).

The check takes the base yaw as given; it does not choose one. Callers that model "the robot
drives to y_r facing the dish" pass `facing_yaw(y_r, dish)` (plus their navigation noise):
with the arm mounted on the base's x axis, that yaw also points the arm base A at the dish.
`reach_offset` moves the grasp target in the world (the reach noise T^m): (dx, dy) or
(dx, dy, dz).

Two methods give the same answers. On 2,750 random queries in the restaurant and ten generated
tasks (`s3o bench reachability-agreement`), 718 of them with a
collision-free base,
they disagreed twice (99.7% of those, 99.9% of all): both times the map found a configuration
whose clearance lies within IK's 0.1 mm margin of the 1 cm, which IK then could not certify.

- "map" (fast): the reachability map gives the arm configurations of every IK branch at the
  grasp's distance and height from A; they are turned to the grasp's bearing (shoulder pan)
  and wrist turn (wrist 3) and checked with the collision checker, the first free one wins.
  The map aims 1.8 mm above the grasp point, and a side grasp whose configurations all
  collide is tried again tilted by 1.8° (wrist up): both inside IK's tolerances, they give
  the map the clearance over the table that IK finds there. With `fallback_ik`, bounded IK
  seeded from the candidates gets a try when they all collide; measured on 64 x 64 x 5
  heatmaps of the restaurant it changed 9 answers in 61,440 (candidates grazing the 1 cm
  clearance by < 0.1 mm) at about 40 ms per try (1,300 tries), so it is off by default.
- "ik" (the reference, slow): exhaustive Drake IK (`ik.solve_grasp_ik`) with the
  minimum-distance constraint, seeded with the map's candidates (when given a map), the
  arm's closed-form solutions at the target (every branch), stow and deterministic
  random configurations.

`check_many` gives exactly `check`'s answers for many base poses at once: the geometry is
vectorised in numpy (s3o_drake/feasibility/grasp_targets.py), out-of-reach queries are
settled without a collision query, and the collision checks go in batches through
`CheckConfigsCollisionFree`.
"""

from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np
import shapely

from s3o_drake.feasibility import ik
from s3o_drake.feasibility.grasp_targets import (
    RANDOM_SEEDS,
    GraspSpec,
    exhaustive_ik_seeds,
    grasp_specs,
    reach_offset_rows,
    target_geometry,
)
from s3o_drake.feasibility.grasps import Grasp, grasps_for
from s3o_drake.feasibility.reachability.map import ReachabilityMap, place
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.worker_processes import drake_parallelism

REASONS = ("ok", "base_collision", "out_of_reach", "arm_collision", "no_ik")
METHODS = ("map", "ik")
#: Bounded IK of the map method's fallback: seeds (the colliding map configurations, best
#: first) and SNOPT major iterations per seed.
FALLBACK_SEEDS = 3
FALLBACK_ITERATIONS = 20
#: The map aims this far (m) above the grasp point: inside IK's position tolerance, it gives
#: the fingertips and the wrist the same few millimetres of extra clearance over the table
#: that IK finds when it needs them (a reach target lowered by noise would otherwise put
#: the fingertips inside the 1 cm clearance, where IK simply lifts them).
MAP_LIFT = 0.9 * ik.POSITION_TOLERANCE
#: A side grasp whose exact configurations all collide is tried again tilted by this much
#: (inside IK's angle tolerance), approach axis dipping: the wrist, 0.3 m behind the grasp
#: point, then clears the table by 1 cm more, as IK finds it.
SIDE_PITCH = 0.9 * ik.ANGLE_TOLERANCE


@dataclass
class CheckResult:
    """The answer of one check.

    feasible: whether the robot can pick the dish from where it stands; q: its positions
    at the grasp (gripper open) when feasible, else None; grasp: "top" or "side" when
    feasible; reason: "ok", or why not: "base_collision" (the base itself collides),
    "out_of_reach" (no arm configuration reaches any grasp, obstacles aside),
    "arm_collision" (every configuration that reaches collides) or "no_ik" (exhaustive IK
    found nothing although the target is near the reach).
    """

    feasible: bool
    q: np.ndarray | None
    grasp: str | None
    reason: str


@dataclass
class _Batch:
    """Per-query arrays of one `_run`."""

    feasible: np.ndarray
    q: np.ndarray
    grasp: np.ndarray
    reason: np.ndarray


class FeasibilityChecker:
    """Motion-level feasibility checks in one scene (see the module docstring).

    `reachability` defaults to the scene's robot's shipped map for method "map"; method "ik"
    needs none and takes its candidates as extra seeds when given one. `fallback_ik` adds
    the map method's bounded IK for queries whose candidates all collide; it is off by
    default because it rarely changes an answer and costs tens of milliseconds per such
    query (see the module docstring). `exhaustive=False` makes method "ik" plain bounded IK
    from stow alone (a speed reference, not ground truth). `parallelize`
    lets the collision checker spread batches over its contexts.
    """

    def __init__(self, scene: FeasibilityScene, reachability: ReachabilityMap | None = None, *,
                 method: str = "map", fallback_ik: bool = False,
                 fallback_seeds: int = FALLBACK_SEEDS,
                 fallback_iterations: int = FALLBACK_ITERATIONS,
                 ik_iterations: int = ik.MAX_MAJOR_ITERATIONS, exhaustive: bool = True,
                 random_seeds: int = RANDOM_SEEDS, parallelize: bool = True):
        if method not in METHODS:
            raise ValueError(f"method: expected one of {METHODS}, got {method!r}")
        self.scene = scene
        self.method = method
        if reachability is None and method == "map":
            reachability = ReachabilityMap.shared(robot=scene.robot)
        self.reachability = reachability
        self.fallback_ik = fallback_ik
        self.fallback_seeds = fallback_seeds
        self.fallback_iterations = fallback_iterations
        self.ik_iterations = ik_iterations
        self.random_seeds = random_seeds
        self.exhaustive = exhaustive
        self.parallelize = parallelize
        self._specs: dict[str, list[GraspSpec]] = {}
        #: How many fallback IK solves ran and how many found a configuration.
        self.fallback_calls = 0
        self.fallback_successes = 0
        if method == "map":
            # One-time preparations up front (about 15 ms per dish and 0.3 s per grasp kind
            # of a new map), so that no check pays for them.
            for dish in scene.dishes:
                self._grasp_checker(dish)
                for spec in self._specs_for(dish):
                    self.reachability.prepare(spec.kind)

    def identity(self) -> tuple:
        """What its answers depend on besides the query (the oracle cache's key): the
        plant's contents (its chairs without their names), the obstacles' footprints (WKB),
        the padding, the method and its settings, and the reachability map's fingerprint."""
        obstacles = self.scene.obstacles
        shapes = shapely.to_wkb([obstacles.room, *obstacles.footprints])
        # A chair's name names its model instance and nothing a check depends on: a belief
        # (perceived_0, ...) and the true world (chair_1, ...) with the same chairs agree.
        contents = replace(self.scene.contents, chairs=tuple(
            replace(c, name="") for c in self.scene.contents.chairs))
        return (contents, b"".join(shapes), self.scene.padding, self.method,
                self.fallback_ik, self.fallback_seeds, self.fallback_iterations,
                self.ik_iterations, self.random_seeds, self.exhaustive,
                None if self.reachability is None else self.reachability.fingerprint)

    # ------------------------------------------------------------------------ public API
    def check(self, base: np.ndarray, dish: str,
              reach_offset: np.ndarray | None = None) -> CheckResult:
        """Whether the robot standing at `base` (x, y, yaw) can pick `dish`; see the module."""
        bases = np.asarray(base, dtype=float).reshape(1, 3)
        offsets = None if reach_offset is None else reach_offset_rows(reach_offset, 1)
        if self.method == "map":
            return self._check_one(bases, dish, offsets)
        out = self._run(bases, dish, offsets, details=True)
        feasible = bool(out.feasible[0])
        return CheckResult(
            feasible=feasible, q=out.q[0].copy() if feasible else None,
            grasp=self._specs_for(dish)[out.grasp[0]].kind if feasible else None,
            reason=REASONS[out.reason[0]])

    def check_many(self, bases: np.ndarray, dish: str,
                   reach_offsets: np.ndarray | None = None) -> np.ndarray:
        """`check(...).feasible` for base poses (n, 3) and reach offsets (n, 3): bool (n,)."""
        bases = np.asarray(bases, dtype=float).reshape(-1, 3)
        if reach_offsets is not None:
            reach_offsets = reach_offset_rows(reach_offsets, len(bases))
        if len(bases) == 0:
            return np.zeros(0, dtype=bool)
        return self._run(bases, dish, reach_offsets, details=False).feasible

    def grasps(self, base: np.ndarray, dish: str,
               reach_offset: np.ndarray | None = None) -> list[Grasp]:
        """The dish's grasps (with their world poses) from a base pose."""
        p_WD, table_height = self._target(dish, reach_offset)
        return grasps_for(self.scene.dishes[dish].kind, p_WD, table_height,
                          self.scene.p_WA(np.asarray(base, dtype=float)), robot=self.scene.robot)

    def first_grasps(self, bases: np.ndarray, dish: str, reach_offsets: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray, list[str | None]]:
        """`check`'s answers for base poses (n, 3) at once, as arrays: feasible (n,), the
        configurations q (n, the robot's positions) (NaN where infeasible) and the grasp kinds
        (None there)."""
        bases = np.asarray(bases, dtype=float).reshape(-1, 3)
        if reach_offsets is not None:
            reach_offsets = reach_offset_rows(reach_offsets, len(bases))
        if len(bases) == 0:
            return np.zeros(0, dtype=bool), np.zeros((0, self.scene.robot.num_positions)), []
        out = self._run(bases, dish, reach_offsets, details=False)
        specs = self._specs_for(dish)
        kinds = [specs[g].kind if ok else None
                 for g, ok in zip(out.grasp, out.feasible, strict=True)]
        return out.feasible, out.q, kinds

    def free_grasps(self, base: np.ndarray, dish: str,
                    reach_offset: np.ndarray | None = None) -> Iterator[CheckResult]:
        """Every feasible answer `check` could give, in its order (the first is `check`'s):
        the collision-free grasp configurations of the map method (the one IK solution of
        method "ik"). A base in collision gives one infeasible result with reason
        "base_collision" and nothing else. Picking needs more than a grasp (a pre-grasp, a
        lift), so `pickup_geometry` goes on to the next one when the first does not do."""
        bases = np.asarray(base, dtype=float).reshape(1, 3)
        offsets = None if reach_offset is None else reach_offset_rows(reach_offset, 1)
        if self.method == "map":
            results = self._map_grasps(bases[0], dish, offsets)
        else:
            results = iter([self.check(bases[0], dish, reach_offset)])
        for result in results:
            if result.feasible or result.reason == "base_collision":
                yield result

    # ------------------------------------------------------------------------- helpers
    def _specs_for(self, dish: str) -> list[GraspSpec]:
        return self._specs_for_kind(self.scene.dishes[dish].kind)

    def _specs_for_kind(self, kind: str) -> list[GraspSpec]:
        if kind not in self._specs:
            self._specs[kind] = grasp_specs(kind, robot=self.scene.robot)
        return self._specs[kind]

    def _target(self, dish: str, reach_offset: np.ndarray | None) -> tuple[np.ndarray, float]:
        p_WD, table_height = self.scene.dish_p_WD(dish)
        if reach_offset is not None:
            offset = reach_offset_rows(reach_offset, 1)[0]
            return p_WD + offset[:2], table_height + offset[2]
        return p_WD, table_height

    def _geometry(self, bases: np.ndarray, dish: str, offsets: np.ndarray | None):
        """Per spec: (ρ, h, bearing relative to A's x axis) arrays, each (n,)
        (`grasp_targets.target_geometry`)."""
        p_WD, table_height = self.scene.dish_p_WD(dish)
        return target_geometry(self._specs_for(dish), p_WD, table_height, bases, offsets,
                               robot=self.scene.robot)

    def base_free(self, bases: np.ndarray) -> np.ndarray:
        """Whether base poses (n, 3) are inside the room and collision-free with the arm
        stowed: bool (n,)."""
        bases = np.asarray(bases, dtype=float).reshape(-1, 3)
        return self._base_free(bases, np.arange(len(bases)))

    def _base_free(self, bases: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Collision-free with the arm stowed, for the queries `rows`: bool (len(rows),)."""
        if rows.size == 0:
            return np.zeros(0, dtype=bool)
        # Plan-view geometry settles most base poses for certain (`clearance`); Drake
        # answers the rest.
        free = self.scene.clearance.certainly_free(bases[rows, :2])
        open_ = np.flatnonzero(~free & self.scene.clearance.in_room(bases[rows, :2]))
        posed = self.scene.clearance.certainly_free_posed(bases[rows[open_]])
        free[open_[posed]] = True
        open_ = open_[~posed]
        collides = self.scene.collision.certainly_colliding(bases[rows[open_]])
        ask = open_[~collides]
        if ask.size:
            robot = self.scene.robot
            stowed = np.broadcast_to(robot.arm_stow, (ask.size, robot.num_arm_joints))
            qs = self._positions(bases[rows[ask]], stowed)
            free[ask] = self._check_configs(qs)
        return free

    def _positions(self, bases: np.ndarray, arms: np.ndarray) -> np.ndarray:
        gripper_open = self.scene.robot.gripper_open
        gripper = np.broadcast_to(gripper_open, (len(bases), len(gripper_open)))
        return np.concatenate([bases, arms, gripper], axis=1)

    def _grasp_checker(self, dish: str):
        """The scene's checker as inside `scene.grasping(dish)` (a cached clone)."""
        return ik.grasp_checker(self.scene, dish)

    def _check_configs(self, qs: np.ndarray, checker=None) -> np.ndarray:
        checker = self.scene.checker if checker is None else checker
        if len(qs) == 1:
            return np.array([checker.CheckConfigCollisionFree(qs[0])])
        free = checker.CheckConfigsCollisionFree(
            list(qs), parallelize=drake_parallelism() if self.parallelize else False)
        return np.asarray(free, dtype=bool)

    # ----------------------------------------------------------------------- the check
    def _run(self, bases: np.ndarray, dish: str, offsets: np.ndarray | None, *,
             details: bool) -> _Batch:
        n = len(bases)
        batch = _Batch(feasible=np.zeros(n, dtype=bool),
                       q=np.full((n, self.scene.robot.num_positions), np.nan),
                       grasp=np.full(n, -1), reason=np.full(n, REASONS.index("out_of_reach")))
        geometry = self._geometry(bases, dish, offsets)
        if self.method == "map":
            self._run_map(batch, bases, dish, offsets, geometry, details)
        else:
            self._run_ik(batch, bases, dish, offsets, geometry)
        return batch

    def _placed_candidates(self, spec_index: int, spec: GraspSpec, geometry, rows: np.ndarray,
                           pitch: float = 0.0, *,
                           compact: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The map's configurations for queries `rows`, turned to their bearing and wrist
        turn: (m, K, n) and validity (m, K), in the map's try order (valid slots first
        when `compact`)."""
        rho, h, bearing = (g[rows] for g in geometry[spec_index])
        q, valid = self.reachability.candidates_many(spec.kind, rho, h + MAP_LIFT, pitch=pitch)
        q = place(q, bearing[:, None], spec.wrist_turn, robot=self.scene.robot)
        if compact and not valid.all(axis=1).all():
            order = np.argsort(~valid, axis=1, kind="stable")
            q = np.take_along_axis(q, order[..., None], axis=1)
            valid = np.take_along_axis(valid, order, axis=1)
        return q, valid

    def _passes(self, dish: str) -> list[tuple[int, GraspSpec, float]]:
        """(grasp index, grasp, pitch) in the order the map method tries them: every grasp
        exactly, then side grasps tilted."""
        specs = self._specs_for(dish)
        passes = [(i, spec, 0.0) for i, spec in enumerate(specs)]
        return passes + [(i, spec, SIDE_PITCH) for i, spec in enumerate(specs)
                         if spec.kind == "side"]

    def _check_one(self, bases: np.ndarray, dish: str, offsets: np.ndarray | None) -> CheckResult:
        """`_run_map` for one query, without its batch bookkeeping (which would cost more
        than the collision checks): the same candidates, in the same order, against the same
        checkers, so the same answer."""
        return next(self._map_grasps(bases[0], dish, offsets))

    def _map_grasps(self, base: np.ndarray, dish: str,
                    offsets: np.ndarray | None) -> Iterator[CheckResult]:
        """The map method's collision-free grasp configurations for one query, in the order
        `check` tries them, then one infeasible result that says why there are no more."""
        robot = self.scene.robot
        geometry = self._geometry(base[None], dish, offsets)
        if not self.scene.clearance.in_room(base[:2])[0] or \
                not self.scene.checker.CheckConfigCollisionFree(
                    np.concatenate([base, robot.arm_stow, robot.gripper_open])):
            yield CheckResult(False, None, None, "base_collision")
            return
        checker = self._grasp_checker(dish)
        row = np.zeros(1, dtype=int)
        reachable = False
        for i, spec, pitch in self._passes(dish):
            q, valid = self._placed_candidates(i, spec, geometry, row, pitch, compact=False)
            reachable |= bool(valid[0].any())
            for arm in q[0][valid[0]]:
                q_full = np.concatenate([base, arm, robot.gripper_open])
                if checker.CheckConfigCollisionFree(q_full):
                    yield CheckResult(True, q_full, spec.kind, "ok")
        if reachable and self.fallback_ik:
            batch = _Batch(feasible=np.zeros(1, dtype=bool),
                           q=np.full((1, robot.num_positions), np.nan),
                           grasp=np.full(1, -1), reason=np.zeros(1, dtype=int))
            self._fallback(batch, 0, base, dish, None if offsets is None else offsets[0],
                           geometry)
            if batch.feasible[0]:
                yield CheckResult(True, batch.q[0].copy(), self._specs_for(dish)[
                    batch.grasp[0]].kind, "ok")
        yield CheckResult(False, None, None, "arm_collision" if reachable else "out_of_reach")

    def _run_map(self, batch: _Batch, bases, dish, offsets, geometry, details: bool) -> None:
        """Grasp by grasp: the map's candidates, the base check (once, when first needed:
        a query out of reach needs none, except for check()'s reason), then rounds of
        batched collision checks, each round trying every open query's next candidate."""
        reasons = REASONS.index
        n = len(bases)
        base_state = np.zeros(n, dtype=np.int8)  # 0 unknown, 1 free, -1 collides
        if details:
            base_state[:] = np.where(self._base_free(bases, np.arange(n)), 1, -1)
        reachable = np.zeros(n, dtype=bool)
        open_ = base_state >= 0
        checker = self._grasp_checker(dish)
        for i, spec, pitch in self._passes(dish):
            rows = np.flatnonzero(open_)
            if rows.size == 0:
                break
            q, valid = self._placed_candidates(i, spec, geometry, rows, pitch)
            keep = valid[:, 0]
            rows, q, valid = rows[keep], q[keep], valid[keep]
            reachable[rows] = True
            unknown = rows[base_state[rows] == 0]
            if unknown.size:
                base_state[unknown] = np.where(self._base_free(bases, unknown), 1, -1)
                open_[unknown[base_state[unknown] < 0]] = False
            keep = base_state[rows] > 0
            rows, q, valid = rows[keep], q[keep], valid[keep]
            for slot in range(valid.shape[1]):
                pick = np.flatnonzero(valid[:, slot] & open_[rows])
                if pick.size == 0:
                    break
                qs = self._positions(bases[rows[pick]], q[pick, slot])
                free = self._check_configs(qs, checker)
                won = rows[pick[free]]
                batch.feasible[won] = True
                batch.q[won] = qs[free]
                batch.grasp[won] = i
                open_[won] = False
        batch.reason[:] = reasons("out_of_reach")
        batch.reason[reachable & (base_state > 0)] = reasons("arm_collision")
        batch.reason[base_state < 0] = reasons("base_collision")
        batch.reason[batch.feasible] = reasons("ok")
        if self.fallback_ik:
            for row in np.flatnonzero(open_ & reachable & (base_state > 0)):
                self._fallback(batch, row, bases[row], dish,
                               None if offsets is None else offsets[row], geometry)

    def _fallback(self, batch: _Batch, row: int, base: np.ndarray, dish: str,
                  offset: np.ndarray | None, geometry) -> None:
        """Bounded IK seeded from the colliding map configurations, grasp by grasp."""
        grasps = self.grasps(base, dish, offset)
        for i, (spec, grasp) in enumerate(zip(self._specs_for(dish), grasps, strict=True)):
            q, valid = self._placed_candidates(i, spec, geometry, np.array([row]))
            seeds = q[0][valid[0]][:self.fallback_seeds]
            if len(seeds) == 0:
                continue
            self.fallback_calls += 1
            q = ik.solve_grasp_ik(self.scene, base, grasp, dish=dish, seeds=seeds,
                                  max_major_iterations=self.fallback_iterations)
            if q is not None:
                self.fallback_successes += 1
                batch.feasible[row] = True
                batch.q[row] = q
                batch.grasp[row] = i
                batch.reason[row] = REASONS.index("ok")
                return

    def _stored_seeds(self, spec_index: int, spec: GraspSpec, geometry, row: int) -> np.ndarray:
        """The map's candidates for one query (those the map method tries), if there is a
        map: IK seeded from them confirms every configuration the map finds."""
        if self.reachability is None:
            return np.zeros((0, self.scene.robot.num_arm_joints))
        pitches = (0.0, SIDE_PITCH) if spec.kind == "side" else (0.0,)
        parts = []
        for pitch in pitches:
            q, valid = self._placed_candidates(spec_index, spec, geometry, np.array([row]),
                                               pitch)
            parts.append(q[0][valid[0]])
        return np.vstack(parts)

    def _run_ik(self, batch: _Batch, bases, dish, offsets, geometry) -> None:
        rows = np.arange(len(bases))
        base_ok = self._base_free(bases, rows)
        batch.reason[~base_ok] = REASONS.index("base_collision")
        specs = self._specs_for(dish)
        for row in np.flatnonzero(base_ok):
            offset = None if offsets is None else offsets[row]
            grasps = self.grasps(bases[row], dish, offset)
            tried = False
            for i, (spec, grasp) in enumerate(zip(specs, grasps, strict=True)):
                if self.exhaustive:
                    rho, h, bearing = (g[row] for g in geometry[i])
                    seeds = exhaustive_ik_seeds(spec, rho, h, bearing, self.random_seeds,
                                                robot=self.scene.robot)
                    stored = self._stored_seeds(i, spec, geometry, row)
                    if seeds is None and len(stored) == 0:
                        continue
                    seeds = np.vstack([stored] + ([] if seeds is None else [seeds]))
                else:
                    seeds = self.scene.robot.arm_stow[None, :]
                tried = True
                q = ik.solve_grasp_ik(self.scene, bases[row], grasp, dish=dish, seeds=seeds,
                                      max_major_iterations=self.ik_iterations)
                if q is not None:
                    batch.feasible[row] = True
                    batch.q[row] = q
                    batch.grasp[row] = i
                    batch.reason[row] = REASONS.index("ok")
                    break
            if not batch.feasible[row]:
                batch.reason[row] = REASONS.index("no_ik" if tried else "out_of_reach")

