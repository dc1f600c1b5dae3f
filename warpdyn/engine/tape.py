"""The wp.Tape that is recording, and launches it must not record (their adjoints registered by hand).

Warp has one recording tape per process (`with wp.Tape():` in any thread records the launches of every
thread), so warpdyn ties a recording tape to the first thread that launches under it and refuses, with a
RuntimeError naming both threads, launches from another thread while it records (`check_thread`): they
would land on that thread's tape. Differentiate in one thread at a time (a lock around `with tape:`, the
calls under it and `tape.backward`); calls without a tape run in any number of threads.
"""

from __future__ import annotations

import contextlib
import threading
import weakref

from . import warp_private

__all__ = ["taping", "suspended", "check_thread"]

_owners: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_owners_lock = threading.Lock()


def taping() -> bool:
    """Whether a wp.Tape is recording (warp_private.recording_tape; a Warp version that does not say raises)."""
    if warp_private.recording_tape() is None:
        return False
    check_thread()
    return True


def check_thread() -> None:
    """A RuntimeError when a wp.Tape records launches of another thread (see the module docstring); the
    first thread that launches under a tape becomes its thread."""
    tape = warp_private.recording_tape()
    if tape is None:
        return
    me = threading.current_thread()
    owner = _owners.get(tape)
    if owner is None:
        with _owners_lock:
            owner = _owners.setdefault(tape, (me.ident, me.name))
    if owner[0] != me.ident:
        raise RuntimeError(
            f"a wp.Tape is recording warpdyn's launches from thread {owner[1]!r}, and this call comes from thread "
            f"{me.name!r}: Warp records the launches of every thread on its one active tape, so this call would "
            "land on the other thread's tape. Differentiate in one thread at a time (hold a lock around `with "
            "wp.Tape():`, the calls under it and tape.backward); calls without a tape may run in any thread."
        )


@contextlib.contextmanager
def suspended():
    """Warp records no launch inside (the recording tape, if any, is set aside and restored after); yields it."""
    tape = warp_private.recording_tape()
    warp_private.set_recording_tape(None)
    try:
        yield tape
    finally:
        warp_private.set_recording_tape(tape)
