"""Kernel factories: the functions that make Warp kernels and `@wp.func`s for a scalar type (and settings), each
result made once.

`factory(build)` keeps build's result per arguments, as functools.cache does but bound to build's signature (a call
with an argument by position, by keyword or left to its default gets the same result), and makes it under
`BUILD_LOCK`, one thread at a time: Warp parses a function's source with `ast` when it makes a kernel or a function,
and CPython 3.11 parsing in two threads at once can fail ("SystemError: AST constructor recursion depth mismatch",
seen in tests/test_threads.py, four threads making their first launch together). warpdyn.engine.loading makes its
forward-only twins and loads modules under the same lock. Once made, a result is read without the lock.
"""

import functools
import inspect
import threading

BUILD_LOCK = threading.RLock()
"""Held while a factory makes its result (reentrant: factories call factories)."""

_MISSING = object()


def factory(build):
    """`build`, its result kept per arguments and made under BUILD_LOCK (see the module docstring)."""
    signature = inspect.signature(build)
    by_call: dict = {}  # (args, sorted kwargs): the result, for the calls already seen
    by_value: dict = {}  # every parameter's value, in build's order: the result

    @functools.wraps(build)
    def get(*args, **kwargs):
        call = (args, tuple(sorted(kwargs.items())))
        value = by_call.get(call, _MISSING)
        if value is _MISSING:
            with BUILD_LOCK:
                bound = signature.bind(*args, **kwargs)
                bound.apply_defaults()
                key = tuple(bound.arguments.values())
                value = by_value.get(key, _MISSING)
                if value is _MISSING:
                    value = by_value[key] = build(*args, **kwargs)
                by_call[call] = value
        return value

    return get
