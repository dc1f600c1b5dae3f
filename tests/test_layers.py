"""The package's layers, read from its source: api -> engine -> types -> description/arrays -> kernels.

Each module of warpdyn (and of kernels/, installed as warpdyn.kernels) belongs to one layer (LAYERS). The
test parses every module's imports (ast, no import is executed) and asserts:
- no arrow from a lower layer to a higher one, and bridges (torch, visualization, envs) import only the api
  (and their own package's modules);
- no cycle among the modules (imports at module level; a package's own __init__ is not an arrow);
- no module reads another module's private names (`from .x import _y`, `x._y`);
- no import inside a function, except of optional dependencies (torch, rerun, mujoco, yourdfpy, trimesh,
  icub_models, matplotlib), which a user may not have installed;
- the leaves (LEAVES: warpdyn.config, warpdyn.assets, warpdyn.engine.warp_private), which every layer may use,
  import nothing of warpdyn (tests/test_warp_private.py checks that warp_private alone reads Warp's internals);
- no Python file of the project (tests, examples and benchmarks included) is over 700 lines;
- pyproject.toml installs every package (a non-editable install would otherwise lack one);
- no kernel loop ends an iteration with `continue` (Warp's adjoint loses that iteration's gradients).
A module missing from LAYERS fails the test: a new module is placed in a layer on purpose.
"""

import ast
import pathlib

import pytest
import warp as wp

ROOT = pathlib.Path(__file__).resolve().parents[1]

LAYERS = {
    "bridge": 5,
    "api": 4,
    "engine": 3,
    "types": 2,
    "description": 1,
    "kernels": 0,
}

API = {
    "warpdyn",
    "warpdyn.model",
    "warpdyn.data",
    "warpdyn.references",
    "warpdyn.link",
    "warpdyn.frame",
    "warpdyn.joint",
    "warpdyn.com",
    "warpdyn.contact",
    "warpdyn.simulation",
    "warpdyn.autodiff",
    "warpdyn.terrain",
    "warpdyn.math",
    "warpdyn.common",
    "warpdyn.ode",
    "warpdyn.integrators",
    "warpdyn.actuation_model",
    "warpdyn.kin_dyn_parameters",
    "warpdyn.rbda",
    "warpdyn.rbda.contacts",
}
BRIDGES = {"warpdyn.torch", "warpdyn.visualization"}
LEAVES = {"warpdyn.assets", "warpdyn.config", "warpdyn.engine.warp_private"}  # import nothing of warpdyn: any layer may use them
OPTIONAL = {"torch", "rerun", "mujoco", "yourdfpy", "trimesh", "icub_models", "matplotlib", "gymnasium", "rsl_rl", "tensordict"}


def layer_of(module: str) -> str:
    if module in BRIDGES or module == "warpdyn.envs" or module.startswith("warpdyn.envs."):
        return "bridge"
    if module in API:
        return "api"
    for prefix, layer in (("warpdyn.engine", "engine"), ("warpdyn.types", "types"), ("warpdyn.kernels", "kernels")):
        if module == prefix or module.startswith(prefix + "."):
            return layer
    if module.startswith("warpdyn.description") or module == "warpdyn.arrays":
        return "description"
    raise KeyError(module)


def _modules() -> dict[str, pathlib.Path]:
    """{module name: file} for warpdyn/ and kernels/ (installed as warpdyn.kernels)."""
    found = {}
    for path in sorted((ROOT / "warpdyn").rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    for path in sorted((ROOT / "kernels").glob("*.py")):
        found["warpdyn.kernels" + ("" if path.stem == "__init__" else "." + path.stem)] = path
    return found


MODULES = _modules()


def _package(module: str, path: pathlib.Path) -> str:
    return module if path.name == "__init__.py" else module.rsplit(".", 1)[0]


def _resolve(module: str, path: pathlib.Path, node: ast.ImportFrom | ast.Import) -> list[tuple[str, str | None]]:
    """[(imported warpdyn module, name imported from it or None)] of an import statement."""
    if isinstance(node, ast.Import):
        return [(a.name, None) for a in node.names if a.name.split(".")[0] == "warpdyn"]
    if node.level:
        base = _package(module, path).split(".")
        base = base[: len(base) - (node.level - 1)]
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module or ""
    if target.split(".")[0] != "warpdyn":
        return []
    out = []
    for alias in node.names:
        sub = f"{target}.{alias.name}"
        out.append((sub, None) if sub in MODULES else (target, alias.name))
    return out


def _imports(module: str) -> list[tuple[str, str | None, ast.AST, bool]]:
    """(imported module, name, node, inside a function) for every import of `module`."""
    path = MODULES[module]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []

    def visit(node, in_function: bool):
        for child in ast.iter_child_nodes(node):
            inside = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                if isinstance(child, ast.ImportFrom) and child.level == 0 and child.module is None:
                    continue
                targets = _resolve(module, path, child)
                if not targets and inside:
                    out.append((None, None, child, True))
                for target, name in targets:
                    out.append((target, name, child, inside))
            visit(child, inside)

    visit(tree, False)
    return out


def _is_parent_package(importer: str, imported: str) -> bool:
    return importer.startswith(imported + ".")


def test_every_module_has_a_layer():
    missing = [m for m in MODULES if m not in LEAVES and not _has_layer(m)]
    assert not missing, f"modules without a layer (add them to tests/test_layers.py): {missing}"
    assert len(MODULES) > 40  # the walk found the package (not an empty listing)


def _has_layer(module: str) -> bool:
    try:
        layer_of(module)
    except KeyError:
        return False
    return True


def test_no_import_goes_up_and_bridges_use_the_api_only():
    wrong = []
    for module in MODULES:
        if module in LEAVES or module == "warpdyn":
            continue
        mine = layer_of(module)
        for target, _, node, _ in _imports(module):
            if target is None or target in LEAVES or _is_parent_package(module, target):
                continue
            theirs = layer_of(target)
            same_package = target.rsplit(".", 1)[0] == module.rsplit(".", 1)[0] or target.startswith(module + ".")
            if LAYERS[theirs] > LAYERS[mine] or (mine == "bridge" and theirs != "api" and not same_package):
                wrong.append(f"{module} ({mine}) imports {target} ({theirs}), line {node.lineno}")
    assert not wrong, "imports against the layering:\n" + "\n".join(wrong)


def test_no_import_cycle():
    graph = {m: set() for m in MODULES}
    for module in MODULES:
        for target, _, _, inside in _imports(module):
            if target is not None and not inside and not _is_parent_package(module, target) and target in graph:
                graph[module].add(target)
    state, stack = {}, []

    def visit(m):
        state[m] = "open"
        stack.append(m)
        for n in sorted(graph[m]):
            if state.get(n) == "open":
                cycle = stack[stack.index(n):] + [n]
                raise AssertionError("import cycle: " + " -> ".join(cycle))
            if n not in state:
                visit(n)
        stack.pop()
        state[m] = "done"

    for m in sorted(graph):
        if m not in state:
            visit(m)


def test_no_private_names_across_modules_and_no_imports_in_functions():
    wrong = []
    for module in MODULES:
        path = MODULES[module]
        imported_modules = {}
        for target, name, node, inside in _imports(module):
            if inside and (target is not None or any(a.name.split(".")[0] not in OPTIONAL for a in node.names if isinstance(node, ast.Import))):
                if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in OPTIONAL:
                    continue
                wrong.append(f"{module}: an import inside a function, line {node.lineno}")
            if name is not None and name.startswith("_"):
                wrong.append(f"{module} imports the private name {target}.{name}, line {node.lineno}")
            if target is not None and name is None:
                for alias in node.names:
                    imported_modules[alias.asname or alias.name.split(".")[-1]] = target
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (
                isinstance(node, ast.Attribute)
                and isinstance(node.value, ast.Name)
                and node.value.id in imported_modules
                and node.attr.startswith("_")
                and not node.attr.startswith("__")
            ):
                wrong.append(f"{module} reads {imported_modules[node.value.id]}.{node.attr}, line {node.lineno}")
    assert not wrong, "\n".join(wrong)


def test_leaves_import_nothing_of_warpdyn():
    wrong = [f"{module} imports {target}, line {node.lineno}" for module in sorted(LEAVES) for target, _, node, _ in _imports(module) if target is not None]
    assert not wrong, "\n".join(wrong)


PYTHON_FILES = sorted(p.relative_to(ROOT).as_posix() for folder in ("warpdyn", "kernels", "tests", "examples", "benchmarks") for p in (ROOT / folder).rglob("*.py"))


@pytest.mark.parametrize("path", PYTHON_FILES)
def test_no_python_file_is_over_700_lines(path):
    """Every Python file of the project (package, kernels, tests, examples, benchmarks) reads in one sitting."""
    lines = (ROOT / path).read_text(encoding="utf-8").count("\n")
    assert lines <= 700, f"{path} has {lines} lines"


def test_pyproject_installs_every_package():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        from pip._vendor import tomli as tomllib
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]
    found = {".".join(p.parent.relative_to(ROOT / "warpdyn").parts) for p in (ROOT / "warpdyn").rglob("__init__.py")}
    found = {"warpdyn" + (f".{name}" if name else "") for name in found} | {"warpdyn.kernels"}
    assert set(setuptools["packages"]) == found
    assert setuptools["package-dir"]["warpdyn.kernels"] == "kernels"


def test_no_kernel_loop_continues():
    """No `continue` in kernels/: Warp 1.19's adjoint of a dynamic loop skips the iterations a `continue` ended, so
    their gradients vanish (JaxSim's frame welds' rows lost theirs: A off by 10 against central differences). The
    repro below is Warp's behaviour (d/dx of 2x + 2x + 3x + 3x comes out 6, not 10); when Warp differentiates it
    right, this test says so and the rule can go."""
    offenders = [f"{p.name}:{node.lineno}" for p in sorted((ROOT / "kernels").glob("*.py")) for node in ast.walk(ast.parse(p.read_text()))
                 if isinstance(node, ast.Continue)]  # fmt: skip
    assert not offenders, f"`continue` in kernels: {offenders}; write the loop's body under if/else"

    @wp.kernel(module="unique")
    def continued(x: wp.array(dtype=float), kind: wp.array(dtype=int), out: wp.array(dtype=float)):
        for e in range(kind.shape[0]):
            if kind[e] == 1:
                for a in range(2):
                    out[e * 2 + a] = x[0] * 2.0
                continue
            for a in range(2):
                out[e * 2 + a] = x[0] * 3.0

    x = wp.array([1.0], dtype=float, requires_grad=True)
    out = wp.zeros(4, dtype=float, requires_grad=True)
    tape = wp.Tape()
    with tape:
        wp.launch(continued, 1, [x, wp.array([1, 0], dtype=int)], [out])
    tape.backward(grads={out: wp.ones(4, dtype=float)})
    assert out.numpy().tolist() == [2.0, 2.0, 3.0, 3.0]
    assert x.grad.numpy()[0] != 10.0, "Warp now differentiates `continue` in dynamic loops: test_no_kernel_loop_continues' rule can go"
