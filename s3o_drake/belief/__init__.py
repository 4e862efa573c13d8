"""What the robot knows: its belief, apart from the true world.

`known_world.py`: the `Briefing` (what the robot is given: its map, the settings, the task's
objects, its start, the robot itself) and the `KnownWorld` it plans from (the map, the
perceived chairs, the objects that remain, its pose). `chair_perception.py`: the unmapped
chairs found in the overhead camera's images (`ChairPerception(map, camera, pose=pose,
robot=robot)(color, depth, label)`, `perceived_chairs(briefing, images)`), and
`perceive_known_world`, which makes the KnownWorld of them;
`scenario_unmapped_chairs(scenario)` is perfect perception, for tests and comparisons (it
reads the truth). `blobs.py`: the obstacle blobs perception starts from.
`s3o bench perception` measures its accuracy."""

from s3o_drake.belief.chair_perception import (
    ChairPerception,
    Perceive,
    perceive_known_world,
    perceived_chairs,
    scenario_unmapped_chairs,
)

__all__ = ["ChairPerception", "Perceive", "perceive_known_world",
           "perceived_chairs", "scenario_unmapped_chairs"]
