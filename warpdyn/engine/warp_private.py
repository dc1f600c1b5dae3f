"""The only module of warpdyn that reads Warp's private internals (warp._src), each with a fallback.

- `recording_tape()` / `set_recording_tape(tape)`: the wp.Tape that records launches (Warp 1.19 keeps it in
  `warp._src.context.runtime.tape`; Warp has no public accessor). Without it, warpdyn takes its tape-safe
  paths everywhere (`tape_known()` is False) and refuses what needs it (checkpointed rollouts).
- `array_descriptor(ptr, shape, strides)`: the launch descriptor of a view of memory (Warp's `array_t`),
  about 1 µs to make where a view object takes ~8 µs on a slow CPU; without it, a view object.
tests/test_layers.py checks that both are found with the pinned Warp version.
"""

from __future__ import annotations

import warp as wp

try:
    from warp._src import context as _context
except ImportError:  # pragma: no cover - other Warp versions
    _context = None

try:
    from warp._src.types import array_t as _array_t
except ImportError:  # pragma: no cover - other Warp versions
    _array_t = None

__all__ = ["tape_known", "recording_tape", "set_recording_tape", "descriptor_known", "array_descriptor"]


def tape_known() -> bool:
    """Whether this Warp version tells which tape records."""
    return _context is not None and hasattr(_context.runtime, "tape")


def recording_tape():
    """The wp.Tape recording launches, or None (a Warp version that does not say: see `tape_known`)."""
    return _context.runtime.tape if tape_known() else None


def set_recording_tape(tape) -> None:
    _context.runtime.tape = tape


def descriptor_known() -> bool:
    return _array_t is not None


def array_descriptor(array: wp.array, shape: tuple, strides: tuple, offset: int = 0):
    """A launch argument that shows `array`'s memory from `offset` bytes with `shape` and byte `strides`; it
    carries no gradient and does not keep `array` alive (the caller keeps it)."""
    ptr = (array.ptr or 0) + offset
    if _array_t is None:
        return wp.array(ptr=ptr, shape=shape, strides=strides, dtype=array.dtype, device=array.device)
    return _array_t(ptr, 0, len(shape), shape, strides)
