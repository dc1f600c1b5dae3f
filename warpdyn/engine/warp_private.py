"""The only module of warpdyn that reads Warp's private internals (warp._src), each with a fallback.

- `recording_tape()` / `set_recording_tape(tape)`: the wp.Tape that records launches (Warp 1.19 keeps it in
  `warp._src.context.runtime.tape`; Warp has no public accessor). Without it, warpdyn takes its tape-safe
  paths everywhere (`tape_known()` is False) and refuses what needs it (checkpointed rollouts).
- `array_descriptor(ptr, shape, strides)`: the launch descriptor of a view of memory (Warp's `array_t`),
  about 1 µs to make where a view object takes ~8 µs on a slow CPU; without it, a view object.
- `cpu_launch(command)`: a recorded CPU launch run from an argument struct kept between runs (`CpuLaunch`);
  without what it reads, None, and the command runs as Warp runs it.
- `grads(arrays)`: the arrays' gradient arrays, read from the attribute behind Warp's `grad` property (a
  dynamics call reads the 20 parameters' at each call; the property call is what costs); without it, the
  property.
- `compiles_cuda()`: whether this Warp build compiles CUDA code, a GPU present or not (Warp 1.19's runtime
  says it: `core.wp_is_cuda_enabled`; the pip wheel compiles PTX on a machine without a GPU); without it,
  whether Warp found a GPU. tests/test_fused_step.py compiles the GPU's kernels where it is True.
tests/test_layers.py checks that all are found with the pinned Warp version.
"""

from __future__ import annotations

import ctypes

import warp as wp

try:
    from warp._src import context as _context
except ImportError:  # pragma: no cover - other Warp versions
    _context = None

try:
    from warp._src.types import array_t as _array_t
except ImportError:  # pragma: no cover - other Warp versions
    _array_t = None

try:
    from warp._src.codegen import Struct as _Struct
except ImportError:  # pragma: no cover - other Warp versions
    _Struct = None

__all__ = ["tape_known", "recording_tape", "set_recording_tape", "descriptor_known", "array_descriptor", "grads_known", "grads", "CpuLaunch", "cpu_launch", "cuda_compiler_known", "compiles_cuda"]


_tape_found = False


def tape_known() -> bool:
    """Whether this Warp version tells which tape records (once found, Warp's runtime keeps telling)."""
    global _tape_found
    if not _tape_found:
        _tape_found = _context is not None and hasattr(_context.runtime, "tape")
    return _tape_found


def recording_tape():
    """The wp.Tape recording launches, or None (a Warp version that does not say: see `tape_known`)."""
    return _context.runtime.tape if _tape_found or tape_known() else None


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


def cuda_compiler_known() -> bool:
    """Whether this Warp version's runtime says if it compiles CUDA code (`compiles_cuda`)."""
    wp.init()
    return _context is not None and hasattr(_context.runtime.core, "wp_is_cuda_enabled")


def compiles_cuda() -> bool:
    """Whether this Warp build compiles CUDA code (its NVRTC), a GPU present or not; where Warp does not say
    (`cuda_compiler_known`), whether it found a GPU."""
    if cuda_compiler_known():
        return bool(_context.runtime.core.wp_is_cuda_enabled())
    return wp.is_cuda_available()


_GRAD_ATTRIBUTE = "_grad"  # where Warp 1.19's wp.array keeps what its `grad` property returns (`grads` reads a._grad)


def grads_known() -> bool:
    """Whether Warp's arrays keep their gradient array where `grads` reads it."""
    getter = getattr(getattr(wp.array, "grad", None), "fget", None)
    return getter is not None and getter.__code__.co_names == (_GRAD_ATTRIBUTE,)


def grads(arrays: tuple) -> tuple:
    """The `.grad` of each of `arrays` (None where an array has none), as Warp's property returns it. A list
    comprehension over the attribute: a third less time than map(operator.attrgetter) on 20 arrays (CPython 3.11),
    and the dynamics calls read the model's 20 parameter arrays at each call."""
    try:
        return tuple([a._grad for a in arrays])
    except AttributeError:  # pragma: no cover - other Warp versions
        return tuple([a.grad for a in arrays])


class CpuLaunch:
    """A recorded launch (wp.launch(..., record_cmd=True)) on the CPU, run with one argument struct kept between
    runs: Warp's Launch.launch builds that struct from the packed parameters at every run, which costs about as
    much as a dynamics kernel on one environment. It has the methods of Warp's Launch that a replay uses
    (`kernel`, `set_param_at_index`, `set_dim`, `launch`); a parameter set goes to Warp's launch and to the
    struct. Struct parameters (kernel bundles) are copied at every run, as Warp does: Warp packs a
    struct as its live ctype, which assigning a field of the struct changes. While a CPU graph capture records
    (Warp's APIC capture), a run is Warp's own, which the capture records. One thread at a time."""

    __slots__ = ("command", "_params", "_labels", "_structs", "_args", "_args_ref", "_forward")

    def __init__(self, command, labels: list, structs: list):
        params = command.params
        fields = [(label, type(value)) for label, value in zip(labels, params[1:])]
        self.command, self._params, self._labels, self._structs = command, params, labels, structs
        self._args = type("LaunchArgs", (ctypes.Structure,), {"_fields_": fields})()
        for label, value in zip(labels, params[1:]):
            setattr(self._args, label, value)
        self._args_ref = ctypes.byref(self._args)
        self._forward = command.hooks.forward

    @property
    def kernel(self):
        return self.command.kernel

    def set_param_at_index(self, index: int, value) -> None:
        """Bind `value` to the kernel's parameter `index` (inputs, then outputs)."""
        self.command.set_param_at_index(index, value)
        setattr(self._args, self._labels[index], self._params[1 + index])

    def set_dim(self, dim) -> None:
        self.command.set_dim(dim)

    def launch(self) -> None:
        if _context.runtime._apic_capture is not None:
            self.command.launch()
            return
        args, params = self._args, self._params
        for label, index in self._structs:
            setattr(args, label, params[index])
        self._forward(ctypes.byref(params[0]), self._args_ref)


def cpu_launch(command) -> CpuLaunch | None:
    """A `CpuLaunch` of the recorded launch `command` when it runs on the CPU as one forward call (no adjoint, no
    blocks of threads) and this Warp version has what CpuLaunch reads; else None."""
    try:
        if _context is None or _Struct is None or not command.device.is_cpu or command.adjoint or command.block_dim > 1:
            return None
        if not hasattr(_context.runtime, "_apic_capture") or command.hooks.forward is None:
            return None
        arguments = command.kernel.adj.args
        if len(command.params) != 1 + len(arguments):
            return None
        labels = [a.label for a in arguments]
        structs = [(a.label, 1 + i) for i, a in enumerate(arguments) if isinstance(a.type, _Struct)]
        return CpuLaunch(command, labels, structs)
    except AttributeError:  # pragma: no cover - other Warp versions
        return None
