"""The order in which the fused step (kernels/fused_step.py) walks a model's tree."""

from __future__ import annotations

import numpy as np

__all__ = ["fused_walk"]


def fused_walk(parent) -> tuple[np.ndarray, int]:
    """(walk (nL, 3) int32, slots): the links in depth-first order for the fused step (kernels/fused_step.py),
    the base first and the children of a link in index order, each as (i, its slot, its parent's slot). A link
    with two children or more has a slot (0, 1, ...; else -1): its first child follows it in the walk and takes
    what it hands over in registers, the others read and write the slot. The parent's slot is -1 where the
    parent is the link before i in the walk. parent (nL,): the parent of each link, -1 for the base (link 0)."""
    parent = [int(p) for p in parent]
    children = [[] for _ in parent]
    for i, p in enumerate(parent[1:], start=1):
        children[p].append(i)
    order, pending = [], [0]
    while pending:
        i = pending.pop()
        order.append(i)
        pending.extend(reversed(children[i]))
    branching = [i for i, c in enumerate(children) if len(c) > 1]
    slot = {i: k for k, i in enumerate(branching)}
    walk = [(0, slot.get(0, -1), -1)]
    for k, i in enumerate(order[1:], start=1):
        walk.append((i, slot.get(i, -1), -1 if order[k - 1] == parent[i] else slot[parent[i]]))
    return np.array(walk, dtype=np.int32).reshape(len(parent), 3), len(branching)
