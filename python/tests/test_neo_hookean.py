# vimpipeline.simulate with material.model neo-hookean (a static load case given as a dict). Truths: the
# CLI's report.json and step file for the same image and scenario (the YAML file of the same dict), and
# the homogeneous uniaxial state of the energy W = C10 (Ī₁ − 3) + (J − 1)²/D₁ (docs/finite-strain.md),
# solved here by bisection on central differences of W.
import json

import numpy as np
import pytest

import vimpipeline as vp
from conftest import run_cli, write_nrrd

E, NU, HEIGHT, PUSH = 10.0, 0.3, 20.0, 3.0  # kPa, -, mm (block height), mm (15 % compression)

SCENARIO = {
    "material": {"model": "neo-hookean", "youngs_modulus": "image", "poisson_ratio": NU},
    "boundary_conditions": [
        {"type": "fixed", "region": {"box_face": "x_min"}, "components": ["x"]},
        {"type": "fixed", "region": {"box_face": "y_min"}, "components": ["y"]},
        {"type": "fixed", "region": {"box_face": "z_min"}, "components": ["z"]},
        {"type": "displacement", "region": {"box_face": "z_max"}, "value": [0, 0, -PUSH], "components": ["z"]},
    ],
    "targets": [{"name": "top", "position": [7.0, 3.0, 16.0]}],
}


def energy(stretches):
    c10, d1 = E / (4 * (1 + NU)), 6 * (1 - 2 * NU) / E
    j = np.prod(stretches)
    i1 = np.sum(np.square(stretches))
    return c10 * (j ** (-2.0 / 3.0) * i1 - 3) + (j - 1) ** 2 / d1


def lateral_stretch(l3):
    """λ with ∂W/∂λ₁ (λ, λ, λ₃) = 0 (lateral faces free), by bisection."""
    def p11(l, h=1e-6):
        return (energy([l + h, l, l3]) - energy([l - h, l, l3])) / (2 * h)

    lo, hi = 0.5, 2.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if p11(mid) < 0 else (lo, mid)
    return 0.5 * (lo + hi)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    d = tmp_path_factory.mktemp("neo_hookean")
    write_nrrd(d / "block.nrrd", np.full((20, 10, 10), E), (1.0, 1.0, 1.0), (0.5, 0.5, 0.5), np.eye(3))
    (d / "scenario.yaml").write_text(json.dumps(SCENARIO))  # JSON is YAML
    result = vp.simulate(str(d / "block.nrrd"), SCENARIO, mesher="grid", nodes=300)
    return d, result


def test_dict_scenario_equals_the_cli_run(cli, case):
    d, result = case
    run_cli(cli, d / "block.nrrd", "--simulate", d / "scenario.yaml", "--mesher", "grid", "--nodes", 300,
            "--export", "none", "-q", "--out", d / "cli")
    theirs = json.loads((d / "cli" / "report.json").read_text())["simulation"]
    ours = result.report["simulation"]
    assert ours["static_load"]["material_model"] == theirs["static_load"]["material_model"] == "neo-hookean"
    for key in ("targets", "newton", "max_displacement", "max_strain"):
        assert ours["static_load"][key] == theirs["static_load"][key], key
    assert ours["max_strain"] == theirs["max_strain"]
    result.write(d / "py")
    step = "steps/step_0000.vtu"
    assert (d / "py" / step).read_bytes() == (d / "cli" / step).read_bytes()


def test_dict_scenario_is_the_neo_hookean_uniaxial_state(case):
    _, result = case
    sl = result.report["simulation"]["static_load"]
    l3 = 1 - PUSH / HEIGHT
    lam = lateral_stretch(l3)
    expected = np.array([(lam - 1) * 7, (lam - 1) * 3, (l3 - 1) * 16])
    assert np.allclose(sl["targets"]["top"]["displacement"], expected, rtol=0, atol=1e-5)
    # The linear model's lateral displacement ν ε x differs from this by more than the tolerance.
    assert abs(NU * PUSH / HEIGHT * 7 - expected[0]) > 1e-2
    for step in sl["newton"]["load_steps"]:
        assert step["residual_norm"][-1] <= 1e-10 * step["residual_norm"][0]


def test_needle_on_neo_hookean_tissue_equals_the_cli_run(cli, tmp_path):
    """A needle scenario dict with material.model neo-hookean: the same axial forces, targets and Newton
    record as the CLI's run of the YAML of the same dict; the linear model gives other forces."""
    needle = {"entry": [5.2, 4.9, 20.0], "direction": [0, 0, -1], "depth": 8.0, "steps": 4, "diameter": 1.0,
              "friction": {"model": "stick-slip", "max_shear_per_length": 4.0}}
    scenario = {"material": {"model": "neo-hookean", "youngs_modulus": "image", "poisson_ratio": NU},
                "boundary_conditions": [{"type": "fixed", "region": {"box_face": "z_min"}}],
                "needle": needle, "targets": [{"name": "side", "position": [8.0, 6.0, 14.0]}]}
    write_nrrd(tmp_path / "block.nrrd", np.full((20, 10, 10), E), (1.0, 1.0, 1.0), (0.5, 0.5, 0.5), np.eye(3))
    (tmp_path / "scenario.yaml").write_text(json.dumps(scenario))
    ours = vp.simulate(str(tmp_path / "block.nrrd"), scenario, mesher="grid", nodes=300).report["simulation"]
    run_cli(cli, tmp_path / "block.nrrd", "--simulate", tmp_path / "scenario.yaml", "--mesher", "grid", "--nodes",
            300, "--export", "none", "-q", "--out", tmp_path / "cli")
    theirs = json.loads((tmp_path / "cli" / "report.json").read_text())["simulation"]
    a, b = ours["needles"][0], theirs["needles"][0]
    assert a["material_model"] == b["material_model"] == "neo-hookean"
    assert a["per_step"]["axial_force"] == b["per_step"]["axial_force"]
    assert a["per_step"]["target_displacement"] == b["per_step"]["target_displacement"]
    assert [s["iterations"] for s in a["newton"]["per_step"]] == [s["iterations"] for s in b["newton"]["per_step"]]
    scenario["material"]["model"] = "linear"
    lin = vp.simulate(str(tmp_path / "block.nrrd"), scenario, mesher="grid", nodes=300).report["simulation"]
    assert lin["needles"][0]["per_step"]["axial_force"] != a["per_step"]["axial_force"]
