# vimpipeline.read_image and vimpipeline.mesh. Truths: the bytes and header values written by conftest
# (read_image), the CLI's mesh.vtu read by meshio (the same mesh, bit for bit), a brute-force point-in-
# simplex count of voxel centres from the array (cell means), and mesh invariants (positive volumes,
# the quality bound, a never-rising energy, voxels shared out exactly once).
import os
import re
import threading
import time

import meshio
import numpy as np
import pytest

import vimpipeline as vp
from conftest import run_cli, sphere_image, write_mha_2d, write_nrrd


def test_read_image_returns_the_written_voxels_and_geometry(oblique_image):
    # Truth: the array, spacing, origin and direction written into the NRRD file.
    img = vp.read_image(oblique_image["path"])
    assert img.array.shape == oblique_image["array"].shape  # [z, y, x]
    assert np.array_equal(img.array, oblique_image["array"].astype(np.float32))
    assert np.allclose(img.spacing, oblique_image["spacing"], rtol=1e-12)
    assert np.allclose(img.origin, oblique_image["origin"], rtol=1e-12)
    assert np.allclose(img.direction, oblique_image["direction"], atol=1e-9)


def test_read_image_2d_axis_order(tmp_path):
    # Truth: a 2D MetaImage whose voxel (x=4, y=1) alone holds 7.
    array = np.zeros((3, 5), dtype=np.float32)
    array[1, 4] = 7.0
    write_mha_2d(tmp_path / "a.mha", array, (0.5, 2.0), (1.0, -1.0))
    img = vp.read_image(tmp_path / "a.mha")
    assert img.array.shape == (3, 5) and img.array[1, 4] == 7.0 and img.array.sum() == 7.0
    assert img.spacing == (0.5, 2.0) and img.origin == (1.0, -1.0)
    assert np.array_equal(img.direction, np.eye(2))


@pytest.fixture(scope="module")
def density_file(oblique_image, tmp_path_factory):
    """A sizing image on the oblique image's grid: denser towards x = 0."""
    path = tmp_path_factory.mktemp("sizing") / "density.nrrd"
    n = oblique_image["array"].shape[2]
    density = np.broadcast_to(1.0 + 4.0 * (1.0 - np.arange(n) / n), oblique_image["array"].shape)
    write_nrrd(path, density, oblique_image["spacing"], oblique_image["origin"], oblique_image["direction"])
    return str(path)


@pytest.mark.parametrize("variant", ["plain", "threshold", "grid", "sizing", "search"])
def test_mesh_equals_the_cli_bit_for_bit(cli, oblique_image, density_file, tmp_path, variant):
    # Truth: the CLI's mesh.vtu on the same file and options (points, cells and cell data exactly equal).
    args = ["--nodes", 300, "--lambda", 0.4, "--max-iterations", 8, "--export", "none", "-q"]
    options = dict(nodes=300, lam=0.4, max_iterations=8)
    extra = {"plain": ([], {}), "threshold": (["--threshold", 2.0], {"threshold": 2.0}),
             "grid": (["--mesher", "grid"], {"mesher": "grid"}),
             "sizing": (["--sizing", density_file], {"sizing": density_file}),
             "search": (["--min-dihedral", 8, "--min-radius-ratio", 0.1, "--search-width", 0, "--convergence", 0.01,
                         "--energy-convergence", 0], dict(min_dihedral=8, min_radius_ratio=0.1, search_width=0,
                                                          convergence=0.01, energy_convergence=0))}[variant]
    run_cli(cli, oblique_image["path"], *args, *extra[0], "--out", tmp_path / "cli")
    ref = meshio.read(tmp_path / "cli" / "mesh.vtu")
    mesh = vp.mesh(oblique_image["path"], **options, **extra[1])
    assert np.array_equal(mesh.points, ref.points)
    assert np.array_equal(mesh.cells, ref.cells_dict["tetra"])
    expected = {"mean", "variance", "voxels", "quality"} | ({"segment", "object"} if variant == "threshold" else set())
    assert set(mesh.cell_data) == expected
    for name in expected:
        assert np.array_equal(mesh.cell_data[name], ref.cell_data[name][0]), name
    assert np.array_equal(mesh.point_data["boundary"], ref.point_data["boundary"])
    # Mesh.write produces the CLI's file byte for byte.
    mesh.write(tmp_path / "py.vtu")
    assert (tmp_path / "py.vtu").read_bytes() == (tmp_path / "cli" / "mesh.vtu").read_bytes()


def test_mesh_of_an_array_equals_the_mesh_of_its_file(oblique_image):
    # Truth: the mesh of the file; the array path must carry spacing, origin and direction the same way.
    from_file = vp.mesh(oblique_image["path"], nodes=200, max_iterations=5)
    from_array = vp.mesh(oblique_image["array"], spacing=oblique_image["spacing"], origin=oblique_image["origin"],
                         direction=oblique_image["direction"].ravel(), nodes=200, max_iterations=5)
    assert np.array_equal(from_file.cells, from_array.cells)
    assert np.allclose(from_file.points, from_array.points, rtol=0, atol=1e-12)


def test_2d_mesh_equals_the_cli(cli, tmp_path):
    # Truth: the CLI's 2D mesh.vtu (triangles; meshio pads points to 3D with z = 0).
    y, x = np.mgrid[:40, :50]
    array = np.where((x - 20) ** 2 + (y - 22) ** 2 < 100, 5.0, 1.0)
    write_mha_2d(tmp_path / "disc.mha", array, (0.5, 0.5), (0.0, 0.0))
    run_cli(cli, tmp_path / "disc.mha", "--nodes", 150, "--export", "none", "-q", "--out", tmp_path / "cli")
    ref = meshio.read(tmp_path / "cli" / "mesh.vtu")
    mesh = vp.mesh(str(tmp_path / "disc.mha"), nodes=150)
    assert mesh.points.shape[1] == 2 and mesh.cells.shape[1] == 3
    assert np.array_equal(mesh.points, ref.points[:, :2])
    assert np.array_equal(mesh.cells, ref.cells_dict["triangle"])


def simplex_volumes(points, cells):
    e = points[cells[:, 1:]] - points[cells[:, :1]]
    return np.linalg.det(e) / (6.0 if points.shape[1] == 3 else 2.0)


def test_mesh_invariants_and_cell_means_by_brute_force():
    # Truths: positive world volumes summing to the image box, quality within the bound, E never
    # rising, every voxel centre counted once, and each cell's mean and variance recomputed from the
    # voxel centres found inside it by barycentric coordinates.
    array = sphere_image(n=16, radius=5.0)
    spacing, origin = (0.7, 0.5, 0.6), (1.0, 2.0, 3.0)
    mesh = vp.mesh(array, spacing=spacing, origin=origin, nodes=150, max_iterations=6, max_dihedral=150)
    vol = simplex_volumes(mesh.points, mesh.cells)
    assert (vol > 0).all()
    assert np.isclose(vol.sum(), np.prod(np.array(array.shape[::-1]) * spacing), rtol=1e-10)
    assert (mesh.cell_data["quality"] <= 150 + 1e-9).all()
    assert (np.diff(mesh.history["E"]) <= 1e-12).all() and mesh.history["iteration"][0] == 0
    assert mesh.cell_data["voxels"].sum() == array.size

    z, y, x = np.mgrid[: array.shape[0], : array.shape[1], : array.shape[2]]
    centres = np.stack([origin[0] + x * spacing[0], origin[1] + y * spacing[1], origin[2] + z * spacing[2]], -1)
    centres, values = centres.reshape(-1, 3), array.astype(np.float32).reshape(-1).astype(float)  # voxels are float
    checked = 0
    for c in range(0, len(mesh.cells), 7):
        p = mesh.points[mesh.cells[c]]
        lam = np.linalg.solve((p[1:] - p[0]).T, (centres - p[0]).T).T
        bary = np.column_stack([1 - lam.sum(1), lam])
        if (np.abs(bary) < 1e-9).any(axis=1)[(bary > -1e-9).all(1)].any():
            continue  # a centre on a face: which cell owns it is a tie rule, not checked here
        inside = (bary > 0).all(axis=1)
        assert inside.sum() == mesh.cell_data["voxels"][c]
        if inside.sum():
            assert np.isclose(mesh.cell_data["mean"][c], values[inside].mean(), rtol=1e-9, atol=1e-12)
            assert np.isclose(mesh.cell_data["variance"][c], values[inside].var(), rtol=1e-6, atol=1e-9)
        checked += 1
    assert checked > 10


def test_threshold_segments_the_ball():
    # Truth: the object is the ball (value 3 > 2) of known volume 4/3 pi r^3 within the mesh's resolution.
    array = sphere_image(n=24, radius=7.0)
    mesh = vp.mesh(array, nodes=1500, threshold=2.0)
    obj = mesh.cell_data["object"] == 1
    assert (mesh.cell_data["mean"][obj] > 2.0).all()
    volume = simplex_volumes(mesh.points, mesh.cells)[obj].sum()
    assert abs(volume - 4 / 3 * np.pi * 7.0 ** 3) < 0.15 * 4 / 3 * np.pi * 7.0 ** 3


def test_thread_count_does_not_change_the_mesh():
    # Truth: the mesh with one thread (the CLI's determinism guarantee).
    array = sphere_image(n=16, radius=5.0)
    a = vp.mesh(array, nodes=300, threads=1, max_iterations=5)
    b = vp.mesh(array, nodes=300, threads=2, max_iterations=5)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.cells, b.cells)


def test_progress_callback_sees_every_iteration():
    # Truth: the returned history; an exception in the callback reaches the caller.
    seen = []
    mesh = vp.mesh(sphere_image(n=16), nodes=200, max_iterations=4, progress=lambda s, r: seen.append((s, r)))
    assert [r["iteration"] for s, r in seen if s == "vim"] == list(mesh.history["iteration"])
    assert np.array_equal([r["E"] for s, r in seen if s == "vim"], mesh.history["E"])

    def fail(stage, record):
        raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        vp.mesh(sphere_image(n=16), nodes=200, progress=fail)


def test_the_gil_is_released_while_meshing():
    # Truth: a Python thread keeps running (no gap as long as the meshing) while mesh() runs.
    array = sphere_image(n=32, radius=10)
    done, ticks = threading.Event(), []

    def ticker():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.002)

    t = threading.Thread(target=ticker)
    t.start()
    start = time.perf_counter()
    vp.mesh(array, nodes=3000, max_iterations=3, threads=1)
    seconds = time.perf_counter() - start
    done.set()
    t.join()
    gaps = np.diff(ticks)
    assert seconds > 0.1 and len(ticks) > 10
    assert gaps.max() < 0.5 * seconds


def test_bad_input_raises_value_error_with_the_cli_message(cli, tmp_path):
    # Truth: the CLI's `vim-pipeline: error: MESSAGE` line for the same input.
    missing = str(tmp_path / "missing.mha")
    r = run_cli(cli, missing, "--out", tmp_path / "o", check=False)
    assert r.returncode == 1
    message = re.match(r"vim-pipeline: error: (.*)", r.stderr.strip().splitlines()[-1]).group(1)
    with pytest.raises(ValueError) as e:
        vp.read_image(missing)
    assert str(e.value) == message
    with pytest.raises(ValueError, match="NaN or infinite"):
        vp.mesh(np.full((4, 4, 4), np.nan))
    with pytest.raises(ValueError, match="spacing"):
        vp.mesh(np.ones((4, 4, 4)), spacing=(1, 0, 1))
    with pytest.raises(ValueError, match="1 voxel thick"):
        vp.mesh(np.ones((1, 4, 4)))
    with pytest.raises(ValueError, match="lambda"):
        vp.mesh(np.ones((4, 4, 4)), lam=1.5)
    with pytest.raises(ValueError, match="orthonormal"):
        vp.mesh(np.ones((4, 4, 4)), direction=np.diag([1.0, 2.0, 1.0]))


def test_to_meshio_round_trip(tmp_path):
    # Truth: meshio's own reading of what Mesh.write wrote and of what to_meshio gives.
    mesh = vp.mesh(sphere_image(n=12), nodes=100, threshold=2.0)
    m = mesh.to_meshio()
    assert np.array_equal(m.points, mesh.points) and np.array_equal(m.cells_dict["tetra"], mesh.cells)
    mesh.write(tmp_path / "m.vtu")
    back = meshio.read(tmp_path / "m.vtu")
    assert np.array_equal(back.cell_data["object"][0], mesh.cell_data["object"])


def test_version_is_the_project_version(cli):
    # Truth: the CLI's --version and CMakeLists.txt's project(VERSION).
    assert run_cli(cli, "--version").stdout.split()[-1] == vp.__version__
    source = os.environ.get("VIM_SOURCE_DIR")
    if source:
        text = open(os.path.join(source, "CMakeLists.txt")).read()
        assert re.search(r"project\(vim_pipeline VERSION ([0-9.]+)", text).group(1) == vp.__version__


def _label_array(shape):
    """Three labels on [z, y, x]: 1 everywhere, 2 in a slab of x, 7 in a ball."""
    z, y, x = np.indices(shape)
    labels = np.ones(shape, dtype=np.int16)
    labels[:, :, shape[2] // 2:] = 2
    labels[(x - 4) ** 2 + (y - 5) ** 2 + (z - 5) ** 2 <= 9] = 7
    return labels


@pytest.mark.parametrize("alone", [True, False])
def test_label_mesh_equals_the_cli_bit_for_bit(cli, tmp_path, alone):
    # Truth: the CLI's mesh.vtu with --labels on the same files and options (points, cells and every cell
    # array, the label included, exactly equal); the labels as an array on the image's grid give the same.
    shape, spacing, origin = (11, 12, 13), (1.0, 1.5, 1.2), (-3.0, 2.0, 0.5)
    labels = _label_array(shape)
    write_nrrd(tmp_path / "labels.nrrd", labels, spacing, origin, np.eye(3))
    modulus = {1: 10.0, 2: 20.0, 7: 45.0}
    args = ["--nodes", 250, "--max-iterations", 6, "--export", "none", "-q"]
    if alone:
        image_args = [tmp_path / "labels.nrrd", "--labels", tmp_path / "labels.nrrd"]
        image_args += [a for l, e in modulus.items() for a in ("--label-modulus", "%d=%g" % (l, e))]
    else:
        modulus_image = np.where(labels == 7, 45.0, 12.0).astype(np.float32)
        write_nrrd(tmp_path / "modulus.nrrd", modulus_image, spacing, origin, np.eye(3))
        image_args = [tmp_path / "modulus.nrrd", "--labels", tmp_path / "labels.nrrd"]
    run_cli(cli, *image_args, *args, "--out", tmp_path / "cli")
    ref = meshio.read(tmp_path / "cli" / "mesh.vtu")
    options = dict(nodes=250, max_iterations=6)
    if alone:
        meshes = [vp.mesh(None, labels=str(tmp_path / "labels.nrrd"), label_modulus=modulus, **options),
                  vp.mesh(None, labels=labels, spacing=spacing, origin=origin, label_modulus=modulus, **options)]
    else:
        image = vp.read_image(tmp_path / "modulus.nrrd")
        meshes = [vp.mesh(str(tmp_path / "modulus.nrrd"), labels=str(tmp_path / "labels.nrrd"), **options),
                  vp.mesh(image, labels=labels, **options)]
    for m in meshes:
        assert np.array_equal(m.points, ref.points)
        assert np.array_equal(m.cells, ref.cells_dict["tetra"])
        assert set(np.unique(m.cell_data["label"])) == {1, 2, 7}
        assert set(m.cell_data) == set(ref.cell_data)
        for name in ref.cell_data:
            assert np.array_equal(m.cell_data[name], ref.cell_data[name][0]), name


def test_label_errors_raise_value_error_with_the_cli_message(tmp_path):
    # Truth: the CLI's one-line errors (a label without a modulus alone; a non-integer label image).
    labels = _label_array((8, 8, 8))
    with pytest.raises(ValueError, match=r"label 7 .* has no Young's modulus"):
        vp.mesh(None, labels=labels, label_modulus={1: 10, 2: 20}, nodes=64)
    with pytest.raises(ValueError, match="integer"):
        vp.mesh(labels.astype(float) + 10.0, labels=labels + 0.5, nodes=64)
