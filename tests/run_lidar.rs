//! LAS/LAZ in, LAS/LAZ out through the real binary (issue 13): a LAS 1.4 point format 7 file
//! with extra bytes, a WKT CRS and two EVLRs, and a LAS 1.2 point format 1 file with GeoTIFF
//! keys, both written here with the las crate from the synthetic box, are run with the
//! automatic format and read back with the las crate. Every record keeps its bytes (unmoved
//! points entirely, moved points all but X/Y/Z, which sit on the file's grid where sharpedge
//! put them), the header keeps version, format, scale, offset and the VLRs, sharpedge's fields
//! follow as described extra bytes, edge points get the asked class, and edges.geojson holds
//! the edges and corners in the file's CRS. Also: `--format` and its errors, an edge class
//! the point format cannot store.

mod run_common;

use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use las::point::{Classification, Format};
use las::{Builder, Color, Point, Transform, Vector, Vlr};
use run_common::*;

const SCALE: f64 = 0.001;
const OFFSET: [f64; 3] = [512000.0, 4101000.0, 0.0];
const OURS: [&str; 5] = ["edge_id", "edge_kind", "moved", "displacement", "sharpness"];
/// Bytes of sharpedge's fields per point: i32, u8, u8, f32, f32.
const OURS_LEN: usize = 14;
const WKT: &str = r#"PROJCS["NAD83(HARN) / New Mexico Central (ftUS)",GEOGCS["NAD83(HARN)",AUTHORITY["EPSG","4152"]],UNIT["US survey foot",0.3048006096012192,AUTHORITY["EPSG","9003"]],AUTHORITY["EPSG","2903"]]"#;

/// An Extra Bytes descriptor (LAS 1.4 R15 Table 24), written here independently of sharpedge.
fn descriptor(data_type: u8, name: &str, description: &str) -> Vec<u8> {
    let mut d = vec![0u8; 192];
    d[2] = data_type;
    d[4..4 + name.len()].copy_from_slice(name.as_bytes());
    d[160..160 + description.len()].copy_from_slice(description.as_bytes());
    d
}

fn names_of_descriptors(data: &[u8]) -> Vec<(u8, String)> {
    data.chunks_exact(192)
        .map(|d| {
            let raw = &d[4..36];
            let end = raw.iter().position(|&b| b == 0).unwrap_or(32);
            (d[2], String::from_utf8_lossy(&raw[..end]).into_owned())
        })
        .collect()
}

fn vlr(user_id: &str, record_id: u16, data: Vec<u8>) -> Vlr {
    Vlr {
        user_id: user_id.into(),
        record_id,
        description: "test".into(),
        data,
    }
}

/// The synthetic box, moved to georeferenced coordinates and put on the file's grid.
fn box_points(dir: &Path) -> Vec<[f64; 3]> {
    let mut args = BOX.to_vec();
    args.extend(["--translate", "512345.1,4101234.5,80"]);
    let p = synth(dir, "box.ply", &args);
    read_cloud(&p)
        .positions
        .iter()
        .map(|p| [0, 1, 2].map(|k| ((p[k] - OFFSET[k]) / SCALE).round() * SCALE + OFFSET[k]))
        .collect()
}

/// Writes `positions` as LAS with varied attributes in every field the format has and
/// `extra` bytes per point.
fn write_input(
    path: &Path,
    version: (u8, u8),
    format: u8,
    extra: u16,
    positions: &[[f64; 3]],
    vlrs: Vec<Vlr>,
    evlrs: Vec<Vlr>,
) {
    let mut b = Builder::from(version);
    b.point_format = Format::new(format).unwrap();
    b.point_format.extra_bytes = extra;
    let t = |k: usize| Transform {
        scale: SCALE,
        offset: OFFSET[k],
    };
    b.transforms = Vector {
        x: t(0),
        y: t(1),
        z: t(2),
    };
    b.vlrs = vlrs;
    b.evlrs = evlrs;
    let header = b.into_header().unwrap();
    let f = *header.point_format();
    let mut w = las::Writer::from_path(path, header).unwrap();
    for (i, p) in positions.iter().enumerate() {
        let returns = if f.is_extended { 15 } else { 5 };
        w.write_point(Point {
            x: p[0],
            y: p[1],
            z: p[2],
            intensity: (i * 37 % 65536) as u16,
            return_number: (i % returns) as u8 + 1,
            number_of_returns: returns as u8,
            classification: Classification::new((i % 10) as u8).unwrap(),
            is_synthetic: i % 7 == 0,
            is_withheld: i % 11 == 0,
            scan_angle: if f.is_extended {
                (i % 60) as f32 * 0.5 - 15.0
            } else {
                (i % 61) as f32 - 30.0
            },
            user_data: (i % 256) as u8,
            point_source_id: (i % 1000) as u16,
            gps_time: f.has_gps_time.then_some(1000.0 + 0.25 * i as f64),
            color: f.has_color.then_some(Color {
                red: (i * 3) as u16,
                green: 65535 - i as u16,
                blue: (i % 256 * 256) as u16,
            }),
            nir: f.has_nir.then_some(i as u16),
            extra_bytes: (0..extra)
                .map(|k| (i * 13 + usize::from(k)) as u8)
                .collect(),
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
}

/// Header and raw records of a LAS/LAZ file, as the las crate reads them.
fn records(path: &Path) -> (las::Header, Vec<u8>) {
    let mut r = las::Reader::from_path(path).unwrap();
    let header = r.header().clone();
    let pd = r.read_all().unwrap();
    (header, pd.raw_bytes().to_vec())
}

/// Every EVLR of a LAS 1.4 file, read from the raw header (the las crate keeps only the
/// first).
fn all_evlrs(path: &Path) -> Vec<(String, u16, Vec<u8>)> {
    let mut f = std::fs::File::open(path).unwrap();
    let raw = las::raw::Header::read_from(&mut f).unwrap();
    let Some(e) = raw.evlr else { return Vec::new() };
    f.seek(SeekFrom::Start(e.start_of_first_evlr)).unwrap();
    (0..e.number_of_evlrs)
        .map(|_| {
            let v = Vlr::new(las::raw::Vlr::read_from(&mut f, true).unwrap());
            (v.user_id, v.record_id, v.data)
        })
        .collect()
}

/// sharpedge's fields of one output record.
struct Ours {
    edge_id: i32,
    kind: u8,
    moved: u8,
    displacement: f32,
}

fn ours(rec: &[u8], at: usize) -> Ours {
    let f32_at = |o: usize| f32::from_le_bytes(rec[at + o..at + o + 4].try_into().unwrap());
    Ours {
        edge_id: i32::from_le_bytes(rec[at..at + 4].try_into().unwrap()),
        kind: rec[at + 4],
        moved: rec[at + 5],
        displacement: f32_at(6),
    }
}

/// Compares input and output record by record; returns the number of moved points. `class`:
/// the class edge points must have (and the offset of the class byte), else classes are
/// unchanged.
fn check_records(
    input: &(las::Header, Vec<u8>),
    output: &(las::Header, Vec<u8>),
    class: Option<(u8, usize, bool)>,
) -> usize {
    let (hi, ri) = input;
    let (ho, ro) = output;
    let li = usize::from(hi.point_format().len());
    let lo = usize::from(ho.point_format().len());
    assert_eq!(lo, li + OURS_LEN, "sharpedge's 14 bytes appended");
    let n = ri.len() / li;
    assert_eq!(ro.len() / lo, n, "point count");
    let t = hi.transforms();
    let mut moved = 0;
    let mut edge_points = 0;
    for i in 0..n {
        let a = &ri[i * li..(i + 1) * li];
        let b = &ro[i * lo..(i + 1) * lo];
        let o = ours(b, li);
        assert_eq!(
            o.kind == 2,
            o.edge_id >= 0,
            "point {i}: edge_kind 2 iff edge_id set"
        );
        let mut want = a.to_vec();
        if let Some((c, at, legacy)) = class
            && o.edge_id >= 0
        {
            want[at] = if legacy { (a[at] & 0xE0) | c } else { c };
        }
        edge_points += usize::from(o.edge_id >= 0);
        if o.moved == 0 {
            assert_eq!(&b[..li], &want[..], "point {i}: unmoved record changed");
            assert_eq!(o.displacement, 0.0, "point {i}");
            continue;
        }
        moved += 1;
        assert!(o.edge_id >= 0, "point {i}: moved without an edge");
        // All but X/Y/Z kept; the new position on the grid, as far from the old one as
        // `displacement` says (to the grid's rounding).
        assert_eq!(
            &b[12..li],
            &want[12..],
            "point {i}: attributes of a moved point changed"
        );
        let xyz = |r: &[u8]| {
            [0, 1, 2].map(|k| i32::from_le_bytes(r[4 * k..4 * k + 4].try_into().unwrap()))
        };
        let (pa, pb) = (xyz(a), xyz(b));
        let tr = [t.x, t.y, t.z];
        let d = (0..3)
            .map(|k| (tr[k].direct(pb[k]) - tr[k].direct(pa[k])).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            (d - f64::from(o.displacement)).abs() <= SCALE,
            "point {i}: moved {d}, displacement says {}",
            o.displacement
        );
    }
    assert!(edge_points > 0, "edge points were labelled");
    moved
}

/// `sharpedge run pipeline.toml --input INPUT --out OUT EXTRA...` in the case's folder.
fn run_to(c: &Case, input: &str, out: &str, extra: &[&str]) -> Run {
    let mut args = vec!["run", "pipeline.toml", "--input", input, "--out", out];
    args.extend_from_slice(extra);
    sharpedge(c.path(), &args)
}

fn geojson(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("edges.geojson")).unwrap()).unwrap()
}

/// A run that must be refused before any work: exit 1, the message `parts`, no `out` folder.
fn refused(c: &Case, input: &str, out: &str, extra: &[&str], parts: &[&str]) {
    let r = run_to(c, input, out, extra);
    assert_failed_cleanly(&r, parts, &c.path().join(out));
    assert!(!c.path().join(out).exists(), "{out} left behind");
}

fn extra_bytes_vlr(h: &las::Header) -> Vec<(u8, String)> {
    let v = h
        .vlrs()
        .iter()
        .find(|v| v.user_id == "LASF_Spec" && v.record_id == 4)
        .expect("an Extra Bytes VLR");
    names_of_descriptors(&v.data)
}

#[test]
fn las14_format7_with_extra_bytes_crs_and_evlrs_round_trips() {
    let c = Case::new();
    let pts = box_points(c.path());
    let input = c.path().join("scan.las");
    // The input's own extra bytes: a u8 and an i32 named like one of sharpedge's fields.
    let eb = [
        descriptor(1, "quality_flag", "input u8"),
        descriptor(6, "edge_id", "input's own edge id"),
    ]
    .concat();
    let wkt = [WKT.as_bytes(), &[0]].concat();
    write_input(
        &input,
        (1, 4),
        7,
        5,
        &pts,
        vec![
            vlr("LASF_Spec", 4, eb),
            vlr("LASF_Projection", 2112, wkt.clone()),
            vlr("custom", 77, b"kept as is".to_vec()),
        ],
        vec![
            vlr("first_evlr", 1, vec![1, 2, 3]),
            vlr("second_evlr", 2, vec![4, 5, 6, 7]),
        ],
    );
    assert_eq!(all_evlrs(&input).len(), 2, "the test input holds two EVLRs");
    c.run("scan.las", &["-q"]).assert_ok();
    assert_eq!(
        entries(&c.out()),
        [
            ".sharpedge-current",
            ".sharpedge-run-*",
            "edges.geojson",
            "features.ply",
            "rectified.las",
            "report.json"
        ]
    );
    let out_path = c.out().join("rectified.las");
    let (i, o) = (records(&input), records(&out_path));
    let (hi, ho) = (&i.0, &o.0);
    assert_eq!(ho.version(), las::Version::new(1, 4));
    assert_eq!(ho.point_format().to_u8().unwrap(), 7);
    assert_eq!(ho.point_format().extra_bytes, 5 + OURS_LEN as u16);
    assert_eq!(ho.transforms(), hi.transforms());
    let moved = check_records(&i, &o, None);
    assert!(
        moved > 100,
        "the box's edges were rectified ({moved} points)"
    );
    assert_eq!(report(&c.out())["counts"]["moved"], moved);
    // VLRs: the CRS and the custom one byte for byte; the input's descriptors first, the
    // clashing name renamed, then sharpedge's.
    let find = |h: &las::Header, u: &str, r: u16| {
        h.vlrs()
            .iter()
            .find(|v| v.user_id == u && v.record_id == r)
            .map(|v| v.data.clone())
    };
    assert_eq!(find(ho, "LASF_Projection", 2112), Some(wkt));
    assert_eq!(find(ho, "custom", 77), Some(b"kept as is".to_vec()));
    let mut want: Vec<(u8, String)> = vec![(1, "quality_flag".into()), (6, "input_edge_id".into())];
    want.extend([6, 1, 1, 9, 9].into_iter().zip(OURS.map(String::from)));
    assert_eq!(extra_bytes_vlr(ho), want);
    assert!(ho.has_wkt_crs());
    // Both EVLRs, though the las crate's reader sees only the first.
    assert_eq!(
        all_evlrs(&out_path),
        [
            ("first_evlr".to_string(), 1, vec![1, 2, 3]),
            ("second_evlr".to_string(), 2, vec![4, 5, 6, 7])
        ]
    );
    // edges.geojson: every edge and corner, in the WKT's CRS (its EPSG authority).
    let rep = report(&c.out());
    let g = geojson(&c.out());
    assert_eq!(g["type"], "FeatureCollection");
    assert_eq!(g["crs"]["properties"]["name"], "urn:ogc:def:crs:EPSG::2903");
    let edges = rep["edges"].as_array().unwrap();
    let corners = rep["corners"].as_array().unwrap();
    assert_eq!(edges.len(), 12, "the box's 12 edges");
    assert_eq!(corners.len(), 8, "the box's 8 corners");
    let features = g["features"].as_array().unwrap();
    assert_eq!(features.len(), 20);
    for (f, e) in features.iter().zip(edges) {
        assert_eq!(f["geometry"]["type"], "LineString");
        assert_eq!(f["geometry"]["coordinates"], e["polyline"]);
        assert_eq!(f["properties"]["id"], e["id"]);
        assert_eq!(f["properties"]["kind"], "edge");
        assert_eq!(f["properties"]["edge_kind"], "sharp");
        assert_eq!(f["properties"]["edge_kind"], e["kind"]);
        assert_eq!(f["properties"]["convex"], e["convex"]);
        assert_eq!(f["properties"]["dihedral"], e["dihedral_deg"]);
        assert_eq!(f["properties"]["rms"], e["rms"]);
    }
    for (f, k) in features[12..].iter().zip(corners) {
        assert_eq!(f["geometry"]["type"], "Point");
        assert_eq!(f["geometry"]["coordinates"], k["position"]);
        assert_eq!(f["properties"]["kind"], "corner");
        assert!(f["properties"]["edge_kind"].is_null());
    }
    // Georeferenced: the corner lies near the translated box.
    let x = features[12]["geometry"]["coordinates"][0].as_f64().unwrap();
    assert!((x - 512345.1).abs() < 100.0, "{x}");
}

#[test]
fn las12_format1_with_geotiff_round_trips_and_classifies_edges() {
    let c = Case::new();
    let pts = box_points(c.path());
    let input = c.path().join("scan.las");
    let keys: Vec<u8> = [1u16, 1, 0, 1, 3072, 0, 1, 32611]
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .collect();
    write_input(
        &input,
        (1, 2),
        1,
        0,
        &pts,
        vec![vlr("LASF_Projection", 34735, keys.clone())],
        Vec::new(),
    );
    config(
        c.path(),
        "[output]\nclassify_edges = true\nedge_class = 20\n",
    );
    c.run("scan.las", &["-q"]).assert_ok();
    let (i, o) = (records(&input), records(&c.out().join("rectified.las")));
    assert_eq!(o.0.version(), las::Version::new(1, 2));
    assert_eq!(o.0.point_format().to_u8().unwrap(), 1);
    assert!(
        o.0.vlrs()
            .iter()
            .any(|v| v.record_id == 34735 && v.data == keys)
    );
    // Format 1's class byte is at 15; its top three bits (synthetic, key-point, withheld)
    // stay.
    let moved = check_records(&i, &o, Some((20, 15, true)));
    assert!(moved > 100, "{moved}");
    assert_eq!(
        extra_bytes_vlr(&o.0),
        [6, 1, 1, 9, 9]
            .into_iter()
            .zip(OURS.map(String::from))
            .collect::<Vec<_>>()
    );
    let g = geojson(&c.out());
    assert_eq!(
        g["crs"]["properties"]["name"],
        "urn:ogc:def:crs:EPSG::32611"
    );
    // The same run as LAZ: the same records once decompressed, a new laszip VLR.
    let r = run_to(&c, "scan.las", "laz", &["-q", "--format", "laz"]);
    r.assert_ok();
    let z = records(&c.path().join("laz/rectified.laz"));
    assert!(z.1 == o.1, "LAZ and LAS outputs differ");
    assert!(z.0.point_format().is_compressed);
    // Format 1 stores classes up to 31 only: refused before any work.
    config(
        c.path(),
        "[output]\nclassify_edges = true\nedge_class = 64\n",
    );
    refused(
        &c,
        "scan.las",
        "big",
        &[],
        &[
            "output.edge_class",
            "class 64 does not fit point format 1",
            "0..=31",
        ],
    );
}

#[test]
fn format_option_chooses_ply_for_las_and_refuses_las_for_ply() {
    let c = Case::new();
    let pts = box_points(c.path());
    write_input(
        &c.path().join("scan.las"),
        (1, 2),
        3,
        0,
        &pts,
        Vec::new(),
        Vec::new(),
    );
    c.run("scan.las", &["-q", "--format", "ply"]).assert_ok();
    assert_eq!(entries(&c.out()), PLY_OUTPUTS);
    let rect = read_cloud(&c.out().join("rectified.ply"));
    assert_eq!(rect.len(), pts.len());
    assert_eq!(column(&rect, "intensity")[5], (5 * 37) as f64);
    // No CRS in the input: the GeoJSON says so instead of implying WGS84.
    let g = geojson(&c.out());
    assert_eq!(g["crs"]["properties"]["name"], sharpedge::io::NO_CRS);
    // A PLY input has no LAS header to write back.
    refused(
        &c,
        "box.ply",
        "las_out",
        &["--format", "las"],
        &[
            "output.format",
            "box.ply",
            "a LAS or LAZ output is written from a LAS or LAZ input",
        ],
    );
    // And from the pipeline file, with its line.
    config(c.path(), "[output]\nformat = \"las3\"\n");
    refused(
        &c,
        "scan.las",
        "bad",
        &[],
        &[
            "pipeline.toml:2: output.format: must be one of \"auto\", \"ply\", \"las\", \"laz\", \"pcd\", \"e57\", got \"las3\"",
        ],
    );
    let mut f = std::fs::File::open(c.path().join("scan.las")).unwrap();
    let mut sig = [0u8; 4];
    f.read_exact(&mut sig).unwrap();
    assert_eq!(&sig, b"LASF", "the input is left alone");
}
