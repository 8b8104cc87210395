# The installed module: `cmake --install` into a temporary prefix puts vimpipeline under
# lib/python3/dist-packages. Truth: the build tree's module (the same mesh from the installed copy).
import os
import subprocess
import sys

import numpy as np
import pytest

import vimpipeline as vp

SCRIPT = """
import numpy as np, vimpipeline
z, y, x = np.mgrid[:10, :10, :10]
m = vimpipeline.mesh((x + 2 * y + 3 * z).astype(float), nodes=60)
np.save("points.npy", m.points)
print(vimpipeline.__file__)
"""


def test_installed_module_imports_and_meshes(tmp_path):
    build = os.environ.get("VIM_BUILD_DIR")
    if not build:
        pytest.skip("VIM_BUILD_DIR (the CMake build tree) is not set")
    prefix = tmp_path / "prefix"
    subprocess.run(["cmake", "--install", build, "--prefix", str(prefix)], check=True, capture_output=True)
    site = prefix / "lib" / "python3" / "dist-packages"
    env = dict(os.environ, PYTHONPATH=str(site))
    r = subprocess.run([sys.executable, "-c", SCRIPT], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().startswith(str(site))
    z, y, x = np.mgrid[:10, :10, :10]
    expected = vp.mesh((x + 2 * y + 3 * z).astype(float), nodes=60).points
    assert np.array_equal(np.load(tmp_path / "points.npy"), expected)
