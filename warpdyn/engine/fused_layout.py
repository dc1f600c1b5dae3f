"""How the fused step (kernels/fused_step.py) runs a model: the order in which it walks the tree and its
groups (the subtrees below the base split into sets of about equal work, which the threads of one
environment can walk side by side: its lanes), how many threads an environment gets, whether the joint
transforms are kept between passes, and where the links' records between passes are kept."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import warp as wp

from .. import config
from ..kernels.fused_step import BASE, shared_numbers

__all__ = [
    "FusedWalk",
    "fused_walk",
    "fused_lanes",
    "keeps_joint_transforms",
    "shared_records",
    "MAX_LANES",
    "LANES_UP_TO",
    "KEEP_JOINT_TRANSFORMS_UP_TO",
    "SHARED_RECORDS_BYTES",
]


class FusedWalk(NamedTuple):
    """walk (nL, 3) int32: the links in depth-first order, the base first, each as (i, its slot or -1, its
    parent's slot, or where the parent hands over in registers -1 (it is the link before i in the walk) or
    BASE (-2: i is the first link of a group, its parent the base)); starts (groups + 1,) int32: where each
    group begins in the walk, then nL; slots: how many links have a slot (those with two children or more)."""

    walk: np.ndarray
    starts: np.ndarray
    slots: int

    @property
    def groups(self) -> int:
        """The number of groups (1 at least; the threads of an environment when it runs on lanes)."""
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
    size = {r: float(work[trees[r]].sum()) for r in roots}
    load, members = [0.0] * count, [[] for _ in range(count)]
    for r in sorted(roots, key=lambda r: (-size[r], r)):
        g = min(range(count), key=lambda g: (load[g], g))
        members[g].append(r)
        load[g] += size[r]
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


KEEP_JOINT_TRANSFORMS_UP_TO = 4096
"""The most environments for which the fused step keeps its joint transforms on a GPU (`keeps_joint_transforms`)."""


def keeps_joint_transforms(device, N: int) -> bool:
    """Whether the fused step of N environments keeps the joint transforms of its first pass for the other two
    (kernels/fused_step.py) rather than rebuild them from the joint positions: on the CPU, and on
    a GPU for up to KEEP_JOINT_TRANSFORMS_UP_TO environments, whose local arrays its caches hold. Measured on an
    H100 (benchmarks/results/performance_rounds.md, round 4): keeping them, the step took 7-11% less time at N = 1, 7% less
    (float32) or as long (float64) at 4096, and 7-12% more at 32768 and 131072 (round 5's smaller local arrays
    were not re-measured by a script in the repository)."""
    return device.is_cpu or N <= KEEP_JOINT_TRANSFORMS_UP_TO


SHARED_RECORDS_BYTES = 46 * 1024
"""The most CUDA shared memory that a block of the fused step gives its threads' records (`shared_records`):
a kernel's static shared memory is at most 48 KiB per block, and Warp takes 1 KiB of it."""


def shared_records(plan, lanes: int, block_dim: int | None) -> tuple:
    """(block, shared_c): the CUDA block size for which the fused step of `plan` (its device, scalar and links)
    with `lanes` threads per environment keeps its links' records (kernels/fused_step.py) in the block's shared
    memory, and whether their c_i too, or (0, False): in each thread's local memory. Shared (while
    warpdyn.config.fused_shared_records) on a GPU, one thread per environment, the whole records when a block of
    `block_dim` threads holds them in SHARED_RECORDS_BYTES, else without c_i when that fits (the legs' 13 links
    in blocks of 64: 42.25 KiB in float32, whole; 45.5 KiB in float64, without c_i). Local memory shares the L1
    cache with the loads of the state, which evict the records; shared memory keeps them (measured on an H100:
    benchmarks/results/performance_rounds.md, round 12)."""
    if not config.fused_shared_records or not plan.device.is_cuda or lanes != 1 or block_dim is None:
        return 0, False
    size = wp.types.type_size_in_bytes(plan.scalar)
    for shared_c in (True, False):
        if shared_numbers(plan.nL, block_dim, shared_c) * size <= SHARED_RECORDS_BYTES:
            return block_dim, shared_c
    return 0, False


MAX_LANES = 8
"""The most threads (lanes) that the fused step gives one environment: the groups of its walk (`fused_walk`)."""

LANES_UP_TO = {4: 768, 8: 384}
"""The most environments for which the fused step runs one environment on several threads on a GPU
(`fused_lanes`), by the scalar's size in bytes."""


def fused_lanes(plan, N: int) -> int:
    """The threads (lanes) per environment of the fused step of N environments with `plan` (a
    warpdyn.engine.step.Plan: its device, scalar and lanes, the groups of its walk), by warpdyn.config.fused_lanes:
    by default, on a GPU for up to LANES_UP_TO environments, one per group of the model's walk (its subtrees
    below the base walked side by side: a shorter chain of dependent operations per step, while the blocks of
    a few threads leave most of each warp idle), else 1; on the CPU 1 (Warp runs blocks of threads there
    only with wp.config.enable_cpu_blocks, as fibers of one core). Measured on an H100 with
    benchmarks/step.py --fused one,groups (benchmarks/results/performance_rounds.md, round 6): the legs' lanes gave the shorter step up to
    768 environments in float32 and 384 in float64."""
    setting = config.fused_lanes
    if setting is None:
        limit = LANES_UP_TO[wp.types.type_size_in_bytes(plan.scalar)]
        return plan.lanes if plan.device.is_cuda and N <= limit else 1
    if not setting or plan.lanes == 1:
        return 1
    if not plan.device.is_cuda and not wp.config.enable_cpu_blocks:
        raise RuntimeError(
            f"warpdyn.config.fused_lanes = True on '{plan.device}' needs wp.config.enable_cpu_blocks = True: Warp runs "
            "blocks of threads on the CPU only then"
        )
    return plan.lanes
