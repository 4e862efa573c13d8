"""The execution's progress bar counts simulated seconds against the predicted execution
time and never runs past its total."""

import io

from s3o_drake.execution.execute import SimulatedSeconds


def _shown(text: str) -> list[str]:
    """The bar's states, as tqdm redraws them ("n/total")."""
    return [part.split("|")[2].split()[0] for part in text.split("\r") if part.count("|") >= 2]


def test_the_total_grows_when_the_simulation_outlasts_the_prediction():
    out = io.StringIO()
    bar = SimulatedSeconds(122.2, file=out)
    assert bar.bar.total == 122
    for t in (0.5, 60.0, 121.9, 124.3, 150.0):
        bar.show(t)
        assert bar.bar.n <= bar.bar.total
    assert (bar.bar.n, bar.bar.total) == (150, 150)
    bar.close(151.7)
    assert (bar.bar.n, bar.bar.total) == (151, 151)
    for state in _shown(out.getvalue()):
        done, total = map(int, state.split("/"))
        assert done <= total, state
    assert _shown(out.getvalue())[-1] == "151/151"


def test_a_run_shorter_than_predicted_ends_full_at_its_own_time():
    out = io.StringIO()
    bar = SimulatedSeconds(122.2, file=out)
    bar.show(80.4)
    assert (bar.bar.n, bar.bar.total) == (80, 122)
    bar.close(95.0)
    assert _shown(out.getvalue())[-1] == "95/95"


def test_a_disabled_bar_follows_the_time_silently():
    bar = SimulatedSeconds(10.0, disable=True)
    bar.show(30.0)
    bar.close(31.0)
    assert bar.bar.total == 31
