"""The world as the feasibility checks see it: a RobotDiagram and a collision checker.

A `FeasibilityScene` holds the robot, the tables, the dishes and the chairs of a room in a
`RobotDiagram` (plant + scene graph, no simulation), and a `SceneGraphCollisionChecker` with
a padding between robot and environment, asked in the robot's positions (`RobotChecker`:
a robot of parts has more positions in the plant than its own). Which room it holds
is the caller's choice: the true world's (`Scenario.contents`: ground truth, for labels and
the execution's judge) or a belief's (`KnownWorld.contents`: what a planner may know; the
planner's one scene per plan is `feasibility.planning_scene.PlanningScene`).
"""

from collections.abc import Iterator
from contextlib import contextmanager
from functools import cached_property

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.tree import RigidBody
from pydrake.planning import RobotDiagramBuilder, SceneGraphCollisionChecker

from s3o_drake.feasibility.clearance import (
    BaseClearance,
    CertainCollision,
    robot_horizontal_radius,
    robot_plan_extent,
)
from s3o_drake.feasibility.robot_checker import RobotChecker
from s3o_drake.world.builder import populate_plant
from s3o_drake.world.contents import SceneContents
from s3o_drake.world.obstacles import Obstacles
from s3o_drake.world.worker_processes import drake_parallelism

# Robot-environment clearance of a feasible configuration (m): the arm stays at least 1 cm
# from every obstacle, and the base keeps the same small margin.
ENVIRONMENT_PADDING = 0.01
# Collision checker edge step (rad or m); only used when checking motions.
EDGE_STEP = 0.05


class FeasibilityScene:
    """Robot and environment for IK and collision queries, built once per scene."""

    def __init__(self, contents: SceneContents, *, padding: float = ENVIRONMENT_PADDING,
                 obstacles: Obstacles | None = None):
        """`obstacles`: the footprints of the room's furniture, when the caller has them
        already (a KnownWorld's); made from `contents` otherwise."""
        self.contents = contents
        builder = RobotDiagramBuilder(time_step=0.0)
        self.models = populate_plant(builder.plant(), builder.scene_graph(), contents)
        builder.plant().Finalize()
        self.diagram = builder.Build()
        self.plant = self.diagram.plant()
        self.robot = contents.robot
        self.robot_instances = self.models.robot
        """The robot in the plant: its model instances (one, or one per part)."""
        self.positions = self.robot_instances.position_map()
        """The robot's positions among the plant's (the identity for a robot that is one
        model instance)."""
        # Every instance of the robot is the robot's. Drake's checker takes the plant's
        # positions (a robot of parts has mimic joints among them, which follow); the
        # scene's checker takes the robot's and lifts them (`robot_checker`).
        self.checker = RobotChecker(SceneGraphCollisionChecker(
            model=self.diagram, robot_model_instances=list(self.robot_instances.instances),
            edge_step_size=EDGE_STEP, env_collision_padding=padding,
            implicit_context_parallelism=drake_parallelism()), self.positions)
        """The collision checker over the robot's positions (`Robot.joints` order)."""
        self.table_height = {t.name: t.height for t in contents.tables}
        self.dishes = {d.name: d for d in contents.dishes}
        self.grasp_frame = self.robot_instances.frame(self.robot.grasp_frame)
        self.arm_base_frame = self.robot_instances.frame(self.robot.arm_base_link)
        context = self.plant.CreateDefaultContext()
        inspector = self.diagram.scene_graph().model_inspector()
        extent = robot_plan_extent(self.plant, inspector, self.robot_instances, context)
        self.robot_radius = robot_horizontal_radius(extent)
        """Horizontal reach (m) of the robot's collision geometry with the arm stowed."""
        self.padding = padding
        self._keep_from_unmapped_chairs(padding + contents.unmapped_chairs_margin)
        self.obstacles = Obstacles.of_contents(contents) if obstacles is None else obstacles
        self.clearance = BaseClearance(self.obstacles, robot_extent=extent, padding=padding)
        self.collision = CertainCollision.of_scene(self.plant, inspector,
                                                   self.robot_instances, context)
        """Base positions that need no collision query (see `clearance`)."""

    def _keep_from_unmapped_chairs(self, padding: float) -> None:
        """The arm's and the gripper's padding against the chairs not on the map, where
        their placement is uncertain. The base's stays: its clearance is the footprint's
        (`clearance`), the same in every direction, and its protective stop watches what
        it drives past."""
        if padding == self.padding:
            return
        on_base = {b.index() for b in self.base_bodies}
        arm = [self.plant.get_body(i) for i in self.robot_instances.body_indices()
               if i not in on_base]
        chairs = [self.plant.GetBodyByName("chair", self.models.chairs[c.name])
                  for c in self.contents.chairs if not c.mapped]
        for body in arm:
            for chair in chairs:
                self.checker.inner.SetPaddingBetween(body, chair, padding)

    def q(self, base: np.ndarray, arm: np.ndarray | None = None,
          gripper: np.ndarray | None = None) -> np.ndarray:
        """The robot's positions for a base pose (x, y, yaw) and arm (default
        stowed, the gripper open)."""
        return self.robot.positions(*base, arm=arm, gripper=gripper)

    def p_WA(self, base: np.ndarray) -> np.ndarray:
        """Where the arm's base frame A is, for a base pose (x, y, yaw)."""
        x, y, yaw = base
        c, s = np.cos(yaw), np.sin(yaw)
        mx, my, mz = self.robot.arm_mount_xyz
        return np.array([x + c * mx - s * my, y + s * mx + c * my, mz])

    def dish_p_WD(self, name: str) -> tuple[np.ndarray, float]:
        """A dish's (x, y) and the height of the surface it stands on (`surface_height`)."""
        dish = self.dishes[name]
        return np.array(dish.position, dtype=float), self.table_height[dish.table] + \
            dish.elevation

    def dish_body(self, name: str):
        return self.plant.GetBodyByName("dish", self.models.dishes[name])

    @contextmanager
    def grasping(self, name: str) -> Iterator[None]:
        """Within it, the gripper may touch the dish `name` (the one it grasps)."""
        dish = self.dish_body(name)
        bodies = [self.robot_instances.body(b) for b in self.robot.gripper_bodies]
        for body in bodies:
            self.checker.SetCollisionFilteredBetween(body, dish, True)
        try:
            yield
        finally:
            for body in bodies:
                self.checker.SetCollisionFilteredBetween(body, dish, False)

    @cached_property
    def base_bodies(self) -> list[RigidBody]:
        """The robot's bodies welded to its base link: they move only as the base moves."""
        base = self.robot_instances.body(self.robot.base_link)
        return list(self.plant.GetBodiesWeldedTo(base))

    @cached_property
    def standing_checker(self) -> RobotChecker:
        """A clone of `checker` without the padding between the base and the world: for the
        arm's motions while the base stands, which the base's own distance to the world
        does not change. A base that stopped inside the padding (a protective stop, a
        landing off by the localisation's error) may still move its arm."""
        clone = self.checker.Clone()
        for body in self.base_bodies:
            clone.inner.SetPaddingOneRobotBodyAllEnvironmentPairs(body.index(), 0.0)
        return clone

    def arm_checker(self, q: np.ndarray) -> RobotChecker:
        """The checker for the arm's motions from `q` with the base standing: `checker`,
        or, where `q` is in collision only by the base's padding, `standing_checker`."""
        if self.checker.CheckConfigCollisionFree(q):
            return self.checker
        return self.standing_checker

    def grasp_pose(self, q: np.ndarray) -> RigidTransform:
        """X_WG of the grasp frame at the robot positions q."""
        context = self.plant.CreateDefaultContext()
        self.robot_instances.set_positions(context, q)
        return self.grasp_frame.CalcPoseInWorld(context)
