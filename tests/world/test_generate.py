"""The benchmark task generator: valid tasks by the paper's protocol, the same per seed."""

import math
from pathlib import Path

import pytest

from s3o_drake.commands.generate import main as generate_main
from s3o_drake.world.scenario import load_scenario, parse_scenario
from s3o_drake.world.task_generation import CUSTOM_LAYOUT, generate_task, layout_of

REPO = Path(__file__).resolve().parents[2]
BASE = REPO / "scenarios" / "restaurant.yaml"


# Drawing a task checks a stop for every dish per chair drawn (seconds per dense task):
# the tests share one drawing of each layout.
@pytest.fixture(scope="module")
def spacious_tasks(tmp_path_factory):
    out = tmp_path_factory.mktemp("spacious")
    assert generate_main(["--count", "2", "--seed", "0", "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="module")
def one_chair_tasks(tmp_path_factory):
    """Tasks with one chair (--chairs 1) rather than one per dish: the stop check runs once
    per chair drawn, and what these tests compare does not depend on the chairs' count."""
    out = tmp_path_factory.mktemp("one_chair")
    assert generate_main(["--count", "2", "--seed", "0", "--chairs", "1", "--out", str(out),
                          "--quiet"]) == 0
    return out


@pytest.fixture(scope="module")
def dense_tasks(tmp_path_factory):
    out = tmp_path_factory.mktemp("dense")
    assert generate_main(["--layout", "dense", "--count", "1", "--seed", "0", "--out",
                          str(out), "--quiet"]) == 0
    return out


def test_tasks_are_valid_and_follow_the_protocol(spacious_tasks):
    base = load_scenario(BASE)
    files = sorted(spacious_tasks.glob("task_*.yaml"))
    assert [f.name for f in files] == [f"task_{i:03d}.yaml" for i in range(2)]
    counts = set()
    for f in files:
        task = load_scenario(f)  # validates: dishes on tables, no overlaps, robot free
        assert task.tables == base.tables
        assert task.robot == base.robot
        assert 5 <= len(task.dishes) <= 7
        counts.add(len(task.dishes))
        assert len(task.chairs) == len(task.dishes)
        for dish, chair in zip(task.dishes, task.chairs, strict=True):
            assert not chair.mapped
            assert math.dist(dish.position, chair.pose[:2]) <= 1.0
    assert len(counts) > 1  # the dish count varies


def test_same_seed_same_files(one_chair_tasks, tmp_path):
    assert generate_main(["--count", "1", "--seed", "0", "--chairs", "1", "--out",
                          str(tmp_path), "--quiet"]) == 0
    assert (tmp_path / "task_000.yaml").read_bytes() == \
        (one_chair_tasks / "task_000.yaml").read_bytes()


def test_a_task_depends_only_on_seed_and_index():
    """The draw itself, without the stop check (`stops`), which only redraws."""
    base = load_scenario(BASE)
    assert generate_task(base, 7, 5) == generate_task(base, 7, 5)
    assert generate_task(base, 7, 5) != generate_task(base, 7, 6)
    assert generate_task(base, 7, 5) != generate_task(base, 8, 5)


@pytest.mark.parametrize("args", [["--count", "0"], ["--seed", "-1"], ["--count", "x"],
                                  ["--places", "4"], ["--places", "-1"],
                                  ["--layout", "cramped"],
                                  ["--layout", "dense", "--base", str(BASE)],
                                  ["--dishes", "0"], ["--dishes", "41"],
                                  ["--dishes", "6", "--chairs", "7"], ["--chairs", "-1"],
                                  ["--chair-margin", "-0.01"], ["--chair-margin", "1"],
                                  ["--check", "no/such/folder"]])
def test_bad_arguments_exit_2_and_write_nothing(args, tmp_path, capsys):
    out = tmp_path / "tasks"
    with pytest.raises(SystemExit) as info:
        generate_main([*args, "--out", str(out)])
    assert info.value.code == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert not out.exists()


def test_shipped_benchmark_tasks_are_what_the_generator_makes(spacious_tasks):
    """scenarios/generated holds `generate --count 100 --seed 0`; spot-check that it still is."""
    shipped = REPO / "scenarios" / "generated"
    assert len(list(shipped.glob("task_*.yaml"))) == 100
    for name in ("task_000.yaml", "task_001.yaml"):
        made, kept = (spacious_tasks / name).read_text(), (shipped / name).read_text()
        # The same scenario, read back: the shipped files predate settings added since
        # (execution, the localisation noise), which they take at their defaults, and their
        # first line names the command as it was run before the commands moved to
        # s3o_drake.commands. Rewriting them would change the digests that key the
        # studies' stored runs.
        assert parse_scenario(made) == parse_scenario(kept)
        assert "generate --seed 0`" in kept.split("\n", 1)[0]


def test_mixed_tasks_put_cups_down_on_another_table(one_chair_tasks, tmp_path):
    """--places 1: one cup of each task is to be put down at a free spot on another table;
    where the task had a cup, it is otherwise the collect-only task. One task: each is
    drawn on its own (`test_a_task_depends_only_on_seed_and_index`), a second adds only
    its seconds."""
    assert generate_main(["--count", "1", "--seed", "0", "--chairs", "1", "--places", "1",
                          "--out", str(tmp_path), "--quiet"]) == 0
    (path,) = tmp_path.glob("task_*.yaml")
    assert path.name == "task_000.yaml" and "--places 1" in path.read_text().splitlines()[0]
    task = load_scenario(path)  # validates the places: on a top, clear of the objects
    (cup,) = [d for d in task.dishes if d.goal == "place"]
    assert cup.kind == "cup" and cup.place.table not in ("", cup.table)
    assert all(d.goal == "collect" for d in task.dishes if d is not cup)
    plain = load_scenario(one_chair_tasks / path.name)
    assert [d.name for d in plain.dishes] == [d.name for d in task.dishes]
    assert task.chairs == plain.chairs
    assert [(d.position, d.kind) for d in task.dishes] == [
        (d.position, d.kind) for d in plain.dishes]


def test_dense_tasks_stand_in_the_dense_restaurant_and_say_so(dense_tasks):
    """--layout dense draws the tasks by the same protocol among the dense restaurant's
    tables; a task's layout is read back from its room and tables."""
    dense = load_scenario(REPO / "scenarios" / "restaurant_dense.yaml")
    assert layout_of(dense) == "dense" and layout_of(load_scenario(BASE)) == "spacious"
    for f in sorted(dense_tasks.glob("task_*.yaml")):
        task = load_scenario(f)
        assert task.tables == dense.tables and task.room == dense.room
        assert layout_of(task) == "dense" and 5 <= len(task.dishes) <= 7
        assert "--layout dense" in f.read_text().split("\n", 1)[0]
    # The dense restaurant is the paper's cramped one: a 2 x 2 block of small tables 0.3 m
    # apart, the mid-sized tables 0.8 m apart.
    tables = {t.name: t for t in dense.tables}
    assert tables["small_2"].center[0] - tables["small_1"].center[0] - 0.7 == \
        pytest.approx(0.3)
    assert tables["mid_2"].center[0] - tables["mid_1"].center[0] - 1.6 == pytest.approx(0.8)
    assert layout_of(load_scenario(REPO / "scenarios" / "tidy_home.yaml")) == CUSTOM_LAYOUT


def test_shipped_dense_tasks_are_what_the_generator_makes(dense_tasks):
    shipped = REPO / "scenarios" / "generated_dense"
    assert len(list(shipped.glob("task_*.yaml"))) == 100
    for name in ("task_000.yaml",):
        # The same scenario, read back: settings added since (execution.detour) take their
        # defaults in the shipped files, which stay as they are, since their digests key
        # the studies' stored runs.
        made, kept = (dense_tasks / name).read_text(), (shipped / name).read_text()
        assert parse_scenario(made) == parse_scenario(kept)


def test_a_chair_that_closes_the_aisle_to_a_dish_is_named_and_redrawn(dense_tasks):
    """In the dense restaurant a chair in the 0.9 m aisle above the small tables' block
    leaves the cup on its top edge no stop that a drive reaches: `dishes_without_stops`
    names it, and it has stops again without the chair. A generated dense task keeps a
    stop for every dish."""
    import dataclasses

    from s3o_drake.experiments.generation import dishes_without_stops
    from s3o_drake.world.map import Chair
    from s3o_drake.world.objects import Dish

    dense = load_scenario(REPO / "scenarios" / "restaurant_dense.yaml")
    cup = Dish(name="cup_1", table="small_3", position=[1.224, 2.4393], kind="cup")
    room = dataclasses.replace(dense, dishes=[cup], chairs=[])
    assert dishes_without_stops(room) == []
    aisle = [Chair(name="chair_1", pose=[1.208, 3.172, 2.715], mapped=False),
             Chair(name="chair_2", pose=[0.5099, 2.791, -0.3746], mapped=False),
             Chair(name="chair_3", pose=[2.856, 2.466, 3.037], mapped=False)]
    assert dishes_without_stops(dataclasses.replace(room, chairs=aisle)) == ["cup_1"]
    # The generator's cheaper question (the first dish without a stop) says the same.
    assert dishes_without_stops(dataclasses.replace(room, chairs=aisle), first=True) == \
        ["cup_1"]
    assert dishes_without_stops(room, first=True) == []
    for f in sorted(dense_tasks.glob("task_*.yaml")):
        assert dishes_without_stops(load_scenario(f)) == []


def test_tasks_at_scale_have_their_dishes_and_chairs_and_a_stop_for_each_dish(tmp_path):
    """--dishes 12 --chairs 3: twelve dishes, three chairs each near a dish of the task,
    and every dish keeps a stop that a drive reaches; the shipped scale tasks are what
    the generator makes."""
    from s3o_drake.experiments.generation import dishes_without_stops

    assert generate_main(["--dishes", "12", "--chairs", "3", "--count", "1", "--seed", "0",
                          "--out", str(tmp_path), "--quiet"]) == 0
    task = load_scenario(tmp_path / "task_000.yaml")
    assert len(task.dishes) == 12 and len(task.chairs) == 3
    for chair in task.chairs:
        assert min(math.dist(d.position, chair.pose[:2]) for d in task.dishes) <= 1.0
    assert dishes_without_stops(task) == []
    assert "--dishes 12 --chairs 3`" in (tmp_path / "task_000.yaml").read_text()
    shipped = REPO / "scenarios" / "generated_scale"
    for size in (5, 10, 15, 20, 30, 40):
        files = sorted((shipped / f"dishes_{size:02d}").glob("task_*.yaml"))
        assert len(files) == 3
        for f in files:
            scenario = load_scenario(f)
            assert len(scenario.dishes) == size and len(scenario.chairs) == 5
    made = generate_task(load_scenario(BASE), 0, 0, dishes=5, chairs=5,
                         stops=dishes_without_stops)
    assert made == load_scenario(shipped / "dishes_05" / "task_000.yaml")


def test_a_dish_whose_only_way_passes_a_chair_by_millimetres_is_named_with_a_margin(
        tmp_path, capsys):
    """Dense task_045: every dish has a stop on the true chairs, but three lose theirs when
    the chairs are 15 mm larger (perception's worst error): on the perceived chairs no run
    of the study reached them. `generate --check` lists such tasks."""
    import shutil

    from s3o_drake.experiments.generation import dishes_without_stops

    dense = REPO / "scenarios" / "generated_dense"
    task = load_scenario(dense / "task_045.yaml")
    assert dishes_without_stops(task) == []
    assert dishes_without_stops(task, chair_margin=0.015) == ["bowl_1", "cup_1", "plate_1"]
    for name in ("task_000.yaml", "task_045.yaml"):
        shutil.copy(dense / name, tmp_path / name)
    assert generate_main(["--check", str(tmp_path), "--chair-margin", "0.015",
                          "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "task_045: bowl_1, cup_1, plate_1" in out and "task_000" not in out
    assert "1 of 2 tasks" in out

