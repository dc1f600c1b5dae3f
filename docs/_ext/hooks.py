"""MkDocs hooks of warpdyn's site (mkdocs.yml, `hooks:`): the source of executed code blocks for Warp, and
the benchmark figures.

Warp compiles a `@wp.kernel` from its Python source, which it reads through `linecache` (as `inspect` does).
markdown-exec runs a page's code blocks with `compile` and `exec`, under file names such as
`<code block: n3>` that nothing can read back, so a block that defines a kernel fails with Warp's "Directly
evaluating Warp code defined as a string using `exec()` is not supported". This hook puts each block's
source into `linecache` under that name before markdown-exec runs it: what Python's own REPLs do to make
source available. It wraps markdown-exec's `exec_python` (an internal name of markdown-exec 1.x): if a
version renames it, the build fails here, loudly, rather than later in a kernel.
"""

from __future__ import annotations

import linecache
import pathlib

from markdown_exec._internal.formatters import python as _markdown_exec_python


def on_startup(**kwargs) -> None:
    run = _markdown_exec_python.exec_python
    if getattr(run, "registers_source", False):
        return  # `mkdocs serve` starts once and builds many times

    def exec_python(code: str, filename: str, exec_globals: dict | None = None) -> None:
        linecache.cache[filename] = (len(code), None, code.splitlines(keepends=True), filename)
        run(code, filename, exec_globals)

    exec_python.registers_source = True
    _markdown_exec_python.exec_python = exec_python


# Figures the benchmark scripts write under benchmarks/results/, shown on the pages as assets/<name>: served
# from where the scripts wrote them, so that the site never holds a stale copy.
FIGURES = ("speed_accuracy_cpu.png", "speed_accuracy_nvidia_h200.png", "speed_accuracy_cpu_soft_relaxed_rigid.png", "rl_go1_walk_h100.png")


def on_files(files, *, config):
    from mkdocs.structure.files import File

    results = pathlib.Path(config["config_file_path"]).parent / "benchmarks" / "results"
    for name in FIGURES:
        files.append(File.generated(config, f"assets/{name}", abs_src_path=str(results / name)))
    return files
