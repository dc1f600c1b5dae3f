"""Output pools: a few sets of output arrays that a functional call hands out again once nobody else refers
to them.

`warpdyn.model.step` and the dynamics functions return new arrays that the caller owns: nothing they return is
ever overwritten while anybody can still see it. On the CPU, allocating those arrays was most of a call's cost
(a `wp.empty` is ~4 µs of Python, a step returns 7 arrays). An `OutputPool` keeps at most `POOL_SIZE` sets of
them and hands a set out again only when no Python object other than the pool refers to any array of the set;
when none is free it makes no more and the caller allocates fresh arrays, as without a pool.

Why that is safe. Whatever lets Python code see an array's memory holds a reference to the array (its owner,
the object the pool handed out):
- a Data (its fields), a list, a closure, a frame's local variable;
- a Warp view: `arr[0]`, `arr[:, 6:]`, `reshape`, `flatten`, `view`, `transpose`, `wp.array(arr, copy=False)`
  keep the array in their `_ref`, and so does `warpdyn.arrays.strided_view`;
- a NumPy view: `arr.numpy()` on the CPU goes through `__array_interface__`, whose ndarray keeps the array as
  its `base`;
- a PyTorch tensor: `wp.to_torch` makes it from that NumPy view on the CPU and through
  `__cuda_array_interface__`, which torch keeps, on a GPU; a DLPack capsule (`wp.to_dlpack`, `torch.from_dlpack`)
  increments the array's count until its consumer lets it go;
- a Warp struct (a kernel bundle's field) and a `wp.Tape` (its recorded launches keep their arguments).
tests/test_output_pool.py checks each of these. So when `sys.getrefcount` of every array of a set reads what
it reads for an object that only one tuple refers to (the set's own tuple, the pool's only reference to its
arrays; measured once on a probe, `_ALONE`), nobody can read those arrays any more, and overwriting them is as
good as allocating new ones. A new set that reads more is not kept. The check needs no lock: an array that
nothing else refers to cannot be reached by another thread either.

What the pool itself keeps must not move those counts, and must never leave the engine: the launches, kernel
bundles and captured graphs of the engine reach a set's memory through `shadow` objects (Warp arrays made with
`ptr=` on the same memory, or launch descriptors) that hold no reference to the arrays handed out. Those shadows
are used only for launches made at once outside a wp.Tape (or captured into the pool's own graphs); nothing
that a user or a tape could keep refers to them, since anything kept that way must count on the arrays (so a
State bundle of aliases is never put on a Data: a tape recording a launch with it would not count). Where the
engine keeps a user's arrays (a recorded launch's bound arguments, fast_step's last foreign input state), it
holds ordinary references: when those are another pool's arrays, they only keep that set from reuse.

Not covered, as with freed memory before: what sees the memory without a reference (`arr.ptr`, a user's
`wp.array(ptr=...)`, a graph the user captured, a weak reference, which stays alive while the pool keeps the
array, and sees new values once the set is reused). On a GPU, reuse is ordered on the stream the pool belongs to
(warpdyn.engine.launch.per_thread keys on it): work of another stream that read a set must end before the last
reference to it is dropped, as with memory freed to Warp's allocator.

Assumptions. CPython's reference counting: `sys.getrefcount` is exact and an object's count drops when a
holder lets it go. Where that does not hold (another interpreter, or CPython built without the GIL, whose
counts are split between threads), `available()` is False and every call allocates. Objects in a reference cycle
that the garbage collector has not collected yet still count: their set is only not reused. A pool is used by
one thread at a time (one per model, thread and stream: warpdyn.engine.launch.per_thread), outside a wp.Tape and
outside a graph capture (the callers check both).
"""

from __future__ import annotations

import operator
import sys

import warp as wp

from .. import config
from ..arrays import fill_outputs_with_nan
from . import warp_private

__all__ = ["POOL_SIZE", "available", "OutputPool", "Slot", "alias"]

POOL_SIZE = 4
"""The most sets a pool keeps: a loop `data = step(model, data)` cycles through 2, a caller holding a few
results more; a caller that keeps every result gets fresh arrays once all are held."""

_AVAILABLE = sys.implementation.name == "cpython" and hasattr(sys, "getrefcount") and getattr(sys, "_is_gil_enabled", lambda: True)()


def available() -> bool:
    """Whether reference counts tell that nobody holds a set (CPython with the GIL)."""
    return _AVAILABLE


def alias(array: wp.array) -> wp.array:
    """A Warp array on `array`'s memory (same shape, strides and dtype) that does not keep `array` alive and
    carries no gradient: what the engine's launches bind instead of an array the pool hands out."""
    return wp.array(ptr=array.ptr, dtype=array.dtype, shape=array.shape, strides=array.strides, device=array.device)


def _counts(arrays: tuple) -> tuple:
    # one function for the reference count below and for the checks, so that its temporaries cancel out
    return tuple(map(sys.getrefcount, arrays))


_ALONE = _counts((object(),))[0]
"""What `_counts` reads for an object that only its tuple refers to: a set's arrays when nobody else holds
them. Measured once on a probe rather than on each new set, so that a reference that happens to exist while a
set is made (Warp's CPU capture keeps the arrays allocated while it records, in another thread say) cannot
become part of what counts as free."""


class Slot:
    """One set of a pool: `arrays`, what callers hand out; `shadow`, the engine's objects on the same memory
    (see the module docstring); `index`, its place in the pool; `cache`, what a caller derives from the set
    once (launch lists, descriptors), which must refer to the shadow only."""

    __slots__ = ("arrays", "shadow", "index", "cache", "lent")

    def __init__(self, make, shadow, index: int):
        self.arrays = tuple(make())  # make's own list is gone once the tuple is made
        self.shadow = shadow(self.arrays) if shadow is not None else None
        self.index = index
        self.cache: dict = {}
        self.lent = False  # taken, not handed out yet (see OutputPool.take)

    def free(self) -> bool:
        """Whether nothing but the pool refers to the set's arrays (and none was marked for gradients since)."""
        if self.lent:
            return False
        arrays = self.arrays
        return _counts(arrays) == (_ALONE,) * len(arrays) and warp_private.grads(arrays) == (None,) * len(arrays)

    def holds(self, arrays) -> bool:
        """Whether `arrays` are this set's arrays, the same objects in the same order."""
        mine = self.arrays
        return len(arrays) == len(mine) and all(map(operator.is_, arrays, mine))


class OutputPool:
    """At most `size` sets of output arrays, each made by `make()` (a list of new arrays), with the engine's
    objects on them made by `shadow(arrays)` (or None). See the module docstring."""

    def __init__(self, make, shadow=None, size: int = POOL_SIZE):
        self._make, self._shadow, self._size = make, shadow, size
        self.slots: list[Slot] = []
        self._by_first: dict = {}

    def slot_of(self, arrays) -> Slot | None:
        """The set whose arrays `arrays` are (the same objects), or None."""
        slot = self._by_first.get(id(arrays[0])) if arrays else None
        return slot if slot is not None and slot.holds(arrays) else None

    def take(self, busy: Slot | None = None) -> Slot | None:
        """A set that nobody holds (other than `busy`, which the caller reads), a new one while there are fewer
        than `size`, or None. A reused set is filled with NaN when warpdyn.config.fill_outputs_with_nan is set, as
        a new one is (warpdyn.arrays.output). The set is lent until `hand_out`: no other take returns it meanwhile,
        not even one from code that runs inside the caller's (a finalizer that the garbage collector runs)."""
        for slot in self.slots:
            if slot is not busy and slot.free():
                slot.lent = True
                if config.fill_outputs_with_nan:
                    for a in slot.arrays:
                        fill_outputs_with_nan(a)
                return slot
        if len(self.slots) >= self._size:
            return None
        slot = Slot(self._make, self._shadow, len(self.slots))
        if not slot.free():  # something else already refers to the new arrays: not a set to recycle
            return None
        slot.lent = True
        self.slots.append(slot)
        if slot.arrays:
            self._by_first[id(slot.arrays[0])] = slot
        return slot

    @staticmethod
    def hand_out(slot: Slot) -> list:
        """The taken set's arrays, in a list that the caller keeps while it uses them (its references keep the
        set from being taken again); the set is no longer lent."""
        try:
            return list(slot.arrays)
        finally:
            slot.lent = False
