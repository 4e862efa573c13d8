"""Task planning: the visiting order and the task-level sequences, from clingo
(`planner.py` with domain.lp, order.lp and locations.lp; `problem.py` its facts and answers),
the locations' costs (`costs.py`), the orders tried first (`first_order.py`), the exact
ordering and its bound (`exact_order.py`), and an independent plan checker (`check.py`)."""
