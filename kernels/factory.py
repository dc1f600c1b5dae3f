"""Kernel factories: the functions that make Warp kernels and `@wp.func`s for a scalar type (and settings), each
result made once.

`factory(build)` keeps build's result per arguments, as functools.cache does, and makes it under `BUILD_LOCK`, one
thread at a time: Warp parses a function's source with `ast` when it makes a kernel or a function, and CPython
3.11 parsing in two threads at once can fail ("SystemError: AST constructor recursion depth mismatch", seen in
tests/test_threads.py, four threads making their first launch together). warpdyn.engine.loading makes its
forward-only twins and loads modules under the same lock. Once made, a result is read without the lock.
"""

import functools
import threading

BUILD_LOCK = threading.RLock()
"""Held while a factory makes its result (reentrant: factories call factories)."""

_MISSING = object()
_KEYWORDS = object()  # marks a key made with keyword arguments, so that it cannot equal a positional one


def factory(build):
    """`build`, its result kept per arguments and made under BUILD_LOCK (see the module docstring)."""
    made: dict = {}

    @functools.wraps(build)
    def get(*args, **kwargs):
        key = (args, _KEYWORDS, tuple(sorted(kwargs.items()))) if kwargs else args
        value = made.get(key, _MISSING)
        if value is _MISSING:
            with BUILD_LOCK:
                value = made.get(key, _MISSING)
                if value is _MISSING:
                    value = made[key] = build(*args, **kwargs)
        return value

    return get
