"""What a scenario's settings need from its robot's folder, and what of it is missing.

A robot's built files (models/<robot>/, `s3o build robot`) are read deep inside planning;
a command checks first, so that a robot without its network, its failure price or its
shared-stop shares is told so in one line, with the setting that needs the file and how to
make it or do without.
"""

from s3o_drake.abstraction.shared_stop import uses_recorded_shares
from s3o_drake.planning.failure_price import uses_recorded_price
from s3o_drake.world.choices import FeasibilitySource
from s3o_drake.world.resources import repo_path
from s3o_drake.world.robot import Robot
from s3o_drake.world.settings import Settings


def missing_robot_files(settings: Settings, robot: Robot) -> list[str]:
    """One line per file that `settings` need and `robot`'s folder lacks: the setting, the
    file, and how to make it (or the setting that does without). A robot still being built
    gets one line: what its description says it lacks."""
    files = robot.files
    build = f"s3o build robot {robot.name}"
    if robot.description.missing:  # still being built: its description says what it lacks
        return [f"robot.name: {robot.name!r} is not ready to plan and execute; it lacks "
                f"{' '.join(robot.description.missing.split())}"]
    needed = [("robot.name", files.reachability_map, f"`{build} --steps reachability`"),
              ("robot.name", files.time_model, f"`{build} --steps time-model`")]
    if settings.planner.feasibility == FeasibilitySource.FCN.value:
        needed.append(("planner.feasibility", files.fcn_weights,
                       f"`{build} --steps fcn-data fcn`, or planner.feasibility: oracle"))
    if uses_recorded_price(settings):
        needed.append(("planner.failure_price", files.failure_price,
                       "`s3o failure-price` on the robot's recovery runs, or "
                       "planner.failure_price: paper"))
    if uses_recorded_shares(settings):
        needed.append(("planner.shared_stop", files.shared_stop,
                       "`s3o shared-stop` on the robot's open-loop runs, or "
                       "planner.shared_stop: paper"))
    return [f"{field}: {robot.name!r} has no {repo_path(path)}; make it with {how}"
            for field, path, how in needed if not path.is_file()]
