"""`s3o sim`: the simulated robot alone on a bus of this machine, publishing its state to
whoever listens in another process; bad input is one line and status 2."""

import random
import signal
import subprocess
import sys
import time

import pytest
from pydrake.lcm import DrakeLcm

from s3o_drake.commands.sim import main
from s3o_drake.world import robot_channels as ch
from s3o_drake.world.lcmtypes.s3o_lcm import robot_state_t
from s3o_drake.world.robot import load_robot

SCENE = "scenarios/small/two_dishes.yaml"


def test_a_bus_of_one_process_or_a_bad_rate_is_refused_in_one_line(capsys):
    for args, field in ((["--lcm", "memq://"], "--lcm"), (["--realtime-rate", "-1"],
                                                         "--realtime-rate")):
        with pytest.raises(SystemExit) as exit_:
            main([SCENE, *args])
        assert exit_.value.code == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and field in err


def test_the_robot_publishes_its_state_to_another_process():
    # A port of its own, so that no other run on this machine is heard.
    url = ch.local_bus(random.randint(20000, 60000))
    lcm = DrakeLcm(url)
    states = []
    lcm.Subscribe(ch.ROBOT_STATE, lambda data: states.append(robot_state_t.decode(data)))
    process = subprocess.Popen(
        [sys.executable, "-m", "s3o_drake.commands", "sim", SCENE, "--lcm", url,
         "--realtime-rate", "1", "--time-limit", "3"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not states and time.monotonic() < deadline and process.poll() is None:
        lcm.HandleSubscriptions(100)
    out, err = process.communicate(timeout=120)
    assert process.returncode == 0, err
    assert states, "no robot state heard"
    joints = load_robot("ur5e").joints
    assert list(states[0].joint_name) == list(joints)
    assert ch.positions_of(states[0], joints=joints)[:3] == pytest.approx([0.6, 0.6, 0.0],
                                                                          abs=1e-3)
    assert "publishing S3O_ROBOT_STATE" in err
    assert out.strip() == "ended at 3.00 s: on the tray nothing"


def test_ctrl_c_as_its_first_state_is_heard_ends_it_and_it_says_what_it_holds():
    """The first state comes while the simulator starts: a Ctrl-C then is not lost, as a
    Ctrl-C at any time is not."""
    url = ch.local_bus(random.randint(20000, 60000))
    lcm = DrakeLcm(url)
    states = []
    lcm.Subscribe(ch.ROBOT_STATE, lambda data: states.append(data))
    process = subprocess.Popen(
        [sys.executable, "-m", "s3o_drake.commands", "sim", SCENE, "--lcm", url],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not states and time.monotonic() < deadline and process.poll() is None:
        lcm.HandleSubscriptions(5)
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=60)
    assert states, "no robot state heard"
    assert process.returncode == 130, err
    assert out.startswith("ended at 0.") and out.strip().endswith("on the tray nothing")
