#!/usr/bin/env python3
"""The include order of docs/architecture.md ("Modules and the dependency rule", "The pipeline's folders").

Libraries: core <- mesher; core <- fem <- needle <- pipeline. A source of one library includes only
headers of itself or of a library it may use. Inside pipeline/, the folders of src/ and of
include/vim/pipeline/ are stacked

    common < dose < image < scenario < output < simulation < run < study < fit < app

and a file includes only headers of its own folder or of a folder below it.

Usage: scripts/check-layers.py   (from anywhere; reads the repository this script is in)
Exit status 0 when every include follows the order, 1 otherwise (each offending line is printed).
"""
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PIPELINE_FOLDERS = ["common", "dose", "image", "scenario", "output", "simulation", "run", "study", "fit", "app"]
# library -> the libraries whose headers it may include (itself included)
MAY_USE = {
    "core": {"core"},
    "mesher": {"core", "mesher"},
    "fem": {"core", "fem"},
    "needle": {"core", "fem", "needle"},
    "pipeline": {"core", "mesher", "fem", "needle", "pipeline"},
}
LIBRARY_ROOTS = {
    "core": ROOT / "mesher" / "core",
    "mesher": ROOT / "mesher",
    "fem": ROOT / "fem",
    "needle": ROOT / "needle",
    "pipeline": ROOT / "pipeline",
}
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')
SUFFIXES = {".cpp", ".hpp", ".h"}


def library_of_header(name):
    """The library a project header belongs to, from its include path (None: not the project's)."""
    for lib in ("fem", "needle", "pipeline"):
        if name.startswith(f"vim/{lib}/"):
            return lib
    if name.startswith("vim/"):
        core = LIBRARY_ROOTS["core"] / "include" / name
        return "core" if core.exists() else "mesher"
    return None


def library_of_file(path):
    if LIBRARY_ROOTS["core"] in path.parents:
        return "core"
    for lib in ("mesher", "fem", "needle", "pipeline"):
        if LIBRARY_ROOTS[lib] in path.parents:
            return lib
    return None


def pipeline_folder_of_file(path):
    rel = path.relative_to(ROOT / "pipeline").parts
    if rel[0] == "src" and len(rel) > 2:
        return rel[1]
    if rel[:3] == ("include", "vim", "pipeline") and len(rel) > 4:
        return rel[3]
    return None


def pipeline_folder_of_header(name, path):
    parts = name.split("/")
    if name.startswith("vim/pipeline/") and len(parts) > 3:
        return parts[2]
    if not name.startswith("vim/") and len(parts) == 2 and (ROOT / "pipeline" / "src" / name).exists():
        return parts[0]  # a private header, included by folder
    return None


def violations():
    rank = {f: i for i, f in enumerate(PIPELINE_FOLDERS)}
    for path in sorted(p for lib in LIBRARY_ROOTS.values() if lib.exists() for p in lib.rglob("*")):
        if path.suffix not in SUFFIXES or not path.is_file():
            continue
        lib = library_of_file(path)
        folder = pipeline_folder_of_file(path) if lib == "pipeline" else None
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            m = INCLUDE.match(line)
            if not m:
                continue
            name = m.group(1)
            used = library_of_header(name)
            where = f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
            if used and used not in MAY_USE[lib]:
                yield f"{where}  ({lib} may not use {used})"
            if folder:
                target = pipeline_folder_of_header(name, path)
                if target in rank and folder in rank and rank[target] > rank[folder]:
                    yield f"{where}  (pipeline/{folder} is below pipeline/{target})"


def main():
    found = list(violations())
    for v in found:
        print(f"check-layers: {v}")
    if found:
        print(f"check-layers: {len(found)} includes against the order of docs/architecture.md")
        return 1
    print("check-layers: every include follows the module and folder order")
    return 0


if __name__ == "__main__":
    sys.exit(main())
