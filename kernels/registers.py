"""CUDA register caps of the dynamics kernels: each module keeps a measured MAX_REGISTERS table per scalar, and
`tuned(MAX_REGISTERS)` turns its builder build(scalar, max_registers, *options) into `kernels(scalar,
max_registers="tuned", *options)` (cached): "tuned" takes the table's entry, None the compiler's choice, a number
that cap; options are the builder's others (multi_dof: kernels/joints.py)."""

import functools

from .factory import factory


def tuned(table: dict):
    def decorate(build):
        cached = factory(build)

        @functools.wraps(build)
        def kernels(scalar, max_registers="tuned", *options):
            return cached(scalar, table[scalar] if max_registers == "tuned" else max_registers, *options)

        return kernels

    return decorate
