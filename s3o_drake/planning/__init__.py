"""Planning from what the robot knows: the pipeline (pipeline.py: KnownWorld ->
PlanningResult), the methods (planner.py), the navigation map, the clingo task planner
(task_planner.py with domain.lp), the motion search (GROP*, GROP; PETLON), the base's motion
profile and the time model, the plan and its pictures."""
