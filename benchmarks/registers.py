"""Registers, stack and spills per thread of warpdyn's main CUDA kernels, compiled without a GPU.

    python benchmarks/registers.py --ptxas PATH [--arch 90] [--dtypes float32,float64] [--nvdisasm PATH]

For the seed's ergoCub legs (12 joints, 13 links, 32 points, flat terrain): the fused Euler step (keeping the
joint transforms, and rebuilding them: kernels/fused_step.py; also with its records in the shared memory of
blocks of 64 threads, as a GPU runs it for many environments: whole in float32, without c_i in float64), ABA,
RNEA and CRBA. Warp writes each kernel's PTX (wp.compile_aot_module, no device needed); ptxas -v compiles it
for sm_ARCH and reports each kernel's registers, stack frame and spill bytes; with --nvdisasm, the number of
SASS instructions too. PATH: a ptxas that reads Warp's PTX (Warp 1.19 writes PTX 9.4: CUDA 13.0's ptxas
refuses it, 13.5's from the pip package nvidia-cuda-nvcc reads it). These are the compiler's figures, not
times: speed is measured by revisions.py.
Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import pathlib
import re
import subprocess
import tempfile
import types

import numpy as np
import warp as wp

from common import seed_model
from warpdyn.engine import fused_layout
from warpdyn.engine import step as engine_step
from warpdyn.engine import warp_private
from warpdyn.kernels import aba, crba, rnea


def kernels(dtype: str) -> dict:
    """{name: Warp kernel} for the seed's legs in `dtype`."""
    model = seed_model(np.dtype(dtype), "cpu")
    plan = engine_step.plan(model)
    gpu_plan = types.SimpleNamespace(device=types.SimpleNamespace(is_cuda=True), scalar=plan.scalar, nL=plan.nL)  # as a GPU's
    s = model.scalar
    return {
        "fused step, transforms kept": plan.fused(True, 1),
        "fused step, transforms rebuilt": plan.fused(False, 1),
        "fused step, transforms rebuilt, records in shared memory (blocks of 64)": plan.fused(False, 1, *fused_layout.shared_records(gpu_plan, 1, 64)),
        "ABA": aba.kernels(s, "tuned", False).aba,
        "RNEA": rnea.kernels(s, "tuned", False).rnea,
        "CRBA": crba.kernels(s, "tuned", False).crba,
    }


def compile_report(kernel, arch: int, ptxas: str, nvdisasm: str | None, folder: pathlib.Path) -> tuple:
    """(registers, stack bytes, spill store bytes, spill load bytes, SASS instructions or None) of the kernel's forward entry."""
    wp.compile_aot_module(warp_private.kernel_module(kernel), arch=arch, module_dir=str(folder), use_ptx=True)
    ptx = next(folder.glob("*.ptx"))
    clean = folder / "module.ptx"
    clean.write_bytes(ptx.read_bytes().rstrip(b"\0"))  # Warp's PTX ends in a NUL, which ptxas refuses
    cubin = folder / "module.cubin"
    done = subprocess.run([ptxas, f"-arch=sm_{arch}", "-v", "-o", str(cubin), str(clean)], capture_output=True, text=True, check=True)
    entry = f"{kernel.get_mangled_name()}_cuda_kernel_forward"
    lines = done.stderr.split("Compiling entry function")
    report = next(chunk for chunk in lines if entry in chunk.splitlines()[0])
    numbers = [int(re.search(pattern, report).group(1)) for pattern in (r"Used (\d+) registers", r"(\d+) bytes stack frame", r"(\d+) bytes spill stores", r"(\d+) bytes spill loads")]
    sass = None
    if nvdisasm:
        listing = subprocess.run([nvdisasm, "-c", str(cubin)], capture_output=True, text=True, check=True).stdout
        body = listing.split(f".text.{entry}:", 1)[1].split(".section", 1)[0]  # the entry's own section
        sass = sum(1 for line in body.splitlines() if re.match(r"\s*/\*[0-9a-f]{4,}\*/\s+\S.*;", line))
    return (*numbers, sass)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--ptxas", required=True)
    parser.add_argument("--nvdisasm")
    parser.add_argument("--arch", type=int, default=90)
    parser.add_argument("--dtypes", default="float32,float64")
    args = parser.parse_args()
    wp.config.quiet = True
    print(f"sm_{args.arch}; {subprocess.run([args.ptxas, '--version'], capture_output=True, text=True).stdout.strip().splitlines()[-1]}; warp-lang {wp.config.version}")
    print()
    print("| kernel | dtype | registers | stack [B] | spill stores [B] | spill loads [B] | SASS instructions |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    for dtype in args.dtypes.split(","):
        for name, kernel in kernels(dtype).items():
            with tempfile.TemporaryDirectory(prefix="warpdyn-registers-") as folder:
                r, stack, stores, loads, sass = compile_report(kernel, args.arch, args.ptxas, args.nvdisasm, pathlib.Path(folder))
            print(f"| {name} | {dtype} | {r} | {stack} | {stores} | {loads} | {'' if sass is None else sass} |")


if __name__ == "__main__":
    main()
