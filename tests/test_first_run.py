"""What a new user sees on a first run: Warp kept quiet by warpdyn, and one notice while kernels compile.

Each case runs in a fresh interpreter (Warp is initialised once per process). The compile notice needs a
compilation: the first case points Warp at an empty kernel cache (tmp_path) and lowers the notice's delay
to 0 s, so that it must appear; the second reuses that cache with the default delay (1 s), where loading
takes milliseconds, so that it must not.
"""

import os
import subprocess
import sys

from robots import TEST_DEVICE

SCRIPT = """
import sys
import numpy as np
import warp as wp
wp.config.kernel_cache_dir = sys.argv[1]
import warpdyn as wd
import warpdyn.engine.loading
warpdyn.engine.loading.NOTICE_AFTER = float(sys.argv[2])
model = wd.model.Model.build_from_model_description(
    '<robot name="r"><link name="a"><inertial><mass value="1"/>'
    '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>', device=sys.argv[3])
data = wd.data.Data.build(model)
print("ran", wd.model.free_floating_mass_matrix(model, data).numpy()[0, 0])
"""


def _run(cache, delay, **env):
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(cache), str(delay), TEST_DEVICE],
        capture_output=True,
        text=True,
        env=dict(os.environ, **env),
        cwd=cache,  # the installed warpdyn, not a source tree's
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout, proc.stderr


def test_quiet_by_default_with_one_compile_notice(tmp_path):
    out, err = _run(tmp_path, 0.0, WARPDYN_VERBOSE="0")
    assert "ran 1.0" in out
    assert "Warp 1." not in out + err and "load on device" not in out + err  # no banner, no module lines
    assert err.count(f"warpdyn: compiling Warp kernels for device '{TEST_DEVICE}'") == 1  # once, however many modules
    assert str(tmp_path) in err  # where the compiled kernels are cached
    out, err = _run(tmp_path, 1.0, WARPDYN_VERBOSE="0")  # cached now: loading takes milliseconds
    assert "ran 1.0" in out and "compiling" not in err


def test_verbose_brings_warps_messages_back(tmp_path):
    out, err = _run(tmp_path, 1.0, WARPDYN_VERBOSE="1")
    assert "Warp 1." in out + err and f"load on device '{TEST_DEVICE}'" in out + err
