"""The values on the ObjectTracker's ports (world/object_tracker.py): where the dishes are
and in what state, as the simulation knows them (the referee's view, not the robot's).

All are immutable: Drake copies port values and state, and nothing may change them in
place. The containers are read-only mappings by dish name, in the scenario's order.
"""

from collections.abc import Iterable, Iterator, Mapping
from enum import Enum
from typing import Generic, TypeVar

from pydrake.math import RigidTransform

_V = TypeVar("_V")


class DishState(str, Enum):
    """Where a dish is. A str Enum, so that a state prints, compares and serialises as the
    plain word ("table", "gripper", "tray", "placed", "dropped"). Placed: put down at a
    place by the arm (an object whose goal is place), standing on the surface below."""

    TABLE = "table"
    GRIPPER = "gripper"
    TRAY = "tray"
    PLACED = "placed"
    DROPPED = "dropped"

    def __str__(self) -> str:
        # The word, not "DishState.TABLE": str() of a mixed-in Enum, and since Python 3.11
        # also format() and f-strings, would otherwise name the class and the member.
        return self.value


class _ByDish(Mapping[str, _V], Generic[_V]):
    """A read-only dish name -> value mapping (a private copy of what it was made from)."""

    __slots__ = ("_values",)

    def __init__(self, values: Mapping[str, _V] | Iterable[tuple[str, _V]] = ()) -> None:
        # object.__setattr__: this class's own __setattr__ refuses every assignment.
        object.__setattr__(self, "_values", dict(values))

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable")

    def __reduce__(self) -> tuple:
        # copy, deepcopy and pickle rebuild it through __init__ (the default protocol would
        # set the slot, which __setattr__ refuses).
        return type(self), (self._values,)

    def __getitem__(self, name: str) -> _V:
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._values!r})"


class DishPoses(_ByDish[RigidTransform]):
    """X_WD per dish: the pose of the dish frame D (its bottom face's centre) in the world."""

    __slots__ = ()


class DishStates(_ByDish[DishState]):
    """The DishState of each dish."""

    __slots__ = ()

    def named(self, state: DishState) -> tuple[str, ...]:
        """The dishes in `state`, sorted by name."""
        return tuple(sorted(name for name, s in self.items() if s is state))
