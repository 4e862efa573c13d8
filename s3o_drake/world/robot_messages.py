"""What passes between the robot and its controllers: the commands a robot obeys and what
its sensors report.

The controllers (execution/) act on these and on what the robot was told (the briefing),
never on the simulation's truth; the simulated robot (world/) answers them as a robot
would. All are immutable values: Drake copies port values, and nothing may change them in
place.
"""

from dataclasses import dataclass

#: The random stream of a reach, in `numpy.random.default_rng([seed, REACH_STREAM,
#: command id])`, shared by the two sides in this order: the robot's sensor draws the
#: sensing error of the command's target first (two normal draws, x then y), and the arm's
#: motion planner then takes its seed from the stream's next integer. So a seed fixes each
#: reach whatever ran before it, and the planner's seed is the same with the noise off.
REACH_STREAM = 2


@dataclass(frozen=True)
class GripEvent:
    """What the arm closes its fingers on: `dish` ("" for nothing), `placed` (the dishes the
    arm has put down on the tray so far) and `put` (the objects it has put down at their
    places). The simulated robot follows it by its grasp rules (world/object_tracker.py):
    the fingers catch the dish named here if it is within the gripper's tolerance of where
    they close; when it is no longer named, a caught dish lands on the tray if it is in
    `placed`, comes to stand on the surface below it if it is in `put`, and is dropped where
    it is otherwise."""

    dish: str = ""
    placed: tuple[str, ...] = ()
    put: tuple[str, ...] = ()


@dataclass(frozen=True)
class TargetRequest:
    """The arm asks the robot's sensor where `target` is (a dish, or the place target an
    object is put down at), for reach command `id`; `target` "" asks for nothing."""

    id: int = 0
    target: str = ""


@dataclass(frozen=True)
class TargetSighting:
    """The sensor's answer to `TargetRequest` `id`: where it sees `target`, `p_WT` (x, y;
    m, in the world frame as the robot's localisation places it), None when it does not
    see it (no such target)."""

    id: int = 0
    target: str = ""
    p_WT: tuple[float, float] | None = None  # noqa: N815 (monogram notation)


@dataclass(frozen=True)
class GripperStatus:
    """The gripper's report, as a parallel gripper's driver gives it: `object_detected`,
    the fingers stopped on something as they closed (they hold an object)."""

    object_detected: bool = False

