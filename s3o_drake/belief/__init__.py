"""Perception from the overhead camera: what the robot's map lacks (the chairs).

`ChairPerception(map, camera, pose=pose)(color, depth, label)` returns the unmapped chairs'
poses [x, y, yaw], given only what the robot knows; `perceived_chairs(briefing, images)` is
the one-call form, and
`perceive_known_world` makes the planner's `KnownWorld` of them;
`scenario_unmapped_chairs(scenario)` is perfect perception, for tests and comparisons. See `chairs`
for the method and `s3o bench perception` for its accuracy.
"""

from s3o_drake.belief.chair_perception import (
    ChairPerception,
    Perceive,
    draw_chairs,
    perceive_known_world,
    perceived_chairs,
    scenario_unmapped_chairs,
)

__all__ = ["ChairPerception", "Perceive", "draw_chairs", "perceive_known_world",
           "perceived_chairs", "scenario_unmapped_chairs"]
