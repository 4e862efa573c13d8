"""One process against two: a scenario run with the robot simulated beside its controllers,
and run with the robot in a process of its own (`s3o sim`) and the controllers here,
driving it over a bus of this machine (`execution.controller_process`).

`compare_processes(path, ...)` runs the scenario in one process twice (the second must
repeat the first) and then in two, and returns the row: what each run did, whether the one
process repeated itself and whether the two processes agree with it (`agreement`). With
`loss`, the two processes talk through a `LossyRelay`, which drops that share of the
messages each way.
"""

from __future__ import annotations

import math
import random
import subprocess
import sys
import threading
from collections.abc import Sequence
from functools import partial
from pathlib import Path

from pydrake.lcm import DrakeLcm

from s3o_drake.execution.controller_process import execute_on_bus
from s3o_drake.execution.execute import execute
from s3o_drake.world import robot_channels as ch
from s3o_drake.world.referee_channel import REFEREE
from s3o_drake.world.scenario import Scenario, load_scenario, with_overrides

TIME_TOLERANCE = 0.02
"""Two processes agree with one when their execution times are within this share."""
REPEATED = ("collected_dishes", "outcomes", "outcome_times", "execution_time",
            "closest_approach")
"""What a run in one process must repeat exactly (timings of the machine aside)."""


def stops(report: dict) -> int:
    """The drives a run made: its goto actions that ended, done or not."""
    return sum(action == "goto" for action, _, _ in report["outcomes"])


def summary(report: dict) -> dict:
    """What the comparison reads of a report."""
    return {"collected_dishes": list(report["collected_dishes"]), "stops": stops(report),
            "execution_time": report["execution_time"], "finished": report["finished"],
            "reason": report["reason"], "outcomes": [list(o) for o in report["outcomes"]],
            "outcome_times": list(report.get("outcome_times", [])),
            "closest_approach": report["closest_approach"],
            **{k: report[k] for k in ("waited", "robot_time") if k in report}}


def agreement(one: dict, two: dict, *, tolerance: float = TIME_TOLERANCE) -> list[str]:
    """How the two-process run's summary differs from the one-process run's: the dishes
    collected, the number of stops, the execution time beyond `tolerance` (empty: they
    agree)."""
    differences = []
    if sorted(one["collected_dishes"]) != sorted(two["collected_dishes"]):
        differences.append(f"collected {sorted(two['collected_dishes'])} against "
                           f"{sorted(one['collected_dishes'])}")
    if one["stops"] != two["stops"]:
        differences.append(f"{two['stops']} stops against {one['stops']}")
    share = two["execution_time"] / one["execution_time"] - 1.0 if one["execution_time"] else \
        math.inf
    if abs(share) > tolerance:
        differences.append(f"execution time {two['execution_time']:.2f} s against "
                           f"{one['execution_time']:.2f} s ({100 * share:+.1f} %)")
    return differences


ROBOT_CHANNELS = (ch.ROBOT_STATE, ch.OVERHEAD_IMAGES, ch.GRIPPER_STATUS, ch.TARGET_SIGHTING,
                  ch.PROTECTIVE_STOP, REFEREE)
"""What the robot's process publishes."""
CONTROLLER_CHANNELS = (ch.ROBOT_COMMAND, ch.GRIP, ch.TARGET_REQUEST)
"""What the controllers publish."""


class LossyRelay:
    """A network that loses messages: forwards the robot's channels from its bus to the
    controllers' and theirs back, each message dropped with probability `loss` (drawn from
    `seed`), on a thread of its own until `stop()`."""

    def __init__(self, robot_bus: str, controller_bus: str, *, loss: float, seed: int) -> None:
        if not 0.0 <= loss < 1.0:
            raise ValueError(f"loss: expected a share in [0, 1), got {loss}")
        self._rng = random.Random(seed)
        self._loss = loss
        self._robot, self._controllers = DrakeLcm(robot_bus), DrakeLcm(controller_bus)
        self.passed = self.dropped = 0
        for channel in ROBOT_CHANNELS:
            self._robot.Subscribe(channel, partial(self._forward, self._controllers, channel))
        for channel in CONTROLLER_CHANNELS:
            self._controllers.Subscribe(channel, partial(self._forward, self._robot, channel))
        self._running = True
        self._thread = threading.Thread(target=self._pump, daemon=True)
        self._thread.start()

    def _forward(self, to: DrakeLcm, channel: str, data: bytes) -> None:
        if self._rng.random() < self._loss:
            self.dropped += 1
            return
        self.passed += 1
        to.Publish(channel, data)

    def _pump(self) -> None:
        while self._running:
            self._robot.HandleSubscriptions(1)
            self._controllers.HandleSubscriptions(1)

    def stop(self) -> None:
        self._running = False
        self._thread.join(timeout=5.0)


def _in_two_processes(path: Path, scenario: Scenario, *, overrides: Sequence[str],
                      seed: int, realtime_rate: float, loss: float = 0.0) -> dict:
    """The run with `s3o sim` in a process of its own, on a bus of its own (with `loss`,
    the controllers on another, a `LossyRelay` between them)."""
    # Buses of their own: no other robot on this machine is heard.
    ports = random.SystemRandom().sample(range(20000, 60000), 2)
    url = ch.local_bus(ports[0])
    controller_url = url if not loss else ch.local_bus(ports[1])
    robot = subprocess.Popen(
        [sys.executable, "-m", "s3o_drake.commands", "sim", str(path), "--lcm", url,
         "--seed", str(seed), "--realtime-rate", str(realtime_rate),
         *(a for o in overrides for a in ("--set", o))],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    relay = LossyRelay(url, controller_url, loss=loss, seed=seed) if loss else None
    try:
        run = execute_on_bus(scenario, lcm=DrakeLcm(controller_url), seed=seed, wait=120.0,
                             progress=False)
    finally:
        if robot.poll() is None:
            robot.terminate()
        try:
            tray, said = robot.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            robot.kill()
            tray, said = robot.communicate()
        if relay is not None:
            relay.stop()
    lost = {} if relay is None else {"messages_passed": relay.passed,
                                      "messages_dropped": relay.dropped}
    return {**summary(run.report), "robot_said": tray.strip().splitlines()[-1:],
            "robot_errors": [line for line in said.splitlines() if "Error" in line][-3:],
            **lost}


def compare_processes(path: Path, *, seed: int, overrides: Sequence[str] = (),
                      realtime_rate: float = 1.0, loss: float = 0.0) -> dict:
    """The row of scenario `path` with `overrides`, noise and plans from `seed`: `one`,
    `one_again` and `two` (each run's `summary`; `two` through a `LossyRelay` with `loss`),
    `repeats` (the one process's second run repeated the first in REPEATED) and
    `differences` (`agreement`)."""
    scenario = with_overrides(load_scenario(path), overrides)
    one, one_again = (summary(execute(scenario, seed=seed, meshcat=None, progress=False).report)
                      for _ in range(2))
    two = _in_two_processes(path, scenario, overrides=overrides, seed=seed,
                            realtime_rate=realtime_rate, loss=loss)
    return {"key": f"{path.stem}:{seed}:{loss:g}", "task": path.stem, "seed": seed,
            "loss": loss, "overrides": list(overrides), "one": one, "one_again": one_again,
            "two": two,
            "repeats": all(one[k] == one_again[k] for k in REPEATED),
            "differences": agreement(one, two)}
