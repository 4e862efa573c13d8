"""`s3o bench tracking`: a robot's PD-held arm follows its planned pickup in simulation,
and the command says how closely, a row per robot."""

import pytest

from s3o_drake.commands.tracking_benchmark import main


def test_the_ur5e_follows_its_pickup_and_grasps_where_planned(capsys):
    assert main(["--robot", "ur5e"]) == 0
    (row,) = [line for line in capsys.readouterr().out.splitlines()
              if line.startswith("| ur5e |")]
    pickup, joints, grasp, at_grasp = (float(v) for v in row.strip("| ").split(" | ")[1:])
    assert 3.0 < pickup < 15.0
    # The grasp point lags the plan by up to centimetres while the arm swings, and is
    # where the plan has it when the fingers close.
    assert joints < 0.05 and grasp < 30.0 and at_grasp < 2.0


def test_an_unknown_robot_is_one_line_and_status_2(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--robot", "r2d2"])
    err = capsys.readouterr().err
    assert info.value.code == 2 and err.count("\n") == 1 and "--robot" in err
