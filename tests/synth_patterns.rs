//! The sampling patterns of `synth::generate`, checked as a user would: scan-line points on
//! their cut planes with the asked gap, grid and one-view points only where the sensor sees
//! the part (checked by brute-force rays against the true mesh), the grid's pitch growing with
//! the incidence, each view's points following its own pose, the density ratio across the
//! part, incidence noise, point counts, and determinism for 1 and 2 threads.

use sharpedge::geometry::{V3, dist, dot, norm, scale, sub, unit};
use sharpedge::synth::raycast::ray_triangle;
use sharpedge::synth::{
    GroundTruth, Part, Pattern, Sampling, Scan, ScanPattern, SynthParams, TruthSurface, generate,
};

fn params(part: Part, n: usize, scan: ScanPattern) -> SynthParams {
    SynthParams {
        part,
        sampling: Sampling::Points(n),
        seed: 5,
        scan,
        ..Default::default()
    }
}

fn pattern(pattern: Pattern) -> ScanPattern {
    ScanPattern {
        pattern,
        ..Default::default()
    }
}

fn mesh(gt: &GroundTruth) -> (&[V3], &[[u32; 3]]) {
    match &gt.surface {
        TruthSurface::Mesh {
            vertices,
            triangles,
        } => (vertices, triangles),
        TruthSurface::Sphere { .. } => panic!("not a mesh"),
    }
}

/// Whether the segment from `sensor` to `p` crosses the true surface before `p` (a loop over
/// every triangle: independent of the simulator's grid walk).
fn hidden(gt: &GroundTruth, sensor: V3, p: V3) -> bool {
    let (v, tris) = mesh(gt);
    let l = dist(sensor, p);
    let d = scale(sub(p, sensor), 1.0 / l);
    tris.iter().any(|t| {
        let [a, b, c] = t.map(|i| v[i as usize]);
        ray_triangle(sensor, d, a, b, c).is_some_and(|(t, _, _)| t < l - 1e-6 * gt.spacing)
    })
}

#[test]
fn scan_line_points_lie_on_the_cut_planes() {
    // A rotated L-block cut in a drawn direction: every noise-free point is on a plane
    // n · x = offset + k gap of the truth file (world coordinates).
    for gap in [1.0, 3.0, 10.0] {
        let p = SynthParams {
            rotate: true,
            ..params(
                Part::LBlock,
                40_000,
                ScanPattern {
                    line_gap: gap,
                    ..pattern(Pattern::Lines)
                },
            )
        };
        let s = generate(&p).unwrap();
        let n = s.cloud.len() as f64;
        assert!(
            (n - 40_000.0).abs() < 0.03 * 40_000.0,
            "gap {gap}: {n} points"
        );
        let lines = s.ground_truth.lines.clone().unwrap();
        let h = s.ground_truth.spacing;
        assert!((lines.gap - gap * h).abs() < 1e-12 * h);
        let worst = s
            .cloud
            .positions
            .iter()
            .map(|x| {
                let k = (dot(lines.normal, *x) - lines.offset) / lines.gap;
                (k - k.round()).abs() * lines.gap
            })
            .fold(0.0, f64::max);
        assert!(worst < 1e-9 * 100.0, "gap {gap}: {worst} off a plane");
    }
}

#[test]
fn scan_lines_have_the_asked_along_and_across_spacings() {
    // Planes z = const cut the box's four side faces into horizontal lines; the top and
    // bottom faces, parallel to the planes, get none.
    for gap in [3.0, 10.0] {
        let s = generate(&params(
            Part::Box,
            30_000,
            ScanPattern {
                line_gap: gap,
                line_direction: Some([0.0, 0.0, 1.0]),
                ..pattern(Pattern::Lines)
            },
        ))
        .unwrap();
        let h = s.ground_truth.spacing;
        let gt = &s.ground_truth;
        assert!(
            s.truth
                .iter()
                .all(|t| gt.faces[t.face as usize].normal[2].abs() < 1e-12)
        );
        // The face x = +50: along-line spacing from neighbours on the same line, across-line
        // spacing from the nearest point on any other line.
        let face: Vec<V3> = s
            .cloud
            .positions
            .iter()
            .copied()
            .filter(|p| (p[0] - 50.0).abs() < 1e-9)
            .collect();
        let line_of = |p: &V3| ((p[2] - gt.lines.as_ref().unwrap().offset) / (gap * h)).round();
        let sample: Vec<V3> = face.iter().step_by(7).copied().collect();
        let along: f64 = sample
            .iter()
            .map(|p| {
                face.iter()
                    .filter(|q| line_of(q) == line_of(p))
                    .map(|q| dist(*p, *q))
                    .filter(|&d| d > 0.0)
                    .fold(f64::INFINITY, f64::min)
            })
            .sum::<f64>()
            / sample.len() as f64;
        let across: f64 = sample
            .iter()
            .map(|p| {
                face.iter()
                    .filter(|q| line_of(q) != line_of(p))
                    .map(|q| dist(*p, *q))
                    .fold(f64::INFINITY, f64::min)
            })
            .sum::<f64>()
            / sample.len() as f64;
        // Jitter 0.1 h along the line: the nearest neighbour is a little under h.
        assert!(
            (along / h - 0.97).abs() < 0.04,
            "gap {gap}: along {}",
            along / h
        );
        assert!(
            (across / h - gap).abs() < 0.02 * gap,
            "gap {gap}: across {}",
            across / h
        );
    }
}

#[test]
fn grid_and_one_view_points_are_only_where_the_sensor_sees() {
    // A non-convex part (L-block) rotated, seen from a drawn sensor, from a sensor looking
    // into the L's inner corner, and from three views.
    let sensors = [None, Some([150.0, -20.0, 40.0])];
    for pat in [Pattern::Grid, Pattern::View] {
        for sensor in sensors {
            for views in [1, 3] {
                if sensor.is_some() && views > 1 {
                    continue;
                }
                let p = SynthParams {
                    rotate: sensor.is_none(),
                    noise: 0.0,
                    ..params(
                        Part::LBlock,
                        8_000,
                        ScanPattern {
                            sensors: sensor.into_iter().collect(),
                            views,
                            misregistration: 0.0,
                            ..pattern(pat)
                        },
                    )
                };
                let s = generate(&p).unwrap();
                let gt = &s.ground_truth;
                assert_eq!(gt.sensors.len(), views);
                assert!(s.cloud.len() > 2_000, "{pat:?}: {} points", s.cloud.len());
                let mut seen_faces = std::collections::BTreeSet::new();
                for t in &s.truth {
                    let v = t.view as usize;
                    assert!(v < views, "{pat:?}: view {}", t.view);
                    let sensor = gt.sensors[v].position;
                    let n = gt.faces[t.face as usize].normal;
                    assert!(
                        dot(n, sub(sensor, t.surface)) > 0.0,
                        "{pat:?}: a point on face {} turned away from sensor {v}",
                        t.face
                    );
                    assert!(
                        !hidden(gt, sensor, t.surface),
                        "{pat:?}: a point at {:?} hidden from sensor {v}",
                        t.surface
                    );
                    seen_faces.insert(t.face);
                }
                // A sensor sees at most 3 of the 8 faces' directions of an L-block… but never
                // all 8.
                assert!(seen_faces.len() < gt.faces.len(), "{pat:?}: {seen_faces:?}");
            }
        }
    }
}

#[test]
fn one_view_keeps_every_visible_sample_of_the_uniform_grid() {
    // At a given spacing the one-view scan is the uniform scan's grid kept where the sensor
    // sees it: exactly the uniform points that face the sensor and are not hidden.
    let sensor = [150.0, -20.0, 40.0];
    let base = SynthParams {
        part: Part::LBlock,
        sampling: Sampling::Spacing(1.5),
        seed: 2,
        ..Default::default()
    };
    let uniform = generate(&base).unwrap();
    let view = generate(&SynthParams {
        scan: ScanPattern {
            sensors: vec![sensor],
            ..pattern(Pattern::View)
        },
        ..base.clone()
    })
    .unwrap();
    let gt = &uniform.ground_truth;
    let want: Vec<V3> = uniform
        .truth
        .iter()
        .filter(|t| {
            dot(gt.faces[t.face as usize].normal, sub(sensor, t.surface)) > 0.0
                && !hidden(gt, sensor, t.surface)
        })
        .map(|t| t.surface)
        .collect();
    let mut got: Vec<V3> = view.truth.iter().map(|t| t.surface).collect();
    let mut want = want;
    let key = |a: &V3, b: &V3| a.partial_cmp(b).unwrap();
    got.sort_by(key);
    want.sort_by(key);
    // The inner corner hides part of the L: some points that face the sensor go, and exactly
    // the hidden ones.
    let facing = uniform
        .truth
        .iter()
        .filter(|t| dot(gt.faces[t.face as usize].normal, sub(sensor, t.surface)) > 0.0)
        .count();
    assert!(want.len() + 100 < facing, "{} of {facing} seen", want.len());
    assert!(facing < uniform.cloud.len() * 2 / 3);
    assert_eq!(got.len(), want.len());
    assert_eq!(got, want);
}

#[test]
fn grid_pitch_grows_with_the_incidence_angle() {
    // A far sensor (small perspective change over a face): the density on each seen face of
    // the box is cos θ / pitch² with the pitch scaled by the distance.
    let sensor = unit([1.0, 0.7, 1.6]).unwrap().map(|c| c * 2_000.0);
    let s = generate(&SynthParams {
        jitter: 0.0,
        ..params(
            Part::Box,
            60_000,
            ScanPattern {
                sensors: vec![sensor],
                ..pattern(Pattern::Grid)
            },
        )
    })
    .unwrap();
    let gt = &s.ground_truth;
    let pitch = gt.sensors[0].pitch;
    let mut faces_seen = 0;
    let mut cosines = Vec::new();
    for f in &gt.faces {
        let n = s.truth.iter().filter(|t| t.face as usize == f.id).count();
        let to_sensor = sub(sensor, f.point);
        let c = dot(f.normal, unit(to_sensor).unwrap());
        if c <= 0.0 {
            assert_eq!(n, 0, "face {} turned away has {n} points", f.id);
            continue;
        }
        // f.point is a point of the face, not its centre: use the mean of its points.
        let pts: Vec<V3> = s
            .truth
            .iter()
            .filter(|t| t.face as usize == f.id)
            .map(|t| t.surface)
            .collect();
        let centre = scale(
            pts.iter()
                .fold([0.0; 3], |a, p| [a[0] + p[0], a[1] + p[1], a[2] + p[2]]),
            1.0 / pts.len() as f64,
        );
        let c = dot(f.normal, unit(sub(sensor, centre)).unwrap());
        let d = dist(sensor, centre);
        let expect = f.area * c / (pitch * d / norm(sensor)).powi(2);
        let ratio = n as f64 / expect;
        assert!(
            (ratio - 1.0).abs() < 0.03,
            "face {}: {n} points, {expect:.0} expected",
            f.id
        );
        faces_seen += 1;
        cosines.push(c);
    }
    assert_eq!(faces_seen, 3);
    // The faces were seen at clearly different incidences.
    let (lo, hi) = cosines
        .iter()
        .fold((1.0f64, 0.0f64), |(a, b), &c| (a.min(c), b.max(c)));
    assert!(hi / lo > 2.0, "{cosines:?}");
}

#[test]
fn each_view_follows_its_own_pose_with_the_asked_misregistration() {
    for m in [0.2, 1.0] {
        for pat in [Pattern::View, Pattern::Grid] {
            let s = generate(&SynthParams {
                rotate: true,
                translate: [1000.0, -20.0, 5.0],
                ..params(
                    Part::Box,
                    30_000,
                    ScanPattern {
                        views: 3,
                        misregistration: m,
                        ..pattern(pat)
                    },
                )
            })
            .unwrap();
            let gt = &s.ground_truth;
            let h = gt.spacing;
            for (v, sensor) in gt.sensors.iter().enumerate() {
                let r = sensor.registration_rotation;
                let t = sensor.registration_translation;
                let mut moved: f64 = 0.0;
                let mut n = 0usize;
                for (x, tr) in s.cloud.positions.iter().zip(&s.truth) {
                    if tr.view as usize != v {
                        continue;
                    }
                    n += 1;
                    let q = tr.surface;
                    let posed = [0, 1, 2].map(|k| dot(r[k], q) + t[k]);
                    assert!(dist(*x, posed) < 1e-8 * 1000.0, "{pat:?} view {v}");
                    moved = moved.max(dist(*x, q));
                }
                assert!(n > 1_000, "{pat:?} view {v}: {n} points");
                if v == 0 {
                    assert!(moved < 1e-8 * 1000.0, "the first view is the reference");
                } else {
                    assert!(
                        moved <= m * h * (1.0 + 1e-6),
                        "{pat:?} view {v}: {moved} > {m} h"
                    );
                    assert!(moved > 0.5 * m * h, "{pat:?} view {v}: {moved}");
                }
            }
            // Different densities: pitch h, 1.41 h, 2 h.
            let pitches: Vec<f64> = gt.sensors.iter().map(|s| s.pitch / h).collect();
            assert!((pitches[1] - 2f64.sqrt()).abs() < 1e-12 && (pitches[2] - 2.0).abs() < 1e-12);
            // About the asked number of points in all (a box hides nothing from itself).
            let n = s.cloud.len() as f64;
            assert!((n / 30_000.0 - 1.0).abs() < 0.03, "{pat:?}: {n}");
        }
    }
}

#[test]
fn view_density_follows_its_pitch() {
    // One-view scans of the convex box: every view's points per area of the faces it faces
    // is 1 / pitch².
    let s = generate(&params(
        Part::Box,
        40_000,
        ScanPattern {
            views: 3,
            ..pattern(Pattern::View)
        },
    ))
    .unwrap();
    let gt = &s.ground_truth;
    for (v, sensor) in gt.sensors.iter().enumerate() {
        let n = s.truth.iter().filter(|t| t.view as usize == v).count() as f64;
        let area: f64 = gt
            .faces
            .iter()
            .filter(|f| dot(f.normal, sub(sensor.position, f.point)) > 0.0)
            .map(|f| f.area)
            .sum();
        let ratio = n * sensor.pitch * sensor.pitch / area;
        assert!((ratio - 1.0).abs() < 0.03, "view {v}: {ratio}");
    }
}

#[test]
fn density_differs_by_the_ratio_from_one_end_to_the_other() {
    for (pat, ratio) in [
        (Pattern::Uniform, 4.0),
        (Pattern::Uniform, 10.0),
        (Pattern::Lines, 4.0),
    ] {
        let s = generate(&params(
            Part::Box,
            100_000,
            ScanPattern {
                density_ratio: ratio,
                density_direction: Some([1.0, 0.0, 0.0]),
                line_direction: (pat == Pattern::Lines).then(|| unit([0.3, 0.2, 1.0]).unwrap()),
                ..pattern(pat)
            },
        ))
        .unwrap();
        let n = s.cloud.len() as f64;
        assert!((n / 100_000.0 - 1.0).abs() < 0.03, "{pat:?} {ratio}: {n}");
        let d = s.ground_truth.density.clone().unwrap();
        assert_eq!((d.lo, d.hi), (-50.0, 50.0));
        // Points per area on the two end faces (x = -50 and x = +50, each 80 x 60).
        let dense = s
            .cloud
            .positions
            .iter()
            .filter(|p| p[0] < -50.0 + 1e-9)
            .count() as f64;
        let sparse = s
            .cloud
            .positions
            .iter()
            .filter(|p| p[0] > 50.0 - 1e-9)
            .count() as f64;
        let got = dense / sparse;
        assert!(
            (got / ratio - 1.0).abs() < 0.15,
            "{pat:?}: {got} for {ratio}"
        );
        // And smoothly in between: the middle of the top face holds 1 / sqrt(ratio).
        let h = s.ground_truth.spacing;
        let mid = s
            .cloud
            .positions
            .iter()
            .filter(|p| p[2] > 30.0 - 1e-9 && p[0].abs() < 5.0)
            .count() as f64;
        if pat == Pattern::Uniform {
            let want = 10.0 * 80.0 / (h * h) / ratio.sqrt();
            assert!((mid / want - 1.0).abs() < 0.1, "{pat:?}: {mid} vs {want}");
        }
    }
}

/// Standard deviation of the points of face `f` about its plane.
fn residual(s: &Scan, f: usize) -> f64 {
    let face = &s.ground_truth.faces[f];
    let r: Vec<f64> = s
        .cloud
        .positions
        .iter()
        .zip(&s.truth)
        .filter(|(_, t)| t.face as usize == f)
        .map(|(x, _)| dot(face.normal, sub(*x, face.point)))
        .collect();
    (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt()
}

#[test]
fn incidence_noise_doubles_at_sixty_degrees() {
    // The top face (z = +30) seen from straight above, then from 60° off: the noise about
    // the face doubles (sigma / cos 60°); a face seen at 0° keeps the plain sigma.
    let run = |deg: f64, pat: Pattern| {
        let a = deg.to_radians();
        let sensor = [1e5 * a.sin(), 0.0, 1e5 * a.cos()];
        generate(&SynthParams {
            noise: 0.3,
            ..params(
                Part::Box,
                60_000,
                ScanPattern {
                    sensors: vec![sensor],
                    incidence_noise: true,
                    ..pattern(pat)
                },
            )
        })
        .unwrap()
    };
    for pat in [Pattern::Uniform, Pattern::Lines] {
        let s0 = run(0.0, pat);
        let top = s0
            .ground_truth
            .faces
            .iter()
            .position(|f| f.normal[2] > 0.99)
            .unwrap();
        let h = s0.ground_truth.spacing;
        let r0 = residual(&s0, top);
        assert!((r0 / (0.3 * h) - 1.0).abs() < 0.05, "{pat:?}: {}", r0 / h);
        let r60 = residual(&run(60.0, pat), top);
        assert!((r60 / r0 - 2.0).abs() < 0.1, "{pat:?}: ratio {}", r60 / r0);
    }
    // Grid scans put the noise along the ray: about the face its sigma is the ray's times
    // cos θ, so with incidence noise the residual stays sigma whatever the angle.
    let g0 = run(0.0, Pattern::Grid);
    let top = g0
        .ground_truth
        .faces
        .iter()
        .position(|f| f.normal[2] > 0.99)
        .unwrap();
    let g60 = run(60.0, Pattern::Grid);
    let (r0, r60) = (residual(&g0, top), residual(&g60, top));
    assert!((r60 / r0 - 1.0).abs() < 0.1, "grid: {r0} vs {r60}");
}

#[test]
fn patterns_are_the_same_for_1_and_2_threads() {
    let with = |p: &SynthParams, threads: usize| -> Scan {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| generate(p).unwrap())
    };
    let scans = [
        pattern(Pattern::Lines),
        ScanPattern {
            views: 3,
            ..pattern(Pattern::Grid)
        },
        ScanPattern {
            views: 2,
            density_ratio: 4.0,
            incidence_noise: true,
            ..pattern(Pattern::View)
        },
    ];
    for scan in scans {
        let p = SynthParams {
            noise: 0.2,
            round: 1.5,
            edge_noise: 0.3,
            outliers: 0.01,
            rotate: true,
            ..params(Part::Step, 40_000, scan.clone())
        };
        let a = with(&p, 1);
        let b = with(&p, 2);
        assert_eq!(a.cloud, b.cloud, "{scan:?}");
        assert_eq!(a.truth, b.truth, "{scan:?}");
        assert_eq!(a.ground_truth, b.ground_truth, "{scan:?}");
        // The truth file keeps the sensors and patterns.
        let back = GroundTruth::from_json(&a.ground_truth.to_json().unwrap()).unwrap();
        assert_eq!(back, a.ground_truth);
        assert_eq!(back.params.scan, scan);
    }
}

#[test]
fn bad_pattern_settings_are_named() {
    let err = |scan: ScanPattern| {
        generate(&params(Part::Box, 1_000, scan))
            .unwrap_err()
            .to_string()
    };
    let cases = [
        (
            ScanPattern {
                line_gap: 0.5,
                ..pattern(Pattern::Lines)
            },
            "line_gap",
        ),
        (
            ScanPattern {
                views: 2,
                ..pattern(Pattern::Lines)
            },
            "views",
        ),
        (
            ScanPattern {
                sensors: vec![[1.0, 2.0, 3.0]],
                ..pattern(Pattern::Grid)
            },
            "outside the part's bounding sphere",
        ),
        (
            ScanPattern {
                density_direction: Some([0.0; 3]),
                density_ratio: 2.0,
                ..Default::default()
            },
            "density_direction",
        ),
        (
            ScanPattern {
                sensors: vec![[500.0, 0.0, 0.0]],
                ..pattern(Pattern::Lines)
            },
            "sensors are used by",
        ),
        (
            ScanPattern {
                line_direction: Some([0.0, 0.0, 1.0]),
                ..pattern(Pattern::Grid)
            },
            "line_direction",
        ),
    ];
    for (scan, want) in cases {
        let e = err(scan);
        assert!(e.contains(want), "{e}");
    }
    let sphere = generate(&params(Part::Sphere, 1_000, pattern(Pattern::Grid)));
    assert!(sphere.unwrap_err().to_string().contains("sphere"));
    // Old truth files (without the pattern) still read, as uniform scans.
    let old = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("samples/box.truth.json"),
    )
    .unwrap();
    let gt = GroundTruth::from_json(&old).unwrap();
    assert!(gt.params.scan.is_default() && gt.sensors.is_empty() && gt.lines.is_none());
}

#[test]
fn cli_writes_patterned_scans_and_their_sensors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("l.ply");
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_sharpedge"))
            .arg("-q")
            .arg("synth")
            .args(args)
            .output()
            .unwrap()
    };
    let o = run(&[
        "--part",
        "lblock",
        "--points",
        "5000",
        "--pattern",
        "grid",
        "--sensor",
        "150,-20,40",
        "--sensor",
        "-150,30,60",
        "--truth-fields",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let gt = GroundTruth::read(&dir.path().join("l.truth.json")).unwrap();
    assert_eq!(gt.params.scan.pattern, Pattern::Grid);
    assert_eq!(gt.params.scan.views, 2);
    let pos: Vec<V3> = gt.sensors.iter().map(|s| s.position).collect();
    assert_eq!(pos, vec![[150.0, -20.0, 40.0], [-150.0, 30.0, 60.0]]);
    let ply = std::fs::read(&out).unwrap();
    let header = String::from_utf8_lossy(&ply[..400.min(ply.len())]).into_owned();
    assert!(header.contains("scalar_view"), "{header}");
    // A pattern that does not exist, and a sensor with two coordinates, are named.
    let bad = run(&["--pattern", "spiral", "--out", out.to_str().unwrap()]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("uniform, lines, grid, view"));
    let bad = run(&[
        "--pattern",
        "view",
        "--sensor",
        "1,2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--sensor takes three numbers"));
}
