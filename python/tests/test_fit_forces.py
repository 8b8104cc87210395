# vimpipeline.fit_forces: a curve simulated with hidden needle values (vimpipeline.simulate) is fitted
# from other starting values; the hidden values come back, and OUT holds the CLI's fit files.
import json
import os

import numpy as np
import pytest

import vimpipeline as vp
from conftest import sphere_image, write_nrrd


def scenario(cutting_force, limit):
    return {
        "material": {"youngs_modulus": "image", "scale": 10.0, "poisson_ratio": 0.3},
        "mesh": {"nodes": 300, "lambda": 0.4},
        "boundary_conditions": [{"type": "fixed", "region": {"box_face": "z_min"}}],
        "needle": {"entry": [9.5, 9.5, 19.0], "direction": [0, 0, -1], "depth": 10.0, "steps": 10,
                   "diameter": 1.0, "cutting_force": cutting_force,
                   "friction": {"model": "stick-slip", "max_shear_per_length": limit}},
        "output": {"every": 0},
    }


def test_fit_forces_recovers_hidden_values_and_writes_the_fit_files(tmp_path):
    write_nrrd(tmp_path / "ball.nrrd", sphere_image(n=20, radius=6.0), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), np.eye(3))
    hidden = (0.6, 0.2)
    truth = vp.simulate(str(tmp_path / "ball.nrrd"), scenario(*hidden), max_iterations=6)
    depth, force = list(truth.depths)[1:], list(truth.forces)[1:]
    with open(tmp_path / "measured.csv", "w") as f:
        f.write("depth,force\n")
        for d, F in zip(depth, force):
            f.write("%.17g,%.17g\n" % (d, F))
    (tmp_path / "start.yaml").write_text(json.dumps(scenario(1.2, 0.1)))
    fit = vp.fit_forces(tmp_path / "ball.nrrd", tmp_path / "start.yaml", tmp_path / "measured.csv",
                        tmp_path / "out", max_iterations=6)
    values = {p["name"]: p["value"] for p in fit["parameters"]}
    assert values["needle.cutting_force"] == pytest.approx(hidden[0], rel=0.01)
    assert values["needle.friction.max_shear_per_length"] == pytest.approx(hidden[1], rel=0.01)
    for name in ("fit.json", "fitted.yaml", "figures/force_fit.png", "needle.csv", "report.json"):
        assert os.path.exists(tmp_path / "out" / name), name
    with pytest.raises(ValueError, match="bad.csv"):
        (tmp_path / "bad.csv").write_text("depth,force\n2,1\n1,2\n")
        vp.fit_forces(tmp_path / "ball.nrrd", tmp_path / "start.yaml", tmp_path / "bad.csv", tmp_path / "out2")
