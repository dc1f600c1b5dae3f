"""The wp.Tape that is recording, and launches it must not record (their adjoints registered by hand)."""

from __future__ import annotations

import contextlib

from . import warp_private

__all__ = ["known", "taping", "suspended"]


def known() -> bool:
    """Whether this Warp version tells which tape records (needed by `suspended`)."""
    return warp_private.tape_known()


def taping() -> bool:
    """Whether a wp.Tape is recording (True when this Warp version does not say: callers then take their
    tape-safe path)."""
    return not known() or warp_private.recording_tape() is not None


@contextlib.contextmanager
def suspended():
    """Warp records no launch inside (the recording tape, if any, is set aside and restored after); yields it."""
    if not known():
        raise RuntimeError("this Warp version does not say which wp.Tape records (warp._src.context.runtime.tape)")
    tape = warp_private.recording_tape()
    warp_private.set_recording_tape(None)
    try:
        yield tape
    finally:
        warp_private.set_recording_tape(tape)
