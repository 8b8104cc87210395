# Shared helpers of the vimpipeline tests: image files written here byte by byte from the formats'
# specifications (NRRD, MetaImage), so that what the module reads is checked against what was written,
# and the built CLI (VIM_PIPELINE_CLI, set by CTest) as the reference for meshes and simulation files.
import os
import subprocess

import numpy as np
import pytest


def write_nrrd(path, array, spacing, origin, direction):
    """3D float NRRD in LPS space: `space directions` holds one vector per axis (x, y, z), the axis
    direction times its spacing; array is indexed [z, y, x]."""
    d = np.asarray(direction, dtype=float)
    vectors = " ".join("(%s)" % ",".join(repr(float(v)) for v in d[:, a] * spacing[a]) for a in range(3))
    header = ("NRRD0004\ntype: float\ndimension: 3\nspace: left-posterior-superior\n"
              "sizes: %d %d %d\nspace directions: %s\nspace origin: (%s)\nencoding: raw\nendian: little\n\n"
              % (array.shape[2], array.shape[1], array.shape[0], vectors,
                 ",".join(repr(float(o)) for o in origin)))
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(np.ascontiguousarray(array, dtype="<f4").tobytes())


def write_mha_2d(path, array, spacing, origin):
    """2D float MetaImage with identity direction; array is indexed [y, x]."""
    header = ("ObjectType = Image\nNDims = 2\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
              "CompressedData = False\nTransformMatrix = 1 0 0 1\nOffset = %r %r\nElementSpacing = %r %r\n"
              "DimSize = %d %d\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n"
              % (float(origin[0]), float(origin[1]), float(spacing[0]), float(spacing[1]),
                 array.shape[1], array.shape[0]))
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(np.ascontiguousarray(array, dtype="<f4").tobytes())


def rotation(axis, degrees):
    a = np.asarray(axis, dtype=float)
    a /= np.linalg.norm(a)
    t = np.radians(degrees)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * k @ k


def sphere_image(n=24, radius=7.0, inside=3.0, outside=1.0):
    """A stiff ball in a soft cube, [z, y, x], plus a gradient so that no two regions are flat."""
    z, y, x = np.mgrid[:n, :n, :n].astype(float)
    c = (n - 1) / 2
    ball = (x - c) ** 2 + (y - c + 2) ** 2 + (z - c) ** 2 < radius ** 2
    return np.where(ball, inside, outside) + 0.01 * x


@pytest.fixture(scope="module")
def cli():
    path = os.environ.get("VIM_PIPELINE_CLI")
    if not path or not os.path.exists(path):
        pytest.skip("VIM_PIPELINE_CLI (the built vim-pipeline) is not set")
    return path


def run_cli(cli, *args, check=True):
    r = subprocess.run([cli, *map(str, args)], capture_output=True, text=True)
    if check and r.returncode != 0:
        raise AssertionError("vim-pipeline failed: " + r.stderr)
    return r


@pytest.fixture(scope="module")
def oblique_image(tmp_path_factory):
    """A 3D NRRD with anisotropic spacing, an offset origin and an oblique direction."""
    path = tmp_path_factory.mktemp("images") / "oblique.nrrd"
    array = sphere_image()
    spacing, origin, direction = (0.5, 0.6, 0.7), (-3.0, 2.0, 10.0), rotation([1, 2, 3], 25)
    write_nrrd(path, array, spacing, origin, direction)
    return {"path": str(path), "array": array, "spacing": spacing, "origin": origin, "direction": direction}
