"""warpdyn's global settings, read when arrays are allocated and kernels launched (as `warp.config`).

- `env_fastest`: the physical layout of per-environment arrays (see warpdyn.arrays): None chooses by
  device (environment-fastest on GPUs, environment-major on the CPU), True or False forces one. Arrays
  already allocated keep their layout; every layout gives the same results.
- `fill_outputs_with_nan`: a debugging aid: fill every output with NaN before a kernel writes it, so an
  entry a kernel fails to write shows (the test suite sets it).
- `cuda_launch`: CUDA settings by kernel name ("aba", "rnea", "crba"): (threads per block, register cap per
  thread). Missing: Warp's default block (256) and each kernel module's MAX_REGISTERS; a cap of None: the
  compiler's choice. benchmarks/dynamics.py --sweep measures them.
"""

from __future__ import annotations

env_fastest: bool | None = None
fill_outputs_with_nan: bool = False
cuda_launch: dict[str, tuple[int | None, int | None | str]] = {}
