# vimpipeline.simulate. Truths: the CLI's files for the same image and scenario (byte for byte), its
# needle.csv, the P1 interpolation of the returned nodal displacements at the targets (recomputed here),
# and the boundary conditions (held nodes do not move; nothing moves at rest).
import csv
import json
import os
import re

import numpy as np
import pytest

import vimpipeline as vp
from conftest import run_cli, sphere_image, write_mha_2d, write_nrrd

SCENARIO = {
    "units": {"length": "mm", "modulus": "kPa"},
    "material": {"youngs_modulus": "image", "poisson_ratio": 0.3},
    "mesh": {"nodes": 300, "lambda": 0.4},
    "boundary_conditions": [{"type": "fixed", "region": {"box_face": "z_min"}}],
    "needle": {"entry": [9.5, 9.5, 19.0], "direction": [0, 0, -1], "depth": 8.0, "steps": 4, "diameter": 1.0,
               "model": "kinematic", "friction": {"model": "stick"}},
    # Near the held face z_min: the needle's near-field reading of targets (docs/needle-model.md §6)
    # leaves tissue next to held tissue at the model's value, the P1 interpolation checked below.
    "targets": [{"name": "below", "position": [9.5, 7.0, 1.0]}, {"name": "side", "position": [4.0, 9.5, 0.5]}],
    "output": {"every": 1, "fields": ["displacement", "von_mises"]},
}


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    d = tmp_path_factory.mktemp("simulate")
    write_nrrd(d / "ball.nrrd", sphere_image(n=20, radius=6.0), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), np.eye(3))
    (d / "scenario.yaml").write_text(json.dumps(SCENARIO))  # JSON is YAML
    result = vp.simulate(str(d / "ball.nrrd"), str(d / "scenario.yaml"), max_iterations=6)
    return d, result


def test_result_writes_the_cli_files(cli, case):
    # Truth: the CLI's output folder for the same image, scenario and options, file by file.
    d, result = case
    run_cli(cli, d / "ball.nrrd", "--simulate", d / "scenario.yaml", "--max-iterations", 6, "-q", "--out", d / "cli")
    result.write(d / "py")
    listing = lambda root: sorted(os.path.relpath(os.path.join(p, f), root) for p, _, fs in os.walk(root) for f in fs)
    assert listing(d / "py") == listing(d / "cli")
    for rel in listing(d / "cli"):
        if rel != "report.json":  # timings and the tool's name differ
            assert (d / "py" / rel).read_bytes() == (d / "cli" / rel).read_bytes(), rel
    cli_report = json.loads((d / "cli" / "report.json").read_text())
    for key in ("mesh", "segmentation", "exports"):
        assert result.report.get(key) == cli_report.get(key), key
    for ours, theirs in zip(result.report["simulation"]["needles"], cli_report["simulation"]["needles"]):
        assert ours["final"] == theirs["final"]
    energies = lambda r: [h["E"] for h in r["optimization"]["history"]]
    assert energies(result.report) == energies(cli_report)
    with pytest.raises(ValueError, match="not empty"):
        result.write(d / "cli")


def test_arrays_match_needle_csv(case):
    # Truth: needle.csv as written by the simulation (the CLI's file, checked equal above).
    d, result = case
    result.write(d / "csv")
    rows = list(csv.DictReader(open(d / "csv" / "needle.csv")))
    assert len(rows) == len(result.depths) == SCENARIO["needle"]["steps"] + 1
    depth_key = next(k for k in rows[0] if k.startswith("depth"))
    axial_key = next(k for k in rows[0] if k.startswith("axial"))
    assert np.allclose([float(r[depth_key]) for r in rows], result.depths, rtol=1e-6, atol=1e-9)
    assert np.allclose([float(r[axial_key]) for r in rows], result.forces, rtol=1e-5, atol=1e-9)
    assert result.depths[-1] == pytest.approx(8.0)


def test_force_parts_match_needle_csv_and_sum_to_the_axial_force(case):
    # Truths: needle.csv's friction_force, tip_force and max_strain columns, and the decomposition
    # axial = shaft friction + tip (each is summed separately in the simulation).
    d, result = case
    result.write(d / "parts")
    rows = list(csv.DictReader(open(d / "parts" / "needle.csv")))
    needle = result.needles[0]
    for key in ("friction_force", "tip_force", "max_strain"):
        assert needle[key].shape == (len(rows),), key
        assert np.allclose([float(r[key]) for r in rows], needle[key], rtol=1e-5, atol=1e-9), key
    assert np.allclose(needle["friction_force"] + needle["tip_force"], needle["axial_force"], rtol=1e-9, atol=1e-9)
    assert needle["friction_force"][-1] > 0.0  # the stuck shaft carries force at the end
    assert needle["max_strain"][0] == 0.0 and needle["max_strain"][-1] > 0.0


def test_targets_are_the_p1_interpolation_of_the_displacements(case):
    # Truth: barycentric (P1) interpolation of the returned nodal displacements at each target.
    _, result = case
    mesh, u = result.mesh, result.displacements
    steps, nodes, dim = u.shape
    assert (steps, nodes, dim) == (len(result.depths), len(mesh.points), 3)
    for t, target in enumerate(SCENARIO["targets"]):
        x = np.asarray(target["position"], dtype=float)
        for c, cell in enumerate(mesh.cells):
            p = mesh.points[cell]
            lam = np.linalg.solve((p[1:] - p[0]).T, x - p[0])
            bary = np.concatenate([[1 - lam.sum()], lam])
            if (bary >= -1e-12).all():
                break
        for s in range(steps):
            expected = bary @ u[s, cell]
            assert np.allclose(result.target_displacements[s, t], expected, rtol=1e-8, atol=1e-12)
    assert np.linalg.norm(result.target_displacements[-1, 0]) > 0


def test_boundary_conditions_hold(case):
    # Truths: nodes on the fixed face z_min do not move; at rest (step 0) nothing moves; the tissue at
    # the tip is pushed along the needle (-z); the modulus is the element mean (clamp-free scenario).
    _, result = case
    mesh, u = result.mesh, result.displacements
    fixed = np.isclose(mesh.points[:, 2], -0.5)
    assert fixed.sum() > 4 and np.abs(u[:, fixed]).max() == 0.0
    assert np.abs(u[0]).max() < 1e-12
    tip = np.array([9.5, 9.5, 11.0])
    nearest = np.argmin(np.linalg.norm(mesh.points - tip, axis=1))
    assert u[-1, nearest, 2] < 0
    assert np.array_equal(mesh.cell_data["youngs_modulus"], mesh.cell_data["mean"])


def test_scenario_dict_and_premeshed_mesh_give_the_same_result(case):
    # Truth: the run from the scenario file (same mesh: the scenario's nodes and lambda).
    d, result = case
    from_dict = vp.simulate(vp.read_image(d / "ball.nrrd"), SCENARIO, max_iterations=6)
    assert np.array_equal(from_dict.forces, result.forces)
    premeshed = vp.mesh(str(d / "ball.nrrd"), nodes=300, lam=0.4, max_iterations=6)
    from_mesh = vp.simulate(premeshed, SCENARIO)
    assert np.array_equal(from_mesh.displacements, result.displacements)


def test_bad_scenario_raises_value_error_with_the_cli_message(cli, case):
    # Truth: the CLI's error line for the same scenario file.
    d, _ = case
    bad = dict(SCENARIO, needle=dict(SCENARIO["needle"], depth=-1.0))
    (d / "bad.yaml").write_text(json.dumps(bad))
    r = run_cli(cli, d / "ball.nrrd", "--simulate", d / "bad.yaml", "--out", d / "bad", check=False)
    assert r.returncode == 1
    message = re.match(r"vim-pipeline: error: (.*)", r.stderr.strip().splitlines()[-1]).group(1)
    with pytest.raises(ValueError) as e:
        vp.simulate(str(d / "ball.nrrd"), str(d / "bad.yaml"))
    assert str(e.value) == message
    with pytest.raises(ValueError, match="depth"):
        vp.simulate(str(d / "ball.nrrd"), bad)


SCENARIO_2D = {
    "material": {"youngs_modulus": "image", "poisson_ratio": 0.3},
    "mesh": {"nodes": 200},
    "boundary_conditions": [{"type": "fixed", "region": {"box_face": "y_min"}}],
    "needle": {"entry": [14.5, 23.0], "direction": [0, -1], "depth": 8.0, "steps": 4, "diameter": 1.0,
               "friction": {"model": "stick"}},
    "targets": [{"name": "below", "position": [14.5, 10.0]}],
}


@pytest.mark.parametrize("dim, degree", [(3, 2), (2, 1), (2, 2)])
def test_p2_and_2d_runs_equal_the_cli(cli, tmp_path, dim, degree):
    # Truth: the CLI's needle.csv and last step file for the same image, scenario and --degree.
    if dim == 3:
        write_nrrd(tmp_path / "img.nrrd", sphere_image(n=20, radius=6.0), (1.0,) * 3, (0.0,) * 3, np.eye(3))
        image, scenario = tmp_path / "img.nrrd", SCENARIO
    else:
        y, x = np.mgrid[:24, :30]
        write_mha_2d(tmp_path / "img.mha", np.where((x - 14) ** 2 + (y - 8) ** 2 < 25, 4.0, 1.0), (1.0, 1.0), (0.0, 0.0))
        image, scenario = tmp_path / "img.mha", SCENARIO_2D
    (tmp_path / "s.yaml").write_text(json.dumps(scenario))
    run_cli(cli, image, "--simulate", tmp_path / "s.yaml", "--degree", degree, "--max-iterations", 6, "-q",
            "--out", tmp_path / "cli")
    seen = []
    result = vp.simulate(str(image), scenario, degree=degree, max_iterations=6, progress=lambda s, r: seen.append(s))
    result.write(tmp_path / "py")
    assert "simulate" in seen and "vim" in seen
    for rel in ("needle.csv", "mesh.vtu", "steps/step_0004.vtu"):
        assert (tmp_path / "py" / rel).read_bytes() == (tmp_path / "cli" / rel).read_bytes(), rel
    assert result.displacements.shape == (5, len(result.mesh.points), dim)
    assert result.report["simulation"]["model"]["degree"] == degree


def test_flexible_needle_shape_per_step(tmp_path):
    # Truths: report.json's per-step needle_shape, tip_deviation and tip_angle (the CLI's report), the
    # holder free_length before the entry on the planned line, the tip at the shape's end, and the
    # deviation = tip - (entry + depth x direction).
    write_nrrd(tmp_path / "ball.nrrd", sphere_image(n=20, radius=6.0), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), np.eye(3))
    scenario = json.loads(json.dumps(SCENARIO))
    scenario["needle"].update({"entry": [9.5, 9.5, 19.5], "cutting_force": 5.0, "bevel": {"angle": 30, "side": [0, 1, 0]},
                               "flexible": {"youngs_modulus": 2.0e5, "inner_diameter": 0.6, "free_length": 2.0}})
    result = vp.simulate(str(tmp_path / "ball.nrrd"), scenario, max_iterations=2)
    needle = result.needles[0]
    per_step = result.report["simulation"]["needles"][0]["per_step"]
    steps = len(result.depths)
    assert needle["tip_deviation"].shape == (steps, 3)
    assert needle["tip_angle"].shape == (steps,)
    assert len(needle["needle_shape"]) == steps
    entry, direction = np.array([9.5, 9.5, 19.5]), np.array([0.0, 0.0, -1.0])  # on the image's surface
    for k in range(steps):
        shape = needle["needle_shape"][k]
        assert shape.ndim == 2 and shape.shape[1] == 3 and shape.shape[0] >= 2
        assert np.allclose(shape, np.array(per_step["needle_shape"][k]), rtol=0, atol=1e-12)
        assert np.allclose(shape[0], entry - 2.0 * direction, atol=1e-12)
        assert np.allclose(shape[-1], needle["tip"][k], atol=1e-12)
        planned = entry + result.depths[k] * direction
        assert np.allclose(needle["tip_deviation"][k], needle["tip"][k] - planned, atol=1e-9)
        assert needle["tip_angle"][k] == pytest.approx(per_step["tip_angle"][k], abs=1e-12)
    assert np.linalg.norm(needle["tip_deviation"][-1]) > 1e-4  # the bevel bends it
    assert "tip_deviation" not in vp.simulate(str(tmp_path / "ball.nrrd"), SCENARIO, max_iterations=2).needles[0]


def test_procedure_seeds_as_arrays(tmp_path):
    # Truths: seeds.csv of the same result (the CLI's file), the planned positions on the planned line
    # (entry + depth x direction), error = final - planned, and report.json's seed statistics.
    write_nrrd(tmp_path / "ball.nrrd", sphere_image(n=20, radius=6.0), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), np.eye(3))
    scenario = json.loads(json.dumps(SCENARIO))
    needle = scenario.pop("needle")
    needle["friction"] = {"model": "stick-slip", "max_shear_per_length": 2.0}
    first = dict(needle, name="a", seeds=[3.0, 6.0])
    second = dict(needle, name="b", entry=[7.5, 9.5, 19.0], seeds=[5.0])
    scenario["procedure"] = [{"insert": first}, {"withdraw": {"needle": "a", "steps": 4}},
                             {"insert": second}, {"withdraw": {"needle": "b", "steps": 2}}]
    result = vp.simulate(str(tmp_path / "ball.nrrd"), scenario, max_iterations=2)
    seeds = result.seeds
    assert seeds["needle"] == ["a", "a", "b"]
    assert np.array_equal(seeds["depth"], [3.0, 6.0, 5.0])
    for key in ("planned", "final", "error"):
        assert seeds[key].shape == (3, 3)
    direction = np.array([0.0, 0.0, -1.0])
    entries = [np.array(first["entry"]), np.array(first["entry"]), np.array(second["entry"])]
    for i in range(3):
        assert np.allclose(seeds["planned"][i], entries[i] + seeds["depth"][i] * direction, atol=1e-12)
    assert np.array_equal(seeds["error"], seeds["final"] - seeds["planned"])
    assert np.allclose(seeds["error_norm"], np.linalg.norm(seeds["error"], axis=1), rtol=1e-15, atol=0)
    assert np.max(seeds["error_norm"]) > 1e-6  # the friction moved the tissue at the releases
    result.write(tmp_path / "out")
    with open(tmp_path / "out" / "seeds.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["needle"] for r in rows] == seeds["needle"]
    for i, r in enumerate(rows):
        for key, column in (("planned", "planned"), ("final", "final"), ("error", "error")):
            written = [float(r[column + "_" + a]) for a in "xyz"]
            assert np.allclose(seeds[key][i], written, rtol=1e-11, atol=1e-12)
        assert int(r["release_step"]) == seeds["release_step"][i]
    stats = result.report["simulation"]["seeds"]["all"]
    assert stats["count"] == 3
    assert stats["mean_error"] == pytest.approx(np.mean(seeds["error_norm"]), rel=1e-12)
    assert stats["max_error"] == pytest.approx(np.max(seeds["error_norm"]), rel=1e-12)
