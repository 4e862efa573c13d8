"""Execution in the Drake simulation: the diagram builder (diagram.py), `execute()`
(execute.py), one LeafSystem per file (s3o_planner, base_navigator, arm_controller,
task_monitor) and the messages they send each other (messages.py)."""
