"""Warp's private internals: the only module of warpdyn (package, kernels, examples, benchmarks) that reads them.

warpdyn reads Warp where Warp has no public way to do what it needs, or one that costs too much per call. Each
function below reads one internal, verified with Warp `VERIFIED` and pinned by tests/test_warp_private.py (it is
there, with the fields warpdyn reads, and behaves as warpdyn relies on). Each checks, at import or at its first
use, that its internal is there with the shape it reads, and where it is not:
- raises `MissingWarpInternal`, naming the internal and the Warp version, where Warp's public API has no
  equivalent (never a wrong answer, never another path taken silently);
- or, where Warp's public API does the same more slowly, takes that path, warns once (`WarpInternalWarning`) and
  lists the internal in `FALLBACKS`.

| function | reads (Warp 1.19) | missing |
| --- | --- | --- |
| `recording_tape`, `set_recording_tape` | `warp._src.context.runtime.tape` | raises: warpdyn cannot tell a tape-safe call from a fast one |
| `compiles_cuda` | `runtime.core.wp_is_cuda_enabled` | raises (whether a GPU is present is another answer) |
| `array_descriptor` | `warp._src.types.array_t` | `wp.array(ptr=...)` views, warned |
| `grads` | `wp.array._grad`, behind the `grad` property | the property, warned |
| `cpu_launch` (`CpuLaunch`) | `wp.Launch.params`, `.hooks.forward`, `Kernel.adj.args`, `warp._src.codegen.Struct`, `runtime._apic_capture` | Warp's `Launch.launch`, warned |
| `keep_owner`, `allocation` | `wp.array._ref`, a view's parent | raises |
| `struct_fields`, `struct_copy` | a struct instance's `_cls` and its `vars` | raises |
| `scalar_type`, `item_shape` | a composite dtype's `_wp_scalar_type_` and `_shape_` | raises |
| `tape_recording`, `tape_kernel_launches` | `wp.Tape.launches` and the layout of its entries | raises |
| `kernel_module`, `kernel_source` | `wp.Kernel.module`, `.func`, `.options` | raises |
| `native_name` | `warp._src.codegen.Var.type_to_ctype`, the C++ name of a vector or matrix type | raises |

It imports nothing of warpdyn, so that every layer may use it (tests/test_layers.py).
"""

from __future__ import annotations

import ctypes
import warnings
from typing import NamedTuple

import warp as wp

VERIFIED = "1.19.0"
"""The Warp version each internal was verified with."""


class MissingWarpInternal(RuntimeError):
    """A Warp internal that warpdyn reads is not there, or not as warpdyn reads it (another Warp version)."""


class WarpInternalWarning(UserWarning):
    """warpdyn takes a slower public path of Warp because an internal it reads is not there (see `FALLBACKS`)."""


FALLBACKS: dict = {}
"""{internal: the public path warpdyn takes instead}: empty with the Warp version warpdyn was verified with."""


def _missing(internal: str, what: str) -> MissingWarpInternal:
    return MissingWarpInternal(
        f"warpdyn reads {internal} ({what}), which Warp {wp.config.version} does not have as warpdyn reads it "
        f"(verified with Warp {VERIFIED}): warpdyn/engine/warp_private.py must be updated for this Warp version "
        "(tests/test_warp_private.py pins each internal)"
    )


def _fall_back(internal: str, instead: str) -> None:
    """Take Warp's public `instead` for `internal` from now on, said once."""
    if internal in FALLBACKS:
        return
    FALLBACKS[internal] = instead
    warnings.warn(
        f"warpdyn: Warp {wp.config.version} does not have {internal} as warpdyn reads it (verified with Warp {VERIFIED}); "
        f"warpdyn takes {instead} instead: the same results, more time per call",
        WarpInternalWarning,
        stacklevel=3,
    )


try:
    from warp._src import codegen as _codegen
    from warp._src import context as _context
    from warp._src import types as _types
except ImportError as error:  # another layout of Warp's sources
    raise _missing("warp._src.context, warp._src.types and warp._src.codegen", "Warp's internal modules") from error


# -- the recording tape ------------------------------------------------------------------------------------------

_verified_runtime = None


def recording_tape():
    """The wp.Tape recording launches, or None: `warp._src.context.runtime.tape` (Warp 1.19.0), which `with
    wp.Tape():` sets and Warp reads to record a launch; Warp has no public accessor. None before Warp is
    initialised (entering a tape initialises it). Checked when a runtime is first seen: the attribute is there and
    holds None or a wp.Tape."""
    runtime = _context.runtime
    if runtime is not _verified_runtime:
        if runtime is None:
            return None
        _verify_runtime(runtime)
    return runtime.tape


def _verify_runtime(runtime) -> None:
    global _verified_runtime
    if not isinstance(getattr(runtime, "tape", False), (wp.Tape, type(None))):
        raise _missing("warp._src.context.runtime.tape", "the wp.Tape that records launches, or None")
    _verified_runtime = runtime


def set_recording_tape(tape) -> None:
    """Make `tape` (a wp.Tape or None) the tape that records launches, as `with tape:` does (Warp 1.19.0's
    `warp._src.context.runtime.tape`; warpdyn.engine.tape.suspended sets a tape aside and back)."""
    if recording_tape() is not tape:
        _context.runtime.tape = tape


# -- whether this Warp build compiles CUDA code ------------------------------------------------------------------


def compiles_cuda() -> bool:
    """Whether this Warp build compiles CUDA code (its NVRTC), a GPU present or not: Warp 1.19.0's
    `runtime.core.wp_is_cuda_enabled()` (the pip wheel compiles PTX on a machine without a GPU).
    tests/test_fused_step.py compiles the GPU's kernels where it is True."""
    wp.init()
    enabled = getattr(_context.runtime.core, "wp_is_cuda_enabled", None)
    if enabled is None:
        raise _missing("warp._src.context.runtime.core.wp_is_cuda_enabled", "whether this Warp build compiles CUDA code")
    return bool(enabled())


# -- launch descriptors ------------------------------------------------------------------------------------------


def _find_array_t():
    """Warp 1.19.0's `warp._src.types.array_t(data, grad, ndim, shape, strides)`, checked on a probe; else None."""
    array_t = getattr(_types, "array_t", None)
    try:
        probe = array_t(16, 0, 2, (3, 4), (32, 8))
        found = (probe.data, probe.grad, probe.ndim, tuple(probe.shape[:2]), tuple(probe.strides[:2]))
    except (TypeError, AttributeError, ValueError):
        found = None
    if found != (16, 0, 2, (3, 4), (32, 8)):
        _fall_back("warp._src.types.array_t", "wp.array(ptr=...) views as launch arguments")
        return None
    return array_t


_array_t = _find_array_t()


def array_descriptor(array: wp.array, shape: tuple, strides: tuple, offset: int = 0):
    """A launch argument that shows `array`'s memory from `offset` bytes with `shape` and byte `strides`; it
    carries no gradient and does not keep `array` alive (the caller keeps it). Warp 1.19.0's launch descriptor
    `warp._src.types.array_t`, what Warp packs a wp.array into, about 1 µs to make where a view object takes ~8 µs
    on a slow CPU; without it, a view object (warned)."""
    ptr = (array.ptr or 0) + offset
    if _array_t is None:
        return wp.array(ptr=ptr, shape=shape, strides=strides, dtype=array.dtype, device=array.device)
    return _array_t(ptr, 0, len(shape), shape, strides)


# -- gradient arrays ---------------------------------------------------------------------------------------------

_grad_getter = getattr(getattr(wp.array, "grad", None), "fget", None)
_GRAD_READ = _grad_getter is not None and _grad_getter.__code__.co_names == ("_grad",)
if not _GRAD_READ:
    _fall_back("wp.array._grad", "the wp.array.grad property")


def grads(arrays: tuple) -> tuple:
    """The `.grad` of each of `arrays` (None where an array has none), as Warp's property returns it, read from
    Warp 1.19.0's `wp.array._grad`, the attribute the property returns (checked at import on the property's
    code): the property call is what costs, and the dynamics calls read the model's 20 parameter arrays at each
    call. A list comprehension: a third less time than map(operator.attrgetter) on 20 arrays (CPython 3.11)."""
    if _GRAD_READ:
        return tuple([a._grad for a in arrays])
    return tuple([a.grad for a in arrays])


# -- recorded CPU launches ---------------------------------------------------------------------------------------


class CpuLaunch:
    """A recorded launch (wp.launch(..., record_cmd=True)) on the CPU, run with one argument struct kept between
    runs: Warp's Launch.launch builds that struct from the packed parameters at every run, which costs about as
    much as a dynamics kernel on one environment. It has the methods of Warp's Launch that a replay uses
    (`kernel`, `set_param_at_index`, `set_dim`, `launch`); a parameter set goes to Warp's launch and to the
    struct. Struct parameters (kernel bundles) are copied at every run, as Warp does: Warp packs a
    struct as its live ctype, which assigning a field of the struct changes. While a CPU graph capture records
    (Warp 1.19.0's `runtime._apic_capture`), a run is Warp's own, which the capture records. One thread at a time."""

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


_CPU_LAUNCH = "wp.Launch.params, wp.Launch.hooks.forward, wp.Kernel.adj.args, warp._src.codegen.Struct, runtime._apic_capture"


def cpu_launch(command) -> CpuLaunch | None:
    """A `CpuLaunch` of the recorded launch `command` when it runs on the CPU as one forward call (no adjoint, no
    blocks of threads: Launch's documented `device`, `adjoint`, `block_dim`), else None: Warp runs it. Reads Warp
    1.19.0's undocumented `command.params` (the launch bounds, then one packed value per kernel argument),
    `command.hooks.forward` (the compiled forward function), `command.kernel.adj.args` (the arguments' labels and
    types), `warp._src.codegen.Struct` and `runtime._apic_capture`, checked on each command; where one is not as
    read, Warp's `Launch.launch` from then on (warned)."""
    if not command.device.is_cpu or command.adjoint or command.block_dim > 1 or _CPU_LAUNCH in FALLBACKS:
        return None
    try:
        arguments = command.kernel.adj.args
        labels = [a.label for a in arguments]
        structs = [(a.label, 1 + i) for i, a in enumerate(arguments) if isinstance(a.type, _codegen.Struct)]
        found = len(command.params) == 1 + len(arguments) and command.hooks.forward is not None
        found = found and hasattr(_context.runtime, "_apic_capture")
    except AttributeError:
        found = False
    if not found:
        _fall_back(_CPU_LAUNCH, "Warp's Launch.launch for recorded CPU launches")
        return None
    return CpuLaunch(command, labels, structs)


# -- views and their owners --------------------------------------------------------------------------------------


def keep_owner(view: wp.array, owner: wp.array) -> None:
    """Make `view` (a wp.array made with ptr= on `owner`'s memory) keep `owner` alive as its parent, as Warp's own
    views (slices, reshape, view) keep theirs: Warp 1.19.0's `wp.array._ref`, which Warp's constructor sets (None)
    and Warp follows from a view to its parents (to mark reads on a tape)."""
    if not hasattr(view, "_ref"):
        raise _missing("wp.array._ref", "the array a view keeps alive, its parent")
    view._ref = owner


def allocation(array: wp.array) -> wp.array:
    """The array at the end of `array`'s chain of parents (Warp 1.19.0's `wp.array._ref`): the allocation that
    a view (Warp's or `keep_owner`'s) shows, or `array` itself when it is not a view."""
    try:
        while array._ref is not None:
            array = array._ref
    except AttributeError:
        raise _missing("wp.array._ref", "the array a view keeps alive, its parent") from None
    return array


# -- struct instances --------------------------------------------------------------------------------------------


def struct_fields(value) -> tuple | None:
    """The field names of a Warp struct instance (of a @wp.struct class), in declaration order, or None when
    `value` is not one (wp.types.is_struct): Warp 1.19.0's `value._cls.vars` (its Struct and that struct's
    {name: Var}); Warp's public API does not list a struct's fields."""
    if not wp.types.is_struct(value):
        return None
    try:
        return tuple(value._cls.vars)
    except AttributeError:
        raise _missing("a Warp struct instance's _cls.vars", "the fields of a struct") from None


def struct_copy(value):
    """A new instance of `value`'s struct with its fields' values (StructInstance.assign): Warp 1.19.0's
    `value._cls()`, the struct of an instance made anew."""
    try:
        copy = value._cls()
    except AttributeError:
        raise _missing("a Warp struct instance's _cls", "the struct of an instance") from None
    copy.assign(value)
    return copy


# -- dtypes ------------------------------------------------------------------------------------------------------


def scalar_type(dtype):
    """The scalar type of a Warp dtype: itself for a scalar, Warp 1.19.0's `dtype._wp_scalar_type_` for a
    composite (vector, matrix, quaternion, transformation: wp.types.type_is_composite); warp.types has no public
    accessor."""
    if not wp.types.type_is_composite(dtype):
        return dtype
    try:
        return dtype._wp_scalar_type_
    except AttributeError:
        raise _missing("a Warp composite dtype's _wp_scalar_type_", "the scalar type of a vector or matrix") from None


def item_shape(dtype) -> tuple:
    """The shape of one element of a Warp dtype: () for a scalar, Warp 1.19.0's `dtype._shape_` for a composite
    ((3,) for a vec3, (3, 3) for a mat33, (7,) for a transformation); warp.types has no public accessor."""
    if not wp.types.type_is_composite(dtype):
        return ()
    try:
        return tuple(dtype._shape_)
    except AttributeError:
        raise _missing("a Warp composite dtype's _shape_", "the shape of a vector or matrix") from None


# -- what a tape recorded ----------------------------------------------------------------------------------------


def tape_recording(tape: wp.Tape) -> list:
    """What identifies `tape`'s current recording: Warp 1.19.0's `tape.launches`, the list that a recorded launch
    is appended to and that `tape.reset()` replaces with a new one."""
    launches = getattr(tape, "launches", None)
    if not isinstance(launches, list):
        raise _missing("wp.Tape.launches", "the list of a tape's recorded launches")
    return launches


class TapeLaunch(NamedTuple):
    """A kernel launch that a tape recorded: the arguments of the wp.launch that made it."""

    kernel: object
    dim: object
    max_blocks: int
    inputs: list
    outputs: list
    device: object
    block_dim: int


def tape_kernel_launches(tape: wp.Tape) -> list:
    """The kernel launches `tape` recorded, in order: Warp 1.19.0's `tape.launches` entries that are lists
    [kernel, dim, max_blocks, inputs, outputs, device, block_dim, metadata] (recorded functions are other
    objects there)."""
    out = []
    for entry in tape_recording(tape):
        if isinstance(entry, list):
            if len(entry) < 7 or not isinstance(entry[0], wp.Kernel):
                raise _missing("wp.Tape.launches", "a recorded launch as [kernel, dim, max_blocks, inputs, outputs, device, block_dim, ...]")
            out.append(TapeLaunch(*entry[:7]))
    return out


# -- kernels -----------------------------------------------------------------------------------------------------


def kernel_module(kernel: wp.Kernel) -> wp.Module:
    """The wp.Module that compiles `kernel` (what wp.load_module, wp.force_load, wp.get_module_options,
    wp.set_module_options and wp.compile_aot_module take): Warp 1.19.0's `kernel.module`."""
    module = getattr(kernel, "module", None)
    if not isinstance(module, wp.Module):
        raise _missing("wp.Kernel.module", "the wp.Module of a kernel")
    return module


def kernel_source(kernel: wp.Kernel) -> tuple:
    """(the Python function, the keyword options of wp.kernel) that made `kernel`, with which wp.kernel makes it
    again: Warp 1.19.0's `kernel.func` and `kernel.options` (the option dict, copied)."""
    func, options = getattr(kernel, "func", None), getattr(kernel, "options", None)
    if not callable(func) or not isinstance(options, dict):
        raise _missing("wp.Kernel.func and wp.Kernel.options", "the function and options that made a kernel")
    return func, dict(options)


# -- native code -------------------------------------------------------------------------------------------------


def native_name(dtype) -> str:
    """The C++ type of a Warp vector or matrix type in generated code (e.g. `wp::vec_t<3,wp::float64>`), as a
    wp.func_native snippet names it: Warp 1.19.0's `warp._src.codegen.Var.type_to_ctype`, the name Warp's code
    generator writes."""
    name = getattr(getattr(_codegen, "Var", None), "type_to_ctype", None)
    if name is None:
        raise _missing("warp._src.codegen.Var.type_to_ctype", "the C++ name of a Warp type")
    return name(dtype)
