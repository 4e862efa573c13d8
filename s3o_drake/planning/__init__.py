"""Planning from what the robot knows: `pipeline.py` (KnownWorld -> PlanningResult, in
`result.py`), the compared methods as a registry under one budget (`methods.py`),
navigation (`navigation/`), task planning with clingo (`task/`), the motion search
(`motion/`), the time model and the failure price the utility is costed with
(`time_model.py`, `failure_price.py`), and the plan itself (`plan.py`)."""
