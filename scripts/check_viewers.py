#!/usr/bin/env python3
"""Opens PLY files with the real CloudCompare and MeshLab (pymeshlab) and checks what they show.

Usage: check_viewers.py FILE.ply...   (scripts/check_viewers.sh installs the programs first)
       check_viewers.py --self-test   (writes broken files and checks that they are caught)

For each file, the PLY is parsed here (ascii, binary little/big endian; vertex and edge
elements, other elements skipped) to know what it holds, then:

* CloudCompare (command line, headless with QT_QPA_PLATFORM=offscreen) loads it and exports
  it as ASCII with a header; the export must have the same point count, every `scalar_*`
  vertex property as a scalar field (CloudCompare shows it without the `scalar_` prefix) with
  the file's values, the colours when the file has red/green/blue, and the coordinates.
* MeshLab (pymeshlab) loads it; the vertex count, the coordinates, `quality` (MeshLab's
  per-vertex scalar) and the colours must match the file, and so must the edges (count and
  end points) when the file has `element edge`.
* Properties that neither viewer shows by default (a custom name without `scalar`, e.g.
  what the input carried) are listed as a note.

Coordinates must agree within 1e-6 of the cloud's extent (bounding-box diagonal): that keeps
georeferenced files honest, where an error relative to the coordinates' magnitude (4e6) would
let float rounding (0.25 at 4e6) through. CloudCompare stores float32 coordinates after a
global shift of its choosing (only on axes beyond 1e4, e.g. not a z of 2300 m), so half a
float32 step of the shifted coordinate is allowed there too and said so.

Prints what each program showed and exits 1 if anything does not match.
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np

TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def read_ply(path):
    """Returns (elements, data): elements = [(name, count, [(prop, type | ('list', ct, t))])],
    data = {element name: {prop: numpy array}} for elements without list properties."""
    with open(path, "rb") as f:
        raw = f.read()
    end = raw.find(b"end_header")
    if not raw.startswith(b"ply") or end < 0:
        raise ValueError(f"{path}: not a PLY file")
    body_start = raw.index(b"\n", end) + 1
    lines = raw[:end].decode("ascii", "replace").splitlines()
    fmt = None
    elements = []
    for line in lines[1:]:
        w = line.split()
        if not w or w[0] in ("comment", "obj_info"):
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property":
            if w[1] == "list":
                elements[-1][2].append((w[4], ("list", w[2], w[3])))
            else:
                elements[-1][2].append((w[2], w[1]))
    data = {}
    body = raw[body_start:]
    if fmt == "ascii":
        tokens = body.split()
        pos = 0
        for name, count, props in elements:
            cols = {p: [] for p, _ in props}
            for _ in range(count):
                for p, t in props:
                    if isinstance(t, tuple):
                        n = int(tokens[pos])
                        pos += 1 + n
                    else:
                        cols[p].append(float(tokens[pos]))
                        pos += 1
            data[name] = {p: np.array(v, dtype=TYPES[t]) for (p, t), v
                          in zip(props, cols.values()) if not isinstance(t, tuple)}
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        pos = 0
        for name, count, props in elements:
            if any(isinstance(t, tuple) for _, t in props):
                # Walk the records one by one to find where the element ends.
                for _ in range(count):
                    for _, t in props:
                        if isinstance(t, tuple):
                            ct = np.dtype(order + TYPES[t[1]])
                            n = int(np.frombuffer(body, ct, 1, pos)[0])
                            pos += ct.itemsize + n * np.dtype(TYPES[t[2]]).itemsize
                        else:
                            pos += np.dtype(TYPES[t]).itemsize
                continue
            dt = np.dtype([(p, order + TYPES[t]) for p, t in props])
            arr = np.frombuffer(body, dt, count, pos)
            pos += dt.itemsize * count
            data[name] = {p: arr[p].astype(arr[p].dtype.newbyteorder("=")) for p, _ in props}
    return elements, data


def close(a, b, rel=1e-6, abs_=1e-6):
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and np.allclose(a, b, rtol=rel, atol=abs_)


# Vertex properties each viewer shows, besides the scalar fields CloudCompare's command line
# makes of properties whose name contains one of CC_SCALAR_WORDS.
CC_SHOWS = {"x", "y", "z", "red", "green", "blue", "nx", "ny", "nz"}
CC_SCALAR_WORDS = ("scalar", "intensity")
MESHLAB_SHOWS = {"x", "y", "z", "red", "green", "blue", "alpha", "nx", "ny", "nz", "quality"}
# Largest coordinate error, relative to the cloud's extent.
COORD_REL = 1e-6


def report_coordinates(viewer, shown, vertex, problems, f32_shift=None):
    """Compares a viewer's coordinates (n x 3) with the file's; prints the largest error.
    f32_shift: the viewer stores float32 coordinates after adding this shift (CloudCompare),
    so half a float32 step of the shifted coordinate is allowed too."""
    xyz = np.stack([np.asarray(vertex[a], dtype=np.float64) for a in "xyz"], axis=1)
    if len(xyz) == 0:
        return
    diag = float(np.linalg.norm(xyz.max(axis=0) - xyz.min(axis=0)))
    magnitude = float(np.max(np.abs(xyz)))
    # Never below double rounding of the values (a single point has no extent).
    tol = max(COORD_REL * diag, 8 * np.finfo(np.float64).eps * magnitude)
    diff = np.abs(np.asarray(shown, dtype=np.float64) - xyz)
    err = float(np.max(diff))
    allowed = np.full(xyz.shape, tol)
    if f32_shift is not None:
        f32_step = np.abs(xyz + np.asarray(f32_shift)) * 2.0 ** -24 * 1.001
        allowed = np.maximum(allowed, f32_step)
    ok = bool(np.all(diff <= allowed))
    print(f"  {viewer}: coordinates {'match' if ok else 'DIFFER'} (largest difference "
          f"{err:.3g} = {err / diag if diag else 0:.2g} of the extent {diag:.4g}, "
          f"{err / magnitude if magnitude else 0:.2g} of the largest coordinate "
          f"{magnitude:.6g})")
    if ok and err > tol:
        print(f"  {viewer}: (more than {COORD_REL:g} of the extent, but within its own float "
              f"storage after its shift {tuple(f32_shift)}: the file's coordinates reached it)")
    if not ok:
        problems.append(f"{viewer}: coordinates differ by up to {err:.3g}, more than "
                        f"{COORD_REL:g} of the extent ({tol:.3g})")


def check_cloudcompare(path, vertex, problems):
    work = tempfile.mkdtemp(prefix="cc_check_")
    try:
        local = os.path.join(work, os.path.basename(path))
        shutil.copy(path, local)
        env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
        cmd = ["CloudCompare", "-SILENT", "-NO_TIMESTAMP", "-O", "-GLOBAL_SHIFT", "AUTO",
               local, "-C_EXPORT_FMT", "ASC", "-PREC", "12", "-SEP", "SPACE", "-ADD_HEADER",
               "-SAVE_CLOUDS"]
        r = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True, timeout=300)
        log = r.stdout + r.stderr
        if "loaded successfully" not in log and len(vertex["x"]) == 0 and \
                "nothing to load" in log:
            # An empty result (e.g. features.ply of a run that found no edge).
            print("  CloudCompare: refuses a file with 0 points (\"nothing to load\"), as "
                  "expected")
            return
        if "loaded successfully" not in log:
            problems.append(f"CloudCompare did not load it:\n{log[-2000:]}")
            print("  CloudCompare: FAILED to load")
            return
        exports = [f for f in os.listdir(work) if f.endswith(".asc")]
        if not exports:
            what = "it loaded a mesh (the file has faces)" if "mesh" in log.lower() else log[-500:]
            problems.append(f"CloudCompare exported no cloud to compare: {what}")
            print("  CloudCompare: loaded, but exported no cloud")
            return
        with open(os.path.join(work, exports[0])) as f:
            header = f.readline().lstrip("/").split()
            rows = np.loadtxt(f, ndmin=2)
        found = re.search(r"Found one cloud with (\d+) points", log)
        print(f"  CloudCompare: loaded, {rows.shape[0]} points"
              + (f" (log: {found.group(1)})" if found else "")
              + f"; fields: {' '.join(header)}")
        n = len(vertex["x"])
        if rows.shape[0] != n:
            problems.append(f"CloudCompare: {rows.shape[0]} points, the file has {n}")
            return
        col = {name: rows[:, i] for i, name in enumerate(header)}
        if not all(a in col for a in "XYZ"):
            problems.append(f"CloudCompare: no X Y Z columns in its export ({header})")
            return
        # CloudCompare keeps float32 coordinates after a global shift it chooses (only on axes
        # beyond 1e4); the log says which.
        shift = re.search(r"Translation: \(([-\d.e+]+) ; ([-\d.e+]+) ; ([-\d.e+]+)\)", log)
        shift = [float(v) for v in shift.groups()] if shift else [0.0, 0.0, 0.0]
        report_coordinates("CloudCompare", np.stack([col[a] for a in "XYZ"], axis=1),
                           vertex, problems, f32_shift=shift)
        for prop, values in vertex.items():
            if not any(w in prop for w in CC_SCALAR_WORDS):
                continue
            shown = prop[len("scalar_"):] if prop.startswith("scalar_") else prop
            name = shown if shown in col else prop if prop in col else None
            if name is None:
                problems.append(f"CloudCompare: scalar field of `{prop}` missing")
                print(f"  CloudCompare: `{prop}` MISSING")
            elif not close(col[name], values):
                problems.append(f"CloudCompare: values of `{prop}` differ")
                print(f"  CloudCompare: `{prop}` shown as `{name}` with DIFFERENT values")
            else:
                shown_range = (f", min {np.min(col[name]):.6g} max {np.max(col[name]):.6g}"
                               if len(values) else "")
                print(f"  CloudCompare: `{prop}` shown as scalar field `{name}`, values "
                      f"match{shown_range}")
        if all(c in vertex for c in ("red", "green", "blue")):
            ok = all(c in col for c in "RGB") and all(
                close(col[c], vertex[name]) for c, name in zip("RGB", ("red", "green", "blue")))
            print(f"  CloudCompare: colours {'match' if ok else 'MISSING or DIFFERENT'}")
            if not ok:
                problems.append("CloudCompare: colours missing or different")
    finally:
        shutil.rmtree(work, ignore_errors=True)


def check_meshlab(path, vertex, edge_count, edges, problems):
    import pymeshlab
    ms = pymeshlab.MeshSet()
    try:
        ms.load_new_mesh(path)
    except Exception as e:  # pymeshlab raises its own exception type
        problems.append(f"MeshLab did not load it: {e}")
        print(f"  MeshLab: FAILED to load: {e}")
        return
    m = ms.current_mesh()
    n = len(vertex["x"])
    print(f"  MeshLab: loaded, {m.vertex_number()} vertices, {m.edge_number()} edges, "
          f"{m.face_number()} faces; quality: {m.has_vertex_scalar()}, "
          f"colour: {m.has_vertex_color()}")
    if m.vertex_number() != n:
        problems.append(f"MeshLab: {m.vertex_number()} vertices, the file has {n}")
        return
    report_coordinates("MeshLab", m.vertex_matrix(), vertex, problems)
    if "quality" in vertex:
        ok = m.has_vertex_scalar() and close(m.vertex_scalar_array(), vertex["quality"])
        shown_range = (f" (min {np.min(m.vertex_scalar_array()):.6g} max "
                       f"{np.max(m.vertex_scalar_array()):.6g})" if ok and n else "")
        print(f"  MeshLab: quality {'matches' if ok else 'MISSING or DIFFERENT'}{shown_range}")
        if not ok:
            problems.append("MeshLab: quality missing or different")
    if all(c in vertex for c in ("red", "green", "blue")):
        rgb = np.stack([vertex[c] for c in ("red", "green", "blue")], axis=1) / 255.0
        ok = m.has_vertex_color() and close(m.vertex_color_matrix()[:, :3], rgb, abs_=1e-3)
        print(f"  MeshLab: colours {'match' if ok else 'MISSING or DIFFERENT'}")
        if not ok:
            problems.append("MeshLab: colours missing or different")
    if edge_count is not None:
        if m.edge_number() != edge_count:
            print(f"  MeshLab: {m.edge_number()} edges, the file has {edge_count}")
            problems.append(f"MeshLab: {m.edge_number()} edges, the file has {edge_count}")
        elif edges is not None:
            shown = np.sort(np.asarray(m.edge_matrix(), dtype=np.int64).reshape(-1, 2), axis=1)
            wanted = np.sort(np.stack([edges["vertex1"], edges["vertex2"]], axis=1)
                             .astype(np.int64), axis=1)
            # Compared as sets of vertex pairs, in case MeshLab reorders them.
            ok = sorted(map(tuple, shown)) == sorted(map(tuple, wanted))
            print(f"  MeshLab: {edge_count} edges, end points {'match' if ok else 'DIFFER'}")
            if not ok:
                problems.append("MeshLab: edge end points differ from the file's")


def check_file(path):
    """Checks one file with both viewers; returns the list of problems."""
    try:
        elements, data = read_ply(path)
    except Exception as e:
        print(f"  cannot parse it here: {e}")
        return [f"cannot parse it here: {e}"]
    vertex = data.get("vertex")
    if vertex is None:
        print("  no vertex element without lists: nothing to check")
        return ["no vertex element without lists"]
    edge_count = next((c for name, c, _ in elements if name == "edge"), None)
    edges = data.get("edge")
    if edges is not None and not all(k in edges for k in ("vertex1", "vertex2")):
        edges = None
    print(f"  file: {len(vertex['x'])} vertices, properties {' '.join(vertex)}"
          + (f", {edge_count} edges" if edge_count is not None else ""))
    problems = []
    # Not a failure: sharpedge's own fields all have names the viewers show (checked below);
    # what the input carried keeps its name (e.g. a LAS `classification`), which CloudCompare
    # offers only in its interactive PLY dialog.
    unseen = [p for p in vertex if not any(w in p for w in CC_SCALAR_WORDS)
              and p not in CC_SHOWS and p not in MESHLAB_SHOWS]
    if unseen:
        print(f"  note: not shown by either viewer's defaults (carried from the input?): "
              f"{' '.join(unseen)}")
    if edge_count is not None and edges is None:
        problems.append("`element edge` is not `int vertex1, int vertex2`")
    check_cloudcompare(path, vertex, problems)
    check_meshlab(path, vertex, edge_count, edges, problems)
    return problems


def self_test():
    """Writes a good file and files each check must catch; returns 1 unless the good one
    passes and every bad one fails for the expected reason."""
    header = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\n"
              "property double y\nproperty double z\nproperty float {name}\n"
              "property float quality\nproperty uchar red\nproperty uchar green\n"
              "property uchar blue\n{edge}end_header\n")
    # Georeferenced doubles, 2^-3 steps: exact in binary and in the ascii text.
    rows = "".join(f"{4101234.5 + 0.5 * i} {512345.125 - 0.25 * i} {80 + 0.125 * i} "
                   f"{0.25 * i} {0.5 * i} {50 * i} 7 {255 - 50 * i}\n" for i in range(4))
    # With input colours 1 2 3 before the real ones.
    clash_rows = "".join(f"{4101234.5 + 0.5 * i} {512345.125 - 0.25 * i} {80 + 0.125 * i} "
                         f"{0.25 * i} {0.5 * i} 1 {50 * i} 2 7 3 {255 - 50 * i}\n"
                         for i in range(4))
    good_edge = "element edge 2\nproperty int vertex1\nproperty int vertex2\n"
    list_edge = "element edge 2\nproperty list uchar int vertex_indices\n"
    cases = [
        ("good.ply", header.format(name="scalar_value", edge=good_edge) + rows
         + "0 1\n2 3\n", None),
        # CloudCompare would take `input_red`, the first property containing `red`, as colour.
        ("colour_clash.ply", header.format(name="scalar_value", edge="")
         .replace("property uchar red", "property uchar input_red\nproperty uchar red")
         .replace("property uchar green", "property uchar input_green\nproperty uchar green")
         .replace("property uchar blue", "property uchar input_blue\nproperty uchar blue")
         + clash_rows,
         "CloudCompare: colours missing or different"),
        # MeshLab paints a float `intensity` over the colours as grey.
        ("float_intensity.ply", header.format(name="intensity", edge="") + rows,
         "MeshLab: colours missing or different"),
        ("list_edges.ply", header.format(name="scalar_value", edge=list_edge) + rows
         + "2 0 1\n2 2 3\n", "`element edge` is not `int vertex1, int vertex2`"),
    ]
    work = tempfile.mkdtemp(prefix="viewer_self_test_")
    wrong = 0
    try:
        for name, text, expected in cases:
            path = os.path.join(work, name)
            with open(path, "w") as f:
                f.write(text)
            print(f"{name} (expected: {expected or 'OK'}):")
            problems = check_file(path)
            for p in problems:
                print(f"  PROBLEM: {p}")
            ok = not problems if expected is None else any(expected in p for p in problems)
            print(f"  self-test {'passed' if ok else 'FAILED'}")
            wrong += not ok
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"self-test: {len(cases) - wrong} of {len(cases)} cases as expected")
    return 1 if wrong else 0


def main(paths):
    if not paths:
        print(__doc__)
        return 2
    if paths == ["--self-test"]:
        return self_test()
    failed = 0
    for path in paths:
        print(f"{path}:")
        problems = check_file(path)
        if problems:
            failed += 1
            for p in problems:
                print(f"  PROBLEM: {p}")
        else:
            print("  OK")
    print(f"{len(paths) - failed} of {len(paths)} files OK")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
