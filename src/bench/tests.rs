//! Tests of the bench's case list, metrics and verdicts with hand-made answers.

use super::*;
use crate::geometry::{add, cross, dot, norm, scale, sub};

/// A small, exact (noise-free, unrotated) box: its ground truth gives true edges and corners.
fn box_truth() -> synth::Scan {
    synth::generate(&SynthParams {
        sampling: Sampling::Points(5_000),
        ..SynthParams::default()
    })
    .unwrap()
}

fn corner_out(position: V3, scheme1: V3, exact: V3) -> CornerOut {
    CornerOut {
        id: 0,
        position,
        edges: Vec::new(),
        error: None,
        scheme1,
        exact,
    }
}

fn unit(v: V3) -> V3 {
    scale(v, 1.0 / norm(v))
}

/// A unit vector perpendicular to `d`.
fn perpendicular(d: V3) -> V3 {
    let a = if d[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    unit(cross(d, a))
}

#[test]
fn suite_has_every_case_of_the_issue_in_order() {
    let dir = tempfile::TempDir::new().unwrap();
    std::fs::create_dir(dir.path().join("cad")).unwrap();
    for f in ["fandisk.off", "anchor_dense.off"] {
        std::fs::write(dir.path().join("cad").join(f), "OFF\n").unwrap();
    }
    let (cases, skipped) = suite(None, 1000, 1, Some(dir.path())).unwrap();
    assert!(skipped.is_empty());
    let names: Vec<&str> = cases.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, case_names());
    assert_eq!(names.len(), 14);
    for c in &cases {
        assert!(c.params.rotate, "{}", c.name);
        let (noise, points) = match c.name.as_str() {
            "box-noise0.5" => (0.5, 1000),
            "box-noise1.0" => (1.0, 1000),
            "box-30k" => (0.15, 30_000),
            _ => (0.15, 1000),
        };
        assert_eq!(c.params.noise, noise, "{}", c.name);
        assert_eq!(c.params.sampling, Sampling::Points(points), "{}", c.name);
        assert_eq!(c.params.round, 1.5);
    }
    let far = &cases.iter().find(|c| c.name == "box-far").unwrap().params;
    assert!((norm(far.translate) - 4.0e6).abs() < 1e-6);
    let by = |n: &str| cases.iter().find(|c| c.name == n).unwrap().params.clone();
    assert_eq!((by("prism6").sides, by("prism8").sides), (6, 8));
    assert_eq!(by("wedge").angle, 30.0);
    assert_eq!(by("sphere").part, Part::Sphere);
    assert_eq!(
        by("anchor").part,
        Part::Mesh(dir.path().join("cad/anchor_dense.off"))
    );
    // Every case has its own rotation seed.
    let mut seeds: Vec<u64> = cases.iter().map(|c| c.params.seed).collect();
    seeds.sort_unstable();
    seeds.dedup();
    assert_eq!(seeds.len(), 14);
}

#[test]
fn a_case_keeps_its_seed_whatever_else_is_selected() {
    let all = suite(None, 1000, 7, None).unwrap().0;
    let one = suite(Some(&["wedge".to_string()]), 1000, 7, None)
        .unwrap()
        .0;
    let w = all.iter().find(|c| c.name == "wedge").unwrap();
    assert_eq!(one.len(), 1);
    assert_eq!(one[0].params, w.params);
    let other = suite(Some(&["wedge".to_string()]), 1000, 8, None)
        .unwrap()
        .0;
    assert_ne!(other[0].params.seed, w.params.seed);
}

#[test]
fn mesh_cases_are_skipped_with_a_note_without_data() {
    let dir = tempfile::TempDir::new().unwrap();
    let (cases, skipped) = suite(None, 1000, 1, Some(dir.path())).unwrap();
    assert_eq!(cases.len(), 12);
    assert_eq!(skipped.len(), 2);
    assert_eq!(skipped[0].case, "fandisk");
    assert!(
        skipped[0].reason.contains("fandisk.off not found"),
        "{}",
        skipped[0].reason
    );
    let (_, skipped) = suite(Some(&["anchor".into()]), 1000, 1, None).unwrap();
    assert!(skipped[0].reason.contains("pass --data"), "{:?}", skipped);
}

#[test]
fn unknown_case_names_the_valid_ones() {
    let e = suite(Some(&["box".into(), "cube".into()]), 1000, 1, None).unwrap_err();
    let msg = e.to_string();
    assert!(msg.starts_with("--cases: unknown case \"cube\""), "{msg}");
    assert!(msg.contains("box, lblock, step, wedge, prism6"), "{msg}");
}

#[test]
fn repeated_case_names_run_once() {
    let (cases, _) = suite(Some(&["box".into(), " box".into()]), 1000, 1, None).unwrap();
    assert_eq!(cases.len(), 1);
}

#[test]
fn corner_metrics_of_hand_made_corners() {
    let h = 0.5;
    let truth = [[0.0; 3], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]];
    let found = [
        // 0.1 h from corner 0; Scheme 1 at 1 h, exact at 0.05 h.
        corner_out([0.05, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.025, 0.0]),
        // 0.3 h from corner 1.
        corner_out([10.0, 0.15, 0.0], [10.0, 0.15, 0.0], [10.0, 0.15, 0.0]),
        // 4 h from corner 2: unmatched.
        corner_out([0.0, 12.0, 0.0], [0.0; 3], [0.0; 3]),
    ];
    let oracle = [Some([0.0, 0.0, 0.01]), Some([10.0, 0.0, 0.02]), None];
    let m = corner_metrics(&found, &truth, Some(&oracle), h);
    assert_eq!((m.truth, m.found, m.matched), (3, 3, 2));
    assert!((m.recall.unwrap() - 2.0 / 3.0).abs() < 1e-15);
    assert!((m.precision.unwrap() - 2.0 / 3.0).abs() < 1e-15);
    let e = m.error_h.unwrap();
    assert!((e.mean - 0.2).abs() < 1e-12 && (e.max - 0.3).abs() < 1e-12);
    assert!((m.scheme1_h.unwrap().mean - 0.65).abs() < 1e-12);
    assert!((m.exact_h.unwrap().mean - 0.175).abs() < 1e-12);
    // Oracle on the matched true corners: 0.02 h and 0.04 h.
    assert!((m.oracle_h.unwrap().mean - 0.03).abs() < 1e-12);
    assert!((m.ratio_to_oracle.unwrap() - 0.2 / 0.03).abs() < 1e-9);
    assert_eq!(m.missed.len(), 1);
    assert_eq!(m.missed[0].id, 2);
    assert!((m.missed[0].nearest_h.unwrap() - 4.0).abs() < 1e-12);
    assert_eq!(m.spurious.len(), 1);
    assert_eq!(m.spurious[0].id, 2);
}

#[test]
fn nothing_to_find_and_nothing_found_are_undefined_not_zero() {
    let m = corner_metrics(&[], &[], None, 1.0);
    assert_eq!((m.recall, m.precision, m.error_h), (None, None, None));
    let scan = box_truth();
    let e = edge_metrics(&[], &scan.ground_truth, None, 1.0);
    assert_eq!(e.recall, Some(0.0));
    assert_eq!(e.precision, None);
    assert_eq!(e.rms_h, None);
    assert_eq!(e.poorly_found.len(), 12);
}

#[test]
fn edges_offset_by_one_spacing_score_rms_one_and_full_recall() {
    let scan = box_truth();
    let gt = &scan.ground_truth;
    let h = gt.spacing;
    // Every true edge shifted sideways by exactly h (perpendicular to it): within the 2 h
    // tolerance everywhere, so recall and precision are 1 and the RMS is 1 h (the shifted
    // edges stay 1 h from their own edge, and no closer to any other one).
    let found: Vec<Vec<V3>> = gt
        .edges
        .iter()
        .map(|e| {
            let d = unit(sub(e.end, e.start));
            // Outwards along one face normal: away from the box, so no other edge is nearer.
            let n = e.normals[0];
            assert!(dot(n, d).abs() < 1e-12);
            vec![add(e.start, scale(n, h)), add(e.end, scale(n, h))]
        })
        .collect();
    let m = edge_metrics(&found, gt, None, h);
    assert_eq!((m.found, m.true_polylines, m.true_segments), (12, 12, 12));
    assert!((m.recall.unwrap() - 1.0).abs() < 1e-12, "{:?}", m.recall);
    assert!((m.precision.unwrap() - 1.0).abs() < 1e-12);
    assert!((m.duplication.unwrap() - 1.0).abs() < 1e-12);
    assert!((m.rms_h.unwrap() - 1.0).abs() < 1e-9, "{:?}", m.rms_h);
    assert!((m.max_h.unwrap() - 1.0).abs() < 1e-9);
    // Along one face normal: 1/√2 of the offset is along the bisector, away from the rounding.
    let bias = m.offset_to_rounding_h.unwrap();
    assert!((bias + 0.5f64.sqrt()).abs() < 1e-9, "{bias}");
    assert!(m.poorly_found.is_empty() && m.spurious.is_empty());
    let total: f64 = gt.edges.iter().map(|e| e.length).sum();
    assert!((m.true_length_h - total / h).abs() < 1e-9);
}

#[test]
fn edges_moved_onto_the_rounding_have_a_positive_bias() {
    let scan = box_truth();
    let gt = &scan.ground_truth;
    let h = gt.spacing;
    // 0.5 h inwards along the bisector of every (convex) box edge, 1 h short of each end so
    // that no other edge is nearer.
    let found: Vec<Vec<V3>> = gt
        .edges
        .iter()
        .map(|e| {
            let inward = scale(unit(add(e.normals[0], e.normals[1])), -0.5 * h);
            let d = scale(unit(sub(e.end, e.start)), h);
            vec![add(add(e.start, d), inward), add(sub(e.end, d), inward)]
        })
        .collect();
    let m = edge_metrics(&found, gt, None, h);
    assert!((m.offset_to_rounding_h.unwrap() - 0.5).abs() < 1e-9);
    assert!((m.rms_h.unwrap() - 0.5).abs() < 1e-9);
}

#[test]
fn edges_reported_twice_have_duplication_two_and_full_precision() {
    let scan = box_truth();
    let gt = &scan.ground_truth;
    let mut found: Vec<Vec<V3>> = gt.edges.iter().map(|e| vec![e.start, e.end]).collect();
    found.extend(gt.edges.iter().map(|e| vec![e.end, e.start]));
    let m = edge_metrics(&found, gt, None, gt.spacing);
    assert_eq!((m.recall, m.precision), (Some(1.0), Some(1.0)));
    assert!((m.duplication.unwrap() - 2.0).abs() < 1e-12);
    assert_eq!(m.found, 24);
}

#[test]
fn half_of_one_edge_lowers_recall_by_its_share() {
    let scan = box_truth();
    let gt = &scan.ground_truth;
    let h = gt.spacing;
    let e = &gt.edges[3];
    let mid = scale(add(e.start, e.end), 0.5);
    let m = edge_metrics(&[vec![e.start, mid]], gt, None, h);
    let total: f64 = gt.edges.iter().map(|e| e.length).sum();
    // Half of edge 3, the 2 h of it beyond the found half's end that are within the
    // tolerance, and the first 2 h of each of the two edges meeting at its start.
    let expected = (0.5 * e.length + 2.0 * h + 2.0 * 2.0 * h) / total;
    assert!(
        (m.recall.unwrap() - expected).abs() < 1e-12,
        "{:?} vs {expected}",
        m.recall
    );
    assert_eq!(m.precision, Some(1.0));
    assert!(m.rms_h.unwrap() < 1e-12);
    assert_eq!(m.poorly_found.len(), 12);
    let poor = m.poorly_found.iter().find(|p| p.id == e.polyline).unwrap();
    assert!((poor.matched_share - (0.5 + 2.0 * h / e.length)).abs() < 1e-12);
}

#[test]
fn a_spurious_edge_on_a_face_lowers_precision() {
    let scan = box_truth();
    let gt = &scan.ground_truth;
    let h = gt.spacing;
    let f = &gt.faces[0];
    // A 10 h segment in the middle of a face, far from every edge.
    let d = perpendicular(f.normal);
    let centre = scan
        .truth
        .iter()
        .filter(|t| t.face == 0)
        .max_by(|a, b| a.edge_distance.total_cmp(&b.edge_distance))
        .unwrap()
        .surface;
    let spurious_edge = vec![
        add(centre, scale(d, -5.0 * h)),
        add(centre, scale(d, 5.0 * h)),
    ];
    let mut found: Vec<Vec<V3>> = gt.edges.iter().map(|e| vec![e.start, e.end]).collect();
    found.push(spurious_edge);
    let m = edge_metrics(&found, gt, None, h);
    let total: f64 = gt.edges.iter().map(|e| e.length).sum::<f64>() / h;
    assert!((m.precision.unwrap() - total / (total + 10.0)).abs() < 1e-12);
    assert_eq!(m.recall, Some(1.0));
    assert_eq!(m.spurious.len(), 1);
    assert_eq!(m.spurious[0].id, 12);
    assert_eq!(m.spurious[0].matched_share, 0.0);
}

fn truth_at(edge_distance: f64, abnormal: bool, outlier: bool) -> PointTruth {
    PointTruth {
        surface: [0.0; 3],
        edge_distance,
        nearest_edge: 0,
        face: 0,
        abnormal,
        outlier,
        view: u32::MAX,
        noise: 0.0,
    }
}

#[test]
fn rectification_of_hand_made_points() {
    // Surface z = 0, h = 2. Two abnormal points 1 and 3 above it end 0.2 and 0.2 above: mean
    // 2 → 0.2, i.e. 1 h → 0.1 h, ratio 0.1. An outlier moved far is ignored. Of the two points
    // 10 h from the edges one changed by one ulp: it counts.
    let h = 2.0;
    let positions = [
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 3.0],
        [5.0, 5.0, 50.0],
        [9.0, 9.0, 0.5],
        [8.0, 8.0, 0.5],
        [0.0, 1.0, 0.25],
    ];
    let mut rectified = positions;
    rectified[0][2] = 0.2;
    rectified[1][2] = -0.2;
    rectified[2][2] = 0.0;
    rectified[3][2] = f64::from_bits(0.5f64.to_bits() + 1);
    let moved = [true, true, true, false, false, false];
    let truth = [
        truth_at(1.0, true, false),
        truth_at(1.0, true, false),
        truth_at(30.0, false, true),
        truth_at(20.0, false, false),
        truth_at(20.0, false, false),
        // Within 4 h of an edge, not abnormal: neither kind.
        truth_at(7.9, false, false),
    ];
    let away: Vec<bool> = truth
        .iter()
        .map(|t| !t.abnormal && !t.outlier && t.edge_distance > AWAY * h)
        .collect();
    let abnormal: Vec<bool> = truth.iter().map(|t| t.abnormal && !t.outlier).collect();
    let m = rectify_metrics(
        &positions,
        &rectified,
        &moved,
        (&abnormal, 0),
        &away,
        h,
        |p| p[2].abs(),
    );
    assert_eq!((m.abnormal_points, m.abnormal_moved), (2, 2));
    assert!((m.before_h.unwrap() - 1.0).abs() < 1e-15);
    assert!((m.after_h.unwrap() - 0.1).abs() < 1e-15);
    assert!((m.ratio.unwrap() - 0.1).abs() < 1e-15);
    assert_eq!((m.away_points, m.away_moved, m.moved_points), (2, 1, 3));
}

#[test]
fn candidates_against_true_edge_points() {
    let h = 1.0;
    let truth = [
        truth_at(0.5, true, false),
        truth_at(1.5, true, false),
        truth_at(2.5, false, false),
        truth_at(9.0, false, false),
        truth_at(0.1, false, true),
    ];
    let cand = [true, false, true, false, true];
    let m = candidate_metrics(&cand, &truth, h);
    assert_eq!(m.count, 3);
    assert_eq!(m.recall, Some(0.5));
    assert!((m.precision.unwrap() - 1.0 / 3.0).abs() < 1e-15);
}

fn scored(kind: Kind) -> CaseResult {
    let (cases, _) = suite(Some(&["box".into()]), 1000, 1, None).unwrap();
    let mut r = CaseResult::unscored(&cases[0]);
    r.kind = kind;
    r.corners = Some(corner_metrics(&[], &[], None, 1.0));
    r.edges = Some(EdgeMetrics {
        true_polylines: 12,
        true_segments: 12,
        found: 12,
        true_length_h: 100.0,
        unseen_length_h: 0.0,
        found_length_h: 100.0,
        recall: Some(0.99),
        precision: Some(0.97),
        duplication: Some(1.0),
        rms_h: Some(0.02),
        mean_h: Some(0.01),
        max_h: Some(0.1),
        offset_to_rounding_h: Some(0.0),
        crease_length_h: None,
        oracle_rms_h: None,
        oracle_recall: None,
        ratio_to_oracle: None,
        poorly_found: Vec::new(),
        spurious: Vec::new(),
    });
    r.rectify = Some(RectifyMetrics {
        abnormal_points: 10,
        abnormal_unseen: 0,
        abnormal_moved: 10,
        before_h: Some(1.0),
        after_h: Some(0.3),
        ratio: Some(0.3),
        away_points: 100,
        away_moved: 0,
        moved_points: 10,
    });
    r
}

#[test]
fn verdicts_follow_the_issue_thresholds() {
    let r = scored(Kind::Polyhedral);
    let c = checks(Kind::Polyhedral, true, &r);
    let get = |n: &str| c.iter().find(|c| c.name == n).unwrap();
    assert!(get("edge recall").pass);
    assert!(!get("edge precision").pass);
    assert!(get("edge RMS (h)").pass);
    // Nothing found: corner precision and error are undefined, which fails.
    assert!(!get("corner precision").pass && get("corner precision").value.is_none());
    assert!(!get("mean corner error (h)").pass);
    assert!(get("rectified / raw distance").pass); // 0.3 is allowed
    assert!(get("points away from edges moved").pass);
    // No accuracy checks for the noisy boxes.
    assert!(
        checks(Kind::Polyhedral, false, &r)
            .iter()
            .all(|c| c.name != "edge RMS (h)")
    );
    // Curved meshes need 0.9 only.
    let c = checks(Kind::Curved, false, &r);
    assert!(c.iter().all(|c| c.pass), "{c:?}");
    // The sphere must find nothing.
    let c = checks(Kind::Smooth, false, &r);
    let edges = c.iter().find(|c| c.name == "edges found").unwrap();
    assert_eq!((edges.value, edges.pass), (Some(12.0), false));
    assert!(c.iter().find(|c| c.name == "corners found").unwrap().pass);
}

#[test]
fn oracle_of_a_noisy_box_is_far_better_than_a_spacing() {
    let scan = synth::generate(&SynthParams {
        sampling: Sampling::Points(40_000),
        noise: 0.15,
        round: 1.5,
        rotate: true,
        translate: FAR,
        seed: 3,
        ..SynthParams::default()
    })
    .unwrap();
    let gt = &scan.ground_truth;
    let h = gt.spacing;
    let o = oracle::fit(gt, &scan.cloud.positions, &scan.truth);
    assert!(o.planes.iter().all(Option::is_some));
    assert!((o.margin - 4.5 * h).abs() < 1e-9 * h, "{}", o.margin / h);
    assert!(
        o.face_points.iter().all(|&n| n > 1000),
        "{:?}",
        o.face_points
    );
    let true_corners: Vec<V3> = gt.corners.iter().map(|c| c.position).collect();
    for (c, t) in o.corners.iter().zip(&true_corners) {
        let e = dist(c.unwrap(), *t) / h;
        assert!(e < 0.05, "oracle corner error {e} h");
    }
    let m = edge_metrics(&[], gt, Some(&o.edges), h);
    let rms = m.oracle_rms_h.unwrap();
    assert!(rms < 0.03, "oracle edge RMS {rms} h");
    assert!((m.oracle_recall.unwrap() - 1.0).abs() < 1e-9);
}

#[test]
fn sphere_case_runs_and_has_nothing_to_find() {
    let (cases, _) = suite(Some(&["sphere".into()]), 20_000, 1, None).unwrap();
    let r = run_case(&cases[0], &Settings::default());
    assert_eq!(r.error, None);
    let c = r.corners.as_ref().unwrap();
    assert_eq!((c.truth, c.recall), (0, None));
    let e = r.edges.as_ref().unwrap();
    assert_eq!((e.true_segments, e.recall), (0, None));
    assert_eq!(r.oracle_margin_h, None);
    let x = r.rectify.as_ref().unwrap();
    assert_eq!((x.abnormal_points, x.ratio), (0, None));
    assert!(x.away_points > 15_000);
    assert!(r.checks.iter().any(|c| c.name == "edges found"));
    assert_eq!(r.pass, r.checks.iter().all(|c| c.pass));
    let m = r.measured.unwrap();
    assert!(m.spacing_h > 0.8 && m.spacing_h < 1.1, "{m:?}");
}

#[test]
fn away_from_edges_is_beyond_the_rounding_and_the_noise() {
    let h = 0.5;
    // A 90° edge rounded with 1.5 h, σ 0.15 h: 1.5 + 2 + 0.75 = 4.25 h.
    assert!((away_limit(1.5 * h, 0.15, h) - 4.25 * h).abs() < 1e-12);
    // A 30° wedge with the same rounding leaves its faces 5.6 h out: 8.35 h.
    let td = 1.5 * h / (15f64.to_radians()).tan();
    assert!((away_limit(td, 0.15, h) - (td + 2.75 * h)).abs() < 1e-12);
    // Sharp and noise-free: never less than AWAY.
    assert_eq!(away_limit(0.0, 0.0, h), AWAY * h);
}

/// Beside a vertex of a 30° edge, a point on the wedge's face just past the rounding is
/// nearer to the end face's 90° edge than to the 30° edge; it is still not "away": the 30°
/// edge's zone reaches farther. Far along the face it is.
#[test]
fn away_mask_takes_every_edge_into_account_near_vertices() {
    let h = 1.0;
    let scan = synth::generate(&SynthParams {
        part: Part::Wedge,
        angle: 30.0,
        sampling: Sampling::Spacing(h),
        round: 1.5,
        size: Some(200.0),
        ..SynthParams::default()
    })
    .unwrap();
    let gt = &scan.ground_truth;
    let apex = gt
        .edges
        .iter()
        .find(|e| (e.dihedral_deg - 30.0).abs() < 1e-6)
        .expect("the wedge has a 30° edge");
    let d = unit(sub(apex.end, apex.start));
    let n1 = apex.normals[1];
    let mut u0 = unit(cross(d, apex.normals[0]));
    if dot(u0, n1) > 0.0 {
        u0 = scale(u0, -1.0);
    }
    let at = |along: f64, out: f64| -> PointTruth {
        let surface = add(apex.start, add(scale(d, along), scale(u0, out)));
        let (edge_distance, nearest_edge) = gt
            .edges
            .iter()
            .map(|e| (point_segment(surface, e.start, e.end).0, e.id as u32))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap();
        PointTruth {
            surface,
            edge_distance,
            nearest_edge,
            face: 0,
            abnormal: false,
            outlier: false,
            view: u32::MAX,
            noise: 0.0,
        }
    };
    let near_vertex = at(4.8 * h, 6.0 * h);
    let far = at(100.0 * h, 9.0 * h);
    // The nearest edge of the first point is a 90° edge of the end face, 4.8 h away, beyond
    // that edge's own limit (1.5 + 2 + 0.6 h)…
    let nearest = &gt.edges[near_vertex.nearest_edge as usize];
    assert!((nearest.dihedral_deg - 90.0).abs() < 1e-6);
    assert!(near_vertex.edge_distance > away_limit(nearest.tangent_distance, 0.15, h));
    // …but it lies within the 30° edge's zone (5.6 h) plus margin.
    let mask = away_mask(&[near_vertex, far], gt, 0.15, h);
    assert_eq!(mask, vec![false, true]);
    // Issue 17: a point given four times the scan's noise (incidence noise on a face seen at
    // a grazing angle) is uncertain by its own sigma: 9 h out on the face it lies within the
    // 30° edge's 5.6 h plus 2 h plus five of its 0.6 h sigmas, and is not away; 12 h out it is.
    let grazing = |out: f64| PointTruth {
        noise: 0.6 * h,
        ..at(100.0 * h, out)
    };
    let mask = away_mask(&[grazing(9.0 * h), grazing(12.0 * h)], gt, 0.15, h);
    assert_eq!(mask, vec![false, true]);
}

/// The visibility rule on a box whose three faces facing away from (1, 1, 1) were not
/// scanned: the three edges between seen faces are required whole, the nine others (a seen
/// face against an unseen one: a scan border; or two unseen faces) not at all, and a found
/// edge along them counts against precision, but for the 2 h beside the required edges' ends.
#[test]
fn edges_with_an_unseen_face_are_not_required_and_count_against_precision() {
    let scan = synth::generate(&SynthParams {
        sampling: Sampling::Points(20_000),
        ..SynthParams::default()
    })
    .unwrap();
    let gt = &scan.ground_truth;
    let h = gt.spacing;
    // Everything seen: the edges themselves, unchanged.
    assert_eq!(seen::required(gt, &scan.truth, h), Stretches::all(gt));

    let toward = [1.0, 1.0, 1.0];
    let seen_face = |f: u32| dot(gt.faces[f as usize].normal, toward) > 0.0;
    let kept: Vec<PointTruth> = scan
        .truth
        .iter()
        .copied()
        .filter(|t| seen_face(t.face))
        .collect();
    assert!(kept.len() > 8_000 && kept.len() < 12_000, "{}", kept.len());
    let req = seen::required(gt, &kept, h);
    let both_seen: Vec<usize> = gt
        .edges
        .iter()
        .filter(|e| e.faces.iter().all(|&f| seen_face(f as u32)))
        .map(|e| e.id)
        .collect();
    assert_eq!(both_seen.len(), 3);
    assert_eq!(req.edge, both_seen, "only the edges between seen faces");
    for (k, &e) in req.edge.iter().enumerate() {
        assert_eq!(req.segments[k], (gt.edges[e].start, gt.edges[e].end));
    }
    let total = gt.edge_length(); // 4 · (100 + 80 + 60)
    let required: f64 = both_seen.iter().map(|&e| gt.edges[e].length).sum();
    assert!((required - 240.0).abs() < 1e-9 && (total - 960.0).abs() < 1e-9);
    assert!((req.unseen_length - (total - required)).abs() < 1e-9);

    // A tool that reports all twelve edges, exactly.
    let found: Vec<Vec<V3>> = gt.edges.iter().map(|e| vec![e.start, e.end]).collect();
    let m = edge_metrics_on(&found, gt, &req, None, h);
    assert!((m.recall.unwrap() - 1.0).abs() < 1e-12);
    // Each far end of a required edge is a corner with two border edges: 3 · 2 · 2 h of
    // them lie within the tolerance.
    let want = (required + 6.0 * EDGE_TOL * h) / total;
    assert!(
        (m.precision.unwrap() - want).abs() < 1e-9,
        "precision {:?}, want {want}",
        m.precision
    );
    assert!((m.unseen_length_h - (total - required) / h).abs() < 1e-9);
    // The same found edges on the whole scan: perfect.
    let all = edge_metrics(&found, gt, None, h);
    assert!((all.precision.unwrap() - 1.0).abs() < 1e-12);
}

/// A point on a random part's fillet, or just beside its tangent line, is not "away from
/// edges"; one far beyond it on the flat face is.
#[test]
fn away_from_edges_starts_beyond_a_fillet() {
    let seed = (0..200)
        .find(|&s| !synth::random::build(s).unwrap().fillets.is_empty())
        .unwrap();
    let scan = synth::generate(&SynthParams {
        part: Part::Random,
        sampling: Sampling::Points(100_000),
        seed,
        ..SynthParams::default()
    })
    .unwrap();
    let gt = &scan.ground_truth;
    let h = gt.spacing;
    let mask = away_mask(&scan.truth, gt, 0.0, h);
    let f = &gt.fillets[0];
    let on: Vec<usize> = (0..scan.truth.len())
        .filter(|&i| f.faces.contains(&(scan.truth[i].face as usize)))
        .collect();
    assert!(on.len() > 50);
    assert!(
        on.iter().all(|&i| !mask[i]),
        "a fillet point counted as away"
    );
    let limit = away_limit(0.0, 0.0, h);
    let line_distance = |t: &PointTruth| {
        f.tangent_lines
            .iter()
            .map(|[a, b]| point_segment(t.surface, *a, *b).0)
            .fold(f64::INFINITY, f64::min)
    };
    let beside = (0..scan.truth.len())
        .filter(|&i| !on.contains(&i) && line_distance(&scan.truth[i]) < 0.9 * limit)
        .collect::<Vec<_>>();
    assert!(!beside.is_empty());
    assert!(beside.iter().all(|&i| !mask[i]));
    // Far beyond the tangent lines and every edge, points are away.
    let beyond = (0..scan.truth.len()).filter(|&i| {
        let t = &scan.truth[i];
        !on.contains(&i) && line_distance(t) > 2.0 * limit && t.edge_distance > 3.0 * limit
    });
    assert!(beyond.clone().count() > 100);
    assert!(beyond.into_iter().all(|i| mask[i]));
}

/// A box scanned from one side: only its faces turned towards (1, 1, 1) kept, as a one-view
/// scan from far along that direction sees them.
fn one_view_box(toward: V3) -> (synth::Scan, Vec<PointTruth>) {
    let scan = synth::generate(&SynthParams {
        sampling: Sampling::Points(20_000),
        ..SynthParams::default()
    })
    .unwrap();
    let gt = &scan.ground_truth;
    let kept: Vec<PointTruth> = scan
        .truth
        .iter()
        .copied()
        .filter(|t| dot(gt.faces[t.face as usize].normal, toward) > 0.0)
        .collect();
    (scan, kept)
}

/// The corner rule on a one-view box: the corner where the three seen faces meet is
/// required; the six on the silhouette (one or two faces seen) and the hidden one are not.
/// On the whole scan every corner is required.
#[test]
fn corners_with_an_unseen_face_are_not_required() {
    let toward = [1.0, 1.0, 1.0];
    let (scan, kept) = one_view_box(toward);
    let gt = &scan.ground_truth;
    let h = gt.spacing;
    let whole = seen::required(gt, &scan.truth, h);
    assert_eq!(seen::required_corners(gt, &whole, h), vec![true; 8]);
    let req = seen::required_corners(gt, &seen::required(gt, &kept, h), h);
    let facing: Vec<bool> = gt
        .corners
        .iter()
        .map(|c| (0..3).all(|k| c.position[k] > 0.0))
        .collect();
    assert_eq!(facing.iter().filter(|&&f| f).count(), 1);
    assert_eq!(req, facing, "only the corner of the three seen faces");

    // A tool that finds all eight corners exactly: the seen one is matched, the seven others
    // count neither way; one that finds only the seen corner scores the same.
    let all: Vec<CornerOut> = gt
        .corners
        .iter()
        .map(|c| corner_out(c.position, c.position, c.position))
        .collect();
    let truth: Vec<V3> = gt.corners.iter().map(|c| c.position).collect();
    let m = corner_metrics_on(&all, &truth, &req, None, h);
    assert_eq!((m.truth, m.unseen, m.found, m.matched), (1, 7, 8, 1));
    assert_eq!((m.recall, m.precision), (Some(1.0), Some(1.0)));
    assert!(m.missed.is_empty() && m.spurious.is_empty());
    let one: Vec<CornerOut> = all
        .iter()
        .zip(&req)
        .filter(|(_, r)| **r)
        .map(|(c, _)| c.clone())
        .collect();
    let m1 = corner_metrics_on(&one, &truth, &req, None, h);
    assert_eq!((m1.recall, m1.precision), (Some(1.0), Some(1.0)));
    // Nothing found: the seen corner is missed; a corner 10 h off the part is spurious.
    let m0 = corner_metrics_on(&[], &truth, &req, None, h);
    assert_eq!((m0.recall, m0.missed.len()), (Some(0.0), 1));
    let off = [corner_out([0.0, 0.0, 10.0 * h + 50.0], [0.0; 3], [0.0; 3])];
    let m2 = corner_metrics_on(&off, &truth, &req, None, h);
    assert_eq!((m2.precision, m2.spurious.len()), (Some(0.0), 1));
}

/// Scan borders of the one-view box: its seen points beside the silhouette edges (a seen face
/// against one turned away) are border points, those in the middle of a face are not, and
/// found edges along the silhouette count as border length but not those along the seen
/// edges.
#[test]
fn one_view_borders_are_found_and_scored() {
    let toward = [1.0, 1.0, 1.0];
    let (scan, kept) = one_view_box(toward);
    let gt = &scan.ground_truth;
    let h = gt.spacing;
    let on = border::border_points(gt, &kept, h);
    // Every point within 0.5 h of a silhouette edge is a border point; none 3 h or more from
    // every edge is.
    let silhouette: Vec<&synth::TruthEdge> = gt
        .edges
        .iter()
        .filter(|e| {
            e.faces
                .iter()
                .filter(|&&f| dot(gt.faces[f].normal, toward) > 0.0)
                .count()
                == 1
        })
        .collect();
    assert_eq!(silhouette.len(), 6);
    let near_silhouette = |t: &PointTruth| {
        silhouette
            .iter()
            .map(|e| point_segment(t.surface, e.start, e.end).0)
            .fold(f64::INFINITY, f64::min)
    };
    let (mut beside, mut inner) = (0, 0);
    for (t, &b) in kept.iter().zip(&on) {
        if near_silhouette(t) < 0.5 * h {
            assert!(
                b,
                "a point {} h from the silhouette",
                near_silhouette(t) / h
            );
            beside += 1;
        }
        if t.edge_distance > 3.0 * h {
            assert!(!b, "a point {} h inside its face", t.edge_distance / h);
            inner += 1;
        }
    }
    assert!(beside > 100 && inner > 5_000, "{beside} {inner}");

    let req = seen::required(gt, &kept, h);
    let seen_set = SegmentSet::new(req.segments.clone(), EDGE_TOL * h);
    let (near, count) = border::border_set(&kept, &on, EDGE_TOL * h);
    assert_eq!(count, on.iter().filter(|&&b| b).count());
    let seen_edges: Vec<(V3, V3)> = req.segments.clone();
    assert_eq!(
        border::found_length_near(&seen_edges, &near, &seen_set, 0.1 * h),
        0.0
    );
    // The silhouette edges, but for the 2 h next to a seen edge's end at each of their
    // ends that meet one (6 of the 12 such ends).
    let sil: Vec<(V3, V3)> = silhouette.iter().map(|e| (e.start, e.end)).collect();
    let len: f64 = silhouette.iter().map(|e| e.length).sum();
    let got = border::found_length_near(&sil, &near, &seen_set, 0.01 * h);
    let want = len - 6.0 * EDGE_TOL * h;
    assert!((got - want).abs() < 0.05 * h, "{got} vs {want}");
}

/// The facet creases of a mesh: a folded strip of two triangles per fold, folds of 10° and
/// 50°: with the sharp angle 30°, the 10° fold is a crease, the 50° one is not (a sharp edge),
/// nor the flat diagonals or the boundary.
#[test]
fn creases_are_the_folds_below_the_sharp_angle() {
    let mut gt = box_truth().ground_truth;
    // Vertices: the strip's cross-sections at x = 0, 1, 2; z rises after x = 1 by the fold
    // angle's slope for the second panel.
    let up = |deg: f64| deg.to_radians().tan();
    let make = |deg: f64| -> Vec<V3> {
        vec![
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [2.0, 0.0, up(deg)],
            [2.0, 1.0, up(deg)],
        ]
    };
    let triangles = vec![[0, 2, 1], [1, 2, 3], [2, 4, 3], [3, 4, 5]];
    for (deg, creases) in [(10.0, 1), (50.0, 0)] {
        gt.surface = synth::TruthSurface::Mesh {
            vertices: make(deg),
            triangles: triangles.clone(),
        };
        let c = border::creases(&gt, 30.0);
        assert_eq!(c.len(), creases, "fold {deg}°: {c:?}");
        if creases == 1 {
            assert_eq!(c[0], ([1.0, 0.0, 0.0], [1.0, 1.0, 0.0]));
        }
    }
}

/// Issue 17's verdicts: the CAD check is its four detection thresholds; a pattern row with no
/// corner to require passes the corner checks, and a found edge on a scan border fails it.
#[test]
fn cad_and_pattern_verdicts() {
    let mut r = scored(Kind::Cad);
    r.edges.as_mut().unwrap().precision = Some(0.96);
    r.corners = Some(CornerMetrics {
        recall: Some(0.9),
        precision: Some(0.95),
        ..corner_metrics(&[], &[], None, 1.0)
    });
    r.rectify.as_mut().unwrap().away_moved = 5;
    let c = checks(Kind::Cad, false, &r);
    let names: Vec<&str> = c.iter().map(|c| c.name).collect();
    assert_eq!(
        names,
        [
            "corner recall",
            "corner precision",
            "edge recall",
            "edge precision"
        ]
    );
    assert!(c.iter().all(|c| c.pass), "{c:?}");
    r.corners.as_mut().unwrap().recall = Some(0.89);
    assert!(!checks(Kind::Cad, false, &r)[0].pass);

    let mut r = scored(Kind::Pattern);
    r.edges.as_mut().unwrap().precision = Some(1.0);
    let c = checks(Kind::Pattern, false, &r);
    let corners: Vec<&Check> = c.iter().filter(|c| c.name.starts_with("corner")).collect();
    assert_eq!(corners.len(), 2);
    assert!(corners.iter().all(|c| c.pass && c.value == Some(1.0)));
    assert!(c.iter().all(|c| c.pass), "{c:?}");
    assert!(!c.iter().any(|c| c.name.contains("oracle")));
    // The same on a random part scanned in a pattern (one view of a box across one edge):
    // nothing to require, nothing to compare with the oracle.
    let c = checks(Kind::Random, false, &r);
    let corners: Vec<&Check> = c.iter().filter(|c| c.name.starts_with("corner")).collect();
    assert!(corners.iter().all(|c| c.pass && c.value == Some(1.0)));
    let oracle = c.iter().find(|c| c.name.contains("oracle")).unwrap();
    assert_eq!((oracle.value, oracle.pass), (Some(1.0), true));
    // A required corner that was not found is no vacuous pass.
    r.corners.as_mut().unwrap().truth = 1;
    let c = checks(Kind::Random, false, &r);
    assert!(!c.iter().find(|c| c.name == "corner recall").unwrap().pass);
    assert!(!c.iter().find(|c| c.name.contains("oracle")).unwrap().pass);
    r.corners.as_mut().unwrap().truth = 0;
    r.border = Some(BorderMetrics {
        border_points: 100,
        found_on_border_h: 0.5,
        share: Some(0.005),
    });
    let c = checks(Kind::Pattern, false, &r);
    let b = c
        .iter()
        .find(|c| c.name == "found edge on scan borders (h)")
        .unwrap();
    assert_eq!((b.value, b.pass), (Some(0.5), false));
}
