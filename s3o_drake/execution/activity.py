"""What the robot did over time: when its base and its arm moved, from the simulated
robot's own state (its joints' velocities), for the run's timeline (viz/timeline.py)."""

from dataclasses import dataclass

import numpy as np

from s3o_drake.world.robot import Robot

BASE_MOVING = 0.02
"""The base moves when its speed exceeds this (m/s)..."""
BASE_TURNING = 0.05
"""...or its yaw rate this (rad/s): the arm's motions push the PD-held base by less."""
ARM_MOVING = 0.02
"""The arm moves when one of its joints or fingers does, faster than this (rad/s, m/s)."""


@dataclass(frozen=True)
class Activity:
    """The robot's motion sampled over a run: times `t` (s, simulated), the base's speed
    (m/s) and yaw rate (rad/s), and the arm's fastest joint or finger (rad/s or m/s)."""

    t: np.ndarray
    base_speed: np.ndarray
    yaw_rate: np.ndarray
    arm_speed: np.ndarray

    @classmethod
    def of(cls, times: np.ndarray, states: np.ndarray, *, robot: Robot) -> "Activity":
        """From logged states of `robot` (2 robot.num_positions, n): positions then
        velocities."""
        v = np.asarray(states, dtype=float)[robot.num_positions:]
        arm = np.vstack([v[robot.arm_positions], v[robot.gripper_positions]])
        return cls(np.asarray(times, dtype=float), np.hypot(v[0], v[1]), np.abs(v[2]),
                   np.abs(arm).max(axis=0) if arm.size else np.zeros(len(times)))

    @property
    def base_moving(self) -> np.ndarray:
        return (self.base_speed > BASE_MOVING) | (self.yaw_rate > BASE_TURNING)

    @property
    def arm_moving(self) -> np.ndarray:
        return self.arm_speed > ARM_MOVING

    def together(self) -> float:
        """Seconds in which the base and the arm moved at once."""
        if len(self.t) < 2:
            return 0.0
        dt = np.diff(self.t)
        return float((dt * (self.base_moving & self.arm_moving)[:-1]).sum())

    def by_motion(self) -> dict[str, float]:
        """Seconds of the run in each of five kinds of motion, which add up to its length:
        "drive" (the base translates, the arm is still), "turn" (the base turns in place,
        the arm is still), "together" (the base and the arm move at once), "arm" (the arm
        moves, the base is at rest) and "still" (neither moves: a grasp's settling, a
        wait). Where a smooth motion's time goes, against stop-and-go's."""
        if len(self.t) < 2:
            return dict.fromkeys(("drive", "turn", "together", "arm", "still"), 0.0)
        dt = np.diff(self.t)
        translating = (self.base_speed > BASE_MOVING)[:-1]
        base, arm = self.base_moving[:-1], self.arm_moving[:-1]
        kinds = {"drive": translating & ~arm, "turn": base & ~translating & ~arm,
                 "together": base & arm, "arm": arm & ~base, "still": ~base & ~arm}
        return {name: float(dt[mask].sum()) for name, mask in kinds.items()}

