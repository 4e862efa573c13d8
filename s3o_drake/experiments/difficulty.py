"""The paper's difficulty groups (§V-B): tasks sorted by the area from which the robot can
pick their dishes, split evenly into easy, moderate and difficult.

The area of a task is Σ_o ∫ Fea^m(y, o) dy over base positions y, from the Drake oracle
under the scenario's noise model (the expected area, in m², from which each dish can be
picked, summed over the task's dishes): the smaller it is, the harder the task.
"""

from collections.abc import Mapping

import numpy as np

GROUPS = ("easy", "moderate", "difficult")


def difficulty_groups(areas: Mapping[str, float]) -> dict[str, str]:
    """Task name -> group: the largest areas are easy, the smallest difficult; thirds of
    equal size (the first groups take one more task when the count does not divide)."""
    if not areas:
        return {}
    # Ties are broken by name so that the grouping does not depend on the input's order.
    ordered = sorted(areas, key=lambda task: (-areas[task], task))
    groups = {}
    for group, members in zip(GROUPS, np.array_split(np.array(ordered, dtype=object), 3),
                              strict=True):
        for task in members:
            groups[str(task)] = group
    return groups
