"""The named choices of a scenario's settings (methods, feasibility sources, cost profiles,
recovery modes). Nothing heavy is imported here, so that the commands can name the choices in
their --help before they import Drake."""

from enum import Enum

# The methods of the paper's comparison: S3O-GROP* and its ablations and baselines.
METHODS = ("S3O-GROP*", "S3O-GROP", "V-GROP*", "V-GROP", "V-PETLON", "S3O-Random",
           "S3O-Random-Paper")


# Where the planner's Fea^m heatmaps come from: the Drake check, or the learned network.
class FeasibilitySource(str, Enum):
    """Where the planner's Fea^m heatmaps come from (the field `planner.feasibility` holds
    the value: yaml_load_typed reads no Enum)."""

    ORACLE = "oracle"
    """The Drake check of the known world under the noise model."""
    FCN = "fcn"
    """The network of models/ur5e/fcn/, on the overhead depth image."""


FEASIBILITY_SOURCES = tuple(s.value for s in FeasibilitySource)
# The utility's costs: our robot's recorded time model, or the paper's values.
COST_PROFILES = ("robot", "paper")
# How Fea^t of a merged location draws its positions: each dish by its own Fea^m (the paper's
# code), or all of the group's dishes at the same positions, drawn by their joint value.
GROUP_POSITIONS = ("per_dish", "shared")
# The price of a location in the ranking: the paper's γ / λ, or the motion search's own.
LOCATION_PRICES = ("paper", "search")
# What a pickup that may fail costs the utility: the paper's λ whatever the execution does,
# or what it costs in the execution's mode (open loop: the dish, λ; with recovery: the
# recovery's recorded time).
FAILURE_PRICES = ("paper", "execution")


class SharedStop(str, Enum):
    """How a pickup at a stop that serves several dishes is rated (the field
    `planner.shared_stop` holds the value)."""

    PAPER = "paper"
    """At its Fea^m, as every pickup."""
    EXECUTION = "execution"
    """In open loop, at the share of its Fea^m that executed pickups at stops of its size
    achieved (abstraction/shared_stop.py); with recovery at its Fea^m, as the recovery's
    price of a failure was measured."""


SHARED_STOPS = tuple(s.value for s in SharedStop)


class Recovery(str, Enum):
    """What execution does when an action fails (the field `execution.recovery` holds the
    value)."""

    NONE = "none"
    """The paper's open loop: a failed pickup is given up, a blocked drive ends the run."""
    RETRY = "retry"
    """Check each stop from the localised pose, correct it by a short move, retry a failed
    pickup."""
    REPLAN = "replan"
    """All of retry, and a replan of the dishes that remain after a blocked drive or a dish
    that fails all its tries."""


RECOVERY_MODES = tuple(r.value for r in Recovery)


class Motion(str, Enum):
    """How the robot moves (the field `execution.motion` holds the value;
    planning/navigation/base_motion.py has the arithmetic)."""

    SMOOTH = "smooth"
    """The base keeps moving through its path's corners, turning as it drives, and the arm
    leaves and returns to its stow while the base drives."""
    STOP_AND_GO = "stop_and_go"
    """The paper's motion: the base stops and turns in place at every corner, and the arm
    moves only while the base stands still."""


MOTIONS = tuple(m.value for m in Motion)


class Localization(str, Enum):
    """Where the error of the robot's localisation enters a run (the field
    `uncertainty.localization` holds the value)."""

    AT_STOPS = "at_stops"
    """The paper's model: the robot reports its true pose, and the executive adds the error
    where it judges a stop."""
    REPORTED = "reported"
    """The robot reports its pose as its localisation estimates it (odometry corrected by
    scans matched to its map: world/localisation.py), and its controllers act on that
    report."""


LOCALIZATIONS = tuple(m.value for m in Localization)


class Goal(str, Enum):
    """What the task wants done with an object (the field `dishes[i].goal` holds the value)."""

    COLLECT = "collect"
    """Picked and carried away on the tray (the restaurant's dishes)."""
    PLACE = "place"
    """Picked, held in the gripper, and put down at its `place`."""
    STAY = "stay"
    """Left where it is: something another object is placed on (a plate for an apple)."""


GOALS = tuple(g.value for g in Goal)

CALIBRATION_GROUPINGS = ("all", "method", "source", "action", "stop", "facing", "turn",
                         "order", "distance")
"""How the calibration of Fea^m groups executed records: all together, by method, by the
model's source (fcn, oracle), by action (a pickup, or the putting down of an object at
its place), by how many dishes the stop served (a merged location's stop serves
several), or by that and whether the base faced its dish when the arm reached (Fea^m
assumes it does; a turn in place that a chair cuts short leaves it turned away), or by
how far it was turned away (a base turned far from its dish needs an arm that reaches
beside or behind it), or by the pickup's place at its stop (the first is made as the base
arrives, the others after a turn in place), or by the planned stop's distance to its dish
(towards the edge of reach)."""
