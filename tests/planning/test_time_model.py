"""The time model (planning/time_model.py): the planner's goto and pickup times against what
the BaseNavigator and the simulated execution take, the recorded model, the cost profiles."""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator

from s3o_drake.belief import scenario_unmapped_chairs
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.execution.base_navigator import BaseNavigator
from s3o_drake.execution.controllers import navigator_params
from s3o_drake.execution.diagram import build_execution_diagram
from s3o_drake.execution.execute import execute
from s3o_drake.execution.messages import BaseCommand
from s3o_drake.feasibility.heatmaps import compute_heatmaps
from s3o_drake.planning.failure_price import failure_reward
from s3o_drake.planning.methods import plan_task
from s3o_drake.planning.navigation import base_motion
from s3o_drake.planning.navigation.base_motion import STOP_AND_GO
from s3o_drake.planning.navigation.map import NavigationMap
from s3o_drake.planning.plan import TaskMotionPlan
from s3o_drake.planning.time_model import (
    PICKUP_FORMS,
    TURN_TOLERANCE,
    CostModel,
    TimeModel,
    base_profile,
    command_overheads,
)
from s3o_drake.world.angles import facing_yaw, wrap
from s3o_drake.world.choices import MOTIONS
from s3o_drake.world.robot import CONTROL_PERIOD, load_robot
from s3o_drake.world.scenario import dump_scenario, load_scenario, with_overrides
from tests.conftest import COARSE_MAPS, ORACLE_MAPS_ONCE

UR5E = load_robot("ur5e")

REPO = Path(__file__).resolve().parents[2]
TWO_DISHES = REPO / "scenarios" / "small" / "two_dishes.yaml"


def _with(scenario, **planner):
    return dataclasses.replace(scenario, planner=dataclasses.replace(scenario.planner,
                                                                     **planner))


def _known(scenario, perceived_chairs) -> KnownWorld:
    """What the planner knows in `scenario` with these perceived chairs."""
    return KnownWorld.of(scenario, perceived_chairs=perceived_chairs)


def plan(scenario, *, perceived_chairs, **kwargs) -> TaskMotionPlan:
    """The plan of `scenario` from its start with these perceived chairs: the planner's own
    call, `plan_task`, which raises when no plan can be made."""
    return plan_task(_known(scenario, perceived_chairs), **kwargs).plan


def test_overheads_follow_the_control_period():
    o = command_overheads(0.05, 0.3)
    assert (o.gamma, o.pickup, o.plan) == pytest.approx((0.425, 0.175, -0.05))
    o = command_overheads(0.1, 0.0)
    assert (o.gamma, o.pickup, o.plan) == pytest.approx((0.25, 0.35, -0.1))


def test_the_recorded_model_was_made_from_the_code_as_it_is():
    """A stale models/ur5e/time_model.yaml (the navigator's or the systems' timing changed since
    it was derived) fails here: re-run `s3o build time-model`."""
    model = TimeModel.load(UR5E.files.time_model)
    o = command_overheads(CONTROL_PERIOD, base_motion.SETTLE_TIME)
    assert model.overheads.gamma == pytest.approx(o.gamma, abs=1e-6)
    assert model.overheads.pickup == pytest.approx(o.pickup, abs=1e-6)
    assert model.overheads.plan == pytest.approx(o.plan, abs=1e-6)
    assert model.turn_tolerance == TURN_TOLERANCE
    assert model.provenance["control_period"] == CONTROL_PERIOD
    assert model.provenance["base"] == {
        "acceleration": base_motion.ACCELERATION, "yaw_rate": base_motion.YAW_RATE,
        "yaw_acceleration": base_motion.YAW_ACCELERATION,
        "settle_time": base_motion.SETTLE_TIME}
    # The command as it was run: `s3o build time-model`, or at its addresses before the
    # s3o command (the recorded model predates it).
    command = model.provenance["command"]
    assert command.startswith("s3o build time-model ") or command.split()[2] in (
        "s3o_drake.commands.derive_times", "s3o_drake.execution.derive_times")
    assert model.provenance["samples"] >= 100 and model.pickup.form in PICKUP_FORMS
    held_out = model.fit["held_out"]
    assert held_out[model.pickup.form]["rmse"] == min(e["rmse"] for e in held_out.values())
    # Durations of the range it was fitted on, for every kind.
    for kind in ("plate", "bowl", "cup"):
        t = model.pickup.duration(kind, [0.5, 1.0])
        assert np.all((t > 1.0) & (t < 60.0))
    assert TimeModel.from_dict(model.to_dict()) == model


@pytest.mark.parametrize("motion", MOTIONS)
def test_goto_times_are_the_navigators_motion(motion):
    """For paths on the restaurant's map, the navigator's motion (played from the command the
    ExecutiveSystem sends: the map's path from where the base stands, the stop's pose) lasts what
    NavigationMap.path_times says, from any start yaw, with or without a final yaw, stopping at
    every corner or driving through them. (A smooth motion's corner shapes come from a table,
    within microseconds of the played curve's own.)"""
    scenario = with_overrides(load_scenario(REPO / "scenarios" / "restaurant.yaml"),
                              (f"execution.motion={motion}",))
    chairs = [c.pose for c in scenario.chairs if not c.mapped]
    nav = NavigationMap(_known(scenario, chairs).obstacles, robot=UR5E)
    profile = base_profile(scenario.planner, motion, robot=scenario.robot_value)
    navigator = BaseNavigator(robot=scenario.robot_value,
                              params=navigator_params(scenario, noise=False))
    rng = np.random.default_rng(0)
    free = [p for p in rng.uniform([0.5, 0.5], [9.5, 7.5], (400, 2))
            if nav.clearance(p[None])[0] > 0.5][:60]
    P, Q = np.array(free[:30]), np.array(free[30:60])
    yaw0 = rng.uniform(-math.pi, math.pi, 30)
    yaw1 = rng.uniform(-math.pi, math.pi, 30)
    yaw1[::4] = np.nan
    lengths, times, landing = nav.path_times(P, Q, yaw0, yaw1, profile)
    detours = 0
    for k in range(30):
        path = nav.path(P[k], Q[k])
        assert lengths[k] == pytest.approx(nav.path_length(P[k], Q[k]))
        detours += len(path) > 2
        yaw = yaw1[k] if not np.isnan(yaw1[k]) else facing_yaw(path[-2], path[-1])
        assert landing[k] == pytest.approx(yaw)
        context = navigator.CreateDefaultContext()
        state = np.zeros(2 * UR5E.num_positions)
        state[:3] = [*P[k], yaw0[k]]
        navigator.GetInputPort("robot_state").FixValue(context, state)
        command = BaseCommand(id=k + 1, path=tuple(map(tuple, path)), pose=(*Q[k], yaw))
        navigator.GetInputPort("base_command").FixValue(context, AbstractValue.Make(command))
        navigator.CalcForcedUnrestrictedUpdate(context, context.get_mutable_state())
        motion = context.get_abstract_state(0).get_value()
        assert motion.duration == pytest.approx(times[k], rel=1e-12 if motion == STOP_AND_GO
                                                else 1e-6)
    assert detours >= 5  # the routes round the tables are exercised


def _stop_and_go(scenario):
    return with_overrides(scenario, ("execution.motion=stop_and_go",))


def test_turns_at_a_merged_stop():
    """The ExecutiveSystem's rule: before each further pickup, a turn in place if the dish is
    more than TURN_TOLERANCE off; the base leaves facing the last dish it turned to."""
    scenario = _stop_and_go(load_scenario(TWO_DISHES))
    costs = CostModel.for_known(KnownWorld.perfect(scenario))
    stop = np.array([[2.0, 1.5]])
    a = math.atan2(2.3 - 1.5, 1.85 - 2.0)  # plate_a
    b = math.atan2(2.3 - 1.5, 2.15 - 2.0)  # cup_b
    time_s, leave = costs.stop_turns(stop, np.array([a]), ["plate_a", "cup_b"])
    gamma = costs.model.overheads.gamma
    assert time_s[0] == pytest.approx(costs.base.turn_time(b - a) + gamma)
    assert leave[0] == pytest.approx(b)
    # Within the tolerance: no turn, the base keeps its yaw.
    time_s, leave = costs.stop_turns(stop, np.array([b + 0.02]), ["cup_b"])
    assert time_s[0] == 0.0 and leave[0] == pytest.approx(b + 0.02)


@pytest.fixture(scope="module")
def executed():
    """two_dishes (S3O-GROP*, merged stop: drive, pickup, turn, pickup) planned with the
    oracle and executed without noise, stopping and going; every navigator motion and arm
    motion recorded. The oracle's coarse maps: what is compared is the plan's prediction
    and the execution of that plan, whichever stops the maps lead to."""
    scenario = _with(_stop_and_go(load_scenario(TWO_DISHES)), feasibility="oracle", workers=1)
    diagram = build_execution_diagram(scenario, noise=False,
                                      perceive=scenario_unmapped_chairs(scenario),
                                      plan_from=ORACLE_MAPS_ONCE)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    navigator = diagram.GetSubsystemByName("base_navigator")
    arm = diagram.GetSubsystemByName("arm_controller")
    drives, arms = {}, {}

    def record(root):
        motion = navigator.GetMyContextFromRoot(root).get_abstract_state(0).get_value()
        if motion.id:
            drives[motion.id] = motion.duration
        activity = arm.GetMyContextFromRoot(root).get_abstract_state(0).get_value()
        if activity.trajectory is not None:
            arms[activity.command] = activity.trajectory.end_time()

    simulator.set_monitor(record)
    simulator.Initialize()
    simulator.AdvanceTo(600.0)
    monitor = diagram.GetSubsystemByName("task_monitor")
    report = monitor.GetOutputPort("report").Eval(monitor.GetMyContextFromRoot(context))
    executive = diagram.GetSubsystemByName("executive")
    the_plan = executive.GetOutputPort("plan").Eval(executive.GetMyContextFromRoot(context))
    return scenario, the_plan, report, drives, arms


def test_the_plan_predicts_the_simulated_execution(executed):
    """The navigator's motions last what the model says; the prediction with the arm's real
    durations in place of the fitted ones is the simulated execution time, up to the control
    ticks' rounding (the model adds half a period per command; a command really waits
    between nothing and a whole period)."""
    scenario, p, report, drives, arms = executed
    assert [(a, o == "done" or o.startswith("failed: no_")) for a, _, o in report.outcomes] \
        == [("goto", True), ("pickup", True), ("pickup", True)]
    costs = CostModel.for_known(KnownWorld.perfect(scenario))
    (goto,) = p.gotos
    first, second = (a.dish for a in p.pickups)
    # Commands: the drive (id 1), the first pickup (2), the turn (3), the second pickup (4).
    assert sorted(drives) == [1, 3] and set(arms) <= {2, 4}
    nav = NavigationMap(KnownWorld.perfect(scenario).obstacles, robot=UR5E)
    start = np.asarray(scenario.robot.start, float)
    _, drive, _ = nav.path_times(start[None, :2], np.array([goto.pose[:2]]), start[2:],
                                 np.array([goto.pose[2]]), costs.base)
    assert drives[1] == pytest.approx(drive[0], rel=1e-12)
    stop = np.array([goto.pose[:2]])
    turn = float(wrap(costs.facing(stop, second)[0] - goto.pose[2]))
    assert abs(turn) > TURN_TOLERANCE
    # The planner measures the turn from where the plant really stands (its PD lags the
    # navigator by a fraction of a millimetre and a milliradian).
    assert drives[3] == pytest.approx(costs.base.turn_time(turn), abs=1e-3)

    fitted = float(costs.pickup_times([first, second], np.stack([stop, stop], axis=1))[0].sum())
    # A pickup the arm could not plan (no_ik, no_path) fails at once: its report is read a
    # period later, then the two hand-over ticks.
    real = sum(arms.get(cid, -0.5 * CONTROL_PERIOD) for cid in (2, 4)) \
        + 2 * costs.model.overheads.pickup
    expected = p.predicted_time - fitted + real
    assert abs(report.execution_time - expected) <= 4 * CONTROL_PERIOD / 2 + 1e-6
    # The fitted pickup times are near the real ones (what the benchmark measures).
    for cid, dish in ((2, first), (4, second)):
        if cid in arms:
            assert arms[cid] == pytest.approx(costs.model.pickup.duration(
                costs.dishes[dish].kind, np.linalg.norm(stop - costs.dishes[dish].xy)),
                rel=0.1)


@pytest.fixture(scope="module")
def heatmaps():
    scenario = _with(load_scenario(TWO_DISHES), feasibility="oracle")
    return scenario, compute_heatmaps(scenario, workers=1, progress=False, **COARSE_MAPS)


def test_the_cost_profile_switch(heatmaps):
    """"robot": the utility's costs are the predicted time; "paper": len / v + γ and δ from
    the planner settings. The predicted time is the execution's prediction under both."""
    scenario, maps = heatmaps
    chairs = [c.pose for c in scenario.chairs if not c.mapped]
    plans = {profile: plan(_with(scenario, cost_profile=profile), method="S3O-GROP*",
                           heatmaps=maps, perceived_chairs=chairs, seed=0)
             for profile in ("robot", "paper")}
    model = TimeModel.load(UR5E.files.time_model)
    # λ as the execution's mode prices a failure.
    reward = failure_reward(scenario.settings, robot=UR5E)
    robot = plans["robot"]
    gain = sum(reward * k.feasibility for k in robot.pickups)
    assert robot.utility == pytest.approx(-(robot.predicted_time - model.overheads.plan) + gain,
                                          abs=1e-6)
    paper = plans["paper"]
    pl = scenario.planner
    utility = sum(-(g.length / pl.speed + pl.gamma) for g in paper.gotos) + sum(
        -pl.delta + reward * k.feasibility for k in paper.pickups)
    assert paper.utility == pytest.approx(utility, abs=1e-6)
    # The paper's straight estimate is well below the execution's time (pickups of ~7 s
    # against δ = 5 s, the turns, accelerations and hand-overs: 1.66x here).
    straight = sum(g.length for g in paper.gotos) / pl.speed + pl.delta * len(paper.pickups)
    assert paper.predicted_time > 1.3 * straight
    # Same plan under both profiles here: the same prediction.
    if [g.pose for g in paper.gotos] == [g.pose for g in robot.gotos] and \
            paper.task_actions == robot.task_actions:
        assert paper.predicted_time == pytest.approx(robot.predicted_time)


def test_an_unknown_cost_profile_is_one_line_and_status_2(tmp_path):
    scenario = _with(load_scenario(TWO_DISHES), cost_profile="fastest")
    path = tmp_path / "bad.yaml"
    path.write_text(dump_scenario(scenario))
    result = subprocess.run([sys.executable, "-m", "s3o_drake.run", str(path)],
                            capture_output=True, text=True, cwd=tmp_path,
                            env={**os.environ, "PYTHONPATH": str(REPO)})
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "planner.cost_profile" in result.stderr
    assert "fastest" in result.stderr and not (tmp_path / "out").exists()


def test_the_command_fits_every_form_of_the_model_in_its_order():
    from s3o_drake.commands.derive_times import FORMS

    assert tuple(FORMS) == PICKUP_FORMS


def test_a_robot_being_built_is_timed_on_plans_that_need_no_recorded_shares(
        monkeypatch, tmp_path):
    """The time model's runs plan before the robot's calibration records its shared-stop
    shares (which need this model): a robot without them is timed on plans that rate shared
    stops as the paper does; one with them, on the plans it executes."""
    from s3o_drake.abstraction.shared_stop import uses_recorded_shares
    from s3o_drake.commands import derive_times
    from s3o_drake.experiments.jobs import as_benchmarked
    from s3o_drake.world import robot as robot_module

    files = robot_module.RobotFiles(tmp_path)
    monkeypatch.setattr(robot_module, "load_robot",
                        lambda name: dataclasses.replace(UR5E, files=files))
    task = load_scenario(REPO / "scenarios" / "generated" / "task_000.yaml")
    assert uses_recorded_shares(as_benchmarked(task).settings)  # measured open loop
    being_built = as_benchmarked(with_overrides(task, derive_times.unmeasured_ratings("ur5e")))
    assert not uses_recorded_shares(being_built.settings)
    files.shared_stop.write_text("")
    assert derive_times.unmeasured_ratings("ur5e") == ()


# ------------------------------------------------------------------------- smooth motion
def test_smooth_terms_of_a_merged_stop():
    """With smooth motion a stop's first pickup is the grasp alone (the arm came to the
    pre-grasp while the base drove), or after a drive too short to hide the arm's way there
    what that way outlasts it by; the next pickup waits for the first dish to reach the tray
    or for the turn to it, whichever is longer, then comes from the tray; the plan's last
    pickup holds the arm's last motions. The turn is in that term, not in the stop's."""
    scenario = load_scenario(TWO_DISHES)
    costs = CostModel.for_known(KnownWorld.perfect(scenario))
    arm, o = costs.model.smooth, costs.model.overheads
    stop = np.array([[2.0, 1.5]])
    a = math.atan2(2.3 - 1.5, 1.85 - 2.0)  # plate_a
    b = math.atan2(2.3 - 1.5, 2.15 - 2.0)  # cup_b
    where = np.stack([stop, stop], axis=1)
    d = np.linalg.norm(stop[0] - np.array([[1.85, 2.3], [2.15, 2.3]]), axis=1)
    got = costs.pickup_times(["plate_a", "cup_b"], where, stops=[0, 0],
                             gotos=np.array([[10.0]]))[0]
    part = {name: [float(arm.duration(name, kind, x)) for kind, x in
                   zip(("plate", "cup"), d, strict=True)] for name in arm.parts}
    turn = costs.base.turn_time(b - a) + o.gamma
    assert got[0] == pytest.approx(part["grasp"][0] + o.pickup)
    assert got[1] == pytest.approx(max(part["tail"][0], turn) + part["from_tray"][1]
                                   + part["grasp"][1] + o.pickup
                                   + part["tail"][1] + part["stow"][1])
    short = costs.pickup_times(["plate_a", "cup_b"], where, stops=[0, 0],
                               gotos=np.array([[0.5]]))[0]
    assert short[0] == pytest.approx(got[0] + part["prepare"][0] - 0.5)
    time_s, leave = costs.stop_turns(stop, np.array([a]), ["plate_a", "cup_b"])
    assert time_s[0] == 0.0 and leave[0] == pytest.approx(b)
    # Stopping and going, the same pickups are the recorded whole motions.
    plain = CostModel.for_known(KnownWorld.perfect(_stop_and_go(scenario)))
    np.testing.assert_allclose(plain.pickup_times(["plate_a", "cup_b"], where, stops=[0, 0]),
                               plain.pickup_times(["plate_a", "cup_b"], where))


def test_smooth_the_plan_predicts_the_simulated_execution():
    """two_dishes planned for smooth motion and executed without noise: the prediction is
    the simulated execution time within 3 % (the benchmark's target over 20 tasks). Planned
    on the oracle's coarse maps, as `executed` is."""
    scenario = _with(load_scenario(TWO_DISHES), feasibility="oracle", workers=1)
    run = execute(scenario, meshcat=None, noise=False, progress=False,
                  perceive=scenario_unmapped_chairs(scenario), plan_from=ORACLE_MAPS_ONCE)
    assert run.report["collected"] == 2
    assert run.plan.predicted_time == pytest.approx(run.report["execution_time"], rel=0.03)
    assert run.activity.together() > 1.0  # the arm moved while the base did
    # Where the time went adds up to the run, and says the same of the motion together.
    split = run.report["time_by_motion"]
    assert sum(split.values()) == pytest.approx(run.report["simulated_time"], abs=0.06)
    assert split["together"] == pytest.approx(run.activity.together())
    assert split["drive"] > 0 and split["arm"] > 0


# -------------------------------------------------------------------------------- noise
def test_the_noise_terms_apply_only_at_the_noise_they_were_measured_at():
    """A plan's expected time adds what the noise adds per goto and pickup, for its motion,
    at the scenario noise the terms were measured at, and nothing is made up elsewhere."""
    from s3o_drake.planning.plan import Goto, Pickup
    from s3o_drake.planning.time_model import NoiseTerms
    from s3o_drake.world.settings import Uncertainty

    at = {"nav_xy_std": 0.1, "nav_yaw_std": 0.05, "reach_std": 0.01}
    model = dataclasses.replace(TimeModel.load(UR5E.files.time_model), noise={
        "smooth": NoiseTerms(goto=1.5, pickup=0.5, uncertainty=at, fit={"pairs": 3})})
    assert TimeModel.from_dict(model.to_dict()) == model
    assert model.noise_time("smooth", Uncertainty(), gotos=2, pickups=3) == pytest.approx(4.5)
    assert model.noise_time("stop_and_go", Uncertainty(), gotos=2, pickups=3) is None
    assert model.noise_time("smooth", Uncertainty(nav_xy_std=0.2), gotos=2, pickups=3) is None

    scenario = with_overrides(load_scenario(TWO_DISHES), ("execution.motion=smooth",))
    costs = CostModel.for_known(KnownWorld.perfect(scenario), time_model=model)
    actions = (Goto("l0", (1.0, 1.0, 0.0), ((0.0, 0.0), (1.0, 1.0)), 1.4),
               Pickup("a", "l0", 0.9), Pickup("b", "l0", 0.9))
    assert costs.expected_time(100.0, actions) == pytest.approx(100.0 + 1.5 + 2 * 0.5)
    stop_and_go = CostModel.for_known(KnownWorld.perfect(with_overrides(
        scenario, ("execution.motion=stop_and_go",))), time_model=model)
    assert stop_and_go.expected_time(100.0, actions) is None


def test_the_shipped_model_knows_what_the_default_noise_adds_in_each_motion():
    from s3o_drake.world.settings import Uncertainty

    model = TimeModel.load(UR5E.files.time_model)
    for motion in MOTIONS:
        terms = model.noise[motion]
        assert terms.applies(Uncertainty())
        # Measured on plans executed as planned both ways, and the noise costs time.
        assert terms.fit["as_planned"] >= 10 and terms.goto > 0 and terms.pickup > 0
