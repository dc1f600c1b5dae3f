"""Warp's private internals that warpdyn reads (warpdyn.engine.warp_private), each pinned: it is there, with the
fields warpdyn reads, and it behaves as warpdyn relies on. A Warp upgrade that changes one fails its test here
(and warp_private raises, or takes Warp's public path with a warning, instead of answering wrongly).

The last test parses every Python file of warpdyn/, kernels/, examples/ and benchmarks/ (ast, nothing executed)
and fails on a Warp internal read anywhere but warp_private: an import of Warp's private modules, a private or
unknown name read from `warp` or its public modules, a name with a leading underscore that Warp's objects carry
(found on them at test time), or one of the undocumented attributes of Warp's objects that warp_private reads.

No reference beyond Warp itself: each test compares warp_private's reading with what Warp's own public calls do
(exact: the same memory, the same objects)."""

import ast
import pathlib
import pkgutil
import sys
import types
import warnings

import numpy as np
import pytest
import warp as wp
import warp._src
import warp.config
import warp.types

import robots
from warpdyn.engine import tape as engine_tape
from warpdyn.engine import warp_private

ROOT = pathlib.Path(__file__).resolve().parents[1]
DEVICE = robots.TEST_DEVICE
CPU_BACKEND = pytest.mark.skipif(not wp.is_cpu_available(), reason="this Warp build has no CPU backend (LLVM)")


@wp.struct
class Pair:
    scale: wp.float64
    values: wp.array(dtype=wp.float64)
    offset: wp.vec3d


@wp.kernel
def _scaled(p: Pair, x: wp.array(dtype=wp.float64), y: wp.array(dtype=wp.float64)):
    i = wp.tid()
    y[i] = p.scale * x[i] + p.values[0]


@wp.kernel
def _copy_rows(x: wp.array2d(dtype=wp.float64), y: wp.array2d(dtype=wp.float64)):
    i, j = wp.tid()
    y[i, j] = x[i, j]


@wp.kernel(cuda_max_registers=64)
def _twice(x: wp.array(dtype=wp.float64), y: wp.array(dtype=wp.float64)):
    i = wp.tid()
    y[i] = wp.float64(2.0) * x[i]


def _pair(scale: float, value: float, device=DEVICE) -> Pair:
    p = Pair()
    p.scale = wp.float64(scale)
    p.values = wp.array([value], dtype=wp.float64, device=device)
    return p


def test_the_verified_warp_needs_no_fallback():
    """With the Warp version warpdyn was verified with, every internal is found: no slower path is taken."""
    assert warp_private.FALLBACKS == {}


def test_runtime_tape_is_the_recording_tape_inside_a_tape_and_none_outside():
    """`runtime.tape`: None outside a tape, the tape inside `with tape:`, None again after; setting it aside
    stops recording (what warpdyn.engine.tape.suspended relies on); warpdyn's `taping()` follows it."""
    x = wp.array(np.arange(3.0), dtype=wp.float64, device=DEVICE, requires_grad=True)
    y = wp.zeros(3, dtype=wp.float64, device=DEVICE, requires_grad=True)
    assert warp_private.recording_tape() is None and not engine_tape.taping()
    tape = wp.Tape()
    with tape:
        assert warp_private.recording_tape() is tape and engine_tape.taping()
        warp_private.set_recording_tape(None)
        try:
            wp.launch(_twice, dim=3, inputs=[x], outputs=[y], device=DEVICE)  # not recorded
            assert warp_private.recording_tape() is None
        finally:
            warp_private.set_recording_tape(tape)
        wp.launch(_twice, dim=3, inputs=[x], outputs=[y], device=DEVICE)  # recorded
    assert warp_private.recording_tape() is None and not engine_tape.taping()
    assert len(warp_private.tape_kernel_launches(tape)) == 1


def test_a_runtime_without_tape_raises_instead_of_answering(monkeypatch):
    """A Warp whose runtime does not hold the recording tape: warpdyn raises, naming it, rather than answering
    that a tape records (every call's slow path) or that none does (a wrong gradient)."""
    monkeypatch.setattr(warp_private._context, "runtime", types.SimpleNamespace())
    with pytest.raises(warp_private.MissingWarpInternal, match=r"runtime\.tape.*Warp 1\.19"):
        engine_tape.taping()


def test_compiles_cuda_says_whether_this_build_compiles_ptx(tmp_path):
    """`runtime.core.wp_is_cuda_enabled`: True exactly when this Warp build compiles a kernel to PTX (a GPU
    present or not): what tests/test_fused_step.py asks before compiling the GPU's kernels."""
    compiles = warp_private.compiles_cuda()
    assert isinstance(compiles, bool)
    assert compiles or not wp.is_cuda_available()
    if compiles:
        wp.compile_aot_module(warp_private.kernel_module(_twice), arch=90, module_dir=str(tmp_path), use_ptx=True)
        assert list(tmp_path.glob("*.ptx"))
    else:
        with pytest.raises(Exception):  # Warp's error for a build without CUDA: its type is not what warpdyn relies on
            wp.compile_aot_module(warp_private.kernel_module(_twice), arch=90, module_dir=str(tmp_path), use_ptx=True)


def _descriptor_fields(d) -> tuple:
    return (d.data, d.grad, d.ndim, tuple(d.shape[: d.ndim]), tuple(d.strides[: d.ndim]), d.flags)


@pytest.mark.parametrize(
    ("shape", "strides", "offset"),
    [((2, 3), (24, 8), 0), ((1, 3), (0, 8), 8), ((4, 3), (0, 8), 16)],
    ids=["contiguous", "one-environment-at-an-offset", "broadcast"],
)
def test_array_descriptor_equals_warps_own_and_launches(monkeypatch, shape, strides, offset):
    """`warp._src.types.array_t`: the descriptor warpdyn makes equals the one Warp packs for a wp.array view of
    the same memory, shape and strides, and a kernel reads that memory through it; the fallback (a wp.array
    view) packs the same."""
    host = np.arange(12.0)
    a = wp.array(host, dtype=wp.float64, device=DEVICE)
    view = wp.array(ptr=a.ptr + offset, shape=shape, strides=strides, dtype=wp.float64, device=DEVICE)
    made = warp_private.array_descriptor(a, shape, strides, offset)
    assert isinstance(made, warp_private._types.array_t)
    assert _descriptor_fields(made) == _descriptor_fields(view.__ctype__())
    out = wp.zeros(shape, dtype=wp.float64, device=DEVICE)
    wp.launch(_copy_rows, dim=shape, inputs=[made], outputs=[out], device=DEVICE)
    expected = np.lib.stride_tricks.as_strided(host[offset // 8 :], shape=shape, strides=strides)
    np.testing.assert_array_equal(out.numpy(), expected)
    monkeypatch.setattr(warp_private, "_array_t", None)
    fallback = warp_private.array_descriptor(a, shape, strides, offset)
    assert isinstance(fallback, wp.array)
    assert _descriptor_fields(fallback.__ctype__()) == _descriptor_fields(view.__ctype__())


def test_grads_read_what_the_grad_property_returns(monkeypatch):
    """`wp.array._grad`: what the `grad` property returns (the same objects; None without gradients), after
    marking and unmarking arrays; the fallback (the property) reads the same."""
    a = wp.zeros(3, dtype=wp.float64, device=DEVICE, requires_grad=True)
    b = wp.zeros(3, dtype=wp.float64, device=DEVICE)
    c = wp.zeros(2, dtype=wp.vec3d, device=DEVICE)
    c.requires_grad = True
    arrays = (a, b, c, a[1:])
    expected = tuple(x.grad for x in arrays)
    assert expected[1] is None and all(g is not None for i, g in enumerate(expected) if i != 1)
    got = warp_private.grads(arrays)
    assert len(got) == len(expected) and all(g is e for g, e in zip(got, expected))
    a.requires_grad = False
    assert warp_private.grads((a,)) == (None,) == (a.grad,)
    monkeypatch.setattr(warp_private, "_GRAD_READ", False)
    assert all(g is e for g, e in zip(warp_private.grads(arrays), tuple(x.grad for x in arrays)))


@CPU_BACKEND
def test_a_recorded_cpu_launch_has_what_cpu_launch_reads():
    """`Launch.params` (the bounds, then one packed value per argument), `Launch.hooks.forward`,
    `Kernel.adj.args` (labels, types: a struct is a codegen.Struct), `runtime._apic_capture` (None outside a
    CPU capture, set inside): a CpuLaunch made from them computes what Warp's launch computes, re-bound too."""
    x = wp.array(np.arange(4.0), dtype=wp.float64, device="cpu")
    y = wp.zeros(4, dtype=wp.float64, device="cpu")
    command = wp.launch(_scaled, dim=4, inputs=[_pair(2.0, 1.0, "cpu"), x], outputs=[y], device="cpu", record_cmd=True)
    arguments = command.kernel.adj.args
    assert [a.label for a in arguments] == ["p", "x", "y"]
    assert isinstance(arguments[0].type, warp_private._codegen.Struct)
    assert len(command.params) == 1 + len(arguments) and callable(command.hooks.forward)
    assert warp_private._context.runtime._apic_capture is None
    with wp.ScopedCapture(device="cpu", force_module_load=False):
        assert warp_private._context.runtime._apic_capture is not None
    fast = warp_private.cpu_launch(command)
    assert isinstance(fast, warp_private.CpuLaunch)
    fast.launch()
    np.testing.assert_array_equal(y.numpy(), 2.0 * np.arange(4.0) + 1.0)
    fast.set_param_at_index(1, wp.array(np.ones(4), dtype=wp.float64, device="cpu"))
    fast.launch()
    np.testing.assert_array_equal(y.numpy(), np.full(4, 3.0))


def test_a_launch_without_what_cpu_launch_reads_is_warps_with_a_warning(monkeypatch):
    """A recorded CPU launch that does not have the fields CpuLaunch reads: Warp's own Launch.launch, said once."""
    monkeypatch.setattr(warp_private, "FALLBACKS", {})
    command = types.SimpleNamespace(device=wp.get_device("cpu"), adjoint=False, block_dim=1, kernel=_scaled)
    with pytest.warns(warp_private.WarpInternalWarning, match="Launch.params"):
        assert warp_private.cpu_launch(command) is None
    assert list(warp_private.FALLBACKS) == [warp_private._CPU_LAUNCH]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert warp_private.cpu_launch(command) is None  # said once


def test_a_views_owner_is_its_ref_as_for_warps_own_views():
    """`wp.array._ref`: Warp's own views (slices, reshape) keep their parent there; `keep_owner` keeps a ptr=
    view's owner alive the same way, and `allocation` walks back to the array that owns the memory."""
    a = wp.zeros(6, dtype=wp.float64, device=DEVICE)
    sliced = a[1:5]
    chained = sliced.reshape((2, 2))
    assert sliced._ref is a and warp_private.allocation(chained) is a and warp_private.allocation(a) is a
    view = wp.array(ptr=a.ptr, shape=(2, 3), dtype=wp.float64, device=DEVICE)
    assert view._ref is None and warp_private.allocation(view) is view
    count = sys.getrefcount(a)
    warp_private.keep_owner(view, a)
    kept = sys.getrefcount(a) - count  # measured outside an assert (pytest keeps an assert's operands)
    assert kept == 1 and warp_private.allocation(view) is a
    with pytest.raises(warp_private.MissingWarpInternal, match=r"wp\.array\._ref"):
        warp_private.keep_owner(types.SimpleNamespace(), a)


def test_struct_fields_and_copy():
    """A struct instance's `_cls.vars`: its fields in declaration order (None for anything else); `_cls()`: a
    new instance, which `struct_copy` fills with the same values (the same arrays), independent of the first."""
    p = _pair(2.0, 1.0)
    p.offset = wp.vec3d(1.0, 2.0, 3.0)
    assert warp_private.struct_fields(p) == ("scale", "values", "offset")
    assert warp_private.struct_fields(p.values) is None and warp_private.struct_fields(3) is None
    copy = warp_private.struct_copy(p)
    assert type(copy) is type(p) and copy is not p
    assert copy.scale == p.scale and copy.values is p.values and copy.offset == p.offset
    copy.scale = wp.float64(5.0)
    assert p.scale == 2.0


@pytest.mark.parametrize(
    ("dtype_", "scalar", "shape"),
    [
        (wp.float64, wp.float64, ()),
        (wp.float32, wp.float32, ()),
        (wp.vec3d, wp.float64, (3,)),
        (wp.types.vector(6, wp.float32), wp.float32, (6,)),
        (wp.mat33f, wp.float32, (3, 3)),
        (wp.types.matrix((6, 6), wp.float64), wp.float64, (6, 6)),
        (wp.quatd, wp.float64, (4,)),
        (wp.transformf, wp.float32, (7,)),
    ],
    ids=lambda v: getattr(v, "__name__", str(v)),
)
def test_scalar_type_and_item_shape(dtype_, scalar, shape):
    """A dtype's `_wp_scalar_type_` and `_shape_`: the scalar and shape of its elements, as an array of it shows
    them to NumPy (the torch bridge compares tensors' shapes with them)."""
    assert warp_private.scalar_type(dtype_) is scalar
    assert warp_private.item_shape(dtype_) == shape
    host = wp.zeros(2, dtype=dtype_, device="cpu").numpy()
    assert host.shape == (2, *shape) and host.dtype == np.dtype(wp.dtype_to_numpy(scalar))


def test_a_tapes_launches_identify_its_recording_and_list_its_kernel_launches():
    """`wp.Tape.launches`: a list that a recorded launch is appended to as [kernel, dim, max_blocks, inputs,
    outputs, device, block_dim, ...] (a recorded function is another object there), and that `reset()`
    replaces (a new recording: warpdyn.engine.determinism makes new copies)."""
    x = wp.array(np.arange(3.0), dtype=wp.float64, device=DEVICE, requires_grad=True)
    y = wp.zeros(3, dtype=wp.float64, device=DEVICE, requires_grad=True)
    tape = wp.Tape()
    with tape:
        wp.launch(_twice, dim=3, inputs=[x], outputs=[y], device=DEVICE)
        tape.record_func(backward=lambda: None, arrays=[x])
    first = warp_private.tape_recording(tape)
    assert len(first) == 2
    (launch,) = warp_private.tape_kernel_launches(tape)
    assert launch.kernel is _twice and tuple(launch.dim) == (3,) and launch.inputs == [x] and launch.outputs == [y]
    assert launch.device == wp.get_device(DEVICE)
    tape.reset()
    assert warp_private.tape_recording(tape) is not first and warp_private.tape_recording(tape) == []


def test_a_kernels_module_and_source_make_it_again():
    """`Kernel.module`: the wp.Module whose options Warp's public get/set_module_options read and write;
    `Kernel.func` and `Kernel.options`: wp.kernel makes the same kernel from them (its own options kept), as
    warpdyn.engine.loading makes forward-only twins."""
    module = warp_private.kernel_module(_twice)
    assert isinstance(module, wp.Module) and {"enable_backward", "fuse_fp"} <= set(wp.get_module_options(module))
    func, options = warp_private.kernel_source(_twice)
    assert options == {"cuda_max_registers": 64}
    again = wp.kernel(func, module="unique", module_options={"enable_backward": False}, **options)
    assert warp_private.kernel_source(again)[1] == options
    assert wp.get_module_options(warp_private.kernel_module(again))["enable_backward"] is False
    x = wp.array(np.arange(3.0), dtype=wp.float64, device=DEVICE)
    y = wp.zeros(3, dtype=wp.float64, device=DEVICE)
    wp.launch(again, dim=3, inputs=[x], outputs=[y], device=DEVICE)
    np.testing.assert_array_equal(y.numpy(), [0.0, 2.0, 4.0])


VEC7D = wp.types.vector(7, wp.float64)
MAT23F = wp.types.matrix((2, 3), wp.float32)


def _unfilled(dtype_) -> str:
    """kernels/fused_step.py's `unfilled` snippet: a value of dtype_ that no constructor writes."""
    name = warp_private.native_name(dtype_)
    return f"""
    union Unfilled {{ {name} value; unsigned char none; CUDA_CALLABLE Unfilled() : none(0) {{}} }} unfilled;
    return unfilled.value;"""


@wp.func_native(_unfilled(VEC7D))
def _vec7_unfilled() -> VEC7D:
    """A VEC7D that nothing wrote."""


@wp.func_native(_unfilled(MAT23F))
def _mat23_unfilled() -> MAT23F:
    """A MAT23F that nothing wrote."""


@wp.kernel
def _fill_unfilled(x: wp.array(dtype=wp.float64), z: wp.array(dtype=wp.float32), v: wp.array(dtype=VEC7D), m: wp.array(dtype=MAT23F)):
    a = _vec7_unfilled()
    for k in range(7):
        a[k] = x[k]
    b = _mat23_unfilled()
    for r in range(2):
        for c in range(3):
            b[r, c] = z[3 * r + c]
    v[0] = a
    m[0] = b


def test_native_names_are_what_a_native_snippet_returns():
    """`codegen.Var.type_to_ctype`: the C++ names of Warp's vectors and matrices, which a wp.func_native snippet
    returns (the fused step's records): a kernel built from such snippets compiles and writes through them."""
    assert warp_private.native_name(VEC7D) == "wp::vec_t<7, wp::float64>"
    assert warp_private.native_name(MAT23F) == "wp::mat_t<2, 3, wp::float32>"
    v = wp.zeros(1, dtype=VEC7D, device=DEVICE)
    m = wp.zeros(1, dtype=MAT23F, device=DEVICE)
    x = wp.array(np.arange(7.0), dtype=wp.float64, device=DEVICE)
    z = wp.array(np.arange(6.0), dtype=wp.float32, device=DEVICE)
    wp.launch(_fill_unfilled, dim=1, inputs=[x, z], outputs=[v, m], device=DEVICE)
    np.testing.assert_array_equal(v.numpy()[0], np.arange(7.0))
    np.testing.assert_array_equal(m.numpy()[0], np.arange(6.0).reshape(2, 3))


# -- no other module reads Warp's internals -----------------------------------------------------------------------

SCANNED = sorted(p for folder in ("warpdyn", "kernels", "examples", "benchmarks") for p in (ROOT / folder).rglob("*.py"))
WARP_PRIVATE = ROOT / "warpdyn" / "engine" / "warp_private.py"

UNDOCUMENTED = {"adj", "hooks", "params", "module", "func", "options", "key", "launches", "vars", "runtime", "core", "ctype", "__ctype__"}
"""Attributes of Warp's objects that Warp does not document and that warpdyn has read (Kernel.adj, .module, .func,
.options, .key; Launch.params, .hooks; Tape.launches; a struct's .vars; the runtime and its core; an array's
ctype): read anywhere but warp_private, they are flagged, but for the names that warpdyn's own classes define too (`_own_names`:
a step workspace's `launches`, the kinematic structure's `options`), which the check cannot tell apart."""

SHARED_NAMES = {"launches", "options"}
"""The names of UNDOCUMENTED that warpdyn's own classes may define: no other, so that the check keeps the rest."""


def _own_names(paths) -> set:
    """The attribute names that classes of `paths` define: in their bodies, or assigned to `self`."""
    names = set()
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                for item in node.body:
                    targets = item.targets if isinstance(item, ast.Assign) else [getattr(item, "target", None)]
                    names.update(t.id for t in targets if isinstance(t, ast.Name))
                    if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
                        names.add(item.name)
            elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) and isinstance(node.value, ast.Name) and node.value.id == "self":
                names.add(node.attr)
    return names


def _warp_names() -> set:
    """The attributes with a leading underscore (and __ctype__) that Warp's objects carry in the running Warp:
    an array and a view, a kernel and its module and code generator, a recorded launch and its hooks, a tape, a
    struct and an instance, composite and scalar dtypes and values, a device, the runtime."""
    device = "cpu" if wp.is_cpu_available() else wp.get_device()  # a Warp build without its CPU backend: the GPU
    a = wp.zeros(3, dtype=wp.float64, device=device, requires_grad=True)
    command = wp.launch(_twice, dim=3, inputs=[a], outputs=[wp.zeros_like(a)], device=device, record_cmd=True)
    p = _pair(1.0, 0.0, device)
    objects = [a, a[1:], wp.array, _twice, warp_private.kernel_module(_twice), _twice.adj, command, command.hooks, wp.Tape()]
    objects += [Pair, p, type(p), wp.vec3d, wp.vec3d(), wp.mat33f, wp.quatd, wp.transformf, wp.float64, wp.get_device(device)]
    objects.append(warp_private._context.runtime)
    names = {n for o in objects for n in dir(o) if n.startswith("_") and not n.startswith("__")}
    return names | {"__ctype__"}


def _public(module, name: str) -> bool:
    return (not name.startswith("_") or (name.startswith("__") and name.endswith("__"))) and hasattr(module, name)


def _internal_modules() -> set:
    """The names of Warp's internal modules (warp._src's) that no public module of Warp shares."""
    public = {m.name for m in pkgutil.iter_modules(wp.__path__) if not m.name.startswith("_")}
    return {m.name for m in pkgutil.iter_modules(warp._src.__path__)} - public


def _internals_read(path: pathlib.Path, private: set, undocumented: set) -> list:
    """Where the file at `path` reads Warp's internals (see the module docstring)."""
    public_modules = {"warp": wp, "warp.types": warp.types, "warp.config": warp.config}
    internal = _internal_modules()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    aliases: dict = {}  # local name -> the public Warp module it is bound to
    found = []

    def where(node, what: str):
        found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {what}")

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "warp":
                    if alias.name not in public_modules:
                        where(node, f"imports {alias.name}")
                    else:  # `import warp.types` binds warp
                        aliases[alias.asname or "warp"] = public_modules[alias.name] if alias.asname else wp
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "warp" and node.level == 0:
            if node.module not in public_modules:
                where(node, f"imports from {node.module}")
                continue
            for alias in node.names:
                target = f"{node.module}.{alias.name}"
                if target in public_modules:
                    aliases[alias.asname or alias.name] = public_modules[target]
                elif not _public(public_modules[node.module], alias.name):
                    where(node, f"imports {target}")
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            chain, base = [node.attr], node.value
            while isinstance(base, ast.Attribute):
                chain.insert(0, base.attr)
                base = base.value
            if isinstance(base, ast.Name) and base.id in aliases:
                module, first = aliases[base.id], chain[0]
                if module is wp and (first in internal or (first.startswith("_") and not first.startswith("__"))):
                    where(node, f"reads {base.id}.{first}, an internal of Warp")
                elif module is not wp and not _public(module, first):
                    where(node, f"reads {base.id}.{first}, not a public name of {module.__name__}")
                elif isinstance(getattr(module, first, None), types.ModuleType) and len(chain) > 1 and not _public(getattr(module, first), chain[1]):
                    where(node, f"reads {base.id}.{first}.{chain[1]}, not a public name of {module.__name__}.{first}")
                continue
            receiver = ast.unparse(node.value)
            if node.attr in private:
                where(node, f"reads {receiver}.{node.attr}, an internal attribute of Warp's objects")
            elif node.attr in undocumented:
                where(node, f"reads {receiver}.{node.attr}, an undocumented attribute of Warp's objects")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "hasattr", "setattr", "delattr"):
            name = node.args[1].value if len(node.args) > 1 and isinstance(node.args[1], ast.Constant) else None
            if name in private or name in undocumented:
                where(node, f"{node.func.id}(..., {name!r}), an internal attribute of Warp's objects")
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.startswith("warp._src"):
            where(node, f"names the module {node.value}")
    return sorted(set(found))  # an attribute chain is walked once per link


def test_no_module_but_warp_private_reads_warps_internals():
    private = _warp_names()
    assert {"_grad", "_ref", "_cls", "_shape_", "_wp_scalar_type_", "_apic_capture"} <= private  # the walk found them
    assert WARP_PRIVATE in SCANNED and len(SCANNED) > 100
    shared = UNDOCUMENTED & _own_names(SCANNED)
    assert shared <= SHARED_NAMES, f"warpdyn's own classes define {sorted(shared - SHARED_NAMES)}, which Warp's objects carry undocumented: rename them, so that the check can tell warpdyn's reads from Warp's"
    undocumented = UNDOCUMENTED - shared
    found = [line for path in SCANNED if path != WARP_PRIVATE for line in _internals_read(path, private, undocumented)]
    assert not found, "Warp's internals read outside warpdyn/engine/warp_private.py:\n" + "\n".join(found)
    assert len(_internals_read(WARP_PRIVATE, private, UNDOCUMENTED)) > 20, "the check finds warp_private's own reads"
