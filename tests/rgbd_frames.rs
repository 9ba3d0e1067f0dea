//! The real RGB-D frames of ../shared/data/rgbd (boxes on a table, Kinect class): the
//! reference edges that `sharpedge bench --frames` scores against, built from planes fitted
//! to each labelled object's faces, must be the box edges a person sees in the frame; and the
//! command itself must run on them and write its JSON. Skipped when ../shared/data is absent.

use std::path::{Path, PathBuf};
use std::process::Command;

use sharpedge::bench::frames::{RefKind, reference_edges};
use sharpedge::io::{NonFinite, ReadOptions, read};

fn frame(name: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/rgbd")
        .join(name);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("skipped: ../shared/data absent ({} not found)", p.display());
        None
    }
}

fn refs(name: &str) -> Option<Vec<sharpedge::bench::frames::RefEdge>> {
    let path = frame(name)?;
    let cloud = read(
        &path,
        &ReadOptions {
            non_finite: NonFinite::Reject,
        },
    )
    .unwrap();
    Some(reference_edges(&cloud, "label").unwrap())
}

/// box.ply: two boxes (labels 20 and 30), each showing its top and one side; each gives one
/// edge between its faces and one where its side stands on the table, all square.
#[test]
fn box_frame_reference_is_the_boxes_visible_edges() {
    let Some(r) = refs("box.ply") else { return };
    for label in [20, 30] {
        let of = |kind| {
            r.iter()
                .filter(|e| e.labels[0] == label && e.kind == kind)
                .collect::<Vec<_>>()
        };
        assert_eq!(of(RefKind::BoxEdge).len(), 1, "box {label}: {r:#?}");
        assert_eq!(of(RefKind::BaseEdge).len(), 1, "box {label}: {r:#?}");
    }
    for e in &r {
        assert!(
            (e.normal_angle_deg - 90.0).abs() < 5.0,
            "a box's faces and the table meet square: {e:?}"
        );
    }
    // The near box's edges are long (128 and 132 mm measured); the far box is half hidden.
    let near: Vec<f64> = r
        .iter()
        .filter(|e| e.labels[0] == 20)
        .map(|e| e.length())
        .collect();
    assert!(near.iter().all(|&l| l > 0.11 && l < 0.15), "{near:?}");
}

/// stacked_boxes.ply: no bevel of the sensor's rounded edge band passes for a face (a 45°
/// "edge" between a face and such a band was the reference's first mistake), and the upper
/// box's base edge on the table is there.
#[test]
fn stacked_frame_reference_has_no_bevel_faces() {
    let Some(r) = refs("stacked_boxes.ply") else {
        return;
    };
    for e in &r {
        assert!(
            (e.normal_angle_deg - 90.0).abs() < 12.0,
            "faces of a box meet square: {e:?}"
        );
    }
    assert!(
        r.iter()
            .any(|e| e.kind == RefKind::BaseEdge && e.length() > 0.2),
        "{r:#?}"
    );
}

#[test]
fn bench_frames_writes_scores_and_figures() {
    let (Some(a), Some(b)) = (frame("box.ply"), frame("stacked_boxes.ply")) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("frames.json");
    let figs = dir.path().join("figs");
    let out = Command::new(env!("CARGO_BIN_EXE_sharpedge"))
        .args(["-q", "bench", "--frames"])
        .arg(format!("{},{}", a.display(), b.display()))
        .arg("--out")
        .arg(&json)
        .arg("--figures")
        .arg(&figs)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let frames = v.as_array().unwrap();
    assert_eq!(frames.len(), 2);
    for f in frames {
        assert!(f["points"].as_u64().unwrap() > 180_000);
        let edges = f["score"]["edges"].as_array().unwrap();
        assert!(edges.len() >= 4, "{f}");
        for e in edges {
            let c = e["coverage"].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&c));
            assert!(e["one_edge"].as_f64().unwrap() <= c + 1e-12);
        }
    }
    // Issue 17: with the local scale, the normal-noise radius rule and the fillet limit that
    // grows with the noise, the near box's edge between its faces and both edges where a box
    // stands on the table are found over 90 % of their length as one edge (measured 96–100 %;
    // with the cloud-wide scale 26 %, 97 % and 81 %). The far, half-hidden box's 50 mm edge
    // too, since pair edges take faces that end up to 2.5 radii across from their line (the
    // sensor rounds that edge over 4–9 mm and its top faces end 40 mm from it): 100 %, before
    // 0 % with 1.5 radii.
    let box_edges = frames[0]["score"]["edges"].as_array().unwrap();
    for e in box_edges {
        assert!(e["one_edge"].as_f64().unwrap() >= 0.9, "{e}");
    }
    // Issue 17: real faces bend (cardboard, the depth camera's warp) and refuse more of
    // their neighbours than simulated ones; once the faces stage lets wide faces bend to a
    // radius of 150 spacings and refuse up to 30 %, every edge of stacked_boxes is found over
    // 99–100 % as one edge (before: 79 % and 0 % for the two box edges).
    let stacked = frames[1]["score"]["edges"].as_array().unwrap();
    for e in stacked {
        assert!(e["one_edge"].as_f64().unwrap() >= 0.9, "{e}");
    }
    for name in ["box.svg", "stacked_boxes.svg"] {
        let svg = std::fs::read_to_string(figs.join(name)).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.contains("polyline"),
            "{name}"
        );
    }
}
