"""The turn in place between two pickups at one stop: the chance that it gets there."""

import numpy as np
import pytest
from shapely.geometry import box

from s3o_drake.abstraction import HeatmapFeasibility
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.feasibility.stop_turns import StopTurns, sequence_pairs
from s3o_drake.planning.motion.grop import SequenceProblem
from s3o_drake.planning.navigation.map import NavigationMap
from s3o_drake.world.goals import place_target_name
from s3o_drake.world.obstacles import Obstacles
from s3o_drake.world.settings import PlanningSettings

# `before` due north of the origin, `dish` due east: a base near the origin that faces
# `before` (yaw π/2) turns clockwise by about π/2 to face `dish`.
DISHES = {"before": (0.0, 5.0), "dish": (5.0, 0.0)}
CELL = 0.05


def _grid(dish: str, values: float = 1.0) -> Heatmap:
    """Fea^m `values` on x, y in [-1, 1]."""
    return Heatmap(dish, np.full((40, 40), values), -1.0, -1.0, CELL)


def _blocked_right_of(x0: float):
    """Free, except that a base at x >= x0 cannot face between 0.3 and 1.2 rad: the turn
    from facing north to facing east is cut there."""
    def free(poses):
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        return ~((poses[:, 0] >= x0) & (poses[:, 2] > 0.3) & (poses[:, 2] < 1.2))
    return free


def test_the_chance_is_the_share_of_landings_whose_turn_gets_there():
    turns = StopTurns(_blocked_right_of(0.0), DISHES, 0.10,
                      {"before": _grid("before"), "dish": _grid("dish")})
    chance = turns.chance("before", "dish")
    at = chance.values_at(np.array([[-0.6, 0.0], [-0.05, 0.0], [0.05, 0.0], [0.6, 0.0]]))
    assert at[0] == pytest.approx(1.0) and at[3] == pytest.approx(0.0, abs=1e-9)
    # Within the landing noise of the edge, part of the landings turn and part do not.
    assert 0.5 < at[1] < 0.9 and 0.1 < at[2] < 0.5
    assert turns.chance("before", "dish") is chance  # kept per pair


def test_landings_that_are_not_free_do_not_count_as_cut_turns():
    """A strip where the base cannot stand at all: its landings stop short beside it, where
    the turn is free, so the chance next to it stays 1."""
    def free(poses):
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        return ~((poses[:, 0] > 0.2) & (poses[:, 0] < 0.4))

    turns = StopTurns(free, DISHES, 0.10, {"before": _grid("before"), "dish": _grid("dish")})
    at = turns.chance("before", "dish").values_at(np.array([[0.1, 0.0], [0.5, 0.3]]))
    assert at == pytest.approx([1.0, 1.0])


def test_no_chance_where_no_stop_serves_both_dishes():
    half = Heatmap("before", np.zeros((40, 40)), -1.0, -1.0, CELL)
    half.values[:, :20] = 1.0  # before is picked only from x < 0
    turns = StopTurns(_blocked_right_of(5.0), DISHES, 0.10, {"before": half, "dish": _grid("dish")})
    at = turns.chance("before", "dish").values_at(np.array([[-0.5, 0.0], [0.5, 0.0]]))
    assert at == pytest.approx([1.0, 0.0])
    assert turns.chances([("before", "dish"), ("ghost", "dish")]).keys() == {("before", "dish")}


def test_the_turns_of_a_sequence_are_the_later_pickups_at_each_stop():
    actions = [("goto", "l0"), ("pickup", "a"), ("pickup", "b"), ("place", "c"),
               ("goto", "l1"), ("pickup", "d"), ("goto", "l2"), ("pickup", "e"),
               ("pickup", "f")]
    assert sequence_pairs(actions) == [("a", "b"), ("b", place_target_name("c")), ("e", "f")]
    assert sequence_pairs([("pickup", "a"), ("pickup", "b")]) == [("a", "b")]


def test_the_motion_search_rates_a_pickup_after_a_turn_by_its_chance():
    """Only the second pickup at the shared stop is scaled; the first and a pickup alone at
    its stop keep Fea^m."""
    heatmaps = {d: _grid(d, 0.9) for d in ("before", "dish", "alone")}
    fea = HeatmapFeasibility(heatmaps)
    turns = StopTurns(_blocked_right_of(0.0), {**DISHES, "alone": (0.0, -5.0)}, 0.10, heatmaps)
    sequence = [("goto", "l0"), ("pickup", "before"), ("pickup", "dish"),
                ("goto", "l1"), ("pickup", "alone")]
    regions = {"l0": box(-1, -1, 1, 1), "l1": box(-1, -1, 1, 1)}
    nav = NavigationMap(Obstacles.of((-2.0, -2.0, 2.0, 2.0), [], []))
    planner = PlanningSettings()
    X = np.array([[[0.6, 0.0], [-0.5, -0.5]], [[-0.6, 0.0], [-0.5, -0.5]]])
    plain = SequenceProblem(sequence, regions, fea, nav, (-1.5, -1.5), planner, None)
    turned = SequenceProblem(sequence, regions, fea, nav, (-1.5, -1.5), planner, None,
                             turns=turns.chances([("before", "dish")]))
    _, _, F_plain, _ = plain.evaluate(X)
    u, _, F, _ = turned.evaluate(X)
    assert F_plain == pytest.approx(np.full((2, 3), 0.9))
    assert F[:, 0] == pytest.approx([0.9, 0.9]) and F[:, 2] == pytest.approx([0.9, 0.9])
    assert F[0, 1] == pytest.approx(0.0, abs=1e-9) and F[1, 1] == pytest.approx(0.9)
    assert u[0] < u[1]
