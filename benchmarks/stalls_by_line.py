"""Nsight Compute's warp-stall samples of the fused step per line of kernels/fused_step.py.

    python benchmarks/stalls_by_line.py --ptxas PATH --nvdisasm PATH --dtype float64 --page PAGE.csv[.xz]
                                        [--against-dtype float32 --against-page PAGE32.csv[.xz]] [--arch 90]

PAGE is the SASS source page of one profiled launch of the fused step with its records in shared memory in
blocks of 64 (as a GPU runs the seed's legs for many environments), exported on the GPU's machine with
`ncu --set full --import-source yes -k regex:fused_euler_step --launch-skip 2 --launch-count 1 -o REPORT
python3 SCRIPT` (SCRIPT: any that steps the legs at a large N) and `ncu -i REPORT --page source --csv
--print-source sass`. Warp's kernels carry no line information for Python by default, so the page names SASS
addresses only. This script compiles the same kernel here (registers.py's, wp.compile_aot_module, ptxas
-lineinfo, nvdisasm -gi; no GPU needed), checks that its SASS is the page's instruction for instruction (the
same tree, the same ptxas as the driver's: else it stops), and charges each instruction's samples to the
outermost fused_step.py line its line information names. Prints a Markdown table per line that holds at least
0.4% of the samples: all samples, long-scoreboard (waits for global or local memory), wait (fixed-latency
dependencies); with --against-*, the same for a second dtype's page and the excess of the first over it.
"""

from __future__ import annotations

import argparse
import collections
import csv
import lzma
import pathlib
import re
import subprocess
import tempfile

import warp as wp
from registers import kernels
from warpdyn.engine import warp_private

KERNEL = "fused step, transforms rebuilt, records in shared memory (blocks of 64)"
SOURCE = pathlib.Path(__file__).resolve().parent.parent / "kernels" / "fused_step.py"
COLUMNS = ("Warp Stall Sampling (All Samples)", "stall_long_sb", "stall_wait")
OPCODE = re.compile(r"\s*/\*[0-9a-f]{4,}\*/\s+(?:@!?U?P\w+\s+)?([A-Z0-9_.]+)")
PAGE_OPCODE = re.compile(r"\s*(?:@!?U?P\w+\s+)?([A-Z0-9_.]+)")
LOCATION = re.compile(r'"([^"]+)", line (\d+)')


def lines_of_instructions(dtype: str, arch: int, ptxas: str, nvdisasm: str) -> list[tuple[str, int]]:
    """(opcode, outermost fused_step.py line or 0) of each SASS instruction of the kernel, in order."""
    wp.config.lineinfo = True
    kernel = kernels(dtype)[KERNEL]
    with tempfile.TemporaryDirectory(prefix="warpdyn-stalls-") as name:
        folder = pathlib.Path(name)
        wp.compile_aot_module(warp_private.kernel_module(kernel), arch=arch, module_dir=str(folder), use_ptx=True)
        clean = folder / "module.ptx"
        clean.write_bytes(next(folder.glob("*.sm*.ptx")).read_bytes().rstrip(b"\0"))  # Warp's PTX ends in a NUL
        cubin = folder / "module.cubin"
        subprocess.run([ptxas, f"-arch=sm_{arch}", "-lineinfo", "-o", str(cubin), str(clean)], check=True)
        listing = subprocess.run([nvdisasm, "-gi", "-c", str(cubin)], capture_output=True, text=True, check=True).stdout
    entry = f"{kernel.get_mangled_name()}_cuda_kernel_forward"
    body = listing.split(f".text.{entry}:", 1)[1].split(".section", 1)[0]
    found, pending, locations = [], [], []
    for text in body.splitlines():
        if "//##" in text:  # an instruction's line information comes before it, innermost call first
            pending.append(text)
            continue
        match = OPCODE.match(text)
        if not match:
            continue
        if pending:
            locations, pending = [(pathlib.Path(f).name, int(n)) for p in pending for f, n in LOCATION.findall(p)], []
        own = [n for f, n in locations if f == SOURCE.name]
        found.append((match.group(1), own[-1] if own else 0))
    return found


def samples_by_line(dtype: str, page: str, arch: int, ptxas: str, nvdisasm: str) -> dict[int, collections.Counter]:
    """{fused_step.py line: Counter of COLUMNS} from a SASS source page of the kernel in `dtype`."""
    opener = lzma.open if page.endswith(".xz") else open
    with opener(page, "rt") as file:
        rows = list(csv.reader(file))
    header = next(row for row in rows if "Address" in row and "Source" in row)
    data = [row for row in rows[rows.index(header) + 1 :] if len(row) >= len(header)]
    index = {name: header.index(name) for name in ("Source", *COLUMNS)}
    local = lines_of_instructions(dtype, arch, ptxas, nvdisasm)
    profiled = [PAGE_OPCODE.match(row[index["Source"]]).group(1) for row in data]
    if [op for op, _ in local] != profiled:
        raise SystemExit(
            f"{page}: its {len(profiled)} SASS instructions are not this tree's {len(local)} for {dtype}: profile this "
            "tree's kernel, and compile with the ptxas of the profiled machine's CUDA version"
        )
    by_line = collections.defaultdict(collections.Counter)
    for (_, line), row in zip(local, data):
        for name in COLUMNS:
            by_line[line][name] += int(row[index[name]] or 0)
    return by_line


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--ptxas", required=True)
    parser.add_argument("--nvdisasm", required=True)
    parser.add_argument("--arch", type=int, default=90)
    parser.add_argument("--dtype", required=True)
    parser.add_argument("--page", required=True)
    parser.add_argument("--against-dtype")
    parser.add_argument("--against-page")
    args = parser.parse_args()
    if (args.against_dtype is None) != (args.against_page is None):
        parser.error("--against-dtype and --against-page go together")
    wp.config.quiet = True
    first = samples_by_line(args.dtype, args.page, args.arch, args.ptxas, args.nvdisasm)
    second = samples_by_line(args.against_dtype, args.against_page, args.arch, args.ptxas, args.nvdisasm) if args.against_page else {}
    total = sum(c[COLUMNS[0]] for c in first.values())
    source = SOURCE.read_text().splitlines()
    print(f"{args.dtype}: {total} samples" + (f"; {args.against_dtype}: {sum(c[COLUMNS[0]] for c in second.values())}" if second else ""))
    print()
    names = "all | long scoreboard | wait"
    print(f"| line | {args.dtype} {names.replace(' | ', f' | {args.dtype} ')} |" + (f" {args.against_dtype} {names.replace(' | ', f' | {args.against_dtype} ')} | excess (all) |" if second else " % |") + " source |")
    print("| ---: | ---: | ---: | ---: | ---: |" + (" ---: | ---: | ---: |" if second else "") + " --- |")
    for line in sorted(set(first) | set(second)):
        a, b = first.get(line, collections.Counter()), second.get(line, collections.Counter())
        if max(a[COLUMNS[0]], b[COLUMNS[0]]) < 0.004 * total:
            continue
        text = source[line - 1].strip()[:80].replace("|", "\\|") if line else "(no fused_step.py line)"
        cells = [a[c] for c in COLUMNS] + ([b[c] for c in COLUMNS] + [a[COLUMNS[0]] - b[COLUMNS[0]]] if second else [f"{100 * a[COLUMNS[0]] / total:.1f}"])
        print(f"| {line} | " + " | ".join(str(c) for c in cells) + f" | `{text}` |")


if __name__ == "__main__":
    main()
