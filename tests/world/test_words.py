"""The words of the program's messages, which people read and other programs may parse."""

from s3o_drake.world.goals import place_target_name, shown_name
from s3o_drake.world.words import counted


def test_a_count_takes_its_noun_in_its_number():
    assert [counted(n, "stop") for n in (0, 1, 2)] == ["0 stops", "1 stop", "2 stops"]
    assert counted(1, "dish", "dishes") == "1 dish" and counted(3, "dish", "dishes") == \
        "3 dishes"


def test_a_place_target_is_shown_as_its_objects_place():
    assert shown_name(place_target_name("apple")) == "apple's place"
    assert shown_name("can_1") == "can_1"


def test_a_one_stop_plan_says_one_stop():
    from s3o_drake.commands.run_scenario import describe_plan, ending
    from s3o_drake.planning.plan import Goto, Pickup, TaskMotionPlan

    plan = TaskMotionPlan(
        method="V-GROP*", seed=0, groups=(("cup",),), locations=("l0",),
        actions=(Goto("l0", (1.0, 1.0, 0.0), ((0.0, 0.0), (1.0, 1.0)), 1.41),
                 Pickup("cup", "l0", 0.9)),
        utility=100.0, predicted_time=30.0, planning_time=1.0, timing={})
    assert describe_plan(plan).splitlines()[0] == "V-GROP* plan (seed 0): 1 stop, 1 pickup"
    report = {"reason": "plan ended", "collected_dishes": [], "unreachable": ["plate"],
              "outcomes": [["goto", "l0", "done"], ["pickup", "cup", "failed: no_ik"]],
              "collected": 0, "dishes": 2}
    assert ending(report) == \
        "plan ended: 1 pickup failed (cup); 1 dish unreachable (plate)"
