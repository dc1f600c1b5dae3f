"""The README as a user reads it: its two set-up commands, and every Python block run as the script it is.

Each ```python block of README.md runs in a fresh interpreter (the default Warp device: the CPU here, the
GPU where the suite runs on one) and must exit 0: a block that needs a name it does not define, or an API
that changed, fails here. The set-up commands are checked for what the README promises (the second is the
command CI runs, .ci/run).
"""

import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
PYTHON_BLOCKS = re.findall(r"^```python\n(.*?)^```$", README, flags=re.S | re.M)
SHELL_BLOCKS = re.findall(r"^```shell\n(.*?)^```$", README, flags=re.S | re.M)


def test_the_readme_has_its_blocks():
    """At least the two set-up commands and the taste of the API: the façade, a simulation, a gradient (a regex
    that found nothing would make the tests below vacuous)."""
    assert len(SHELL_BLOCKS) >= 2 and len(PYTHON_BLOCKS) >= 3


def test_setup_commands():
    """Command 1 installs warpdyn alone and runs the tour; command 2 installs the test extra and runs pytest."""
    install, test = SHELL_BLOCKS[0].strip(), SHELL_BLOCKS[1].strip()
    assert "pip install -e ." in install and install.endswith("python examples/tour.py")
    assert 'pip install -e ".[test]"' in test and test.endswith("python -m pytest")


@pytest.mark.parametrize("index", range(len(PYTHON_BLOCKS)))
def test_python_block_runs(index, tmp_path):
    """README's Python block `index` runs as a script and exits 0."""
    script = tmp_path / f"readme_block_{index}.py"
    script.write_text(PYTHON_BLOCKS[index], encoding="utf-8")
    env = dict(os.environ, PYTHONIOENCODING="utf-8")
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600)
    assert proc.returncode == 0, f"README block {index}:\n{PYTHON_BLOCKS[index]}\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}"
