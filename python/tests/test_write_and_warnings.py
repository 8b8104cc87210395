# Result.write on a failure, and the CLI's warnings in Mesh.warnings / Result.warnings. Truths: the file
# system before and after a write that fails part-way (nothing of the result left, no temporary folder),
# and the CLI's report.json "warnings" for the same image file and scenario file.
import json
import os

import numpy as np
import pytest

import vimpipeline as vp
from conftest import run_cli, write_nrrd

SCENARIO = {
    "material": {"youngs_modulus": 10.0, "poisson_ratio": 0.45},
    "boundary_conditions": [{"type": "fixed", "region": {"box_face": "z_min"}}],
    "needle": {"entry": [4.5, 4.5, 9.0], "direction": [0, 0, -1], "depth": 3.0, "steps": 2, "diameter": 1.0,
               "friction": {"model": "stick"}},
}


@pytest.fixture(scope="module")
def outlier_image(tmp_path_factory):
    """A 10³ image of ones but for one voxel of 1e20: element means lose their accuracy."""
    d = tmp_path_factory.mktemp("warnings")
    array = np.ones((10, 10, 10)) + 0.01 * np.arange(10)
    array[0, 0, 0] = 1e20
    write_nrrd(d / "outlier.nrrd", array, (1.0,) * 3, (0.0,) * 3, np.eye(3))
    (d / "locking.yaml").write_text(json.dumps(SCENARIO))
    return d


def test_warnings_are_the_cli_warnings(cli, outlier_image):
    # Truth: report.json "warnings" of the CLI for the same image (values accuracy) and the same scenario
    # (P1 locking at poisson_ratio >= 0.4).
    d = outlier_image
    run_cli(cli, d / "outlier.nrrd", "--nodes", 100, "--max-iterations", 2, "--export", "none", "-q",
            "--out", d / "mesh")
    expected = json.loads((d / "mesh" / "report.json").read_text())["warnings"]
    mesh = vp.mesh(str(d / "outlier.nrrd"), nodes=100, max_iterations=2)
    assert mesh.warnings == expected and "accurate only to about" in expected[0]
    run_cli(cli, d / "outlier.nrrd", "--simulate", d / "locking.yaml", "--nodes", 100, "--max-iterations", 2, "-q",
            "--out", d / "simulate")
    expected = json.loads((d / "simulate" / "report.json").read_text())["warnings"]
    result = vp.simulate(str(d / "outlier.nrrd"), str(d / "locking.yaml"), nodes=100, max_iterations=2)
    assert result.warnings == expected and any("lock for poisson_ratio >= 0.4" in w for w in expected)
    assert vp.simulate(mesh, str(d / "locking.yaml")).warnings == expected  # on the mesh made above


def test_a_failed_write_leaves_nothing(tmp_path):
    # Truth: the folder listing before and after a write whose last staged file has gone missing.
    array = np.ones((10, 10, 10)) + 0.01 * np.arange(10)
    result = vp.simulate(array, dict(SCENARIO, material={"youngs_modulus": 10.0, "poisson_ratio": 0.3}),
                         nodes=100, max_iterations=2)
    os.remove(os.path.join(result._staging.name, result.files[-1]))
    with pytest.raises(FileNotFoundError):
        result.write(tmp_path / "new" / "out")
    assert os.listdir(tmp_path) == []
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "keep.txt").write_text("an earlier file")
    with pytest.raises(FileNotFoundError):
        result.write(tmp_path / "old", overwrite=True)
    assert os.listdir(tmp_path) == ["old"] and os.listdir(tmp_path / "old") == ["keep.txt"]
