//! Sampling statistics and invariants of `synth::generate`: point count, nearest-neighbour
//! spacing, noise level, the extra-noise band, outliers, determinism across thread counts,
//! large georeferenced offsets, and the ground truth's JSON round trip.

use sharpedge::geometry::{V3, dist, dot, sub};
use sharpedge::synth::{GroundTruth, NN_RATIO, Part, Sampling, Scan, SynthParams, generate};

fn base(part: Part, n: usize) -> SynthParams {
    SynthParams {
        part,
        sampling: Sampling::Points(n),
        seed: 3,
        ..Default::default()
    }
}

/// Mean distance to the nearest other point, by brute force.
fn mean_nn(pos: &[V3]) -> f64 {
    let total: f64 = pos
        .iter()
        .enumerate()
        .map(|(i, p)| {
            pos.iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, q)| dist(*p, *q))
                .fold(f64::INFINITY, f64::min)
        })
        .sum();
    total / pos.len() as f64
}

#[test]
fn point_count_follows_the_request() {
    for n in [1_000usize, 30_000] {
        for part in [Part::Box, Part::Step, Part::Sphere] {
            let s = generate(&base(part.clone(), n)).unwrap();
            let rel = (s.cloud.len() as f64 - n as f64).abs() / n as f64;
            assert!(rel < 0.02, "{part:?} {n}: {} points", s.cloud.len());
            assert_eq!(s.truth.len(), s.cloud.len());
            assert_eq!(s.ground_truth.points, s.cloud.len());
        }
    }
    // A given spacing: area / h² points (box 100 x 80 x 60 has area 37 600).
    let s = generate(&SynthParams {
        sampling: Sampling::Spacing(1.0),
        ..Default::default()
    })
    .unwrap();
    assert_eq!(s.ground_truth.spacing, 1.0);
    assert!((s.cloud.len() as f64 - 37_600.0).abs() < 0.01 * 37_600.0);
}

/// The mean nearest-neighbour distance on a small box, by brute force: the planar-face value
/// `NN_RATIO · h` within 4 % (edges, where faces meet at 90°, pull it down slightly).
#[test]
fn mean_nearest_neighbour_distance_is_close_to_the_spacing() {
    for part in [Part::Box, Part::Sphere] {
        let s = generate(&base(part.clone(), 6_000)).unwrap();
        let h = s.ground_truth.spacing;
        let ratio = mean_nn(&s.cloud.positions) / h;
        assert!(
            (ratio / NN_RATIO - 1.0).abs() < 0.04,
            "{part:?}: mean NN = {ratio:.4} h, NN_RATIO = {NN_RATIO}"
        );
    }
    // Without jitter the grid is exact: the mean NN distance is h except near edges.
    let s = generate(&SynthParams {
        jitter: 0.0,
        ..base(Part::Box, 6_000)
    })
    .unwrap();
    let ratio = mean_nn(&s.cloud.positions) / s.ground_truth.spacing;
    assert!(ratio > 0.97 && ratio <= 1.0 + 1e-9, "{ratio}");
}

#[test]
fn noise_has_the_requested_sigma() {
    let s = generate(&SynthParams {
        noise: 0.5,
        ..base(Part::Box, 50_000)
    })
    .unwrap();
    let h = s.ground_truth.spacing;
    let n = s.cloud.len() as f64;
    let mut sum2 = [0.0; 3];
    for (p, t) in s.cloud.positions.iter().zip(&s.truth) {
        let d = sub(*p, t.surface);
        for k in 0..3 {
            sum2[k] += d[k] * d[k];
        }
    }
    for v in sum2 {
        let sigma = (v / n).sqrt() / h;
        assert!(
            (sigma - 0.5).abs() < 0.01,
            "sigma {sigma} spacings per axis"
        );
    }
    // Noise alone does not make a point abnormal.
    assert_eq!(s.ground_truth.abnormal_points, 0);
}

#[test]
fn edge_noise_band_is_the_abnormal_zone() {
    let s = generate(&SynthParams {
        edge_noise: 1.0,
        edge_band: 2.0,
        rotate: true,
        ..base(Part::Box, 50_000)
    })
    .unwrap();
    let h = s.ground_truth.spacing;
    let (mut inside, mut sum2) = (0usize, 0.0);
    for (p, t) in s.cloud.positions.iter().zip(&s.truth) {
        assert_eq!(t.abnormal, t.edge_distance < 2.0 * h);
        if t.abnormal {
            inside += 1;
            sum2 += sub(*p, t.surface).iter().map(|c| c * c).sum::<f64>();
        } else {
            assert_eq!(*p, t.surface);
        }
    }
    assert!(inside > 1000);
    let sigma = (sum2 / (3.0 * inside as f64)).sqrt() / h;
    assert!((sigma - 1.0).abs() < 0.05, "{sigma}");
    // The band's share of the surface: 2 h on each side of 960 units of edge, over 37 600.
    let want = 960.0 * 2.0 * 2.0 * h / 37_600.0;
    let got = inside as f64 / s.cloud.len() as f64;
    assert!((got / want - 1.0).abs() < 0.05, "{got} vs {want}");
}

#[test]
fn outliers_are_flagged_and_inside_the_enlarged_box() {
    let s = generate(&SynthParams {
        outliers: 0.05,
        round: 1.0,
        ..base(Part::Box, 40_000)
    })
    .unwrap();
    let gt = &s.ground_truth;
    let out: Vec<_> = s
        .cloud
        .positions
        .iter()
        .zip(&s.truth)
        .filter(|(_, t)| t.outlier)
        .collect();
    let frac = out.len() as f64 / s.cloud.len() as f64;
    assert!((frac - 0.05).abs() < 0.005, "{frac}");
    assert_eq!(gt.outlier_points, out.len());
    let mut far = 0;
    for (p, t) in &out {
        assert!(!t.abnormal);
        // Within the box 100 x 80 x 60 grown by 5 % per side.
        assert!(p[0].abs() <= 55.0 && p[1].abs() <= 44.0 && p[2].abs() <= 33.0);
        if gt.distance_to_surface(**p) > 3.0 * gt.spacing {
            far += 1;
        }
    }
    assert!(far > out.len() / 2);
}

fn generate_with_threads(p: &SynthParams, threads: usize) -> Scan {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| generate(p).unwrap())
}

#[test]
fn same_seed_same_output_with_1_and_2_threads() {
    let mesh =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/cad/joint.off");
    let mut parts = vec![Part::Step, Part::Sphere];
    if mesh.is_file() {
        parts.push(Part::Mesh(mesh));
    } else {
        eprintln!("skipped the mesh case: ../shared/data absent");
    }
    for part in parts {
        let p = SynthParams {
            noise: 0.2,
            round: 1.5,
            edge_noise: 0.3,
            outliers: 0.01,
            rotate: true,
            ..base(part.clone(), 60_000)
        };
        let a = generate_with_threads(&p, 1);
        let b = generate_with_threads(&p, 2);
        assert_eq!(a.cloud, b.cloud, "{part:?}");
        assert_eq!(a.truth, b.truth, "{part:?}");
        assert_eq!(a.ground_truth, b.ground_truth, "{part:?}");
        // And a different seed gives a different scan.
        let c = generate_with_threads(
            &SynthParams {
                seed: p.seed + 1,
                ..p.clone()
            },
            2,
        );
        assert_ne!(a.cloud.positions, c.cloud.positions);
    }
}

#[test]
fn georeferenced_offset_shifts_every_point_exactly() {
    for t in [[4_000_000.0, 0.0, 0.0], [512_345.1, 4_101_234.5, 80.0]] {
        let p = SynthParams {
            noise: 0.3,
            round: 1.0,
            outliers: 0.01,
            rotate: true,
            ..base(Part::Box, 20_000)
        };
        let a = generate(&p).unwrap();
        let b = generate(&SynthParams {
            translate: t,
            ..p.clone()
        })
        .unwrap();
        assert_eq!(a.cloud.len(), b.cloud.len());
        assert!(!a.cloud.source.double_precision);
        assert!(b.cloud.source.double_precision);
        for (pa, pb) in a.cloud.positions.iter().zip(&b.cloud.positions) {
            for k in 0..3 {
                assert!((pb[k] - pa[k] - t[k]).abs() < 1e-6, "{pa:?} {pb:?}");
            }
        }
        for (ta, tb) in a.truth.iter().zip(&b.truth) {
            assert!(dist(tb.surface, [0, 1, 2].map(|k| ta.surface[k] + t[k])) < 1e-6);
            assert_eq!(ta.abnormal, tb.abnormal);
            assert_eq!(ta.outlier, tb.outlier);
        }
        let gb = &b.ground_truth;
        assert_eq!(gb.translation, t);
        for (ea, eb) in a.ground_truth.edges.iter().zip(&gb.edges) {
            assert!(dist(eb.start, [0, 1, 2].map(|k| ea.start[k] + t[k])) < 1e-6);
        }
    }
    // Double output on request, also without an offset.
    let d = generate(&SynthParams {
        double: true,
        ..base(Part::Box, 1_000)
    })
    .unwrap();
    assert!(d.cloud.source.double_precision);
}

#[test]
fn ground_truth_json_round_trip() {
    for part in [Part::LBlock, Part::Sphere] {
        let s = generate(&SynthParams {
            round: 1.0,
            rotate: true,
            translate: [1.5, 2.5, -3.5],
            ..base(part, 5_000)
        })
        .unwrap();
        let gt = &s.ground_truth;
        let json = gt.to_json().unwrap();
        assert!(json.contains("\"format\": \"sharpedge-synth-truth/1\""));
        let back = GroundTruth::from_json(&json).unwrap();
        assert_eq!(&back, gt);
        // Bit-exact floats survive, and the queries agree.
        for p in s.cloud.positions.iter().step_by(97) {
            assert_eq!(back.distance_to_surface(*p), gt.distance_to_surface(*p));
            assert_eq!(
                back.distance_to_nearest_edge(*p),
                gt.distance_to_nearest_edge(*p)
            );
            assert_eq!(back.nearest_corner(*p), gt.nearest_corner(*p));
        }
        // Through a file too.
        let dir = tempfile::TempDir::new().unwrap();
        let path = dir.path().join("t.truth.json");
        std::fs::write(&path, &json).unwrap();
        assert_eq!(&GroundTruth::read(&path).unwrap(), gt);
    }
}

#[test]
fn bad_ground_truth_json_is_a_located_error() {
    let e = GroundTruth::from_json("{\"format\": 3}")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("<ground-truth JSON>: line 1, column 12: not a sharpedge ground truth: "),
        "{e}"
    );
    let s = generate(&base(Part::Box, 500)).unwrap();
    let json = s
        .ground_truth
        .to_json()
        .unwrap()
        .replace("sharpedge-synth-truth/1", "other/9");
    let e = GroundTruth::from_json(&json).unwrap_err().to_string();
    assert_eq!(
        e,
        "<ground-truth JSON>: format: ground-truth format \"other/9\" is not \"sharpedge-synth-truth/1\"; regenerate it with this version"
    );
}

#[test]
fn surface_queries_on_known_points() {
    let s = generate(&SynthParams {
        rotate: true,
        ..base(Part::Box, 2_000)
    })
    .unwrap();
    let gt = &s.ground_truth;
    let r = &gt.rotation;
    let world = |m: V3| [0, 1, 2].map(|k| dot(r[k], m));
    // 5 units outside the +x face: distance 5 to the surface, sqrt(5² + 10²) to the nearest
    // edge (the +x/+y edge is 40 − 30 = 10 away in y), corner (50, 40, 30) farther.
    let p = world([55.0, 30.0, 0.0]);
    assert!((gt.distance_to_surface(p) - 5.0).abs() < 1e-9);
    let (d, e) = gt.distance_to_nearest_edge(p).unwrap();
    assert!((d - 125f64.sqrt()).abs() < 1e-9);
    let edge = &gt.edges[e];
    assert!((edge.length - 60.0).abs() < 1e-9);
    let (dc, _) = gt.nearest_corner(p).unwrap();
    assert!((dc - (25.0f64 + 100.0 + 900.0).sqrt()).abs() < 1e-9);
    // Inside the box: distance to the nearest face.
    assert!((gt.distance_to_surface(world([0.0, 0.0, 20.0])) - 10.0).abs() < 1e-9);
}
