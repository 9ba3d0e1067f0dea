#!/usr/bin/env python3
"""Checks a LAS/LAZ run of sharpedge with the tools GIS users have: laspy (+ lazrs) for the
rectified cloud, GDAL's ogrinfo for edges.geojson.

Usage: check_lidar.py SHARPEDGE PIPELINE.toml INPUT... [--work DIR]
       check_lidar.py --self-test SHARPEDGE PIPELINE.toml INPUT   (broken outputs must fail)

For each input it runs `sharpedge run` with the automatic output format into DIR/<name>/ and
compares input and output point by point: the same point count, version, point format,
scales and offsets; the same dimensions plus sharpedge's extra bytes (edge_id, edge_kind,
moved, displacement, sharpness, with their descriptions); the same CRS VLRs (WKT and GeoTIFF,
byte for byte); every other dimension equal point by point; X/Y/Z raw integers identical for
every point whose `moved` is 0 and within the rounding of the file's grid of sharpedge's
positions for moved ones. Then `ogrinfo` must read edges.geojson with as many features as
report.json has edges and corners, and with the input's CRS. Exit code 0 when all pass.
"""

import json
import os
import re
import subprocess
import sys
import tempfile

import laspy
import numpy as np

OURS = {
    "edge_id": "sharpedge edge id, -1 = none",
    "edge_kind": "0face 1candidate 2edge 3outlier",
    "moved": "1 = moved onto the fitted edge",
    "displacement": "distance moved, in model units",
    "sharpness": "normal split: edge score",
}
CRS_RECORDS = {2111, 2112, 34735, 34736, 34737}


class Failure(Exception):
    pass


def check(cond, what):
    if not cond:
        raise Failure(what)


def crs_vlrs(header):
    return sorted(
        (v.user_id, v.record_id, bytes(v.record_data_bytes()))
        for v in list(header.vlrs) + list(header.evlrs or [])
        if v.user_id == "LASF_Projection" and v.record_id in CRS_RECORDS
    )


def wkt_of(header):
    for v in list(header.vlrs) + list(header.evlrs or []):
        if v.user_id == "LASF_Projection" and v.record_id == 2112:
            return bytes(v.record_data_bytes()).split(b"\0")[0].decode("utf-8", "replace")
    return None


def geotiff_epsg(header):
    """The EPSG code of the GeoTIFF keys (projected, else geographic), or None."""
    for v in header.vlrs:
        if v.user_id == "LASF_Projection" and v.record_id == 34735:
            words = np.frombuffer(bytes(v.record_data_bytes()), dtype="<u2")
            keys = {int(words[4 + 4 * k]): words[4 + 4 * k: 8 + 4 * k]
                    for k in range(int(words[3]))}
            for key in (3072, 2048):
                e = keys.get(key)
                if e is not None and e[1] == 0 and e[3] not in (0, 32767):
                    return int(e[3])
    return None


def compare_las(inp, out):
    """Returns a summary line; raises Failure on the first difference."""
    a = laspy.read(inp)
    b = laspy.read(out)
    ha, hb = a.header, b.header
    check(len(a.points) == len(b.points), f"point count {len(a.points)} -> {len(b.points)}")
    check(str(ha.version) == str(hb.version), f"version {ha.version} -> {hb.version}")
    check(ha.point_format.id == hb.point_format.id,
          f"point format {ha.point_format.id} -> {hb.point_format.id}")
    check(np.array_equal(ha.scales, hb.scales), f"scales {ha.scales} -> {hb.scales}")
    check(np.array_equal(ha.offsets, hb.offsets), f"offsets {ha.offsets} -> {hb.offsets}")
    dims_a = list(a.point_format.dimension_names)
    dims_b = list(b.point_format.dimension_names)
    input_extra = list(a.point_format.extra_dimension_names)
    # An input dimension named like one of ours is kept as input_<name>.
    expected = [d if d not in OURS or d not in input_extra else "input_" + d for d in dims_a]
    check(dims_b == expected + list(OURS),
          f"dimensions {dims_a} -> {dims_b} (expected the input's plus {list(OURS)})")
    descr = {}
    for v in hb.vlrs:
        if v.user_id == "LASF_Spec" and v.record_id == 4:
            for info in v.extra_bytes_structs:
                descr[info.name.rstrip(b"\0").decode()] = info.description.rstrip(b"\0").decode()
    for name, text in OURS.items():
        check(descr.get(name) == text, f"extra bytes {name}: description {descr.get(name)!r}")
    check(crs_vlrs(ha) == crs_vlrs(hb), "CRS VLRs differ")
    # Every other (E)VLR is kept byte for byte, except those that describe a layout that is
    # not written again: laszip (rewritten by the LAZ writer), COPC's (the output is no COPC
    # octree) and the Extra Bytes VLR (rewritten with ours appended).
    def kept(h):
        return sorted((v.user_id, v.record_id, bytes(v.record_data_bytes()))
                      for v in list(h.vlrs) + list(h.evlrs or [])
                      if v.user_id not in ("laszip encoded", "copc")
                      and (v.user_id, v.record_id) != ("LASF_Spec", 4))
    check(kept(ha) == kept(hb), "the VLRs and EVLRs other than laszip/COPC/extra bytes differ")
    check(not any(v.user_id == "copc" for v in hb.vlrs), "a COPC VLR in a non-COPC output")
    moved = np.asarray(b["moved"]) != 0
    n_moved = int(moved.sum())
    for d in dims_a:
        if d in ("X", "Y", "Z"):
            continue
        va, vb = np.asarray(a[d]), np.asarray(b[expected[dims_a.index(d)]])
        eq = (va == vb) | (np.isnan(va) & np.isnan(vb)) if va.dtype.kind == "f" else va == vb
        bad = np.flatnonzero(~eq)
        check(bad.size == 0, f"{d} differs at {bad.size} points, first {bad[:5].tolist()}")
    for axis in "XYZ":
        ra, rb = np.asarray(a[axis]), np.asarray(b[axis])
        differ = np.flatnonzero((ra != rb) & ~moved)
        check(differ.size == 0,
              f"{axis}: {differ.size} unmoved points changed, first {differ[:5].tolist()}")
    # A moved point moved by its recorded displacement (to the file's grid).
    if n_moved:
        pa = np.stack([np.asarray(a.x), np.asarray(a.y), np.asarray(a.z)], axis=1)[moved]
        pb = np.stack([np.asarray(b.x), np.asarray(b.y), np.asarray(b.z)], axis=1)[moved]
        dist = np.linalg.norm(pb - pa, axis=1)
        grid = float(np.linalg.norm(ha.scales))
        err = np.abs(dist - np.asarray(b["displacement"])[moved])
        check(err.max() <= grid + 1e-4 * max(1.0, float(dist.max())),
              f"moved points: |distance - displacement| up to {err.max()} (grid {grid})")
    edge_ids = np.asarray(b["edge_id"])
    kinds = np.asarray(b["edge_kind"])
    check(np.array_equal(edge_ids >= 0, kinds == 2), "edge_kind 2 exactly where edge_id >= 0")
    check(not np.any(moved & (edge_ids < 0)), "a moved point without an edge id")
    return (f"{len(b.points)} points, LAS {hb.version} format {hb.point_format.id}, "
            f"{len(dims_a)} dimensions + {len(OURS)} extra bytes, {len(crs_vlrs(hb))} CRS VLRs, "
            f"{len(kept(hb))} (E)VLRs kept, "
            f"{n_moved} moved, {len(dims_a) - 3} attributes equal, unmoved X/Y/Z identical")


def ogr_check(geojson, report, wkt, epsg=None):
    r = subprocess.run(["ogrinfo", "-ro", "-al", "-so", geojson], capture_output=True, text=True)
    check(r.returncode == 0, f"ogrinfo failed: {r.stderr.strip()}")
    m = re.search(r"Feature Count: (\d+)", r.stdout)
    want = len(report["edges"]) + len(report["corners"])
    check(m is not None and int(m.group(1)) == want,
          f"ogrinfo feature count {m.group(1) if m else None}, report has {want}")
    # A layer of edges and corners mixes lines and points: its summary says "Unknown (any)",
    # so the features themselves must show their Z.
    three_d = "3D" in r.stdout
    if want and not three_d:
        full = subprocess.run(["ogrinfo", "-ro", "-al", geojson], capture_output=True, text=True)
        three_d = re.search(r"\b(LINESTRING|POINT) Z \(", full.stdout) is not None
    check(want == 0 or three_d, "ogrinfo sees no 3D geometry")
    srs = r.stdout.split("Layer SRS WKT:", 1)[-1].split("\nData axis", 1)[0].strip()
    top = re.match(r'^\w+\["([^"]*)"', srs)
    check(top is not None, f"ogrinfo reports no layer CRS: {srs[:200]}")
    if wkt is None and epsg is not None:
        check(f'ID["EPSG",{epsg}]' in srs, f"ogrinfo's CRS is not EPSG:{epsg}: {srs[:200]}")
        crs = f"EPSG:{epsg} (GeoTIFF keys)"
    elif wkt is None:
        check(re.match(r"^(ENGCRS|LOCAL_CS)\[", srs) is not None,
              f"an input without CRS must give a local (engineering) CRS, not {top.group(1)}")
        crs = "local (no CRS in the input)"
    else:
        # GDAL's CRS must be the one the input's WKT names (by name: the EPSG database and
        # the input spell the rest differently).
        name = re.match(r'^\w+\["([^"]*)"', wkt).group(1)
        check(top.group(1) == name, f"ogrinfo's CRS is {top.group(1)!r}, the input's {name!r}")
        code = re.search(r'\n    ID\["EPSG",(\d+)\]\]$', srs)
        crs = repr(name) + (f" (EPSG:{code.group(1)})" if code else "")
    return f"ogrinfo: {want} features, CRS {crs}"


def run_one(sharpedge, config, inp, work):
    name = os.path.basename(inp)
    out = os.path.join(work, name)
    r = subprocess.run([sharpedge, "-q", "run", config, "--input", inp, "--out", out],
                       capture_output=True, text=True)
    check(r.returncode == 0, f"sharpedge run failed: {r.stderr.strip()}")
    ext = "laz" if inp.lower().endswith(".laz") else "las"
    rect = os.path.join(out, f"rectified.{ext}")
    check(os.path.exists(rect), f"no rectified.{ext} in {sorted(os.listdir(out))}")
    report = json.load(open(os.path.join(out, "report.json")))
    a = laspy.read(inp)
    return rect, report, a.header, out


def check_file(sharpedge, config, inp, work):
    rect, report, header, out = run_one(sharpedge, config, inp, work)
    las = compare_las(inp, rect)
    ogr = ogr_check(os.path.join(out, "edges.geojson"), report, wkt_of(header),
                    geotiff_epsg(header))
    return f"{las}; {ogr}"


def self_test(sharpedge, config, inp, work):
    """Each broken copy of a good output must be caught."""
    rect, report, header, out = run_one(sharpedge, config, inp, work)
    b = laspy.read(rect)
    caught = []

    def expect_failure(label, mutate):
        c = laspy.read(rect)
        mutate(c)
        path = os.path.join(work, "broken.las")
        c.write(path)
        try:
            compare_las(inp, path)
        except Failure as e:
            caught.append(f"{label}: caught ({e})")
            return
        raise Failure(f"self-test: {label} was not caught")

    unmoved = int(np.flatnonzero(np.asarray(b["moved"]) == 0)[0])

    def shift_unmoved(c):
        c.X[unmoved] += 1

    def change_intensity(c):
        c.intensity[7] ^= 1

    def change_gps(c):
        if "gps_time" in c.point_format.dimension_names:
            c.gps_time[3] += 1e-6
        else:
            c.user_data[3] ^= 1

    expect_failure("an unmoved point's X off by one unit", shift_unmoved)
    expect_failure("one intensity changed", change_intensity)
    expect_failure("one GPS time (or user data) changed", change_gps)
    def drop_crs(c):
        keep = [v for v in c.header.vlrs if v.user_id != "LASF_Projection"]
        c.header.vlrs.clear()
        c.header.vlrs.extend(keep)

    if crs_vlrs(header):
        expect_failure("CRS VLRs removed", drop_crs)
    geo = os.path.join(out, "edges.geojson")
    doc = json.load(open(geo))
    doc["features"] = doc["features"][1:]
    json.dump(doc, open(geo, "w"))
    try:
        ogr_check(geo, report, wkt_of(header))
        raise Failure("self-test: a missing GeoJSON feature was not caught")
    except Failure as e:
        if "self-test" in str(e):
            raise
        caught.append(f"GeoJSON feature removed: caught ({e})")
    return caught


def main(argv):
    work = None
    if "--work" in argv:
        i = argv.index("--work")
        work = argv[i + 1]
        del argv[i:i + 2]
    selftest = argv[:1] == ["--self-test"]
    if selftest:
        argv = argv[1:]
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    sharpedge, config, inputs = argv[0], argv[1], argv[2:]
    work = work or tempfile.mkdtemp(prefix="check_lidar-")
    if selftest:
        for line in self_test(sharpedge, config, inputs[0], work):
            print("self-test " + line)
        print("self-test passed")
        return 0
    failed = 0
    for inp in inputs:
        try:
            print(f"ok   {os.path.basename(inp)}: {check_file(sharpedge, config, inp, work)}")
        except Failure as e:
            failed += 1
            print(f"FAIL {os.path.basename(inp)}: {e}")
    print(f"{len(inputs) - failed} of {len(inputs)} passed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
