"""A collision checker that speaks the robot's positions (`Robot.joints` order).

Drake's `SceneGraphCollisionChecker` takes configurations over its plant's positions, all of
them: its configuration space is the plant's, whatever the robot model instances. For a
robot that is one model instance alone in its plant (the UR5e, the Panda) those are the
robot's positions. A robot of parts has more: the Gen3's plant has 16 positions for its 11
(base 3, arm 7, gripper 1), the other five being the Robotiq 2F-85's mimic joints, coupler
constraints in Drake that follow the knuckle joint. They are not degrees of freedom of the
robot, but the checker cannot be told so: a configuration must give them, and a plant
configuration with them not where their constraints put them is one the robot never takes.

So `RobotChecker` wraps the checker and lifts the robot's positions to the plant's at each
call (`world.robot.PositionMap`). Callers (the feasibility checks, the arm's planner, the
navigator) keep speaking the robot's positions. This is sound for edges too: the lift is
affine (a mimic joint is multiplier x leader + offset), so the checker's straight line
between two lifted configurations is the lift of the straight line between them in the
robot's positions, and every configuration it checks along an edge is one the robot takes.
Its distance (which sets how finely an edge is stepped) counts the mimic joints as well:
an edge that moves the fingers is stepped at least as finely as in the robot's positions,
never more coarsely, and an edge that moves only the arm exactly as finely.

For a single-instance robot the lift is the identity: the arrays are passed on as they are,
so its answers, and its plans, are those of the bare checker.
"""

import numpy as np
from pydrake.planning import SceneGraphCollisionChecker

from s3o_drake.world.robot import PositionMap


class RobotChecker:
    """`SceneGraphCollisionChecker`'s queries over the robot's positions.

    Configurations are the robot's positions (`Robot.joints` order); the methods that take
    none (collision filters, paddings, the plant) are the checker's. `inner` is the Drake
    checker itself, over the plant's positions."""

    def __init__(self, inner: SceneGraphCollisionChecker, positions: PositionMap):
        self.inner = inner
        self.positions = positions
        """The robot's positions among the checker's plant's."""

    # --- configurations: the robot's positions ------------------------------------------
    def CheckConfigCollisionFree(self, q: np.ndarray, *args) -> bool:
        return self.inner.CheckConfigCollisionFree(self.positions.to_plant(q), *args)

    def CheckConfigsCollisionFree(self, configs, **kwargs) -> list[bool]:
        if not self.positions.is_identity:
            configs = list(self.positions.to_plant(np.asarray(configs, dtype=float)))
        return self.inner.CheckConfigsCollisionFree(configs, **kwargs)

    def CheckEdgeCollisionFree(self, q1: np.ndarray, q2: np.ndarray, *args) -> bool:
        lift = self.positions.to_plant
        return self.inner.CheckEdgeCollisionFree(lift(q1), lift(q2), *args)

    def ComputeConfigurationDistance(self, q1: np.ndarray, q2: np.ndarray) -> float:
        lift = self.positions.to_plant
        return self.inner.ComputeConfigurationDistance(lift(q1), lift(q2))

    def CalcRobotClearance(self, q: np.ndarray, influence_distance: float, *args):
        return self.inner.CalcRobotClearance(self.positions.to_plant(q), influence_distance,
                                             *args)

    def position_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """The robot's position limits (lower, upper), from the plant."""
        plant, robot = self.inner.plant(), self.positions.to_robot
        return (robot(plant.GetPositionLowerLimits()), robot(plant.GetPositionUpperLimits()))

    # --- the rest: the checker's ----------------------------------------------------------
    def plant(self):
        return self.inner.plant()

    def edge_step_size(self) -> float:
        return self.inner.edge_step_size()

    def Clone(self) -> "RobotChecker":
        return RobotChecker(self.inner.Clone(), self.positions)

    def GetFilteredCollisionMatrix(self):
        return self.inner.GetFilteredCollisionMatrix()

    def SetCollisionFilterMatrix(self, matrix) -> None:
        self.inner.SetCollisionFilterMatrix(matrix)

    def SetCollisionFilteredBetween(self, *args) -> None:
        self.inner.SetCollisionFilteredBetween(*args)

    def SetPaddingAllRobotRobotPairs(self, padding: float) -> None:
        self.inner.SetPaddingAllRobotRobotPairs(padding)
