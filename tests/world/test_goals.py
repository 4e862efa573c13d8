"""Place targets: where an object to place will stand, resolved from its scenario."""

import dataclasses
from pathlib import Path

import pytest

from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.furniture import DISH_SHAPES
from s3o_drake.world.goals import (
    PLACE_SUFFIX,
    PlaceTarget,
    place_target_name,
    place_targets,
    placed_object,
)
from s3o_drake.world.objects import surface_height
from s3o_drake.world.scenario import load_scenario, parse_scenario
from s3o_drake.world.scenario_checks import ScenarioError

TIDY = Path(__file__).resolve().parents[2] / "scenarios" / "tidy_home.yaml"


def test_the_apple_goes_onto_the_plate_at_the_plates_top():
    scenario = load_scenario(TIDY)
    (apple,) = place_targets(scenario)
    plate = next(d for d in scenario.dishes if d.name == "plate")
    dining = next(t for t in scenario.tables if t.name == "dining")
    assert apple == PlaceTarget("apple", "apple", "dining", tuple(plate.position),
                                dining.height + DISH_SHAPES["plate"].height, onto="plate")
    assert apple.target == "apple__place" and placed_object(apple.target) == "apple"
    as_dish = apple.as_dish(dining.height)
    assert (as_dish.name, as_dish.kind, as_dish.table) == ("apple__place", "apple", "dining")
    assert as_dish.position == list(plate.position) and as_dish.goal == "collect"
    assert as_dish.elevation == pytest.approx(DISH_SHAPES["plate"].height)
    # Standing there, in the feasibility scene and the world, it is on the plate's top.
    scene_scenario = dataclasses.replace(scenario, dishes=[*scenario.dishes, as_dish])
    assert surface_height(scene_scenario.tables, as_dish) == pytest.approx(apple.surface)
    scene = FeasibilityScene(scene_scenario.contents)
    p_WD, z = scene.dish_p_WD("apple__place")
    assert z == pytest.approx(apple.surface) and tuple(p_WD) == apple.position
    X_WD = scene.plant.EvalBodyPoseInWorld(scene.plant.CreateDefaultContext(),
                                           scene.dish_body("apple__place"))
    assert X_WD.translation()[2] == pytest.approx(apple.surface)


def test_a_place_on_a_table_stands_on_its_top():
    text = TIDY.read_text().replace("place: {onto: plate}",
                                    "place: {table: dining, position: [4.4, 4.0]}")
    (apple,) = place_targets(parse_scenario(text))
    assert (apple.table, apple.position, apple.surface, apple.onto) == (
        "dining", (4.4, 4.0), 0.75, "")


def test_names_cannot_clash_with_place_targets():
    assert place_target_name("can_1").endswith(PLACE_SUFFIX) and placed_object("can_1") is None
    text = TIDY.read_text().replace("name: can_3", "name: can__place")
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text)
    assert info.value.path == "dishes[4].name" and "double underscore" in str(info.value)
