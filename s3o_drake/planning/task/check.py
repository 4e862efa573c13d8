"""The task-level plan checker: a plan replayed step by step against its problem.

Independent of the ASP encodings (task_planner.py, domain.lp and order.lp) on purpose, so
that the tests and the soak check the planner rather than repeat it.
"""

from __future__ import annotations

from collections.abc import Sequence

from s3o_drake.planning.task.planner import Action, TaskProblem


def check_plan(problem: TaskProblem, actions: Sequence[Action],
               dishes: Sequence[str] | None = None) -> int:
    """Replays a plan step by step; raises ValueError at the first violated precondition or
    an unmet goal, else returns its navigation cost (rounded as the planner rounds).

    `dishes`: those the goal requires (default: every dish that has a location, and for an
    object to place, whose place has one too): collected, or put down at its place.
    Independent of the ASP encoding on purpose, so that it checks the planner rather than
    repeating it.
    """
    goal = set(dishes) if dishes is not None else {
        d for d, loc in problem.dishes.items()
        if (loc is not None or d == problem.held)
        and (d not in problem.places or problem.places[d] is not None)}
    here = problem.start
    tray: set[str] = set()
    hand: str | None = problem.held
    collected: set[str] = {hand} if hand is not None else set()
    delivered: set[str] = set()
    put: set[str] = set()
    total = 0
    for i, (name, arg) in enumerate(actions):
        if name == "goto":
            if arg == here:
                raise ValueError(f"step {i}: goto({arg}) where the robot already stands")
            if arg not in problem.locations and arg != problem.depot:
                raise ValueError(f"step {i}: goto({arg}): unknown location")
            c = problem.cost(here, arg)
            if c is None:
                raise ValueError(f"step {i}: goto({arg}) cannot be reached from {here}")
            total += round(c)
            here = arg
        elif name == "pickup":
            if arg not in problem.dishes:
                raise ValueError(f"step {i}: pickup({arg}): unknown dish")
            if problem.dishes[arg] != here:
                raise ValueError(f"step {i}: pickup({arg}) at {here}, but the dish is at "
                                 f"{problem.dishes[arg]}")
            if arg in collected:
                raise ValueError(f"step {i}: pickup({arg}) again")
            if hand is not None:
                raise ValueError(f"step {i}: pickup({arg}) while the gripper holds {hand}")
            collected.add(arg)
            if arg in problem.places:
                hand = arg
                continue
            if problem.capacity is not None and len(tray) >= problem.capacity:
                raise ValueError(f"step {i}: pickup({arg}) with a full tray")
            tray.add(arg)
        elif name == "place":
            if hand != arg:
                raise ValueError(f"step {i}: place({arg}) but the gripper holds {hand}")
            if problem.places.get(arg) != here:
                raise ValueError(f"step {i}: place({arg}) at {here}, but its place is at "
                                 f"{problem.places.get(arg)}")
            put.add(arg)
            hand = None
        elif name == "unload":
            if problem.depot is None or here != problem.depot:
                raise ValueError(f"step {i}: unload away from the depot")
            delivered |= tray
            tray.clear()
        else:
            raise ValueError(f"step {i}: unknown action {name!r}")
    done = (delivered if problem.depot is not None else collected - set(problem.places)) | put
    if not goal <= done:
        raise ValueError(f"goal not reached: {sorted(goal - done)} not collected or placed")
    return total
