"""Task and motion planning: the clingo task planner, navigation and the motion search."""
