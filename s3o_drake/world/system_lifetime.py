"""Let Python's garbage collector free a finished Diagram that holds Python LeafSystems.

pydrake 1.51 keeps every such Diagram alive for the rest of the process (measured: a
LeafSystem subclass with no ports at all, added to a DiagramBuilder, makes the built
Diagram immortal; upstream: RobotLocomotion/drake issues 14387 and 22515). Three kinds of
reference hold it, and the gc can see none of them as garbage:

- a callback given to a `Declare...` method is stored in C++, so a bound method there is a
  strong reference from C++ to its system;
- pydrake ties each DiagramBuilder, the systems added to it, their ports and the Diagram
  together in reference-cycle sets (`_pydrake_internal_ref_cycle_peers`), and a Python
  system owned by C++ carries a reference that the gc cannot trace;
- a CacheEntry keeps its system alive from C++ as well: a system keeps the entry's index,
  never the entry (ObjectTracker).

An execution diagram (plant, scene graph, the camera's renderer, the planner's results) is
about 100 MB, so a study or a soak that runs many executions in one process would grow
without bound. The project's LeafSystems therefore declare their callbacks through
`weak_callback`, and `execute()` breaks pydrake's cycle sets with `release_diagram` once
its run is over and it has read out what the run produced.
"""

import weakref
from collections.abc import Callable, Iterator
from typing import Any

from pydrake.systems.framework import Diagram, DiagramBuilder

PEERS = "_pydrake_internal_ref_cycle_peers"
"""The attribute in which pydrake keeps an object's reference-cycle peers."""


def weak_callback(method: Callable[..., Any], **bound_kwargs: Any) -> Callable[..., Any]:
    """`method` (bound to a system) as a callback that does not keep the system alive;
    `bound_kwargs` are passed on every call.

    C++ owns the system while the callback can be called, so the system is there whenever
    the callback runs; a call after the system is gone is a bug and raises."""
    ref = weakref.WeakMethod(method)
    name = method.__qualname__  # not `method` itself, which would hold the system

    def call(*args: Any) -> Any:
        bound = ref()
        if bound is None:
            raise ReferenceError(f"{name} called after its system was freed")
        return bound(*args, **bound_kwargs)

    return call


def _systems(diagram: Diagram) -> Iterator[Any]:
    yield diagram
    for system in diagram.GetSystems():
        if isinstance(system, Diagram):
            yield from _systems(system)
        else:
            yield system


def _held(value: Any, depth: int = 3) -> Iterator[Any]:
    """The objects with pydrake cycle sets that `value` holds in its attributes, lists,
    tuples and dicts (a port a system keeps, as `self._state_port`)."""
    if depth == 0:
        return
    if isinstance(value, (list, tuple, set, frozenset)):
        items = value
    elif isinstance(value, dict):
        items = value.values()
    else:
        if PEERS in getattr(value, "__dict__", {}):
            yield value
        return
    for item in items:
        yield from _held(item, depth - 1)


def release_diagram(diagram: Diagram) -> None:
    """Breaks pydrake's reference cycles between `diagram`, its subsystems (nested
    diagrams included) and the builders that built them, so that the gc frees them all
    once nothing else holds `diagram`. Call it when the diagram's run is over: pydrake
    keeps the Python half of a system alive through these cycles, so neither the diagram
    nor any of its systems or ports may be used afterwards (measured: a release straight
    after Build() crashes the next GetSystems())."""
    # All of them first: a cleared system may be freed, and a nested diagram with it.
    systems = list(_systems(diagram))
    for system in systems:
        attributes = getattr(system, "__dict__", {})
        # A port kept in an attribute and its system hold each other, and the gc leaves
        # that cycle alone (measured); so its set goes too.
        for held in _held([v for k, v in attributes.items() if k != PEERS]):
            held.__dict__[PEERS].clear()
        peers = attributes.get(PEERS)
        if not peers:
            continue
        for peer in peers:
            if isinstance(peer, DiagramBuilder):
                peer.__dict__.get(PEERS, set()).clear()
        peers.clear()
