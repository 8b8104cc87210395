# vimpipeline.simulate's per-step tip state and punctures. Truths: the files the same run writes
# (needle.csv's axial_force and tip_force columns, report.json's per_step.tip_cutting and punctures),
# and the cutting condition (while the tip cuts, its force is the cutting force; a puncture is the
# first cutting step after pressing, with the axial force of the step before and of that step).
import csv
import json

import numpy as np
import pytest

import vimpipeline as vp
from conftest import sphere_image, write_nrrd

CUTTING_FORCE = 0.6
SCENARIO = {
    "material": {"youngs_modulus": "image", "scale": 10.0, "poisson_ratio": 0.3},
    "mesh": {"nodes": 300, "lambda": 0.4},
    "boundary_conditions": [{"type": "fixed", "region": {"box_face": "z_min"}}],
    "needle": {"entry": [9.5, 9.5, 19.0], "direction": [0, 0, -1], "depth": 10.0, "steps": 20,
               "diameter": 1.0, "cutting_force": CUTTING_FORCE,
               "friction": {"model": "stick-slip", "max_shear_per_length": 0.2}},
    "output": {"every": 0},
}


def test_punctures_and_tip_cutting_match_the_runs_files(tmp_path):
    write_nrrd(tmp_path / "ball.nrrd", sphere_image(n=20, radius=6.0), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), np.eye(3))
    (tmp_path / "scenario.yaml").write_text(json.dumps(SCENARIO))
    result = vp.simulate(str(tmp_path / "ball.nrrd"), str(tmp_path / "scenario.yaml"), max_iterations=6)
    result.write(tmp_path / "out")
    needle = result.needles[0]
    rows = list(csv.DictReader(open(tmp_path / "out" / "needle.csv")))
    report = json.loads((tmp_path / "out" / "report.json").read_text())["simulation"]["needles"][0]
    depth_key = next(k for k in rows[0] if k.startswith("depth"))
    depth = np.array([float(r[depth_key]) for r in rows])
    axial = np.array([float(r["axial_force"]) for r in rows])
    tip = np.array([float(r["tip_force"]) for r in rows])

    cutting = needle["tip_cutting"]
    assert cutting.dtype == bool and cutting.shape == (len(rows),)
    assert list(cutting.astype(int)) == report["per_step"]["tip_cutting"]
    assert cutting.any() and not cutting[0]
    assert np.allclose(tip[cutting], CUTTING_FORCE, rtol=1e-6)  # the law holds a cutting tip at F_c
    assert (tip[~cutting] <= CUTTING_FORCE * (1 + 1e-9)).all()

    punctures = needle["punctures"]
    assert punctures == report["punctures"]
    assert len(punctures) >= 1
    starts = [k for k in range(1, len(rows)) if cutting[k] and not cutting[k - 1]]
    assert len(starts) == len(punctures)
    for k, p in zip(starts, punctures):
        assert p["depth"] == pytest.approx(depth[k], rel=1e-6)
        assert p["force_before"] == pytest.approx(axial[k - 1], rel=1e-5, abs=1e-9)
        assert p["force_after"] == pytest.approx(axial[k], rel=1e-5, abs=1e-9)
