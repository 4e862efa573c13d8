"""Candidate state spaces: partitions of the dishes into groups of adjacent cells.

A candidate is a partition of the dish indices into groups whose cells form a connected
piece of the adjacency graph; each group is one merged location. A partition is a tuple
of groups, each a sorted tuple of indices, the groups sorted by their first index: one
canonical form, so equal partitions compare equal.

Two generators, both lazy and deterministic:

- `connected_partitions` enumerates every candidate exactly once, plain Voronoi (all
  singletons) first. The count grows like the Bell numbers on dense graphs (877 for 7
  mutually adjacent dishes, 2^(n-1) on a chain), so it is for small scenes.
- `beam_partitions` searches promising candidates first for many dishes: from plain
  Voronoi, every merge of two adjacent groups is scored (Score is a sum over groups, so
  a merge costs one new group evaluation), every new partition is yielded, and the
  `beam_width` best partitions of each level seed the next; it stops when a level brings
  nothing new.

`generate_candidates` picks between them and bounds the count and the wall time.
"""

import heapq
import time
from collections.abc import Callable, Iterator, Sequence

Partition = tuple[tuple[int, ...], ...]

EXHAUSTIVE_MAX_DISHES = 10
"""Above this many dishes, search with the beam instead of enumerating everything."""
DEFAULT_BEAM_WIDTH = 8


def canonical(groups: Sequence[Sequence[int]]) -> Partition:
    """The canonical form of a partition."""
    return tuple(sorted(tuple(sorted(g)) for g in groups))


def _connected_blocks(v: int, remaining: frozenset[int],
                      adjacency: Sequence[set[int]]) -> Iterator[frozenset[int]]:
    """Connected subsets of `remaining` that contain v, each once, smallest first.

    Branches on the smallest frontier vertex: leave it out first, then take it; a vertex
    left out stays out of this branch, which is what makes every subset appear once.
    """

    def grow(subset: frozenset[int], frontier: frozenset[int],
             excluded: frozenset[int]) -> Iterator[frozenset[int]]:
        if not frontier:
            yield subset
            return
        w = min(frontier)
        yield from grow(subset, frontier - {w}, excluded | {w})
        taken = subset | {w}
        grown = (frontier - {w}) | ((adjacency[w] & remaining) - taken - excluded)
        yield from grow(taken, frozenset(grown), excluded)

    start = frozenset(adjacency[v] & remaining) - {v}
    yield from grow(frozenset({v}), start, frozenset())


def connected_partitions(n: int, adjacency: Sequence[set[int]]) -> Iterator[Partition]:
    """Every partition of range(n) into connected groups, plain Voronoi first."""
    for partition, _ in scored_partitions(n, adjacency, lambda group: 0.0):
        yield partition


def scored_partitions(n: int, adjacency: Sequence[set[int]],
                      group_score: Callable[[tuple[int, ...]], float]
                      ) -> Iterator[tuple[Partition, float]]:
    """`connected_partitions` with each partition's score, the sum of `group_score` over
    its groups, added up along the enumeration (a group's score is asked once per branch,
    not once per partition that holds it).

    Each block holds the smallest dish left, so the blocks come in the canonical order
    already (sorted tuples, sorted by their first element)."""

    def split(remaining: frozenset[int], groups: tuple[tuple[int, ...], ...],
              score: float) -> Iterator[tuple[Partition, float]]:
        # The score adds up from the first group on, as sum() over the partition would.
        if not remaining:
            yield groups, score
            return
        v = min(remaining)
        for block in _connected_blocks(v, remaining, adjacency):
            group = tuple(sorted(block))
            yield from split(remaining - block, (*groups, group), score + group_score(group))

    yield from split(frozenset(range(n)), (), 0)


def _groups_adjacent(a: tuple[int, ...], b: tuple[int, ...],
                     adjacency: Sequence[set[int]]) -> bool:
    return any(adjacency[i] & set(b) for i in a)


def beam_partitions(n: int, adjacency: Sequence[set[int]],
                    group_score: Callable[[tuple[int, ...]], float], *,
                    beam_width: int = DEFAULT_BEAM_WIDTH) -> Iterator[tuple[Partition, float]]:
    """Partitions with their scores, promising ones first, by beam search over merges."""
    start = canonical([(i,) for i in range(n)])
    score = sum(group_score(g) for g in start)
    seen = {start}
    yield start, score
    beam = [(start, score)]
    while beam:
        level: list[tuple[Partition, float]] = []
        for partition, base in beam:
            for a_index, a in enumerate(partition):
                for b in partition[a_index + 1:]:
                    if not _groups_adjacent(a, b, adjacency):
                        continue
                    merged = tuple(sorted(a + b))
                    child = canonical([g for g in partition if g not in (a, b)] + [merged])
                    if child in seen:
                        continue
                    seen.add(child)
                    child_score = base - group_score(a) - group_score(b) + group_score(merged)
                    level.append((child, child_score))
        # Deterministic: best score, then fewer locations, then the canonical form.
        level.sort(key=lambda item: (-round(item[1], 9), len(item[0]), item[0]))
        yield from level
        beam = level[:beam_width]


def generate_candidates(n: int, adjacency: Sequence[set[int]],
                        group_score: Callable[[tuple[int, ...]], float], *,
                        max_count: int = 100_000, time_limit: float = 5.0,
                        exhaustive_max_dishes: int = EXHAUSTIVE_MAX_DISHES,
                        beam_width: int = DEFAULT_BEAM_WIDTH,
                        ) -> tuple[list[tuple[Partition, float]], bool]:
    """Scored candidates, and whether the generator ran to its end within the bounds.

    Exhaustive up to `exhaustive_max_dishes` dishes, beam search above; stops after
    `max_count` candidates or `time_limit` seconds, whichever comes first.
    """
    deadline = time.perf_counter() + time_limit
    if n <= exhaustive_max_dishes:
        source: Iterator[tuple[Partition, float]] = scored_partitions(n, adjacency, group_score)
    else:
        source = beam_partitions(n, adjacency, group_score, beam_width=beam_width)
    found: list[tuple[Partition, float]] = []
    for item in source:
        found.append(item)
        if len(found) >= max_count or time.perf_counter() > deadline:
            # Finished only if nothing is left.
            return found, next(source, None) is None
    return found, True


def connected_components(n: int, adjacency: Sequence[set[int]]) -> list[list[int]]:
    """The adjacency graph's connected components, each sorted, by smallest index.

    Score is a sum over groups and a group never spans two components, so the components
    can be partitioned independently and their best partitions combined.
    """
    seen: set[int] = set()
    components: list[list[int]] = []
    for v in range(n):
        if v in seen:
            continue
        stack, component = [v], []
        seen.add(v)
        while stack:
            u = stack.pop()
            component.append(u)
            for w in sorted(adjacency[u] - seen):
                seen.add(w)
                stack.append(w)
        components.append(sorted(component))
    return components


def best_sums(a: Sequence[tuple[Partition, float]], b: Sequence[tuple[Partition, float]],
              keep: int) -> list[tuple[Partition, float]]:
    """The `keep` best unions of one partition of `a` and one of `b` (both sorted best first).

    A best-first walk over the (i, j) grid with a heap: exact for the value, O(keep log
    keep) instead of |a| * |b|.
    """
    if not a or not b:
        return []
    heap = [(-(a[0][1] + b[0][1]), 0, 0)]
    visited = {(0, 0)}
    result: list[tuple[Partition, float]] = []
    while heap and len(result) < keep:
        _, i, j = heapq.heappop(heap)
        result.append((canonical(a[i][0] + b[j][0]), a[i][1] + b[j][1]))
        for ni, nj in ((i + 1, j), (i, j + 1)):
            if ni < len(a) and nj < len(b) and (ni, nj) not in visited:
                visited.add((ni, nj))
                heapq.heappush(heap, (-(a[ni][1] + b[nj][1]), ni, nj))
    return result
