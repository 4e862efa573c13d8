"""world/system_lifetime.py: a finished execution diagram and its Python systems are freed, so
that many runs in one process (a study's worker, the soak) do not accumulate them."""

import gc
import warnings
import weakref

import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource

from s3o_drake.execution.execute import execute
from s3o_drake.execution.executive_system import ExecutiveSystem
from s3o_drake.execution.messages import PlanProgress
from s3o_drake.execution.task_monitor import TaskMonitor
from s3o_drake.world.dish_messages import DishPoses, DishStates
from s3o_drake.world.object_tracker import ObjectTracker
from s3o_drake.world.scenario import load_scenario
from s3o_drake.world.system_lifetime import release_diagram, weak_callback


class _Counter:
    def __init__(self):
        self.calls = 0

    def count(self, step: int, *, times: int = 1) -> int:
        self.calls += step * times
        return self.calls


def test_a_weak_callback_calls_through_without_keeping_its_object():
    counter = _Counter()
    callback = weak_callback(counter.count)
    assert callback(2) == 2 and callback(3) == 5
    assert weak_callback(counter.count, times=10)(1) == 15
    alive = weakref.ref(counter)
    del counter
    gc.collect()
    assert alive() is None
    with pytest.raises(ReferenceError, match=r"_Counter\.count called after"):
        callback(1)


def _monitor_diagram():
    builder = DiagramBuilder()
    monitor = builder.AddSystem(TaskMonitor())
    for name, value in (("progress", PlanProgress(step=0, total=1)),
                        ("dish_states", DishStates({})), ("dish_poses", DishPoses({}))):
        source = builder.AddSystem(ConstantValueSource(AbstractValue.Make(value)))
        builder.Connect(source.get_output_port(), monitor.GetInputPort(name))
    return builder.Build(), monitor


def test_a_released_diagram_and_its_python_systems_are_freed_after_a_simulation():
    diagram, monitor = _monitor_diagram()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.5)
    report = monitor.GetOutputPort("report").Eval(
        monitor.GetMyContextFromRoot(simulator.get_context()))
    assert report.dishes == 0 and not report.finished  # the system ran, through its callbacks
    alive = (weakref.ref(diagram), weakref.ref(monitor))
    del simulator, monitor
    release_diagram(diagram)
    del diagram
    gc.collect()
    assert [ref() for ref in alive] == [None, None]


def _live(*kinds) -> tuple[int, ...]:
    """How many objects of each of `kinds` are alive (one pass over them all)."""
    gc.collect()
    counts = dict.fromkeys(kinds, 0)
    # isinstance on every live object touches torch's deprecated module proxies, which warn.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        for o in gc.get_objects():
            for kind in kinds:
                if isinstance(o, kind):
                    counts[kind] += 1
    return tuple(counts.values())


def test_an_execution_leaves_no_diagram_behind():
    """What one run leaves, every run in the process would: nothing of its diagram."""
    scenario = load_scenario("scenarios/small/two_dishes.yaml")
    before = _live(ExecutiveSystem, ObjectTracker)
    run = execute(scenario, meshcat=None, progress=False)
    assert run.report["collected"] == 2
    # The run's results stay; its diagram (plant, scene graph, renderer, systems) does not.
    assert run.result is not None and run.plan is not None
    assert _live(ExecutiveSystem, ObjectTracker) == before
