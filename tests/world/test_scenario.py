"""Scenario loading and validation: good files load, bad ones name the field."""

import re
from pathlib import Path

import pytest
import yaml

from s3o_drake.commands.run_scenario import main as run_main
from s3o_drake.world.choices import METHODS
from s3o_drake.world.scenario import dump_scenario, load_scenario, parse_scenario
from s3o_drake.world.scenario_checks import ScenarioError

REPO = Path(__file__).resolve().parents[2]
SMALL = REPO / "scenarios" / "small" / "two_dishes.yaml"


def test_restaurant_loads_with_the_papers_room():
    scenario = load_scenario(REPO / "scenarios" / "restaurant.yaml")
    assert len(scenario.tables) == 7
    assert len(scenario.dishes) == 6
    assert len(scenario.chairs) == 6
    assert not any(chair.mapped for chair in scenario.chairs)
    lengths = sorted(max(t.size[:2]) for t in scenario.tables)
    assert lengths[-1] > 2 * lengths[-2]  # one long bar table
    assert lengths[0] == lengths[3] < lengths[4] == lengths[5]  # four small, two mid-sized
    p = scenario.planner
    assert (p.delta, p.gamma, p.reward, p.speed, p.top_k) == (5.0, 20.0, 150.0, 0.4, 5)
    assert (p.cma_generations, p.cma_population) == (20, 10)


def test_defaults_fill_what_a_file_leaves_out():
    scenario = parse_scenario("robot: {start: [1.5, 1.5, 0.0]}\n")
    assert scenario.uncertainty.nav_xy_std == pytest.approx(0.10)
    assert scenario.uncertainty.nav_yaw_std == pytest.approx(0.05)
    assert scenario.uncertainty.reach_std == pytest.approx(0.01)
    assert scenario.planner.method == "S3O-GROP*"
    assert scenario.planner.method in METHODS


def test_dump_round_trips():
    scenario = load_scenario(SMALL)
    again = parse_scenario(dump_scenario(scenario))
    assert again == scenario and dump_scenario(again) == dump_scenario(scenario)
    assert again.plant.time_step == scenario.plant.time_step == 0.01


def test_drakes_configs_are_fields_of_the_scenario_and_older_files_still_read():
    """`plant` (MultibodyPlantConfig), `simulator` (SimulatorConfig) and `visualization`
    (VisualizationConfig) as Drake's tools have them, validated like the rest; a file that
    gives the step as `simulation.time_step`, or the recording's period as
    `simulation.publish_period` (the shipped generated tasks do), sets the config's."""
    scenario = parse_scenario("plant: {time_step: 0.005, contact_model: point}\n"
                              "simulator: {integration_scheme: runge_kutta2}")
    assert scenario.plant.time_step == 0.005 and scenario.plant.contact_model == "point"
    assert scenario.plant.discrete_contact_approximation == "sap"  # the project's default
    assert scenario.simulator.integration_scheme == "runge_kutta2"
    assert parse_scenario("simulation: {time_step: 0.02}").plant.time_step == 0.02
    assert load_scenario(REPO / "scenarios" / "generated" / "task_000.yaml").plant.time_step \
        == 0.01
    shown = parse_scenario("visualization: {publish_period: 0.1, publish_contacts: true}")
    assert shown.visualization.publish_period == 0.1 and shown.visualization.publish_contacts
    assert not parse_scenario("").visualization.publish_inertia  # the project's default
    assert parse_scenario("simulation: {publish_period: 0.5}").visualization.publish_period \
        == 0.5
    for text, field in (("plant: {time_step: 0.1}", "plant.time_step"),
                        ("visualization: {publish_period: 0}", "visualization.publish_period"),
                        ("visualization: {publish_periodd: 1}", "visualization.publish_periodd"),
                        ("simulation: {publish_period: 0.5}\nvisualization: "
                         "{publish_period: 0.2}", "simulation.publish_period"),
                        ("plant: {time_stepp: 0.1}", "plant.time_stepp"),
                        ("simulator: {integration_scheme: rk9}",
                         "simulator.integration_scheme"),
                        ("simulation: {time_step: 0.005}\nplant: {time_step: 0.01}",
                         "simulation.time_step")):
        with pytest.raises(ScenarioError, match=re.escape(field)):
            parse_scenario(text)


def _mutated(mutate) -> str:
    data = yaml.safe_load(SMALL.read_text())
    mutate(data)
    return yaml.safe_dump(data)


def _set(*keys_and_value):
    *keys, value = keys_and_value

    def mutate(data):
        node = data
        for key in keys[:-1]:
            node = node[key]
        node[keys[-1]] = value
    return mutate


def _append(key, item):
    def mutate(data):
        data.setdefault(key, []).append(item)
    return mutate


# (id, mutation, expected field path, a word the message must hold)
MALFORMED = [
    ("negative size", _set("tables", 0, "size", [1.2, -0.8, 0.04]), "tables[0].size",
     "expected 3 positive numbers, got [1.2, -0.8, 0.04]"),
    ("two-number size", _set("tables", 0, "size", [1.2, 0.8]), "tables[0].size",
     "expected 3 positive numbers"),
    ("string for number", _set("tables", 0, "height", "tall"), "tables[0].height",
     "expected a number"),
    ("unknown field", _set("tables", 0, "colour", "red"), "tables[0].colour", "unknown field"),
    ("unknown top-level field", _set("robots", {}), "robots", "unknown field"),
    ("dish off its table", _set("dishes", 0, "position", [3.5, 0.5]), "dishes[0].position",
     "not on table 'table'"),
    ("dish over the edge", _set("dishes", 0, "position", [2.55, 2.3]), "dishes[0].position",
     "not on table"),
    ("unknown table", _set("dishes", 1, "table", "bar"), "dishes[1].table",
     "no table named 'bar'"),
    ("unknown dish kind", _set("dishes", 1, "kind", "teapot"), "dishes[1].kind",
     "unknown kind 'teapot'"),
    ("overlapping dishes", _set("dishes", 1, "position", [1.9, 2.3]), "dishes[1].position",
     "overlaps"),
    ("overlapping tables", _append("tables", {"name": "other", "center": [2.6, 2.5],
                                              "size": [1.0, 1.0, 0.04]}), "tables[1]",
     "overlaps table 'table'"),
    ("chair through a table", _set("chairs", 0, "pose", [2.0, 2.8, 0.0]), "chairs[0].pose",
     "overlaps table 'table'"),
    ("robot starts in a table", _set("robot", "start", [2.0, 2.0, 0.0]), "robot.start",
     "overlaps table 'table'"),
    ("robot starts in a chair", _set("robot", "start", [2.3, 3.4, 0.0]), "robot.start",
     "chair 'chair'"),
    ("robot starts outside", _set("robot", "start", [-1.0, 1.0, 0.0]), "robot.start",
     "outside the room"),
    ("table outside the room", _set("tables", 0, "center", [3.8, 2.5]), "tables[0].center",
     "outside the room"),
    ("nan position", _set("dishes", 0, "position", [float("nan"), 2.3]),
     "dishes[0].position[0]", "finite"),
    ("inf yaw", _set("chairs", 0, "pose", [2.0, 3.35, float("inf")]), "chairs[0].pose[2]",
     "finite"),
    ("nan setting", _set("planner", {"speed": float("nan")}), "planner.speed", "finite"),
    ("unknown method", _set("planner", {"method": "RRT"}), "planner.method",
     "unknown method 'RRT'"),
    ("unknown feasibility source", _set("planner", {"feasibility": "vgg"}),
     "planner.feasibility", "unknown source 'vgg'"),
    ("unknown cost profile", _set("planner", {"cost_profile": "fast"}),
     "planner.cost_profile", "unknown profile 'fast'"),
    ("zero speed", _set("planner", {"speed": 0.0}), "planner.speed", "greater than 0"),
    ("negative noise", _set("uncertainty", {"nav_xy_std": -0.1}), "uncertainty.nav_xy_std",
     "at least 0"),
    ("float for int", _set("planner", {"top_k": 2.5}), "planner.top_k", "expected an integer"),
    ("duplicate names", _set("dishes", 1, "name", "plate_a"), "dishes[1].name",
     "duplicate name 'plate_a'"),
    ("bad name", _set("tables", 0, "name", "my table"), "tables[0].name", "letters"),
    ("tables not a list", _set("tables", {"name": "t"}), "tables", "expected a list"),
    ("bad bounds", _set("room", "bounds", [0.0, 0.0, 4.0]), "room.bounds", "expected 4"),
    ("camera below the tables", _set("camera", "height", 1.0), "camera.height", "above"),
    ("bool for number", _set("simulation", "hold_time", True), "simulation.hold_time",
     "expected a number"),
    ("chair overlaps chair", _append("chairs", {"name": "chair_2", "pose": [2.1, 3.4, 0.0]}),
     "chairs[1].pose", "overlaps chair 'chair'"),
    # Found by the mutated files of tests/world/test_malformed_yaml.py (issue 19, item 1).
    ("name ending in a newline", _set("tables", 0, "name", "table\n"), "tables[0].name",
     "letters"),
    ("negative seed", _set("seed", -1), "seed", "at least 0"),
    ("huge number", _set("planner", {"time_budget": 1e300}), "planner.time_budget",
     "at most 1e+06"),
    ("int too large for a float", _set("planner", {"speed": 10**400}), "planner.speed",
     "at most 1e+06"),
    ("int beyond 64 bits", _set("seed", 2**64), "seed", "64-bit"),
    ("too many workers", _set("planner", {"workers": 1000}), "planner.workers", "at most 64"),
    ("a count no budget ends", _set("planner", {"location_samples": 10**9}),
     "planner.location_samples", "at most 10000"),
    ("NUL in the output folder", _set("outputs", {"directory": "out\0"}),
     "outputs.directory", "NUL"),
    ("odd unknown key", _set("robot", "", 1), "robot['']", "unknown field ''"),
]


@pytest.mark.parametrize(("mutation", "path", "words"),
                         [m[1:] for m in MALFORMED], ids=[m[0] for m in MALFORMED])
def test_malformed_scenarios_name_the_field(mutation, path, words, tmp_path, capsys):
    text = _mutated(mutation)
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text)
    assert info.value.path == path
    assert words in str(info.value)

    # The command line reports it as one line, exit status 2, and writes nothing.
    scenario = tmp_path / "bad.yaml"
    scenario.write_text(text)
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exit_info:
        run_main([str(scenario), "--out", str(out)])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"{path}: " in err and "Traceback" not in err
    assert not out.exists()


def test_not_yaml_names_the_line(tmp_path):
    with pytest.raises(ScenarioError) as info:
        parse_scenario("room:\n  bounds: [0, 0, 4\n")
    assert info.value.path.startswith("line ")


def test_missing_file_is_bad_input(tmp_path, capsys):
    missing = tmp_path / "nope.yaml"
    with pytest.raises(SystemExit) as info:
        run_main([str(missing), "--out", str(tmp_path / "out")])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err == f"error: {missing}: no such scenario file\n"  # the path once
    assert not (tmp_path / "out").exists()


def test_a_folder_is_not_a_scenario_file(tmp_path, capsys):
    with pytest.raises(SystemExit) as info:
        run_main([str(tmp_path), "--out", str(tmp_path / "out")])
    assert info.value.code == 2
    assert capsys.readouterr().err == f"error: {tmp_path}: is a folder, not a scenario file\n"
    assert not (tmp_path / "out").exists()


def test_a_bad_field_in_a_file_names_the_file_once(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("room: {bounds: [0, 0, 4]}\n")
    with pytest.raises(ScenarioError) as info:
        load_scenario(bad)
    assert (info.value.file, info.value.path) == (str(bad), "room.bounds")
    with pytest.raises(SystemExit) as exit_info:
        run_main([str(bad), "--out", str(tmp_path / "out")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {bad}: room.bounds: ") and err.count(str(bad)) == 1


@pytest.mark.parametrize("text", ["", "\n", "# only a comment\n", "{}\n"],
                         ids=["empty", "blank line", "comment only", "empty mapping"])
def test_an_empty_file_is_all_defaults(text, tmp_path, capsys):
    # The README: every field has a default. A file with none is the defaults, as {} is.
    path = tmp_path / "empty.yaml"
    path.write_text(text)
    assert load_scenario(path) == parse_scenario("{}")
    assert parse_scenario("{}").dishes == []
    # With no dishes there is nothing to run: one line naming the field, exit 2, no output.
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as info:
        run_main([str(path), "--out", str(out)])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {path}: dishes: ") and err.count("\n") == 1
    assert not out.exists()


def test_an_empty_base_is_bad_input_to_generate(tmp_path, capsys):
    from s3o_drake.commands.generate import main as generate_main

    path = tmp_path / "empty.yaml"
    path.write_text("# nothing\n")
    with pytest.raises(SystemExit) as info:
        generate_main(["--base", str(path), "--count", "1", "--out", str(tmp_path / "out")])
    assert info.value.code == 2
    assert capsys.readouterr().err.startswith(f"error: --base: {path}: tables: ")
    assert not (tmp_path / "out").exists()


def test_nan_is_caught_even_in_yaml_spelling():
    with pytest.raises(ScenarioError) as info:
        parse_scenario("planner: {reach: .nan}\n")
    assert info.value.path == "planner.reach"


@pytest.mark.parametrize(("text", "path", "words"), [
    ("planner: {top_k: 3, top_k: 4}\n", "planner.top_k", "duplicate key (also on line 1)"),
    ("tables: " + "[" * 5000 + "]" * 5000 + "\n", "tables[0]", "nested more than 32"),
    ("seed: 1\x07\n", "line 1", "unacceptable character #x0007"),
], ids=["duplicate key", "deep nesting", "control character"])
def test_what_yaml_itself_lets_through_is_named(text, path, words):
    # PyYAML keeps the last of two equal keys and recurses once per level of nesting.
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text)
    assert info.value.path == path and words in info.value.message


def test_exponents_without_a_dot_are_numbers():
    # YAML 1.2 (and yaml_load_typed) read 1e-1 as a number; PyYAML's YAML 1.1, as a string.
    scenario = parse_scenario("planner: {speed: 1e-1, reach: 1E0}\n")
    assert (scenario.planner.speed, scenario.planner.reach) == (0.1, 1.0)


def test_a_file_that_is_not_utf8_names_the_line(tmp_path):
    path = tmp_path / "latin1.yaml"
    path.write_bytes("seed: 1\n# café\n".encode("latin-1"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.path == "line 2" and "not UTF-8 text (byte 0xe9" in info.value.message


TIDY = (REPO / "scenarios" / "tidy_home.yaml").read_text()


def test_the_tidy_home_scenario_gives_its_objects_goals():
    scenario = parse_scenario(TIDY)
    goals = {d.name: (d.goal, d.place.onto) for d in scenario.dishes}
    assert goals == {"can_1": ("collect", ""), "can_2": ("collect", ""), "can_3": ("collect", ""),
                     "apple": ("place", "plate"), "plate": ("stay", "")}
    assert parse_scenario(dump_scenario(scenario)) == scenario


@pytest.mark.parametrize(("old", "new", "path", "words"), [
    ("goal: stay}", "goal: keep}", "dishes[3].goal", "unknown goal 'keep'"),
    ("goal: stay}", "goal: stay, elevation: -0.1}", "dishes[3].elevation",
     "must be in [0, 0.3] m, got -0.1"),
    ("place: {onto: plate}", "place: {onto: sofa}", "dishes[2].place.onto",
     "no other object named 'sofa'"),
    ("place: {onto: plate}", "place: {onto: apple}", "dishes[2].place.onto",
     "no other object named 'apple'"),
    ("kind: plate, goal: stay}", "kind: plate}", "dishes[2].place.onto",
     "'plate' does not stay where it is (its goal is collect)"),
    ("kind: plate, goal: stay}", "kind: can, goal: stay}", "dishes[2].place.onto",
     "the apple is wider than the can 'plate'"),
    ("place: {onto: plate}", "place: {onto: plate, table: dining}", "dishes[2].place",
     "either onto, or table and position"),
    ("place: {onto: plate}", "place: {table: dining, position: [4.95, 3.75]}",
     "dishes[2].place.position", "overlaps dish 'plate'"),
    ("place: {onto: plate}", "place: {table: dining, position: [5.3, 4.3]}",
     "dishes[2].place.position", "not on table 'dining'"),
    ("place: {onto: plate}", "place: {table: bed, position: [4.6, 3.9]}",
     "dishes[2].place.table", "no table named 'bed'"),
    ("kind: can}\n  - {name: can_2", "kind: can, place: {onto: plate}}\n  - {name: can_2",
     "dishes[0].place", "only an object whose goal is place has one"),
    ("place: {onto: plate}", "place: {onto: plate, on: plate}", "dishes[2].place[True]",
     "unknown field True"),
])
def test_bad_goals_and_places_name_the_field(old, new, path, words):
    assert old in TIDY
    with pytest.raises(ScenarioError) as info:
        parse_scenario(TIDY.replace(old, new, 1))
    assert info.value.path == path and words in str(info.value)


def test_a_place_on_a_table_and_two_places_that_overlap():
    text = TIDY.replace("place: {onto: plate}", "place: {table: dining, position: [4.4, 4.0]}")
    assert parse_scenario(text).dishes[2].place.position == [4.4, 4.0]
    both = text.replace("kind: can}\n  - {name: can_2",
                        "kind: can, goal: place,\n     place: {table: dining, position: "
                        "[4.43, 4.0]}}\n  - {name: can_2")
    with pytest.raises(ScenarioError) as info:
        parse_scenario(both)
    assert info.value.path == "dishes[2].place" and "overlaps the place of 'can_1'" in str(
        info.value)


def test_overrides_replace_fields_and_are_checked_like_the_file():
    from s3o_drake.world.scenario import with_overrides
    from s3o_drake.world.scenario_checks import ScenarioError

    base = load_scenario(REPO / "scenarios" / "restaurant.yaml")
    changed = with_overrides(base, ["planner.top_k=8", "uncertainty.nav_xy_std=0.2",
                                    "planner.search_plain_voronoi=true",
                                    "tables[0].height=0.8"])
    assert (changed.planner.top_k, changed.uncertainty.nav_xy_std,
            changed.planner.search_plain_voronoi, changed.tables[0].height) == (8, 0.2, True, 0.8)
    assert base.planner.top_k == 5  # the scenario given is not changed
    assert with_overrides(base, []) is base
    for bad, message in (("planner.topk=3", "planner.topk: unknown field"),
                         ("planner.top_k=x", "planner.top_k: expected an integer"),
                         ("planner.group_positions=joint", "planner.group_positions"),
                         ("tables[99].height=1", "tables[99].height: no item 99"),
                         ("planner", "expected PATH=VALUE")):
        with pytest.raises(ScenarioError, match=message.replace("[", r"\[")):
            with_overrides(base, [bad])


def test_a_scenario_pickles_for_a_worker_process():
    import pickle

    scenario = parse_scenario("plant: {time_step: 0.005}")
    again = pickle.loads(pickle.dumps(scenario))
    assert again == scenario and again.plant.time_step == 0.005
