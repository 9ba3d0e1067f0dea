//! LAS and LAZ: files written here with the las crate's writer in LAS 1.0, 1.2 and 1.4 and
//! point formats 0–3 and 6–8, read back with every attribute; LAS and LAZ copies give the same
//! cloud; chunked reads across chunk boundaries; georeferenced coordinates keep their
//! precision.

use std::path::Path;

use las::point::{Classification, Format};
use las::{Builder, Color, Point, Transform, Vector};
use sharpedge::io::{self, ReadOptions};
use sharpedge::{Cloud, Column};

const SCALE: f64 = 0.001;
const OFFSET: [f64; 3] = [512000.0, 4101000.0, 0.0];

fn points(n: usize, format: &Format) -> Vec<Point> {
    let extended = format.is_extended;
    (0..n)
        .map(|i| {
            let t = i as f64;
            // Values on the file's grid, so the expected coordinates are exact multiples.
            let grid = |v: f64| (v / SCALE).round() * SCALE;
            // LAS before 1.3 counts at most 5 returns.
            let returns = if extended { 15 } else { 5 };
            Point {
                x: grid(512345.123 + 0.01 * t),
                y: grid(4101234.567 - 0.02 * t),
                z: grid(80.5 + 0.001 * t),
                intensity: (i * 37 % 65536) as u16,
                return_number: (i % returns) as u8 + 1,
                number_of_returns: returns as u8,
                // 12 (overlap) is reserved: the las crate expresses it as a flag.
                classification: Classification::new({
                    let c = (i % if extended { 200 } else { 30 }) as u8;
                    if c >= 12 { c + 1 } else { c }
                })
                .expect("valid class"),
                scan_angle: if extended {
                    (i % 60) as f32 * 0.5 - 15.0
                } else {
                    (i % 61) as f32 - 30.0
                },
                user_data: (i % 256) as u8,
                point_source_id: (i % 1000) as u16,
                gps_time: format.has_gps_time.then_some(1000.0 + 0.25 * t),
                color: format.has_color.then_some(Color {
                    red: (i * 3) as u16,
                    green: 65535 - i as u16,
                    blue: (i % 256 * 256) as u16,
                }),
                nir: format.has_nir.then_some(i as u16),
                ..Default::default()
            }
        })
        .collect()
}

fn write_las(path: &Path, version: (u8, u8), format: u8, pts: &[Point]) {
    let mut b = Builder::from(version);
    b.point_format = Format::new(format).expect("format");
    b.transforms = Vector {
        x: Transform {
            scale: SCALE,
            offset: OFFSET[0],
        },
        y: Transform {
            scale: SCALE,
            offset: OFFSET[1],
        },
        z: Transform {
            scale: SCALE,
            offset: OFFSET[2],
        },
    };
    let header = b.into_header().expect("header");
    let mut w = las::Writer::from_path(path, header).expect("writer");
    for p in pts {
        w.write_point(p.clone()).expect("write point");
    }
    w.close().expect("close");
}

fn column<'a>(c: &'a Cloud, name: &str) -> &'a Column {
    &c.attribute(name)
        .unwrap_or_else(|| panic!("attribute {name} missing"))
        .values
}

fn check_cloud(c: &Cloud, pts: &[Point], format: &Format) {
    assert_eq!(c.len(), pts.len());
    assert!(c.is_consistent());
    for (i, (got, p)) in c.positions.iter().zip(pts).enumerate() {
        let want = [p.x, p.y, p.z];
        for k in 0..3 {
            assert!(
                (got[k] - want[k]).abs() < 1e-9,
                "point {i} axis {k}: {} vs {}",
                got[k],
                want[k]
            );
        }
    }
    let u16s = |f: &dyn Fn(&Point) -> u16| Column::U16(pts.iter().map(f).collect());
    let u8s = |f: &dyn Fn(&Point) -> u8| Column::U8(pts.iter().map(f).collect());
    assert_eq!(column(c, "intensity"), &u16s(&|p| p.intensity));
    assert_eq!(column(c, "return_number"), &u8s(&|p| p.return_number));
    assert_eq!(
        column(c, "number_of_returns"),
        &u8s(&|p| p.number_of_returns)
    );
    assert_eq!(
        column(c, "classification"),
        &u8s(&|p| u8::from(p.classification))
    );
    assert_eq!(column(c, "user_data"), &u8s(&|p| p.user_data));
    assert_eq!(column(c, "point_source_id"), &u16s(&|p| p.point_source_id));
    let Column::F32(angles) = column(c, "scan_angle") else {
        panic!("scan_angle must be f32")
    };
    // Extended formats store the angle in 0.006° steps.
    let step = if format.is_extended { 0.006 } else { 1e-6 };
    for (a, p) in angles.iter().zip(pts) {
        assert!((a - p.scan_angle).abs() <= step, "{a} vs {}", p.scan_angle);
    }
    match format.has_gps_time {
        true => assert_eq!(
            column(c, "gps_time"),
            &Column::F64(pts.iter().map(|p| p.gps_time.unwrap_or(f64::NAN)).collect())
        ),
        false => assert!(c.attribute("gps_time").is_none()),
    }
    if format.has_color {
        let col = |f: &dyn Fn(&Color) -> u16| {
            Column::U16(
                pts.iter()
                    .map(|p| f(&p.color.unwrap_or_default()))
                    .collect(),
            )
        };
        assert_eq!(column(c, "red"), &col(&|k| k.red));
        assert_eq!(column(c, "green"), &col(&|k| k.green));
        assert_eq!(column(c, "blue"), &col(&|k| k.blue));
    } else {
        assert!(c.attribute("red").is_none());
    }
    match format.has_nir {
        true => assert_eq!(column(c, "nir"), &u16s(&|p| p.nir.unwrap_or(0))),
        false => assert!(c.attribute("nir").is_none()),
    }
}

#[test]
fn every_version_and_point_format_reads_back_as_las_and_laz() {
    let dir = tempfile::tempdir().unwrap();
    for (version, format) in [
        ((1, 0), 0),
        ((1, 1), 1),
        ((1, 2), 2),
        ((1, 2), 3),
        ((1, 3), 3),
        ((1, 4), 6),
        ((1, 4), 7),
        ((1, 4), 8),
    ] {
        let f = Format::new(format).unwrap();
        let pts = points(500, &f);
        let mut clouds = Vec::new();
        for ext in ["las", "laz"] {
            let path = dir
                .path()
                .join(format!("v{}{}_f{format}.{ext}", version.0, version.1));
            write_las(&path, version, format, &pts);
            let c = io::read(&path, &ReadOptions::default()).unwrap();
            check_cloud(&c, &pts, &f);
            let kind = if ext == "las" { "LAS" } else { "LAZ" };
            assert_eq!(
                c.source.format,
                format!("{kind} {}.{}, point format {format}", version.0, version.1)
            );
            // 0.001 is finer than f32's 1/4 step at 4.1e6.
            assert!(c.source.double_precision);
            clouds.push(c);
        }
        // Identical points and attributes; only the path and format string differ.
        assert_eq!(clouds[0].positions, clouds[1].positions);
        assert_eq!(clouds[0].attributes, clouds[1].attributes);
    }
}

#[test]
fn reads_across_chunk_boundaries() {
    // More points than one fill_points chunk (2^18).
    let dir = tempfile::tempdir().unwrap();
    let f = Format::new(1).unwrap();
    let pts = points(300_001, &f);
    let path = dir.path().join("big.laz");
    write_las(&path, (1, 2), 1, &pts);
    let c = io::read(&path, &ReadOptions::default()).unwrap();
    check_cloud(&c, &pts, &f);
}

#[test]
fn coarse_scale_near_the_origin_does_not_need_double() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("local.las");
    let mut b = Builder::from((1, 2));
    b.transforms = Vector {
        x: Transform {
            scale: 0.01,
            offset: 0.0,
        },
        y: Transform {
            scale: 0.01,
            offset: 0.0,
        },
        z: Transform {
            scale: 0.01,
            offset: 0.0,
        },
    };
    let mut w = las::Writer::from_path(&path, b.into_header().unwrap()).unwrap();
    for i in 0..10 {
        w.write_point(Point {
            x: f64::from(i),
            y: 2.5,
            z: -1.25,
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
    let c = io::read(&path, &ReadOptions::default()).unwrap();
    assert_eq!(c.positions[3], [3.0, 2.5, -1.25]);
    // f32 holds 0.01 steps below 10 easily.
    assert!(!c.source.double_precision);
}

#[test]
fn empty_las_is_an_empty_cloud() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.las");
    write_las(&path, (1, 2), 3, &[]);
    let c = io::read(&path, &ReadOptions::default()).unwrap();
    assert!(c.is_empty());
    assert!(c.is_consistent());
}
