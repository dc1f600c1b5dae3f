"""The wp.Tape that is recording, and launches it must not record (their adjoints registered by hand)."""

from __future__ import annotations

import contextlib

from warp._src import context as _wp_context


def recording():
    """The wp.Tape recording now, or None."""
    return _wp_context.runtime.tape


@contextlib.contextmanager
def suspended():
    """Warp records no launch inside (the recording tape, if any, is set aside and restored after); yields it."""
    runtime = _wp_context.runtime
    tape, runtime.tape = runtime.tape, None
    try:
        yield tape
    finally:
        runtime.tape = tape
