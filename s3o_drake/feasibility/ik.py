"""Full Drake inverse kinematics for one grasp: the slow, exact reference of the checks.

`solve_grasp_ik` asks SNOPT (through `InverseKinematics`) for the robot's positions with the
base held at a given pose, the arm within its joint limits, the fingers open, the grasp frame
G at the grasp pose X_WG (position within `position_tolerance`, orientation within
`angle_tolerance`) and every pair of geometries at least `min_distance` apart
(`MinimumDistanceLowerBoundConstraint` over the scene graph) except the gripper and the dish
it grasps, which touch by design. It tries seeds in turn and returns the first solution that
an independent check confirms (forward kinematics, and `scene.checker` inside
`scene.grasping(dish)`), or None.

SNOPT's major iterations are capped: from a seed near a solution it finishes in 1-3 ms, while
an infeasible problem costs 30-50 ms per seed (and would run longer uncapped). Seeds matter
more than iterations: from stow or a random configuration SNOPT rarely finds a grasp that
exists (it ends in the local minimum of another IK branch), so "exhaustive IK", the reference
the reachability map must agree with (method "ik" of `s3o_drake.feasibility.check`), seeds
this with the arm's closed-form solutions of every branch, the map's candidates, stow and
random configurations.
"""

import math
import weakref

import numpy as np
from pydrake.geometry import CollisionFilterDeclaration, GeometrySet
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.solvers import SnoptSolver, SolverOptions

from s3o_drake.feasibility import kinematics as kin
from s3o_drake.feasibility.grasps import Grasp
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.robot import Robot

#: Grasp-frame tolerances of an IK solution.
POSITION_TOLERANCE = 0.002
ANGLE_TOLERANCE = math.radians(2.0)
#: Clearance from every obstacle (m); the collision checker's padding is the same.
MIN_DISTANCE = 0.01
#: IK asks for this much more clearance than it verifies, so that a solution pressed against
#: the constraint is not rejected by the checker's own distance computation.
DISTANCE_MARGIN = 0.0001
#: SNOPT's major iteration cap per seed: enough for a seed near a solution, and it bounds the
#: time lost on an infeasible problem.
MAX_MAJOR_ITERATIONS = 60
#: Slack when verifying a solution's pose, above the solver's tolerances.
VERIFY_SLACK = 1e-4

_contexts: "weakref.WeakKeyDictionary[FeasibilityScene, dict]" = weakref.WeakKeyDictionary()
_checkers: "weakref.WeakKeyDictionary[FeasibilityScene, dict]" = weakref.WeakKeyDictionary()


def grasp_checker(scene: FeasibilityScene, dish: str):
    """A clone of `scene.checker` made inside `scene.grasping(dish)` (cached per scene).

    Changing a checker's collision filters takes milliseconds (entering and leaving
    `grasping` costs more than a dozen collision checks); a clone keeps the filters of that
    context for good and leaves the scene's own checker untouched.
    """
    per_scene = _checkers.setdefault(scene, {})
    if dish not in per_scene:
        # One matrix update on the clone: the same filters as `scene.grasping(dish)`,
        # without paying for toggling them on the scene's checker and back.
        checker = scene.checker.Clone()
        filtered = np.array(checker.GetFilteredCollisionMatrix())
        d = int(scene.dish_body(dish).index())
        for name in scene.robot.gripper_bodies:
            g = int(scene.robot_instances.body(name).index())
            filtered[g, d] = filtered[d, g] = 1
        checker.SetCollisionFilterMatrix(filtered)
        per_scene[dish] = checker
    return per_scene[dish]


def _diagram_context(scene: FeasibilityScene, dish: str):
    """A diagram context of the scene in which the gripper may touch `dish` (cached)."""
    per_scene = _contexts.setdefault(scene, {})
    if dish not in per_scene:
        context = scene.diagram.CreateDefaultContext()
        plant, scene_graph = scene.plant, scene.diagram.scene_graph()
        gripper = GeometrySet()
        for name in scene.robot.gripper_bodies:
            body = scene.robot_instances.body(name)
            gripper.Add(plant.GetCollisionGeometriesForBody(body))
        dish_geometries = GeometrySet(plant.GetCollisionGeometriesForBody(scene.dish_body(dish)))
        sg_context = scene_graph.GetMyMutableContextFromRoot(context)
        scene_graph.collision_filter_manager(sg_context).Apply(
            CollisionFilterDeclaration().ExcludeBetween(gripper, dish_geometries))
        per_scene[dish] = context
    return per_scene[dish]


def random_arm_seeds(count: int, seed: int = 0, *, robot: Robot) -> np.ndarray:
    """`count` deterministic configurations of `robot`'s arm spread over the joints' working
    ranges."""
    return kin.arm_kinematics(robot).random_configurations(count, seed)


def solve_or_none(solver, prog, guess: np.ndarray, options):
    """`solver.Solve`, or None where evaluating the program threw: a signed distance
    between two capsules that just touch can fail in the collision library's GJK/EPA
    ("Error with configuration"), which is a failed attempt from that seed, not an error of
    the whole check."""
    try:
        return solver.Solve(prog, guess, options)
    except RuntimeError as e:
        if "Error with configuration" not in str(e):
            raise
        return None


def grasp_error(scene: FeasibilityScene, q: np.ndarray,
                X_WG: RigidTransform) -> tuple[float, float]:
    """(angle (rad), distance (m)) between the grasp frame at positions q and X_WG."""
    X = scene.grasp_pose(q)
    angle = (X.rotation().inverse() @ X_WG.rotation()).ToAngleAxis().angle()
    return abs(float(angle)), float(np.linalg.norm(X.translation() - X_WG.translation()))


def verify(scene: FeasibilityScene, q: np.ndarray, dish: str, X_WG: RigidTransform, *,
           position_tolerance: float = POSITION_TOLERANCE,
           angle_tolerance: float = ANGLE_TOLERANCE) -> bool:
    """Whether positions q grasp X_WG within tolerance, within limits and collision-free
    (`scene.checker` as inside `scene.grasping(dish)`: the gripper may touch the dish)."""
    plant, robot = scene.plant, scene.positions.to_robot
    lower = robot(plant.GetPositionLowerLimits())
    upper = robot(plant.GetPositionUpperLimits())
    if np.any(q < lower - 1e-9) or np.any(q > upper + 1e-9):
        return False
    angle, distance = grasp_error(scene, q, X_WG)
    if angle > angle_tolerance + VERIFY_SLACK or distance > position_tolerance + VERIFY_SLACK:
        return False
    return bool(grasp_checker(scene, dish).CheckConfigCollisionFree(q))


def solve_grasp_ik(scene: FeasibilityScene, base: np.ndarray, grasp: Grasp, *, dish: str,
                   seeds: np.ndarray | None = None, min_distance: float = MIN_DISTANCE,
                   max_major_iterations: int = MAX_MAJOR_ITERATIONS,
                   position_tolerance: float = POSITION_TOLERANCE,
                   angle_tolerance: float = ANGLE_TOLERANCE) -> np.ndarray | None:
    """The robot's positions grasping `grasp` with the base at `base`, or None.

    `base` is (x, y, yaw); `dish` names the dish being grasped (the gripper may touch it,
    nothing else); `seeds` are arm configurations (k, n) tried in order (default: the stow
    configuration and a few deterministic random ones). A solution is returned only if it
    passes `verify`.
    """
    plant, robot = scene.plant, scene.robot
    context = _diagram_context(scene, dish)
    plant_context = plant.GetMyMutableContextFromRoot(context)
    ik = InverseKinematics(plant, plant_context, with_joint_limits=True)
    q = ik.q()
    prog = ik.get_mutable_prog()
    base = np.asarray(base, dtype=float)
    # IK's variables are the plant's positions; the robot's are among them (`positions`).
    positions = scene.positions
    indices = positions.indices
    prog.AddBoundingBoxConstraint(base, base, q[indices[:robot.num_base_joints]])
    prog.AddBoundingBoxConstraint(robot.gripper_open, robot.gripper_open,
                                  q[indices[robot.arm_positions.stop:]])
    others = np.setdiff1d(np.arange(plant.num_positions()), indices)
    if others.size:
        # A robot of parts' mimic joints (IK knows no coupler constraints) stay where the
        # open gripper puts them.
        q_open = positions.to_plant(scene.q(base))
        prog.AddBoundingBoxConstraint(q_open[others], q_open[others], q[others])
    p_WG = grasp.X_WG.translation()
    ik.AddPositionConstraint(
        frameB=scene.grasp_frame, p_BQ=np.zeros(3), frameA=plant.world_frame(),
        p_AQ_lower=p_WG - position_tolerance, p_AQ_upper=p_WG + position_tolerance)
    ik.AddOrientationConstraint(
        frameAbar=plant.world_frame(), R_AbarA=grasp.X_WG.rotation(),
        frameBbar=scene.grasp_frame, R_BbarB=RotationMatrix(), theta_bound=angle_tolerance)
    ik.AddMinimumDistanceLowerBoundConstraint(min_distance + DISTANCE_MARGIN)

    solver = SnoptSolver()
    options = SolverOptions()
    options.SetOption(solver.solver_id(), "Major iterations limit", int(max_major_iterations))
    if seeds is None:
        seeds = np.vstack([robot.arm_stow, random_arm_seeds(3, robot=robot)])
    for arm in np.asarray(seeds, dtype=float).reshape(-1, robot.num_arm_joints):
        guess = positions.to_plant(scene.q(base, arm))
        result = solve_or_none(solver, prog, guess, options)
        if result is None or not result.is_success():
            continue
        q_sol = positions.to_robot(result.GetSolution(q))
        if verify(scene, q_sol, dish, grasp.X_WG, position_tolerance=position_tolerance,
                  angle_tolerance=angle_tolerance):
            return q_sol
    return None
