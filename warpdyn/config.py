"""warpdyn's global settings, read when arrays are allocated and kernels launched (as `warp.config`).

- `env_fastest`: the physical layout of per-environment arrays (see warpdyn.arrays): None chooses by
  device (environment-fastest on GPUs, environment-major on the CPU), True or False forces one. Arrays
  already allocated keep their layout; every layout gives the same results.
- `fill_outputs_with_nan`: a debugging aid: fill every output with NaN before a kernel writes it, so an
  entry a kernel fails to write shows (the test suite sets it).
- `cuda_block_dim`: threads per CUDA block of every launch that does not set its own (`cuda_launch`): 64, so
  that a few thousand environments (one thread each) spread over all of a GPU's multiprocessors instead of
  a few of them (an H100 has 132: at N = 4096, blocks of 256 fill 16). A kernel module is compiled once per
  block size: a change compiles the kernels again. benchmarks/step.py --block-dims measures it.
- `cuda_launch`: CUDA settings by kernel name ("aba", "rnea", "crba"): (threads per block, register cap per
  thread). Missing: `cuda_block_dim` and each kernel module's MAX_REGISTERS; a cap of None: the
  compiler's choice. benchmarks/dynamics.py --sweep measures them.
- `fused_step`: steps without gradients (outside a tape, nothing requiring them) with the semi-implicit Euler
  integrators and no gravity compensation run as one fused kernel after the joint forces
  (kernels/fused_step.py) instead of five to seven (True, the default), or as the launch list a tape
  records (False). Both give the same numbers to rounding; launch lists and graphs already built keep theirs.
  benchmarks/step.py --fused measures both.
- `fused_lanes`: the threads per environment of the fused step: None (the default) chooses by device and N
  (warpdyn.engine.fused_layout.fused_lanes: on a GPU, for few environments, one thread per group of the model's
  subtrees below the base, which walk them side by side; else one), True forces the groups (on the CPU only
  with wp.config.enable_cpu_blocks, without which Warp runs no blocks of threads there: a step raises), False
  one thread. All give the same numbers to rounding. benchmarks/step.py --fused one,groups measures them.
- `fused_shared_records`: where the fused step keeps what its passes hand to each other per link, on a GPU
  with one thread per environment: in the CUDA block's shared memory where it fits (True, the default;
  warpdyn.engine.fused_layout.shared_records), or in each thread's local memory (False, as on the CPU). The
  same arithmetic, the same numbers; launch lists and graphs already built keep theirs. benchmarks/step.py
  --fused on,local measures both.
- `fuse_fp`: floating-point contraction (fused multiply-adds) when kernels are compiled: True, Warp's
  default, or False: each kernel then rounds every operation it writes, so the forward code a backward
  kernel replays gives its forward's values bit for bit and repeated backward passes of one tape agree on
  a GPU (with True they differ in the last bits there). Applied as each kernel module is first loaded
  (warpdyn.engine.loading): set it before the first launch; an assignment of another value after it
  raises a RuntimeError (recorded launches and captured graphs hold the compiled kernels).
  benchmarks/reproducibility.py measures both.
"""

from __future__ import annotations

import sys
import threading
import types

env_fastest: bool | None = None
fill_outputs_with_nan: bool = False
cuda_block_dim: int = 64
cuda_launch: dict[str, tuple[int | None, int | None | str]] = {}
fused_step: bool = True
fused_lanes: bool | None = None
fused_shared_records: bool = True
fuse_fp: bool = True


class _Config(types.ModuleType):
    """Validates assignments: fuse_fp is a bool, fixed once kernels are loaded (`loaded_fuse_fp`)."""

    loaded_fuse_fp: bool | None = None
    """fuse_fp as the first kernel module was loaded with it (set by warpdyn.engine.loading under fuse_fp_lock)."""

    fuse_fp_lock = threading.Lock()
    """Held while fuse_fp is assigned and while the first load fixes it."""

    def __setattr__(self, name, value):
        if name == "cuda_block_dim" and not (type(value) is int and 32 <= value <= 1024 and value % 32 == 0):
            raise ValueError(f"warpdyn.config.cuda_block_dim must be a multiple of 32 from 32 to 1024, got {value!r}")
        if name == "fused_step" and not isinstance(value, bool):
            raise TypeError(f"warpdyn.config.fused_step must be True or False, got {value!r}")
        if name == "fused_lanes" and not (value is None or isinstance(value, bool)):
            raise TypeError(f"warpdyn.config.fused_lanes must be None, True or False, got {value!r}")
        if name == "fused_shared_records" and not isinstance(value, bool):
            raise TypeError(f"warpdyn.config.fused_shared_records must be True or False, got {value!r}")
        if name != "fuse_fp":
            super().__setattr__(name, value)
            return
        if not isinstance(value, bool):
            raise TypeError(f"warpdyn.config.fuse_fp must be True or False, got {value!r}")
        with self.fuse_fp_lock:
            if self.loaded_fuse_fp is not None and value is not self.loaded_fuse_fp:
                raise RuntimeError(
                    f"warpdyn.config.fuse_fp = {value}: kernels are loaded with {self.loaded_fuse_fp}; set it before the "
                    "first launch (recorded launches and captured graphs hold the compiled kernels)"
                )
            super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Config
