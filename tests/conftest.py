"""Shared test set-up: Warp quiet, on the device WARPDYN_TEST_DEVICE names (default: the CPU, e.g.
`WARPDYN_TEST_DEVICE=cuda:0 python -m pytest`); outputs filled with NaN so unwritten entries fail; the
`dtype` and `layout` fixtures."""

import os
import sys
import pathlib

import numpy as np
import pytest
import warp as wp

sys.path.insert(0, str(pathlib.Path(__file__).parent))

wp.config.quiet = True
wp.config.log_level = wp.LOG_WARNING
wp.init()
wp.set_device(os.environ.get("WARPDYN_TEST_DEVICE", "cpu"))  # robots.TEST_DEVICE

import warpdyn  # noqa: E402

warpdyn.config.fill_outputs_with_nan = True

DTYPES = [np.float64, np.float32]


@pytest.fixture(params=DTYPES, ids=lambda d: np.dtype(d).name)
def dtype(request):
    return request.param


@pytest.fixture(params=[None, True], ids=["device_layout", "env_fastest_layout"])
def layout(request, monkeypatch):
    """Both physical layouts of per-environment arrays (warpdyn.arrays): the device's default (env-major
    on the CPU) and env-fastest (the GPU's), so that a CPU run covers both."""
    monkeypatch.setattr(warpdyn.config, "env_fastest", request.param)
    return request.param
