//! Occlusion boundaries are borders, never sharp edges (issue 16, item 4; issue 17, item 3).
//!
//! A depth frame is ray-cast here as a depth camera takes it: a 320 x 240 grid of rays, 2 mrad
//! apart, from a sensor at the origin, onto a box turned to show three faces, in front of a
//! wall. Where a ray's neighbour meets the other surface, the camera averages the two: a veil
//! of "mixed pixels" between the box's silhouette and the wall, which an edge fit takes for a
//! second face. The test checks, with the frame's grid and sensor, without the grid but with
//! the sensor, and with neither, that the box's three edges between visible faces are found,
//! and that an edge along the silhouette is found only when nothing tells where the sensor
//! was.

use sharpedge::config::Settings;
use sharpedge::outcome::Outcome;
use sharpedge::pipeline::{NoClock, process};
use sharpedge::{Cloud, Pose, Scan, ScanStructure};

use rand_chacha_like::Rng64;

/// A tiny deterministic generator (splitmix64), so the frame is the same on every machine.
mod rand_chacha_like {
    pub struct Rng64(pub u64);
    impl Rng64 {
        pub fn next_f64(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
        /// Standard normal (Box–Muller).
        pub fn normal(&mut self) -> f64 {
            let (u, v) = (self.next_f64().max(1e-12), self.next_f64());
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        }
    }
}

const COLS: usize = 320;
const ROWS: usize = 240;
const PITCH: f64 = 0.002;
const WALL_Z: f64 = 1.4;
/// Cells of the veil on either side of a silhouette.
const VEIL: usize = 3;
const HALF: [f64; 3] = [0.09, 0.06, 0.05];
const CENTRE: [f64; 3] = [0.0, 0.0, 1.0];

/// The box's rotation (box frame → camera frame): 35° about y, then 25° about x, so that the
/// faces towards -x, -y and -z of the box frame face the camera.
fn rotation() -> [[f64; 3]; 3] {
    let (a, b) = (35f64.to_radians(), 25f64.to_radians());
    let ry = [
        [a.cos(), 0.0, a.sin()],
        [0.0, 1.0, 0.0],
        [-a.sin(), 0.0, a.cos()],
    ];
    let rx = [
        [1.0, 0.0, 0.0],
        [0.0, b.cos(), -b.sin()],
        [0.0, b.sin(), b.cos()],
    ];
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| rx[i][k] * ry[k][j]).sum();
        }
    }
    m
}

fn mul(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| (0..3).map(|k| m[i][k] * v[k]).sum())
}

fn mul_t(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| (0..3).map(|k| m[k][i] * v[k]).sum())
}

/// Range along unit ray `d` to the box (slab method in the box's frame), if hit.
fn hit_box(d: [f64; 3], r: &[[f64; 3]; 3]) -> Option<f64> {
    let o = mul_t(r, [-CENTRE[0], -CENTRE[1], -CENTRE[2]]);
    let dl = mul_t(r, d);
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..3 {
        if dl[k].abs() < 1e-15 {
            if o[k].abs() > HALF[k] {
                return None;
            }
            continue;
        }
        let (a, b) = ((-HALF[k] - o[k]) / dl[k], (HALF[k] - o[k]) / dl[k]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0 <= t1 && t0 > 0.0).then_some(t0)
}

/// The frame: points in grid order (every cell has a point), and each cell's row and column.
fn frame(seed: u64) -> (Vec<[f64; 3]>, Vec<[u32; 2]>) {
    let r = rotation();
    let mut rng = Rng64(seed);
    let ray = |row: usize, col: usize| {
        let (u, v) = (
            (col as f64 - COLS as f64 / 2.0) * PITCH,
            (row as f64 - ROWS as f64 / 2.0) * PITCH,
        );
        let n = (u * u + v * v + 1.0).sqrt();
        [u / n, v / n, 1.0 / n]
    };
    // Range and whether the ray meets the box, per cell.
    let mut range = vec![0.0; ROWS * COLS];
    let mut on_box = vec![false; ROWS * COLS];
    for row in 0..ROWS {
        for col in 0..COLS {
            let d = ray(row, col);
            let k = row * COLS + col;
            match hit_box(d, &r) {
                Some(t) => (range[k], on_box[k]) = (t, true),
                None => range[k] = WALL_Z / d[2],
            }
        }
    }
    let mut points = Vec::with_capacity(ROWS * COLS);
    let mut grid = Vec::with_capacity(ROWS * COLS);
    for row in 0..ROWS {
        for col in 0..COLS {
            let k = row * COLS + col;
            let mut t = range[k];
            // A cell within VEIL cells of the other surface mixes the two ranges, the more the
            // nearer it is (the veil).
            let mut nearest: Option<(usize, usize)> = None;
            for r2 in row.saturating_sub(VEIL)..(row + VEIL + 1).min(ROWS) {
                for c2 in col.saturating_sub(VEIL)..(col + VEIL + 1).min(COLS) {
                    let j = r2 * COLS + c2;
                    let d = r2.abs_diff(row).max(c2.abs_diff(col));
                    if on_box[j] != on_box[k] && nearest.is_none_or(|(dn, _)| d < dn) {
                        nearest = Some((d, j));
                    }
                }
            }
            if let Some((d, j)) = nearest {
                let reach = 0.5 * (VEIL + 1 - d) as f64 / VEIL as f64;
                t += rng.next_f64() * reach * (range[j] - t);
            }
            t += 0.0006 * rng.normal();
            let d = ray(row, col);
            points.push(d.map(|c| c * t));
            grid.push([row as u32, col as u32]);
        }
    }
    (points, grid)
}

/// The box's three edges between visible faces (they meet at the corner nearest the camera),
/// in camera coordinates.
fn visible_edges() -> Vec<([f64; 3], [f64; 3])> {
    let r = rotation();
    let corner = |s: [f64; 3]| {
        let l = mul(&r, [s[0] * HALF[0], s[1] * HALF[1], s[2] * HALF[2]]);
        [l[0] + CENTRE[0], l[1] + CENTRE[1], l[2] + CENTRE[2]]
    };
    // The corner towards the camera in the box frame: the sign of each axis whose face is seen.
    let near = (0..8)
        .map(|m| [m & 1, (m >> 1) & 1, (m >> 2) & 1].map(|b| if b == 1 { 1.0 } else { -1.0 }))
        .min_by(|a, b| {
            let (pa, pb) = (corner(*a), corner(*b));
            let n = |p: [f64; 3]| p.iter().map(|c| c * c).sum::<f64>();
            n(pa).total_cmp(&n(pb))
        })
        .unwrap();
    (0..3)
        .map(|k| {
            let mut other = near;
            other[k] = -other[k];
            (corner(near), corner(other))
        })
        .collect()
}

fn seg_dist(p: [f64; 3], (a, b): ([f64; 3], [f64; 3])) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let w = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let dd: f64 = d.iter().map(|c| c * c).sum();
    let t = ((0..3).map(|k| w[k] * d[k]).sum::<f64>() / dd).clamp(0.0, 1.0);
    (0..3)
        .map(|k| (a[k] + t * d[k] - p[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Share of `e`'s length (sampled) within `tol` of a true visible edge.
fn near_truth(o: &Outcome, tol: f64) -> Vec<(usize, f64, f64)> {
    let truth = visible_edges();
    o.edges
        .iter()
        .map(|e| {
            let n = 20;
            let len = (0..3)
                .map(|k| (e.end[k] - e.start[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            let near = (0..=n)
                .filter(|&i| {
                    let t = i as f64 / n as f64;
                    let p = [0, 1, 2].map(|k| e.start[k] + t * (e.end[k] - e.start[k]));
                    truth.iter().any(|&s| seg_dist(p, s) < tol)
                })
                .count();
            (e.id, len, near as f64 / (n + 1) as f64)
        })
        .collect()
}

fn cloud(with_grid: bool) -> Cloud {
    let (points, grid) = frame(7);
    let n = points.len();
    let mut c = Cloud::from_positions(points);
    if with_grid {
        c.structure = Some(ScanStructure {
            scans: vec![Scan {
                name: "frame".into(),
                pose: Pose::default(),
                grid_size: Some([ROWS as u32, COLS as u32]),
            }],
            scan: vec![0; n],
            grid,
        });
    }
    c
}

fn run(c: Cloud, sensors: Vec<[f64; 3]>) -> Outcome {
    let mut s = Settings::default();
    s.input.sensors = sensors;
    process(c, &s, &mut NoClock).unwrap()
}

/// Each visible box edge is covered (80 % of its length within 3 mm of one found edge).
fn assert_box_edges_found(o: &Outcome, what: &str) {
    for (k, t) in visible_edges().into_iter().enumerate() {
        let n = 20;
        let covered = (0..=n)
            .filter(|&i| {
                let s = i as f64 / n as f64;
                let p = [0, 1, 2].map(|j| t.0[j] + s * (t.1[j] - t.0[j]));
                o.edges
                    .iter()
                    .any(|e| seg_dist(p, (e.start, e.end)) < 0.003)
            })
            .count();
        assert!(
            covered as f64 >= 0.8 * (n + 1) as f64,
            "{what}: visible box edge {k} covered at {covered} of {} samples; edges {:?}",
            n + 1,
            near_truth(o, 0.003)
        );
    }
}

#[test]
fn issue16_the_silhouette_of_a_box_is_a_border_with_the_grid_and_with_the_sensor() {
    // Neither grid nor sensor: nothing tells the veil from a face, and an edge is found
    // along the silhouette (this is what the other two runs must not report).
    let blind = run(cloud(false), vec![]);
    assert_box_edges_found(&blind, "no grid, no sensor");
    let off: Vec<_> = near_truth(&blind, 0.004)
        .into_iter()
        .filter(|&(_, len, share)| share < 0.5 && len > 0.02)
        .collect();
    assert!(
        !off.is_empty(),
        "the veil gave no edge off the box's edges: the test has no teeth ({:?})",
        near_truth(&blind, 0.004)
    );
    for (what, o) in [
        ("grid and sensor", run(cloud(true), vec![])),
        ("sensor only", run(cloud(false), vec![[0.0; 3]])),
    ] {
        assert_box_edges_found(&o, what);
        if std::env::var("DEBUG_OCC").is_ok() {
            for e in &o.edges {
                eprintln!(
                    "{what}: edge {} {:?} -> {:?} convex {:?} dih {:?}",
                    e.id, e.start, e.end, e.convex, e.dihedral_deg
                );
            }
            for l in &o.left_out {
                eprintln!("{what}: left out {}", l.message);
            }
        }
        for (id, len, share) in near_truth(&o, 0.004) {
            assert!(
                share >= 0.5 || len < 0.01,
                "{what}: edge {id} ({:.1} mm) lies off the box's visible edges (share {share:.2})",
                len * 1000.0
            );
        }
        let borders = o.border.iter().filter(|&&b| b).count();
        assert!(borders > 200, "{what}: {borders} points marked border");
    }
}

/// The real organised frames of ../shared/data/pcd, read with their grid: the silhouettes are
/// marked as borders, and no reported edge runs along one (at most a fifth of the points
/// within 3 mm of an edge's middle half are border points; a concave edge is no silhouette,
/// however steep one of its faces: the upper box of mosd_learn17 stands on the lower one). On the two mOSD frames the box
/// edges found are those of their unorganised PLY copies (run with the sensor at the
/// origin): the grid takes nothing away there. Skipped when ../shared/data is absent.
#[test]
fn issue16_real_organised_frames_report_no_edge_along_a_silhouette() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if !dir.join("pcd").exists() {
        eprintln!("skipped: ../shared/data absent");
        return;
    }
    let read = |p: &std::path::Path| sharpedge::io::read(p, &Default::default()).unwrap();
    for (pcd, ply) in [
        ("mosd_test0.pcd", Some("box.ply")),
        ("mosd_learn17.pcd", Some("stacked_boxes.ply")),
        ("organized_edge_1.pcd", None),
    ] {
        let cloud = read(&dir.join("pcd").join(pcd));
        assert!(
            cloud.structure.as_ref().is_some_and(|s| !s.grid.is_empty()),
            "{pcd}: read without its grid"
        );
        let positions = cloud.positions.clone();
        let mut bare = cloud.clone();
        bare.structure = None;
        let o = run(cloud, vec![]);
        let borders = o.border.iter().filter(|&&b| b).count();
        assert!(borders > 1000, "{pcd}: only {borders} border points");
        // The edges (convex or undecided) whose middle half runs along the border points.
        let along = |edges: &[sharpedge::outcome::EdgeOut]| -> Vec<String> {
            edges
                .iter()
                .filter(|e| e.convex != Some(false))
                .filter_map(|e| {
                    let (a, b) = (e.start, e.end);
                    let on_middle = |p: &[f64; 3]| {
                        let d = [0, 1, 2].map(|k| b[k] - a[k]);
                        let dd: f64 = d.iter().map(|x| x * x).sum();
                        let t = (0..3).map(|k| (p[k] - a[k]) * d[k]).sum::<f64>() / dd;
                        (0.25..=0.75).contains(&t) && seg_dist(*p, (a, b)) < 0.003
                    };
                    let near: Vec<usize> = (0..positions.len())
                        .filter(|&i| on_middle(&positions[i]))
                        .collect();
                    let on_border = near.iter().filter(|&&i| o.border[i]).count();
                    (on_border as f64 > 0.2 * near.len() as f64).then(|| {
                        format!(
                            "edge {} from {a:?} to {b:?}: {on_border} of {} points near it \
                             on the border",
                            e.id,
                            near.len()
                        )
                    })
                })
                .collect()
        };
        let bad = along(&o.edges);
        assert!(bad.is_empty(), "{pcd}: edges along a silhouette: {bad:#?}");
        if ply.is_none() {
            // Without its grid and sensor the same frame has edges there: the check has teeth.
            let blind = run(bare, vec![]);
            assert!(
                !along(&blind.edges).is_empty(),
                "{pcd}: no edge along a silhouette even without the grid"
            );
        }
        if let Some(ply) = ply {
            let copy = run(read(&dir.join("rgbd").join(ply)), vec![[0.0; 3]]);
            let ends = |o: &Outcome| -> Vec<[i64; 6]> {
                o.edges
                    .iter()
                    .map(|e| {
                        let s = [e.start, e.end].concat();
                        [0, 1, 2, 3, 4, 5].map(|k| (s[k] * 1e4).round() as i64)
                    })
                    .collect()
            };
            assert_eq!(ends(&o), ends(&copy), "{pcd}: edges differ from {ply}'s");
        }
    }
}
