//! E57 reading and writing on the e57 crate's own test files (../shared/data/e57): double,
//! 21-bit scaled integer, float with colour, spherical with invalid records, a LAS
//! converter's output with 16-bit colour and an extension field, an extension namespace.
//! Checked against the e57 crate itself: sharpedge's points are the crate's simple reader's
//! valid points, bit for bit; written back with nothing moved, every record of every scan
//! is the input's, value for value (extension fields included); with points moved, the moved
//! points read back where they were put, in the file's own record types (spherical stays
//! spherical).

use std::path::Path;

mod e57_common;

use e57::{RecordDataType, RecordValue};
use e57_common::{crate_points, raw, shared};
use sharpedge::io::{self, CloudFormat, Original, ReadOptions};

const GOOD: [&str; 6] = [
    "bunnyDouble.e57",
    "bunnyInt21.e57",
    "tinyCartesianFloatRgb.e57",
    "tiny_spherical.e57",
    "las2e57_no_images_tag.e57",
    "tiny_pc_with_extension.e57",
];

fn read_for_e57(path: &Path) -> (sharpedge::Cloud, io::E57File) {
    match io::read_for_output(path, &ReadOptions::default(), CloudFormat::E57).unwrap() {
        (c, Some(Original::E57(f))) => (c, f),
        (_, o) => panic!("no E57File: {o:?}"),
    }
}

#[test]
fn points_are_the_crates_valid_points_bit_for_bit() {
    for name in GOOD {
        let Some(p) = shared(name) else {
            return;
        };
        let cloud = io::read(&p, &ReadOptions::default()).unwrap();
        assert_eq!(cloud.positions, crate_points(&p), "{name}");
        let s = cloud.structure.as_ref().unwrap();
        assert_eq!(s.scan.len(), cloud.len());
        assert_eq!(s.scans.len(), raw(&p).len());
    }
    // tiny_spherical: half of its 360 records are invalid.
    let Some(p) = shared("tiny_spherical.e57") else {
        return;
    };
    let c = io::read(&p, &ReadOptions::default()).unwrap();
    assert_eq!(c.len(), 180);
}

#[test]
fn colour_and_intensity_are_typed_columns_with_the_stored_values() {
    let Some(p) = shared("tinyCartesianFloatRgb.e57") else {
        return;
    };
    let cloud = io::read(&p, &ReadOptions::default()).unwrap();
    let (pc, records) = raw(&p).remove(0);
    let at = |tag: &str| {
        pc.prototype
            .iter()
            .position(|r| format!("{:?}", r.name) == tag)
            .unwrap()
    };
    for (col, tag) in [
        ("red", "ColorRed"),
        ("green", "ColorGreen"),
        ("blue", "ColorBlue"),
    ] {
        let i = at(tag);
        let want: Vec<u8> = records
            .iter()
            .map(|r| match r[i] {
                RecordValue::Integer(v) => v as u8,
                ref v => panic!("{v:?}"),
            })
            .collect();
        assert_eq!(
            cloud.attribute(col).unwrap().values,
            sharpedge::Column::U8(want),
            "{col}"
        );
    }
    // 16-bit colour of the LAS converter: u16 columns.
    let Some(p) = shared("las2e57_no_images_tag.e57") else {
        return;
    };
    let c = io::read(&p, &ReadOptions::default()).unwrap();
    assert!(matches!(
        c.attribute("red").unwrap().values,
        sharpedge::Column::U16(_)
    ));
}

#[test]
fn unmoved_output_keeps_every_record() {
    let dir = tempfile::tempdir().unwrap();
    for name in GOOD {
        let Some(p) = shared(name) else {
            return;
        };
        let (cloud, file) = read_for_e57(&p);
        let out = dir.path().join(name);
        io::write_e57(&out, &file, &cloud.positions, &vec![false; cloud.len()]).unwrap();
        let (a, b) = (raw(&p), raw(&out));
        assert_eq!(a.len(), b.len(), "{name}");
        for ((pa, va), (pb, vb)) in a.iter().zip(&b) {
            assert_eq!(pa.guid, pb.guid, "{name}");
            assert_eq!(
                format!("{:?}", pa.transform),
                format!("{:?}", pb.transform),
                "{name}"
            );
            // The same records; an invalid state declared [0, 1] (bunny*) is written as
            // [0, 2], the range the e57 writer requires, with the same values.
            let proto = |pc: &e57::PointCloud| {
                format!("{:?}", pc.prototype).replace(
                    "CartesianInvalidState, data_type: Integer { min: 0, max: 1 }",
                    "CartesianInvalidState, data_type: Integer { min: 0, max: 2 }",
                )
            };
            assert_eq!(proto(pa), proto(pb), "{name}");
            assert_eq!(va, vb, "{name}");
        }
        // In again: the same points.
        let again = io::read(&out, &ReadOptions::default()).unwrap();
        assert_eq!(again.positions, cloud.positions, "{name}");
        assert_eq!(again.attributes, cloud.attributes, "{name}");
        assert_eq!(again.structure, cloud.structure, "{name}");
    }
}

#[test]
fn moved_points_read_back_where_they_were_put() {
    let dir = tempfile::tempdir().unwrap();
    for name in GOOD {
        let Some(p) = shared(name) else {
            return;
        };
        let (cloud, file) = read_for_e57(&p);
        let mut rect = cloud.positions.clone();
        let moved: Vec<bool> = (0..cloud.len()).map(|i| i % 3 == 0).collect();
        for (q, _) in rect.iter_mut().zip(&moved).filter(|(_, m)| **m) {
            q[0] += 0.01;
            q[1] -= 0.02;
            q[2] += 0.015;
        }
        let out = dir.path().join(name);
        io::write_e57(&out, &file, &rect, &moved).unwrap();
        let again = io::read(&out, &ReadOptions::default()).unwrap();
        assert_eq!(again.len(), cloud.len(), "{name}");
        // The record type sets the precision: single floats (also spherical float) keep 24
        // bits, 21-bit scaled integers a step of 1e-6, doubles all but rounding.
        let (pc, _) = raw(&p).remove(0);
        let tol = if pc
            .prototype
            .iter()
            .any(|r| matches!(r.data_type, RecordDataType::Single { .. }))
        {
            1e-4
        } else {
            1e-6
        };
        for (i, (a, b)) in again.positions.iter().zip(&rect).enumerate() {
            let d = (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max);
            if moved[i] {
                assert!(d <= tol, "{name}: point {i} off by {d}");
            } else {
                assert_eq!(a, b, "{name}: unmoved point {i}");
            }
        }
        // Same fields: the prototype's record names and types (ranges may widen).
        let (pb, _) = raw(&out).remove(0);
        let kinds = |pc: &e57::PointCloud| {
            pc.prototype
                .iter()
                .map(|r| {
                    let ty = format!("{:?}", r.data_type);
                    format!("{:?} {}", r.name, ty.split_whitespace().next().unwrap())
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(kinds(&pc), kinds(&pb), "{name}");
    }
}
