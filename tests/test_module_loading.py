"""Loading kernel modules (warpdyn/engine/loading.py): a model's first step compiles the modules its launches
need in one parallel load (the launch list's, warpdyn.config.fused_step off: the fused step is one module), each with warpdyn.config.fuse_fp and, on a GPU, warpdyn.config.cuda_block_dim's
block size (the one its launches use), without the backward pass when no tape records, and later steps load
nothing. In a fresh interpreter with an empty kernel cache (the test's own process has loaded everything
already)."""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd

SCRIPT = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    import warp as wp
    wp.config.kernel_cache_dir = sys.argv[1]
    wp.config.quiet = True
    import warpdyn as wd
    wd.config.fuse_fp = False
    wd.config.fused_step = False
    calls = []
    force_load = wp.force_load
    def spy(device=None, modules=None, block_dim=None, max_workers=None):
        calls.append({"block_dim": block_dim, "modules": len(modules), "workers": max_workers, "fuse_fp": sorted({m.options["fuse_fp"] for m in modules}),
                      "backward": sorted({m.options["enable_backward"] for m in modules})})
        return force_load(device=device, modules=modules, block_dim=block_dim, max_workers=max_workers)
    wp.force_load = spy
    from warpdyn.engine import loading
    device = sys.argv[2]
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), device=device)
    legs = wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)
    data = wd.data.Data.build(legs, base_position=(0.0, 0.0, 0.8))
    first, loaded = len(calls), len(loading._loaded)
    data = wd.model.step(legs, data)
    during, grown = calls[first:], len(loading._loaded) - loaded
    data = wd.model.step(legs, data)
    print(json.dumps({"first_step": during, "modules_loaded": grown, "second_step": len(loading._loaded) - loaded - grown,
                      "finite": bool(np.isfinite(data.joint_positions.numpy()).all())}))
    """
)


def test_a_first_step_loads_its_modules_at_once(tmp_path):
    device = str(wp.get_device())
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(tmp_path / "cache"), device],
        capture_output=True, text=True, timeout=600, env={**os.environ, "PYTHONWARNINGS": "ignore"}, cwd=tmp_path,
    )  # fmt: skip (cwd: the warpdyn this process imports, not a source tree in the working directory)
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    loads = report["first_step"]
    assert len(loads) == 1, loads  # one parallel load ...
    assert loads[0]["modules"] == report["modules_loaded"] >= 2, report  # ... of every module the step loaded
    assert loads[0]["workers"] == min(loads[0]["modules"], len(os.sched_getaffinity(0)))
    assert loads[0]["fuse_fp"] == [False]  # warpdyn.config.fuse_fp reached every module
    assert loads[0]["backward"] == [False]  # no tape records the step: forward-only twins (loading.for_launch)
    assert loads[0]["block_dim"] == (wd.config.cuda_block_dim if wp.get_device(device).is_cuda else None)
    assert report["second_step"] == 0 and report["finite"]


@pytest.mark.parametrize("value", [0, 48, 2048, 64.0, "64", None])
def test_cuda_block_dim_must_be_a_multiple_of_32_up_to_1024(value):
    before = wd.config.cuda_block_dim
    with pytest.raises(ValueError, match="cuda_block_dim"):
        wd.config.cuda_block_dim = value
    assert wd.config.cuda_block_dim == before


def test_the_block_size_of_a_launch():
    """On a GPU a launch that names no block size gets warpdyn.config.cuda_block_dim; on the CPU none (Warp would
    compile a CPU module once per block size it is given) but for blocks of threads where Warp runs them there
    (wp.config.enable_cpu_blocks: the fused step's lanes)."""
    from warpdyn.engine.loading import block_size

    cuda = type("Device", (), {"is_cuda": True})()
    cpu = type("Device", (), {"is_cuda": False})()
    before = wd.config.cuda_block_dim
    try:
        wd.config.cuda_block_dim = 128
        assert block_size(None, cuda) == 128
        assert block_size(256, cuda) == 256
        assert block_size(None, cpu) is None and block_size(256, cpu) is None
        wp.config.enable_cpu_blocks = True
        assert block_size(None, cpu) is None and block_size(1, cpu) is None and block_size(2, cpu) == 2
    finally:
        wd.config.cuda_block_dim = before
        wp.config.enable_cpu_blocks = False


def test_launches_that_no_tape_records_run_forward_only_twins():
    """Outside a tape a launch runs its kernel's twin without the backward pass (one twin per kernel); under a
    tape, and for an adjoint, the kernel itself. Both compute the same numbers: ABA with and without a tape."""
    from warpdyn.engine.loading import for_launch
    from warpdyn.kernels.aba import kernels as aba_kernels

    kernel = aba_kernels(wp.float64, "tuned", False).aba
    twin = for_launch(kernel)
    assert twin is not kernel and twin is for_launch(kernel) and twin.key == kernel.key
    assert twin.module.options["enable_backward"] is False and kernel.module.options["enable_backward"] is True
    assert twin.options == kernel.options  # the register cap travels
    assert for_launch(kernel, adjoint=True) is kernel
    with wp.Tape():
        assert for_launch(kernel) is kernel

    model = robots.ergocub_seed_with_points(np.float64)
    data = wd.data.random_model_data(model, num_envs=5, key=3)
    tau = np.random.default_rng(3).normal(size=(5, model.dofs()))
    plain = [a.numpy() for a in wd.model.forward_dynamics_aba(model, data, joint_forces=tau)]
    taped = wd.data.random_model_data(model, num_envs=5, key=3, requires_grad=True)
    with wp.Tape():
        recorded = [a.numpy() for a in wd.model.forward_dynamics_aba(model, taped, joint_forces=tau)]
    for a, b in zip(plain, recorded):
        if robots.TEST_DEVICE == "cpu":
            np.testing.assert_array_equal(a, b)
        else:
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(a).max()))
