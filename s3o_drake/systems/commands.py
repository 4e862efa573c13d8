"""The messages the execution systems pass on their abstract-valued ports.

The planner (`S3OPlanner`) numbers the plan's actions 1, 2, ... and emits at most one
command per controller at a time; a controller starts a command when its `id` changes and
reports on its status port, with the same `id`, when the command is done or has failed. The
planner advances when the status of its current command says done (or gives up on a failed
pickup and goes on with the next action, or stops at a failed goto). Id 0 means "no
command": controllers hold still.

All are frozen dataclasses: a port value is copied by Drake, and nothing may change it in
place.
"""

from dataclasses import dataclass

from s3o_drake.planning.time_model import CONTROL_PERIOD  # noqa: F401 (the systems' period)

NO_COMMAND = 0


@dataclass(frozen=True)
class BaseCommand:
    """Drive along `path` (the navigation map's waypoints, m; the first is where the base
    is) and end at `pose` = (x, y, yaw); `id` 0 is no command. A `turn` turns in place to
    the pose's yaw (its x, y are where the base stands) and lands without the navigation
    noise T^n, which models arriving from a drive."""

    id: int = NO_COMMAND
    path: tuple[tuple[float, float], ...] = ()
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    turn: bool = False


@dataclass(frozen=True)
class PickCommand:
    """Pick `dish` from where the base stands and put it on the tray; `id` 0 is none."""

    id: int = NO_COMMAND
    dish: str = ""


@dataclass(frozen=True)
class Status:
    """A controller's report on command `id`: state "idle" (no command yet), "running",
    "done" or "failed", with the failure's `reason` (e.g. "no_ik", "no_path", "missed",
    "base_collision", "blocked")."""

    id: int = NO_COMMAND
    state: str = "idle"
    reason: str = ""

    @property
    def finished(self) -> bool:
        return self.state in ("done", "failed")


@dataclass(frozen=True)
class GripEvent:
    """What the gripper holds: `dish` ("" for nothing). The arm controller outputs it and
    the object tracker follows it: a dish named here moves with the gripper from the
    moment it appears; when it disappears, the dish lands on the tray if it is in `placed`
    (the dishes the arm has put down on the tray so far), else it is dropped where it is."""

    dish: str = ""
    placed: tuple[str, ...] = ()


@dataclass(frozen=True)
class PlanProgress:
    """The planner's progress through its plan, for the task monitor.

    `step`: the action being executed (1-based; 0 before a plan exists), of `total`.
    `finished`: nothing more will happen (plan done, or it cannot go on: `reason` says
    why, e.g. "plan complete", "goto 3 failed: blocked", "no plan: ...").
    `outcomes`: per finished action, (action, argument, "done" or "failed: <reason>").
    """

    step: int = 0
    total: int = 0
    finished: bool = False
    reason: str = ""
    outcomes: tuple[tuple[str, str, str], ...] = ()
