"""The wp.Tape that is recording, and launches it must not record (their adjoints registered by hand).

Warp 1.19 keeps the recording tape in `warp._src.context.runtime.tape`. Where a Warp version does not say,
`taping()` answers True (callers then take their tape-safe path) and `suspended()` refuses.
"""

from __future__ import annotations

import contextlib

try:
    from warp._src import context as _wp_context
except ImportError:  # pragma: no cover - other Warp versions
    _wp_context = None


def known() -> bool:
    """Whether this Warp version tells which tape records (needed by `suspended`)."""
    return _wp_context is not None and hasattr(_wp_context.runtime, "tape")


def taping() -> bool:
    """Whether a wp.Tape is recording (True when this Warp version does not say)."""
    return not known() or _wp_context.runtime.tape is not None


@contextlib.contextmanager
def suspended():
    """Warp records no launch inside (the recording tape, if any, is set aside and restored after); yields it."""
    if not known():
        raise RuntimeError("this Warp version does not say which wp.Tape records (warp._src.context.runtime.tape)")
    runtime = _wp_context.runtime
    tape, runtime.tape = runtime.tape, None
    try:
        yield tape
    finally:
        runtime.tape = tape
