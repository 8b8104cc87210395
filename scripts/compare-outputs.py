#!/usr/bin/python3
"""Compare two vim-pipeline output folders: every file present in both, numbers within a relative
tolerance (of the largest magnitude of the array/file), timings ignored.
Usage: scripts/compare-outputs.py DIR_A DIR_B [--rtol 1e-12] [--skip REGEX]...  Exit 1 on any difference."""
import argparse, json, math, os, re, sys

TIMING = re.compile(r"^timing$|seconds|per_second|_time|time_|wall|date|command_line|threads|version|elapsed|rss|memory|hostname|\bout\b|path|file", re.I)
SKIP_KEYS = []
NUM = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")

def close(a, b, rtol, scale):
    return abs(a - b) <= rtol * max(scale, 1e-300) or (a == b)

def cmp_json(a, b, rtol, where, out):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if TIMING.search(k) or any(r.search(f"{where}.{k}") for r in SKIP_KEYS):
                continue
            if k not in a or k not in b:
                out.append(f"{where}.{k}: only in {'B' if k not in a else 'A'}"); continue
            cmp_json(a[k], b[k], rtol, f"{where}.{k}", out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{where}: length {len(a)} vs {len(b)}"); return
        nums = [abs(x) for x in a + b if isinstance(x, (int, float)) and not isinstance(x, bool)]
        for i, (x, y) in enumerate(zip(a, b)):
            if isinstance(x, (int, float)) and isinstance(y, (int, float)) and not isinstance(x, bool):
                if not close(x, y, rtol, max(nums) if nums else abs(x)):
                    out.append(f"{where}[{i}]: {x!r} vs {y!r}")
            else:
                cmp_json(x, y, rtol, f"{where}[{i}]", out)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if not close(a, b, rtol, max(abs(a), abs(b))):
            out.append(f"{where}: {a!r} vs {b!r}")
    elif a != b:
        out.append(f"{where}: {str(a)[:80]!r} vs {str(b)[:80]!r}")

def cmp_text_numbers(ta, tb, rtol, where, out, skip_cols=()):
    la, lb = ta.splitlines(), tb.splitlines()
    if len(la) != len(lb):
        out.append(f"{where}: {len(la)} vs {len(lb)} lines"); return
    na = [float(x) for l in la for x in NUM.findall(l)]
    scale = max([abs(x) for x in na] or [1.0])
    for i, (x, y) in enumerate(zip(la, lb)):
        if x == y:
            continue
        sa, sb = NUM.split(x), NUM.split(y)
        fa, fb = NUM.findall(x), NUM.findall(y)
        if sa != sb or len(fa) != len(fb):
            out.append(f"{where}:{i+1}: {x[:100]!r} vs {y[:100]!r}"); continue
        for p, q in zip(fa, fb):
            if not close(float(p), float(q), rtol, scale):
                out.append(f"{where}:{i+1}: {p} vs {q}"); break

def cmp_csv(ta, tb, rtol, where, out):
    la, lb = ta.splitlines(), tb.splitlines()
    if not la or not lb or la[0] != lb[0]:
        out.append(f"{where}: header differs"); return
    head = la[0].split(",")
    keep = [i for i, h in enumerate(head) if not TIMING.search(h)]
    strip = lambda L: "\n".join(",".join(r.split(",")[i] for i in keep if i < len(r.split(","))) for r in L)
    cmp_text_numbers(strip(la), strip(lb), rtol, where, out)

def cmp_mesh(pa, pb, rtol, where, out):
    import meshio, numpy as np
    ma, mb = meshio.read(pa), meshio.read(pb)
    def arr(name, x, y):
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        if x.shape != y.shape:
            out.append(f"{where} {name}: shape {x.shape} vs {y.shape}"); return
        s = max(np.abs(x).max() if x.size else 0, np.abs(y).max() if y.size else 0, 1e-300)
        d = np.abs(x - y).max() if x.size else 0
        if d > rtol * s:
            out.append(f"{where} {name}: max diff {d:.3e} (scale {s:.3e})")
    arr("points", ma.points, mb.points)
    if len(ma.cells) != len(mb.cells):
        out.append(f"{where}: cell blocks {len(ma.cells)} vs {len(mb.cells)}"); return
    for i, (ca, cb) in enumerate(zip(ma.cells, mb.cells)):
        if ca.type != cb.type:
            out.append(f"{where} cells[{i}]: {ca.type} vs {cb.type}")
        elif not np.array_equal(ca.data, cb.data):
            out.append(f"{where} cells[{i}] connectivity differs")
    for k in sorted(set(ma.point_data) | set(mb.point_data)):
        if k not in ma.point_data or k not in mb.point_data:
            out.append(f"{where} point_data {k}: only in one"); continue
        arr(f"point_data[{k}]", ma.point_data[k], mb.point_data[k])
    for k in sorted(set(ma.cell_data) | set(mb.cell_data)):
        if k not in ma.cell_data or k not in mb.cell_data:
            out.append(f"{where} cell_data {k}: only in one"); continue
        for j, (x, y) in enumerate(zip(ma.cell_data[k], mb.cell_data[k])):
            arr(f"cell_data[{k}][{j}]", x, y)

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("a"); ap.add_argument("b")
    ap.add_argument("--rtol", type=float, default=1e-12)
    ap.add_argument("--skip", action="append", default=[], help="regex of relative paths to skip")
    ap.add_argument("--skip-key", action="append", default=[], help="regex of JSON key paths to skip")
    o = ap.parse_args()
    global SKIP_KEYS
    SKIP_KEYS = [re.compile(k) for k in o.skip_key]
    files = lambda d: {os.path.relpath(os.path.join(r, f), d) for r, _, fs in os.walk(d) for f in fs}
    fa, fb = files(o.a), files(o.b)
    out = []
    for f in sorted(fa ^ fb):
        out.append(f"{f}: only in {'A' if f in fa else 'B'}")
    for f in sorted(fa & fb):
        if any(re.search(s, f) for s in o.skip) or f.endswith(".png"):
            continue
        pa, pb = os.path.join(o.a, f), os.path.join(o.b, f)
        try:
            if f.endswith(".json"):
                cmp_json(json.load(open(pa)), json.load(open(pb)), o.rtol, f, out)
            elif f.endswith(".csv"):
                cmp_csv(open(pa).read(), open(pb).read(), o.rtol, f, out)
            elif f.endswith((".vtu", ".vtk", ".msh")) and not f.endswith(".pvtu"):
                cmp_mesh(pa, pb, o.rtol, f, out)
            else:
                cmp_text_numbers(open(pa, errors="replace").read(), open(pb, errors="replace").read(), o.rtol, f, out)
        except Exception as e:  # unreadable by meshio etc.
            out.append(f"{f}: could not compare ({e})")
    for l in out[:200]:
        print(l)
    print(f"compare_outputs: {len(fa & fb)} common files, {len(out)} differences (rtol {o.rtol})")
    sys.exit(1 if out else 0)

main()
