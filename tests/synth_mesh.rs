//! `synth` on triangle meshes from ../shared/data/cad: sharp-edge and corner counts, samples on
//! the surface, rounding, and the ground truth's fast queries against brute force.

use std::path::{Path, PathBuf};

use sharpedge::geometry::{V3, angle, dist, point_segment, point_triangle, sub};
use sharpedge::io::mesh::Mesh;
use sharpedge::synth::{
    GroundTruth, Part, Sampling, SynthParams, TruthSurface, generate, generate_from_mesh,
};

fn cad(file: &str) -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/cad");
    if !root.is_dir() {
        eprintln!("skipped: ../shared/data absent");
        return None;
    }
    Some(root.join(file))
}

fn mesh_params(path: PathBuf, n: usize) -> SynthParams {
    SynthParams {
        part: Part::Mesh(path),
        sampling: Sampling::Points(n),
        rotate: true,
        seed: 11,
        ..Default::default()
    }
}

/// Turning angle of the polyline at a corner joining exactly two edges (degrees).
fn turning(gt: &GroundTruth, corner: usize) -> f64 {
    let c = &gt.corners[corner];
    let other = |e: usize| {
        let e = &gt.edges[e];
        if dist(e.start, c.position) < dist(e.end, c.position) {
            e.end
        } else {
            e.start
        }
    };
    angle(
        sub(c.position, other(c.edges[0])),
        sub(other(c.edges[1]), c.position),
    )
    .to_degrees()
}

/// Total turning along a polyline (degrees): large for a curved crease.
fn polyline_turning(gt: &GroundTruth, id: usize) -> f64 {
    let pl = &gt.polylines[id];
    pl.edges
        .windows(2)
        .map(|w| {
            let (a, b) = (&gt.edges[w[0]], &gt.edges[w[1]]);
            let da = sub(a.end, a.start);
            let db = sub(b.end, b.start);
            // Segments are stored in mesh order: align the second with the first.
            let t = angle(da, db).to_degrees();
            t.min(180.0 - t)
        })
        .sum()
}

#[test]
fn fandisk_and_anchor_sharp_features() {
    // (file, sharp edges as in SOURCES.md, corners, polylines)
    for (file, edges, corners, polylines) in [
        ("fandisk.off", 722, 23, 35),
        ("anchor_dense.off", 890, 24, 43),
        ("joint.off", 225, 12, 22),
        ("pinion.off", 510, 80, 122),
    ] {
        let Some(path) = cad(file) else { return };
        // The mesh as it is: the counts of SOURCES.md.
        let facets = SynthParams {
            subdivide: 0,
            ..mesh_params(path.clone(), 2_000)
        };
        let gt = generate(&facets).unwrap().ground_truth;
        assert_eq!(gt.edges.len(), edges, "{file}");
        assert_eq!(gt.corners.len(), corners, "{file}");
        assert_eq!(gt.polylines.len(), polylines, "{file}");
        // Smoothed by two levels of subdivision (the default for a mesh with curved
        // patches): every sharp edge in four pieces, the same corners and creases.
        let smooth = generate(&mesh_params(path, 2_000)).unwrap().ground_truth;
        assert_eq!(smooth.edges.len(), 4 * edges, "{file}");
        assert_eq!(smooth.corners.len(), corners, "{file}");
        assert_eq!(smooth.polylines.len(), polylines, "{file}");
        for (a, b) in gt.corners.iter().zip(&smooth.corners) {
            assert!(dist(a.position, b.position) < 1e-12, "{file}: corners move");
        }
        assert_eq!(gt.mesh_stats.boundary_edges, 0, "{file}");
        assert!(!gt.mesh_stats.flipped, "{file}");
        // Corners on a crease (two edges) are real turns, far above the 30° threshold.
        for c in 0..gt.corners.len() {
            if gt.corners[c].edges.len() == 2 {
                assert!(turning(&gt, c) > 75.0, "{file}: corner {c}");
            } else {
                assert!(gt.corners[c].edges.len() >= 3);
            }
        }
        let total: f64 = gt.polylines.iter().map(|p| p.length).sum();
        assert!((total - gt.edge_length()).abs() < 1e-9);
    }
}

/// Fandisk's curved creases run through many mesh vertices without a corner.
#[test]
fn fandisk_curved_creases_have_no_corners_along_them() {
    let Some(path) = cad("fandisk.off") else {
        return;
    };
    let gt = generate(&mesh_params(path, 2_000)).unwrap().ground_truth;
    let curved: Vec<usize> = (0..gt.polylines.len())
        .filter(|&i| polyline_turning(&gt, i) > 45.0 && gt.polylines[i].edges.len() >= 10)
        .collect();
    assert!(curved.len() >= 4, "{curved:?}");
    let vertices_on_curves: usize = curved
        .iter()
        .map(|&i| gt.polylines[i].edges.len() - 1)
        .sum();
    // Hundreds of crease vertices turn a little each; none of them is a corner (corners end
    // polylines, so interior vertices are never corners).
    assert!(vertices_on_curves > 100, "{vertices_on_curves}");
    for &i in &curved {
        for w in gt.polylines[i].edges.windows(2) {
            let (a, b) = (&gt.edges[w[0]], &gt.edges[w[1]]);
            let shared = [a.start, a.end]
                .into_iter()
                .find(|p| dist(*p, b.start) < 1e-12 || dist(*p, b.end) < 1e-12)
                .unwrap();
            let (d, _) = gt.nearest_corner(shared).unwrap();
            assert!(d > 0.0);
        }
    }
}

#[test]
fn clean_mesh_samples_lie_on_the_mesh() {
    let Some(path) = cad("fandisk.off") else {
        return;
    };
    let scan = generate(&mesh_params(path, 30_000)).unwrap();
    let gt = &scan.ground_truth;
    assert!((scan.cloud.len() as f64 / 30_000.0 - 1.0).abs() < 0.02);
    // The file's own units are kept (bbox about 0.92 x 0.51 x 1.0).
    assert_eq!(gt.model_scale, 1.0);
    for (p, t) in scan.cloud.positions.iter().zip(&scan.truth) {
        assert_eq!(*p, t.surface);
        assert!(gt.distance_to_surface(*p) < 1e-12);
        let (d, _) = gt.distance_to_nearest_edge(*p).unwrap();
        assert!((d - t.edge_distance).abs() < 1e-12);
    }
}

#[test]
fn rounded_mesh_samples_move_within_the_tangent_band() {
    let Some(path) = cad("anchor_dense.off") else {
        return;
    };
    let scan = generate(&SynthParams {
        round: 1.5,
        ..mesh_params(path, 50_000)
    })
    .unwrap();
    let gt = &scan.ground_truth;
    let r = gt.round_radius;
    let td_max = gt
        .edges
        .iter()
        .map(|e| e.tangent_distance)
        .fold(0.0, f64::max);
    let (mut moved, mut within_cylinder_bound) = (0, 0);
    for (p, t) in scan.cloud.positions.iter().zip(&scan.truth) {
        if t.abnormal {
            moved += 1;
            let shift = dist(*p, t.surface);
            assert!(shift > 0.0 && shift < 2.0 * td_max);
            assert!(t.edge_distance < td_max);
            // On a cylinder the shift is at most the distance from the face to the fillet at
            // the edge itself (ball blends at corners and samples rounded by a neighbouring
            // segment of a curved crease may exceed it a little).
            let e = &gt.edges[t.nearest_edge as usize];
            let beta = (180.0 - (180.0 - e.dihedral_deg).abs()).to_radians();
            if shift <= r / (0.5 * beta).sin() - r + 1e-12 {
                within_cylinder_bound += 1;
            }
        } else {
            assert_eq!(*p, t.surface);
        }
    }
    assert!(moved > 1_000, "{moved}");
    assert!(
        within_cylinder_bound as f64 > 0.95 * moved as f64,
        "{within_cylinder_bound} of {moved}"
    );
    assert_eq!(moved, gt.abnormal_points);
}

#[test]
fn box_obj_scaled_to_size() {
    let Some(path) = cad("box.obj") else { return };
    let scan = generate(&SynthParams {
        size: Some(10.0),
        rotate: false,
        ..mesh_params(path, 3_000)
    })
    .unwrap();
    let gt = &scan.ground_truth;
    assert_eq!(gt.part, "box.obj");
    assert_eq!(
        (gt.edges.len(), gt.corners.len(), gt.faces.len()),
        (12, 8, 6)
    );
    assert_eq!(gt.model_scale, 10.0);
    for c in &gt.corners {
        assert!(c.position.iter().all(|x| (x.abs() - 5.0).abs() < 1e-12));
    }
}

#[test]
fn meshes_in_memory_are_checked() {
    let p = SynthParams::default();
    let e = generate_from_mesh(
        &p,
        Mesh {
            vertices: vec![[0.0; 3]; 2],
            triangles: vec![[0, 1, 2]],
        },
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        e,
        "synth mesh: degenerate input: a triangle refers to a vertex that does not exist"
    );
    let e = generate_from_mesh(
        &p,
        Mesh {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            triangles: vec![[0, 1, 2]],
        },
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        e,
        "synth mesh: degenerate input: surface area is 0; nothing to sample"
    );
}

#[test]
fn mesh_file_errors_pass_through() {
    let p = SynthParams {
        part: Part::Mesh("/nonexistent/part.off".into()),
        ..Default::default()
    };
    let e = generate(&p).unwrap_err();
    assert_eq!(e.to_string(), "/nonexistent/part.off: cannot open");
    assert!(
        std::error::Error::source(&e).is_some(),
        "the OS reason is chained"
    );
}

/// The grid-accelerated queries return exactly the brute-force minimum.
#[test]
fn fast_queries_match_brute_force_on_fandisk() {
    let Some(path) = cad("fandisk.off") else {
        return;
    };
    let scan = generate(&SynthParams {
        noise: 2.0,
        outliers: 0.2,
        translate: [1000.0, 0.0, 0.0],
        ..mesh_params(path, 3_000)
    })
    .unwrap();
    let gt = &scan.ground_truth;
    let TruthSurface::Mesh {
        vertices,
        triangles,
    } = &gt.surface
    else {
        panic!("a mesh part has a mesh surface")
    };
    let brute_surface = |p: V3| {
        triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| vertices[i as usize]);
                point_triangle(p, a, b, c)
            })
            .fold(f64::INFINITY, f64::min)
    };
    let brute_edge = |p: V3| {
        gt.edges
            .iter()
            .map(|e| point_segment(p, e.start, e.end).0)
            .fold(f64::INFINITY, f64::min)
    };
    // Noisy points, outliers, and points far outside the part.
    let mut queries: Vec<V3> = scan.cloud.positions.iter().step_by(3).copied().collect();
    queries.push([1000.0, 5.0, -3.0]);
    queries.push([-50.0, 0.0, 0.0]);
    for q in queries {
        assert_eq!(gt.distance_to_surface(q), brute_surface(q), "{q:?}");
        assert_eq!(
            gt.distance_to_nearest_edge(q).unwrap().0,
            brute_edge(q),
            "{q:?}"
        );
    }
}
