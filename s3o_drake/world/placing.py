"""What counts as an object put down at its place: one source for the execution's judge
(`execution.messages.Placement`) and the planner's model of it (`feasibility.
pickup_geometry.place_probability`). Imports nothing, so that the commands can read it
before the heavy imports."""

PLACE_TOLERANCE = 0.03
"""How far (m, horizontally) a put-down object may stand from its place target and count
as placed (it must also stand upright on the target's surface): the execution's judge, and
what the planner's Fea^m of a place is the probability of (`pickup_geometry.place_probability`)."""
SURFACE_TOLERANCE = 0.005
"""How far (m) the surface it stands on may be from the target's and be the same one."""
