//! Curved sharp edges through the whole pipeline, on simulated scans of small CAD-like parts
//! built here as meshes: a disc (two circular rims, no corner), a rounded plate with a hole
//! (straight edges running tangentially into arcs: bends, not corners; the hole's rims closed),
//! and a block whose edge is a fillet far wider than a scan's rounding (no sharp edge at all).
//! Found edges are compared with the simulator's ground truth.

use sharpedge::config::Settings;
use sharpedge::io::mesh::Mesh;
use sharpedge::outcome::Outcome;
use sharpedge::pipeline::{NoClock, process};
use sharpedge::synth::{GroundTruth, Part, Sampling, SynthParams, generate_from_mesh};

/// A solid between two copies (z = ±half) of a closed outline, optionally with a hole: side
/// walls, and caps triangulated as rings between outline and hole (or fans to the centre).
/// Outline and hole are sampled at the same angles around the origin, counter-clockwise.
fn extrusion(outline: &[[f64; 2]], hole: Option<&[[f64; 2]]>, half: f64) -> Mesh {
    let n = outline.len();
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut add = |p: [f64; 2], z: f64| {
        vertices.push([p[0], p[1], z]);
        (vertices.len() - 1) as u32
    };
    let ot: Vec<u32> = outline.iter().map(|&p| add(p, half)).collect();
    let ob: Vec<u32> = outline.iter().map(|&p| add(p, -half)).collect();
    let inner = hole.map(|h| {
        (
            h.iter().map(|&p| add(p, half)).collect::<Vec<u32>>(),
            h.iter().map(|&p| add(p, -half)).collect::<Vec<u32>>(),
        )
    });
    let centres = inner
        .is_none()
        .then(|| (add([0.0, 0.0], half), add([0.0, 0.0], -half)));
    let mut triangles = Vec::new();
    for i in 0..n {
        let j = (i + 1) % n;
        triangles.push([ob[i], ob[j], ot[j]]);
        triangles.push([ob[i], ot[j], ot[i]]);
        match (&inner, centres) {
            (Some((it, ib)), _) => {
                triangles.push([it[i], ot[i], ot[j]]);
                triangles.push([it[i], ot[j], it[j]]);
                triangles.push([ib[i], ob[j], ob[i]]);
                triangles.push([ib[i], ib[j], ob[j]]);
                triangles.push([it[i], it[j], ib[j]]);
                triangles.push([it[i], ib[j], ib[i]]);
            }
            (None, Some((ct, cb))) => {
                triangles.push([ct, ot[i], ot[j]]);
                triangles.push([cb, ob[j], ob[i]]);
            }
            (None, None) => unreachable!(),
        }
    }
    Mesh {
        vertices,
        triangles,
    }
}

fn circle(r: f64, n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            [r * a.cos(), r * a.sin()]
        })
        .collect()
}

/// The boundary of a rectangle (half sizes a, b) with corners rounded by radius rc, at n
/// angles around the centre.
fn rounded_rectangle(a: f64, b: f64, rc: f64, n: usize) -> Vec<[f64; 2]> {
    let inside = |x: f64, y: f64| {
        let (x, y) = (x.abs(), y.abs());
        if x <= a - rc || y <= b - rc {
            x <= a && y <= b
        } else {
            (x - (a - rc)).powi(2) + (y - (b - rc)).powi(2) <= rc * rc
        }
    };
    (0..n)
        .map(|i| {
            let t = std::f64::consts::TAU * i as f64 / n as f64;
            let (c, s) = (t.cos(), t.sin());
            let (mut lo, mut hi) = (0.0, 2.0 * a.max(b));
            for _ in 0..60 {
                let m = 0.5 * (lo + hi);
                if inside(m * c, m * s) { lo = m } else { hi = m }
            }
            [lo * c, lo * s]
        })
        .collect()
}

fn scan(mesh: Mesh, points: usize, seed: u64) -> (sharpedge::Cloud, GroundTruth) {
    let params = SynthParams {
        part: Part::Mesh("test mesh".into()),
        sampling: Sampling::Points(points),
        noise: 0.15,
        round: 1.5,
        rotate: true,
        seed,
        ..Default::default()
    };
    let s = generate_from_mesh(&params, mesh).unwrap();
    (s.cloud, s.ground_truth)
}

fn run(cloud: sharpedge::Cloud) -> Outcome {
    process(cloud, &Settings::default(), &mut NoClock).unwrap()
}

/// Share of the found edges' length within `tol` spacings of a true edge (precision), and of
/// the true edges' length within `tol` of a found one (recall), sampled every tenth spacing.
fn recall_precision(out: &Outcome, gt: &GroundTruth, tol: f64) -> (f64, f64) {
    let h = gt.spacing;
    let sample = |a: [f64; 3], b: [f64; 3]| {
        let l = ((0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>()).sqrt();
        let n = ((l / (0.1 * h)).ceil() as usize).max(1);
        (0..n)
            .map(move |i| {
                let u = (i as f64 + 0.5) / n as f64;
                [0, 1, 2].map(|k| a[k] + u * (b[k] - a[k]))
            })
            .collect::<Vec<_>>()
    };
    let found: Vec<[f64; 3]> = out
        .edges
        .iter()
        .flat_map(|e| {
            e.polyline
                .windows(2)
                .flat_map(|w| sample(w[0], w[1]))
                .collect::<Vec<_>>()
        })
        .collect();
    let precision = found
        .iter()
        .filter(|p| {
            gt.distance_to_nearest_edge(**p)
                .is_some_and(|(d, _)| d <= tol * h)
        })
        .count() as f64
        / found.len().max(1) as f64;
    let dist_to_found = |p: [f64; 3]| {
        out.edges
            .iter()
            .flat_map(|e| e.polyline.windows(2))
            .map(|w| {
                let (a, b) = (w[0], w[1]);
                let d = [0, 1, 2].map(|k| b[k] - a[k]);
                let v = [0, 1, 2].map(|k| p[k] - a[k]);
                let dd: f64 = d.iter().map(|x| x * x).sum();
                let t = if dd > 0.0 {
                    ((0..3).map(|k| v[k] * d[k]).sum::<f64>() / dd).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (0..3)
                    .map(|k| (v[k] - t * d[k]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let truth: Vec<[f64; 3]> = gt
        .edges
        .iter()
        .flat_map(|e| sample(e.start, e.end))
        .collect();
    let recall = truth
        .iter()
        .filter(|p| dist_to_found(**p) <= tol * h)
        .count() as f64
        / truth.len().max(1) as f64;
    (recall, precision)
}

/// A disc's two rims are circles: each is one closed edge, with no corner anywhere, on the
/// truth to a small fraction of the spacing.
#[test]
fn a_discs_rims_are_two_closed_edges_without_corners() {
    let mesh = extrusion(&circle(0.5, 256), None, 0.15);
    let (cloud, gt) = scan(mesh, 60_000, 3);
    let out = run(cloud);
    assert_eq!(out.corners.len(), 0, "corners on a disc: {:?}", out.corners);
    assert_eq!(
        out.edges.len(),
        2,
        "{:#?}",
        out.edges
            .iter()
            .map(|e| (e.closed, e.polyline.len()))
            .collect::<Vec<_>>()
    );
    for e in &out.edges {
        assert!(e.closed && e.start == e.end, "edge {} is not closed", e.id);
        assert!(e.polyline.len() > 50);
    }
    let (recall, precision) = recall_precision(&out, &gt, 0.5);
    assert!(
        recall > 0.99 && precision > 0.99,
        "recall {recall}, precision {precision} within 0.5 h"
    );
}

/// A rounded plate with a hole: the straight sides run tangentially into the corner arcs, which
/// is a bend, not a corner, so the outline's rims are closed edges too; so are the hole's
/// (about 25 spacings across, 8 neighbourhood radii).
#[test]
fn straight_edges_bending_into_arcs_have_no_corners_and_a_hole_rim_closes() {
    let n = 256;
    let outline = rounded_rectangle(0.5, 0.3, 0.12, n);
    let hole = circle(0.09, n);
    let mesh = extrusion(&outline, Some(&hole), 0.075);
    let (cloud, gt) = scan(mesh, 150_000, 5);
    let out = run(cloud);
    assert_eq!(out.corners.len(), 0, "{:?}", out.corners);
    assert_eq!(
        out.edges.iter().filter(|e| e.closed).count(),
        4,
        "{:#?}",
        out.edges
            .iter()
            .map(|e| (e.closed, e.polyline.len(), e.start))
            .collect::<Vec<_>>()
    );
    let (recall, precision) = recall_precision(&out, &gt, 1.0);
    assert!(
        recall > 0.98 && precision > 0.98,
        "recall {recall}, precision {precision}"
    );
}

/// A block whose long top edges are fillets of radius 20 spacings (a mesh with 12 facets
/// per quarter circle, smoothed by the simulator): no sharp edge there and none of its
/// points move; the block's sharp edges elsewhere are still found.
#[test]
fn a_wide_fillet_is_no_sharp_edge_and_its_points_stay() {
    // Profile in (x, z): a 1.0 × 0.6 rectangle whose two top corners are quarter circles.
    let rf = 0.12;
    let mut profile: Vec<[f64; 2]> = vec![[-0.5, -0.3], [0.5, -0.3]];
    for (cx, a0) in [(0.5 - rf, 0.0f64), (-0.5 + rf, 90.0f64)] {
        for i in 0..=12 {
            let a = (a0 + 90.0 * i as f64 / 12.0).to_radians();
            profile.push([cx + rf * a.cos(), 0.3 - rf + rf * a.sin()]);
        }
    }
    // Extrude the profile along y by 0.8: caps are fans from the profile's centre.
    let n = profile.len();
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    for y in [-0.4, 0.4] {
        for p in &profile {
            vertices.push([p[0], y, p[1]]);
        }
    }
    vertices.push([0.0, -0.4, 0.0]);
    vertices.push([0.0, 0.4, 0.0]);
    let (c0, c1) = ((2 * n) as u32, (2 * n + 1) as u32);
    let mut triangles = Vec::new();
    for i in 0..n as u32 {
        let j = (i + 1) % n as u32;
        let (a0, a1, b0, b1) = (i, j, i + n as u32, j + n as u32);
        triangles.push([a0, b1, a1]);
        triangles.push([a0, b0, b1]);
        triangles.push([c0, a0, a1]);
        triangles.push([c1, b1, b0]);
    }
    let mesh = Mesh {
        vertices,
        triangles,
    };
    let (cloud, gt) = scan(mesh, 100_000, 9);
    let h = gt.spacing;
    assert!(rf / h > 8.0, "fillet radius {} spacings", rf / h);
    let positions = cloud.positions.clone();
    let out = run(cloud);
    // The fillets' axes: y lines at x = ±(0.5 − rf), z = 0.3 − rf (rotated like the scan).
    // Nothing found runs along them...
    for e in &out.edges {
        for p in &e.polyline {
            let (d, _) = gt.distance_to_nearest_edge(*p).unwrap();
            assert!(
                d < 2.0 * h,
                "edge {} runs {:.1} h from every sharp edge",
                e.id,
                d / h
            );
        }
    }
    // ...and no point of the fillets moved: every moved point lies near a true sharp edge.
    for (i, p) in positions.iter().enumerate() {
        if out.moved[i] {
            let (d, _) = gt.distance_to_nearest_edge(*p).unwrap();
            assert!(
                d < 6.0 * h,
                "point {i} moved {:.1} h from every sharp edge",
                d / h
            );
        }
    }
    // The block's straight edges are all found; the four arcs where its end faces meet the
    // fillets (31 spacings each of about 1,100) are found only in part (0.89 to 0.91 in all):
    // their runs are short pieces whose vertices with the fillets' stray runs keep their slabs
    // away. Known gap, noted in issue 4's closing note.
    let (recall, _) = recall_precision(&out, &gt, 2.0);
    assert!(recall > 0.85, "recall {recall} of the block's sharp edges");
}
