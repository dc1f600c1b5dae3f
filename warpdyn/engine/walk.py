"""The order in which the fused step (kernels/fused_step.py) walks a model's tree, and its groups: the subtrees
below the base split into sets of about equal work, which the kernel's threads of one environment walk side by
side (its lanes)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..kernels.fused_step import BASE

__all__ = ["FusedWalk", "fused_walk"]


class FusedWalk(NamedTuple):
    """walk (nL, 3) int32: the links in depth-first order, the base first, each as (i, its slot or -1, its
    parent's slot, or where the parent hands over in registers -1 (it is the link before i in the walk) or
    BASE (-2: i is the first link of a group, its parent the base)); starts (groups + 1,) int32: where each group begins in the walk, then
    nL; slots: how many links have a slot (those with two children or more)."""

    walk: np.ndarray
    starts: np.ndarray
    slots: int

    @property
    def groups(self) -> int:
        return len(self.starts) - 1


def fused_walk(parent, groups: int = 1, work=None) -> FusedWalk:
    """The walk of the tree `parent` (nL,) (the parent of each link, -1 for the base, link 0) in at most `groups`
    groups (`FusedWalk`): the base's subtrees, the largest first, each given to the group with the least work so
    far (work (nL,): each link's, default 1 each), then each group's subtrees in index order; one group when the
    base has one child or none. A group walks its subtrees depth-first, the children of a link in index order. A
    link with two children or more has a slot (0, 1, ... in index order): its first child in the walk takes
    what it hands over in registers, the others read and write the slot."""
    parent = [int(p) for p in parent]
    nL = len(parent)
    work = np.ones(nL) if work is None else np.asarray(work, dtype=float)
    children = [[] for _ in parent]
    for i, p in enumerate(parent[1:], start=1):
        children[p].append(i)

    def subtree(i):
        order, pending = [], [i]
        while pending:
            j = pending.pop()
            order.append(j)
            pending.extend(reversed(children[j]))
        return order

    roots = children[0]
    count = max(1, min(int(groups), len(roots)))
    trees = {r: subtree(r) for r in roots}
    load, members = [0.0] * count, [[] for _ in range(count)]
    for r in sorted(roots, key=lambda r: (-sum(work[j] for j in trees[r]), r)):
        g = min(range(count), key=lambda g: (load[g], g))
        members[g].append(r)
        load[g] += sum(work[j] for j in trees[r])
    slot = {i: k for k, i in enumerate(i for i, c in enumerate(children) if len(c) > 1)}
    walk, starts = [(0, slot.get(0, -1), -1)], []
    for group in members:
        starts.append(len(walk))
        previous = None
        for r in sorted(group):
            for i in trees[r]:
                up = BASE if previous is None else -1 if previous == parent[i] else slot[parent[i]]
                walk.append((i, slot.get(i, -1), up))
                previous = i
    starts.append(nL)
    return FusedWalk(np.array(walk, dtype=np.int32).reshape(nL, 3), np.array(starts, dtype=np.int32), len(slot))
