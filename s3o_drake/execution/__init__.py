"""Execution in the Drake simulation: the Executive (executive.py: the walk of the plan and
the recovery policy, plain Python) and the escape search of the base (escape.py), the
diagram builder (diagram.py), `execute()` (execute.py), one LeafSystem per file
(executive_system, base_navigator, arm_controller, task_monitor) and the messages they send
each other (messages.py)."""
