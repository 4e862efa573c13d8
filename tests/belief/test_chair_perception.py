"""Chair perception: the overhead camera finds the chairs the map lacks, and only those."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import Point

from s3o_drake.belief import ChairPerception, perceived_chairs
from s3o_drake.belief.chair_perception import placement_error
from s3o_drake.belief.known_world import PLACEMENT_ERROR, Briefing
from s3o_drake.commands.perception_benchmark import match, true_chairs
from s3o_drake.viz.chairs import draw_chairs
from s3o_drake.world.builder import render_overhead
from s3o_drake.world.camera import overhead_camera
from s3o_drake.world.scenario import load_scenario

REPO = Path(__file__).resolve().parents[2]
CENTRE_TOLERANCE = 0.05  # m: the target
YAW_TOLERANCE = 0.1  # rad


def _assert_found(scenario, found):
    truth = true_chairs(scenario)
    pairs = match(truth, found)
    assert len(found) == len(truth), (found, truth)
    assert len(pairs) == len(truth), (found, truth)
    for i, j, centre, yaw in pairs:
        assert centre < CENTRE_TOLERANCE, (truth[i], found[j])
        assert yaw < YAW_TOLERANCE, (truth[i], found[j])
        # The known world keeps the arm this much further from a perceived chair.
        assert placement_error(truth[i], found[j]) < PLACEMENT_ERROR, (truth[i], found[j])


@pytest.fixture(scope="module")
def two_dishes():
    scenario = load_scenario(REPO / "scenarios" / "small" / "two_dishes.yaml")
    return scenario, render_overhead(scenario)[:3]


def test_finds_the_unmapped_chair_of_a_small_scene(two_dishes):
    scenario, images = two_dishes
    _assert_found(scenario, perceived_chairs(Briefing.of(scenario), images))


@pytest.mark.parametrize("task", ["task_016"])
def test_finds_every_unmapped_chair_of_a_generated_task(task):
    # task_016: a chair whose backrest faces the image centre, so the camera sees the
    # floor under its seat from the side and the blob comes in two pieces.
    scenario = load_scenario(REPO / "scenarios" / "generated" / f"{task}.yaml")
    _assert_found(scenario, perceived_chairs(Briefing.of(scenario),
                                             render_overhead(scenario)[:3]))


def test_two_touching_chairs_are_found_as_two():
    # Dense task_080: two chairs that touch make one blob; taken for one chair between
    # them, the other was off the map and blocked the robot's drives.
    scenario = load_scenario(REPO / "scenarios" / "generated_dense" / "task_080.yaml")
    _assert_found(scenario, perceived_chairs(Briefing.of(scenario),
                                             render_overhead(scenario)[:3]))


def test_a_blob_is_split_only_when_one_chair_cannot_make_it():
    from s3o_drake.belief.blobs import CHAIR_AREA, split
    from s3o_drake.world.furniture import chair_footprint

    def points_of(pose):
        shape = chair_footprint(pose)
        x0, y0, x1, y1 = shape.bounds
        grid = np.mgrid[x0:x1:0.02, y0:y1:0.02].reshape(2, -1).T
        inside = np.array([shape.contains(Point(*p)) for p in grid])
        return np.column_stack([grid[inside], np.full(inside.sum(), 0.5)])

    one = points_of([2.0, 1.0, 0.3])
    assert len(split(one, CHAIR_AREA)) == 1
    a, b = [2.0, 1.0, 0.3], [2.45, 1.35, 2.0]  # overlapping a little in plan view
    both = np.vstack([points_of(a), points_of(b)])
    parts = split(both, 2 * CHAIR_AREA)
    assert len(parts) == 2 and sum(map(len, parts)) == len(both)
    centres = sorted(tuple(np.round(part[:, :2].mean(axis=0), 2)) for part in parts)
    truth = sorted(tuple(points_of(p)[:, :2].mean(axis=0)) for p in (a, b))
    assert np.allclose(centres, truth, atol=0.06)
    assert [len(p) for p in split(both, 2 * CHAIR_AREA)] == [len(p) for p in parts]


def test_a_scene_without_chairs_gives_none(two_dishes):
    scenario, _ = two_dishes
    empty = dataclasses.replace(scenario, chairs=[])
    assert perceived_chairs(Briefing.of(empty), render_overhead(empty)[:3]) == []


def test_mapped_chairs_are_not_reported(two_dishes):
    scenario, _ = two_dishes
    mapped = dataclasses.replace(
        scenario, chairs=[dataclasses.replace(c, mapped=True) for c in scenario.chairs])
    assert perceived_chairs(Briefing.of(mapped), render_overhead(mapped)[:3]) == []


def test_takes_the_images_as_the_world_diagram_produces_them(two_dishes):
    from s3o_drake.world.builder import build_world_diagram, robot_hold_state

    scenario, _ = two_dishes
    diagram = build_world_diagram(scenario)
    context = diagram.CreateDefaultContext()
    diagram.GetInputPort("robot_desired_state").FixValue(context, robot_hold_state(scenario))
    color, depth, label = (diagram.GetOutputPort(f"overhead_{name}_image").Eval(context).data
                           for name in ("color", "depth", "label"))
    assert color.shape[2] == 4 and depth.shape[2] == 1 and label.shape[2] == 1
    perception = ChairPerception(scenario.map, scenario.camera, pose=scenario.robot.start,
                                 robot=scenario.robot_value)
    found = perception(color, depth[:, :, 0], label[:, :, 0])
    _assert_found(scenario, found)
    assert all(isinstance(v, float) for pose in found for v in pose)
    assert all(-math.pi <= pose[2] < math.pi for pose in found)


def test_rejects_an_image_of_the_wrong_size(two_dishes):
    scenario, (color, depth, label) = two_dishes
    with pytest.raises(ValueError, match="depth"):
        perception = ChairPerception(scenario.map, scenario.camera,
                                     pose=scenario.robot.start, robot=scenario.robot_value)
        perception(color, depth[:-1], label)


def test_draws_the_chairs_on_the_overhead_image(two_dishes):
    scenario, (color, _, _) = two_dishes
    camera = overhead_camera(scenario.room, scenario.camera)
    picture = draw_chairs(camera, color, true_chairs(scenario))
    assert picture.shape == (*color.shape[:2], 3) and picture.dtype == np.uint8
    assert np.any(np.all(picture == (0, 200, 0), axis=2))


def test_the_placement_error_is_the_most_any_point_of_the_chair_moves():
    from s3o_drake.belief.chair_perception import ChairModel

    pose = [2.0, 1.0, 0.4]
    assert placement_error(pose, pose) == 0.0
    assert placement_error(pose, [2.003, 0.996, 0.4]) == pytest.approx(0.005)
    # Turned about its centre, its corner furthest from the centre moves most.
    radius = np.linalg.norm(ChairModel.from_furniture().corners(), axis=1).max()
    assert placement_error(pose, [2.0, 1.0, 0.42]) == pytest.approx(2 * radius * math.sin(0.01))
