"""Deterministic gradients of parameters shared by the environments
(warpdyn.model.parameters_requiring_grad(..., deterministic=True)).

Kernels read a parameter's row min(env, P - 1): a shared parameter (P = 1) is read by every environment's
thread, so under a tape its adjoint is added with atomics from all of them, in an order that varies from
run to run on a GPU (the last bits of the gradient differ). For a parameter marked here, each launch
recorded on a tape reads instead a copy with one row per environment of the launch (N = its first
dimension; the rows equal the parameter, so the launch computes the same numbers): each row's adjoint
then comes from its environment's thread alone. The copy is made once per recording of a tape, when a
launch in it first reads the parameter, and a function recorded on the tape just before that launch sums the rows' adjoints
into the parameter's .grad in environment order (one thread per number) when tape.backward reaches it,
after every launch that read the copy, and zeroes them.

Parameters are recognised by the address of their values (the kernels' bundles hold (1, count) views of
the model's (count,) arrays). Cost: N copies of each marked parameter per recording, a copy and a sum
kernel. The copies hold the values a recording first read: a parameter must not change while a tape
records (an optimiser steps between recordings, after tape.reset() or with a new tape).
"""

from __future__ import annotations

import weakref

import numpy as np
import warp as wp

from ..kernels.env_rows import kernels as env_rows_kernels
from ..types.parameters import MODEL_ARRAYS
from .loading import ensure_loaded
from . import warp_private

__all__ = ["mark", "unmark", "is_marked", "any_marked", "rows_per_environment"]

_marked: dict = {}
"""{address of a parameter's values: weak reference to the array marked}."""

_tapes: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""{tape: (its launch list, {key: (what the key's object was, its replacement)})}: the copies and bundles made
for a tape's recording (tape.reset() gives the tape a new launch list: a new recording, new copies)."""

_FIELDS = frozenset((*MODEL_ARRAYS, "K", "D", "mu", "height"))
"""The parameter fields of the kernels' bundles: the model's, the contacts' and a flat terrain's."""


def mark(array: wp.array) -> None:
    """Give `array` (a shared parameter requiring gradients) deterministic gradients (an empty one has none)."""
    if array.ptr is not None:
        _marked[array.ptr] = weakref.ref(array, lambda _, ptr=array.ptr: _forget(ptr))


def _forget(ptr) -> None:
    ref = _marked.get(ptr)
    if ref is not None and ref() is None:
        _marked.pop(ptr, None)


def unmark(array: wp.array) -> None:
    if array.ptr is not None:
        _marked.pop(array.ptr, None)


def is_marked(array) -> bool:
    """Whether `array`'s values are those of a marked parameter that is alive."""
    if not isinstance(array, wp.array) or array.ptr is None:
        return False
    ref = _marked.get(array.ptr)
    if ref is None:
        return False
    return ref() is not None


def any_marked() -> bool:
    return bool(_marked)


def rows_per_environment(inputs, dim, device) -> list:
    """`inputs` of a launch over `dim` with each marked shared parameter (and each bundle holding one) replaced
    by its copy of one row per environment, when a tape records and the launch has more than one
    environment; otherwise `inputs` unchanged."""
    tape = warp_private.recording_tape()
    N = int(dim) if np.ndim(dim) == 0 else int(dim[0])
    if tape is None or N < 2:
        return inputs
    recording, launches = _tapes.get(tape), warp_private.tape_recording(tape)
    if recording is None or recording[0] is not launches:
        recording = _tapes[tape] = (launches, {})
    return [_replace(value, tape, recording[1], N, device) for value in inputs]


def _replace(value, tape, made: dict, N: int, device):
    if isinstance(value, wp.array):
        return _rows(value, tape, made, N, device) if _shared_and_marked(value) else value
    fields = warp_private.struct_fields(value)
    if fields is None:
        return value
    names = [n for n in fields if n in _FIELDS and _shared_and_marked(getattr(value, n))]
    if not names:
        return value
    key = ("bundle", id(value), N)
    if key in made and made[key][0] is value:
        return made[key][1]
    copy = warp_private.struct_copy(value)
    for name in names:
        setattr(copy, name, _rows(getattr(value, name), tape, made, N, device))
    made[key] = (value, copy)
    return copy


def _shared_and_marked(array) -> bool:
    return isinstance(array, wp.array) and array.ndim >= 1 and array.shape[0] == 1 and array.grad is not None and is_marked(array)


def _rows(shared: wp.array, tape, made: dict, N: int, device) -> wp.array:
    """The tape's copy of `shared` (1, *S) as (N, *S) rows, made on first use: tiled outside the tape, and the
    sum of its rows' adjoints into shared.grad recorded on the tape before the launch that reads it."""
    key = ("rows", shared.ptr, shared.shape, N)
    if key in made and made[key][0] is shared.grad:
        return made[key][1]
    scalar = warp_private.scalar_type(shared.dtype)
    if not (shared.is_contiguous and shared.grad.is_contiguous):
        raise ValueError(f"deterministic gradients need a contiguous parameter, got strides {shared.strides}")
    rows = wp.empty((N, *shared.shape[1:]), dtype=shared.dtype, device=device, requires_grad=True)
    count = shared.size * wp.types.type_size(shared.dtype)
    K = env_rows_kernels(scalar)
    flat_shared = _flat(shared, (count,), scalar)
    flat_rows, flat_rows_adjoint = _flat(rows, (N, count), scalar), _flat(rows.grad, (N, count), scalar)
    flat_shared_adjoint = _flat(shared.grad, (count,), scalar)
    for kernel in (K.tile, K.sum_rows):
        ensure_loaded(kernel, device)
    wp.launch(K.tile, dim=(N, count), inputs=[flat_shared], outputs=[flat_rows], device=device, record_tape=False)

    def backward():
        wp.launch(K.sum_rows, dim=count, inputs=[flat_rows_adjoint], outputs=[flat_shared_adjoint], device=device, record_tape=False)

    tape.record_func(backward=backward, arrays=[rows, shared])
    made[key] = (shared.grad, rows)
    return rows


def _flat(array: wp.array, shape: tuple, scalar) -> wp.array:
    """A view of a contiguous array's numbers with `shape` (as many)."""
    return wp.array(ptr=array.ptr, shape=shape, dtype=scalar, device=array.device)

