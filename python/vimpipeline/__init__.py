"""vim-pipeline from Python: read an image, mesh it with VIM, simulate a needle insertion.

Arrays follow ITK/SimpleITK: an image array is indexed ``array[z, y, x]`` while ``spacing``, ``origin``
and ``direction`` are in x, y, z order; mesh points are world (ITK physical) coordinates.
"""

import json
import os
import shutil
import tempfile

import numpy as np

from . import _core

__version__ = _core.__version__
__all__ = ["Image", "Mesh", "Result", "read_image", "mesh", "simulate", "__version__"]


class Image:
    """A scalar image: ``array[z, y, x]`` (2D: ``[y, x]``) with ``spacing``, ``origin`` (the centre of
    voxel 0) and ``direction`` (dim x dim; column c is image axis c in world axes), all in x, y, z order."""

    def __init__(self, array, spacing=None, origin=None, direction=None, source="array"):
        self.array = np.asarray(array)
        dim = self.array.ndim
        self.spacing = tuple(float(s) for s in (spacing if spacing is not None else [1.0] * dim))
        self.origin = tuple(float(o) for o in (origin if origin is not None else [0.0] * dim))
        d = np.eye(dim) if direction is None else np.asarray(direction, dtype=float)
        self.direction = d.reshape(dim, dim) if d.size == dim * dim else d
        self.source = source

    def _as_dict(self):
        return {"values": self.array, "spacing": self.spacing, "origin": self.origin,
                "direction": self.direction, "source": self.source}

    def __repr__(self):
        return "Image(shape=%s, spacing=%s, origin=%s)" % (self.array.shape, self.spacing, self.origin)


class Mesh:
    """A simplex mesh: ``points`` (n x dim, world), ``cells`` (m x (dim+1)), ``cell_data`` (per-cell
    arrays: mean, variance, voxels, quality; segment and object with a threshold; youngs_modulus after a
    simulation), ``point_data`` (boundary), ``history`` (energy history, entry 0 the initial mesh)."""

    def __init__(self, data):
        self._data = data
        self.points = data.points
        self.cells = data.cells
        self.cell_data = data.cell_data
        self.point_data = data.point_data
        self.history = data.history
        self.warnings = data.warnings

    @property
    def dim(self):
        return self._data.dim

    def write(self, path):
        """Writes the mesh as a VTK XML unstructured grid (.vtu), as the CLI writes mesh.vtu."""
        self._data.write_vtu(os.fspath(path))

    def to_meshio(self):
        """The mesh as a meshio.Mesh (needs the meshio package)."""
        import meshio

        kind = "tetra" if self.dim == 3 else "triangle"
        return meshio.Mesh(self.points, [(kind, self.cells)], point_data=dict(self.point_data),
                           cell_data={k: [v] for k, v in self.cell_data.items()})

    def __repr__(self):
        return "Mesh(%d points, %d cells)" % (len(self.points), len(self.cells))


class Result:
    """A needle-insertion simulation: ``mesh`` (with youngs_modulus), ``needles`` (one dict per needle:
    ``name``, per-step ``depth``, ``axial_force`` (= ``friction_force`` of the shaft + ``tip_force``),
    ``tip_cutting`` (bool: the tip cuts, its force held at the cutting force), ``punctures`` (a list of
    dicts ``depth``, ``force_before``, ``force_after``: the steps at which the tip first cuts after pressing),
    ``lateral_force``, ``max_strain``, ``tip`` and ``force`` (steps x dim, world), ``target_displacement`` (steps x targets x dim), ``displacement`` (steps x nodes x dim);
    with ``needle.flexible`` also ``tip_deviation`` (steps x dim), ``tip_angle`` (degrees per step) and
    ``needle_shape`` (per step an array points x dim, world: the bent needle from its holder to its tip)),
    ``seeds`` (a procedure's seeds, as seeds.csv: a dict of ``needle`` (names), ``depth`` (planned depth),
    ``planned``, ``final`` and ``error`` (seeds x dim, world; error = final - planned), ``error_norm`` and
    ``release_step``), ``target_names``, ``warnings``, ``report`` (report.json). ``write(out_dir)`` writes
    the CLI's files."""

    def __init__(self, data, staging):
        self._data = data
        self._staging = staging
        self.mesh = Mesh(data.mesh)
        self.needles = data.needles
        self.seeds = data.seeds
        self.target_names = data.target_names
        self.warnings = data.warnings
        self.files = data.files
        self.report = json.loads(data.report_json)

    @property
    def forces(self):
        """Axial force per step of the first needle."""
        return self.needles[0]["axial_force"]

    @property
    def depths(self):
        return self.needles[0]["depth"]

    @property
    def target_displacements(self):
        return self.needles[0]["target_displacement"]

    @property
    def displacements(self):
        return self.needles[0]["displacement"]

    def write(self, out_dir, overwrite=False):
        """Writes the CLI's output files (mesh.vtu, exports, simulation.pvd, steps/, needle.csv, figures/,
        report.json) into out_dir, which must be new or empty unless overwrite. The files are first
        copied into a temporary folder next to out_dir and then renamed into place, so that a failure
        leaves no file of this result under out_dir."""
        given = os.fspath(out_dir)
        out_dir = os.path.abspath(given)
        if os.path.exists(out_dir):
            if not os.path.isdir(out_dir):
                raise ValueError("out_dir " + out_dir + ": exists and is not a directory")
            if os.listdir(out_dir) and not overwrite:
                raise ValueError("out_dir " + out_dir + ": output directory is not empty; choose a new or empty "
                                 "directory, or pass overwrite=True")
        made = _missing_folders(os.path.dirname(out_dir))
        os.makedirs(os.path.dirname(out_dir), exist_ok=True)
        temporary = tempfile.mkdtemp(prefix=".vimpipeline-", dir=os.path.dirname(out_dir))
        try:
            for rel in self.files:
                os.makedirs(os.path.dirname(os.path.join(temporary, rel)), exist_ok=True)
                shutil.copyfile(os.path.join(self._staging.name, rel), os.path.join(temporary, rel))
            if not os.path.exists(out_dir) or not os.listdir(out_dir):
                if os.path.exists(out_dir):
                    os.rmdir(out_dir)
                os.rename(temporary, out_dir)
            else:
                _move_into(temporary, out_dir, self.files)
        except BaseException:
            if made:  # the folders this call created above out_dir
                shutil.rmtree(made[0], ignore_errors=True)
            raise
        finally:
            shutil.rmtree(temporary, ignore_errors=True)
        return given


def _missing_folders(path):
    """The folders of path that do not exist yet, outermost first."""
    missing = []
    while path and not os.path.exists(path) and os.path.dirname(path) != path:
        missing.insert(0, path)
        path = os.path.dirname(path)
    return missing


def _move_into(source, target, files):
    """Renames the files (relative paths) from source into the existing folder target; on a failure removes
    what it moved and target's report.json (it would list files that are gone or not its own)."""
    moved = []
    try:
        for rel in files:
            os.makedirs(os.path.dirname(os.path.join(target, rel)), exist_ok=True)
            os.replace(os.path.join(source, rel), os.path.join(target, rel))
            moved.append(rel)
    except BaseException:
        for rel in moved + ["report.json"]:
            if os.path.exists(os.path.join(target, rel)):
                os.remove(os.path.join(target, rel))
        raise


def _image(image, spacing=None, origin=None, direction=None):
    if isinstance(image, (str, os.PathLike)):
        return read_image(image)
    if isinstance(image, Image):
        return image
    return Image(image, spacing, origin, direction)


def read_image(path):
    """Reads a scalar image (.mha/.mhd, .nrrd/.nhdr, .nii/.nii.gz; 2D or 3D; any pixel type, read as float)."""
    d = _core.read_image(os.fspath(path))
    return Image(d["values"], d["spacing"], d["origin"], d["direction"], d["source"])


def _settings(nodes=None, spacing=None, lam=None, max_dihedral=None, min_dihedral=None, max_iterations=None,
              threads=None, sizing=None, threshold=None, mesher=None, degree=None, min_radius_ratio=None,
              convergence=None, energy_convergence=None, search_width=None, seed=None, label_modulus=None):
    s = {"nodes": nodes, "spacing": spacing, "lam": lam, "max_dihedral": max_dihedral,
         "min_dihedral": min_dihedral, "max_iterations": max_iterations, "threads": threads,
         "threshold": threshold, "mesher": mesher, "degree": degree, "min_radius_ratio": min_radius_ratio,
         "convergence": convergence, "energy_convergence": energy_convergence, "search_width": search_width,
         "seed": seed}
    if sizing is not None:
        s["sizing"] = _image(sizing)._as_dict()
    if label_modulus is not None:  # the CLI's --label-modulus LABEL=E, one per label
        s["label_modulus"] = ["%s=%r" % (label, float(e)) for label, e in dict(label_modulus).items()]
    return {k: v for k, v in s.items() if v is not None}


def _label_image(labels, img):
    """The label image beside ``img``: a path or an Image as given, an array on ``img``'s grid."""
    if isinstance(labels, (str, os.PathLike, Image)):
        return _image(labels)
    return Image(labels, img.spacing, img.origin, img.direction, source="labels (array)")


# The defaults of the mesh keywords: the C++ MeshOptions' (vim/pipeline/scenario/mesh_options.hpp), the CLI's.
_MESH_DEFAULTS = _core.mesh_defaults()


def mesh(image_or_array, spacing=None, origin=None, direction=None, nodes=_MESH_DEFAULTS["nodes"],
         lam=_MESH_DEFAULTS["lam"], max_dihedral=_MESH_DEFAULTS["max_dihedral"],
         min_dihedral=_MESH_DEFAULTS["min_dihedral"], max_iterations=_MESH_DEFAULTS["max_iterations"],
         threads=_MESH_DEFAULTS["threads"], sizing=None, threshold=None, mesher="vim", grid_spacing=None,
         progress=None, labels=None, label_modulus=None, **options):
    """Meshes an image (a path, an Image, or an array[z, y, x] with spacing/origin/direction) as
    ``vim-pipeline IMAGE --nodes ... --out DIR`` does; returns a Mesh. ``mesher``: "vim" or "grid";
    ``grid_spacing``: initial grid edge length instead of ``nodes``; ``options``: the CLI's
    min_radius_ratio, convergence, energy_convergence, search_width, seed; ``progress(stage, record)``
    is called after each iteration. ``labels``: a label image (a path, an Image, or an integer array on
    the image's grid), meshed by the label energy as ``--labels``; with ``image_or_array`` None the
    label image alone (an array takes spacing/origin/direction), its moduli from ``label_modulus``
    ({label: E}, as ``--label-modulus``). The mesh's ``cell_data["label"]`` is each element's label. Bad
    input raises ValueError with the CLI's message."""
    alone = image_or_array is None and labels is not None
    img = _image(labels if alone else image_or_array, spacing, origin, direction)
    settings = _settings(nodes=None if grid_spacing else nodes, spacing=grid_spacing, lam=lam,
                         max_dihedral=max_dihedral, min_dihedral=min_dihedral, max_iterations=max_iterations,
                         threads=threads, sizing=sizing, threshold=threshold, mesher=mesher,
                         label_modulus=label_modulus, **options)
    if alone:
        settings["labels_alone"] = True
    elif labels is not None:
        settings["labels"] = _label_image(labels, img)._as_dict()
    return Mesh(_core.mesh(img._as_dict(), settings, progress))


def simulate(image_or_mesh, scenario, progress=None, spacing=None, origin=None, direction=None, **mesh_options):
    """Runs a needle-insertion scenario (a YAML path, or a dict of the same schema) on an image (meshed
    with ``mesh_options``, which override the scenario's mesh keys, as the CLI's options do) or on a Mesh
    from mesh(); ``degree`` (1 or 2) overrides the scenario's mesh.degree. Returns a Result."""
    if isinstance(scenario, dict):
        path, text, name = "", json.dumps(scenario), "scenario (dict)"
    else:
        path, text, name = os.fspath(scenario), "", ""
    if "grid_spacing" in mesh_options:
        mesh_options["spacing"] = mesh_options.pop("grid_spacing")
    settings = _settings(**mesh_options)
    staging = tempfile.TemporaryDirectory(prefix="vimpipeline-")
    if isinstance(image_or_mesh, Mesh):
        data = _core.simulate(None, image_or_mesh._data, settings, path, text, name, staging.name, progress)
    else:
        img = _image(image_or_mesh, spacing, origin, direction)
        data = _core.simulate(img._as_dict(), None, settings, path, text, name, staging.name, progress)
    return Result(data, staging)


def fit_forces(image, scenario, measured, out, overwrite=False, **mesh_options):
    """Fits the scenario's needle (its cutting forces and friction limits, and those of its
    needle.tissues entries) to a measured insertion, as ``vim-pipeline IMAGE --simulate SCENARIO
    --fit-forces MEASURED --out OUT`` does: ``image``, ``scenario`` and ``measured`` (a CSV with
    columns depth, force) are paths; OUT receives fit.json, fitted.yaml, figures/force_fit.png and the
    fitted scenario's run. Returns fit.json as a dict. Bad input raises ValueError."""
    if "grid_spacing" in mesh_options:
        mesh_options["spacing"] = mesh_options.pop("grid_spacing")
    text = _core.fit_forces(os.fspath(image), _settings(**mesh_options), os.fspath(scenario),
                            os.fspath(measured), os.fspath(out), overwrite)
    return json.loads(text)
