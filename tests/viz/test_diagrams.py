"""diagrams/ holds the pictures of the diagrams the code builds now."""

from s3o_drake.commands import diagrams


def test_committed_diagrams_are_current():
    stale = diagrams.stale()
    assert not stale, f"{stale} out of date: run s3o diagrams"


def test_rendering_is_deterministic_and_names_every_system(tmp_path):
    diagrams.write(tmp_path)
    assert diagrams.stale(tmp_path) == []
    execution = (tmp_path / "execution.dot").read_text()
    for name in ("world", "executive", "base_navigator", "arm_controller", "task_monitor",
                 "desired_state_mux", "base_command", "pick_command", "grip"):
        assert name in execution, name
    assert "object_tracker" in (tmp_path / "world.dot").read_text()


def test_normalize_renumbers_ids_and_sorts_connections():
    a = "digraph _17 {\ns40 [label=x]\ns40:y0:e -> s9:u0:w\ns9:y0:e -> s40:u0:w\n}"
    b = "digraph _3 {\ns7 [label=x]\ns5:y0:e -> s7:u0:w\ns7:y0:e -> s5:u0:w\n}"
    assert diagrams.normalize(a) == diagrams.normalize(b)
