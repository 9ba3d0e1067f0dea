//! rectified.ply keeps the input's own per-point attributes without letting the viewers take
//! them for sharpedge's fields (checked with the real programs by scripts/check_viewers.sh):
//! CloudCompare colours the points with the first property whose name contains `red`
//! (`green`, `blue`), so sharpedge's fields come right after x y z; MeshLab paints a float
//! `intensity` over the colours and joins an `alpha` to them, so those are renamed
//! `input_<name>`, and a name already taken gets one more `input_`. A rectified.ply run
//! through the pipeline again (it has both `red` and `input_red`) must work too.

mod run_common;

use std::path::Path;

use run_common::*;
use sharpedge::io::{self, PlyEncoding, PlyWriteOptions, Precision};
use sharpedge::{Attribute, Column};

const OWN: [&str; 8] = [
    "scalar_edge_id",
    "scalar_moved",
    "scalar_displacement",
    "scalar_sharpness",
    "quality",
    "red",
    "green",
    "blue",
];

fn attr(name: &str, values: Column) -> Attribute {
    Attribute {
        name: name.into(),
        values,
    }
}

/// The synth box with a scanner's colours, a float intensity, alpha, a label, and an
/// `input_red` of its own.
fn coloured_scan(dir: &Path) -> sharpedge::Cloud {
    let scan = synth(dir, "plain.ply", BOX);
    let mut cloud = read_cloud(&scan);
    let n = cloud.len();
    let byte = |k: usize| Column::U8((0..n).map(|i| ((i * k) % 256) as u8).collect());
    cloud.attributes = vec![
        attr(
            "intensity",
            Column::F32((0..n).map(|i| (i % 100) as f32 / 100.0).collect()),
        ),
        attr("red", byte(3)),
        attr("green", byte(5)),
        attr("blue", byte(7)),
        attr("alpha", byte(11)),
        attr("input_red", byte(13)),
        attr(
            "label",
            Column::I32((0..n).map(|i| (i % 4) as i32 - 1).collect()),
        ),
    ];
    let refs: Vec<&Attribute> = cloud.attributes.iter().collect();
    let opts = PlyWriteOptions {
        encoding: PlyEncoding::BinaryLittleEndian,
        precision: Precision::F32,
    };
    io::write_ply(&dir.join("scan.ply"), &cloud.positions, &refs, &[], &opts).unwrap();
    read_cloud(&dir.join("scan.ply"))
}

fn property_names(path: &Path) -> Vec<String> {
    let bytes = std::fs::read(path).unwrap();
    parse_header(&bytes)
        .element("vertex")
        .props
        .iter()
        .map(|p| p.name.clone())
        .collect()
}

#[test]
fn carried_attributes_never_pass_for_sharpedge_fields() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let input = coloured_scan(d);
    config(d, "[input]\npath = \"scan.ply\"\n");
    sharpedge(d, &["-q", "run", "pipeline.toml"]).assert_ok();
    let rect_path = d.join("out/rectified.ply");
    let names = property_names(&rect_path);
    let mut want: Vec<&str> = vec!["x", "y", "z"];
    want.extend(OWN);
    want.extend([
        "input_intensity",
        "input_input_red",
        "input_green",
        "input_blue",
        "input_alpha",
        "input_red",
        "label",
    ]);
    assert_eq!(names, want);
    // The first name containing each colour word is sharpedge's own colour.
    for c in ["red", "green", "blue"] {
        assert_eq!(names.iter().find(|n| n.contains(c)).unwrap(), c);
    }
    let rect = read_cloud(&rect_path);
    for (written, read) in [
        ("input_intensity", "intensity"),
        ("input_input_red", "red"),
        ("input_green", "green"),
        ("input_blue", "blue"),
        ("input_alpha", "alpha"),
        ("input_red", "input_red"),
        ("label", "label"),
    ] {
        assert_eq!(
            rect.attribute(written).unwrap().values,
            input.attribute(read).unwrap().values,
            "{written} holds the input's {read}"
        );
    }

    // rectified.ply as input again: `red` and `input_red` are both taken.
    let again = sharpedge(
        d,
        &[
            "-q",
            "run",
            "pipeline.toml",
            "--input",
            "out/rectified.ply",
            "--out",
            "again",
        ],
    );
    again.assert_ok();
    let names2 = property_names(&d.join("again/rectified.ply"));
    assert_eq!(&names2[3..11], OWN);
    let mut sorted = names2.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(sorted.len(), names2.len(), "no name twice: {names2:?}");
    let rect2 = read_cloud(&d.join("again/rectified.ply"));
    assert_eq!(
        rect2.attribute("input_input_red").unwrap().values,
        rect.attribute("input_input_red").unwrap().values
    );
    assert_eq!(
        rect2.attribute("input_input_input_red").unwrap().values,
        rect.attribute("red").unwrap().values,
        "the first run's edge colours are kept"
    );
}

#[test]
fn a_lidar_style_integer_intensity_keeps_its_name() {
    // MeshLab ignores an integer intensity and CloudCompare shows it as a scalar field.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scan = synth(d, "plain.ply", BOX);
    let cloud = read_cloud(&scan);
    let n = cloud.len();
    let i = attr(
        "intensity",
        Column::U16((0..n).map(|k| (k % 4000) as u16).collect()),
    );
    io::write_ply(
        &d.join("scan.ply"),
        &cloud.positions,
        &[&i],
        &[],
        &PlyWriteOptions::default(),
    )
    .unwrap();
    config(d, "[input]\npath = \"scan.ply\"\n");
    sharpedge(d, &["-q", "run", "pipeline.toml"]).assert_ok();
    let names = property_names(&d.join("out/rectified.ply"));
    assert_eq!(names.last().map(String::as_str), Some("intensity"));
}
