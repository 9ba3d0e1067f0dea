//! Ground truth of the parametric parts checked geometrically, in world coordinates after a
//! random rotation and a translation: edge and corner counts and positions, dihedral angles,
//! convexity, and that sampled points lie on the surface (or on the fillets) they claim.

use sharpedge::geometry::{V3, add, cross, dist, dot, mat_vec, norm, sub};
use sharpedge::synth::{GroundTruth, Part, Sampling, SynthParams, generate};

fn params(part: Part) -> SynthParams {
    SynthParams {
        part,
        sampling: Sampling::Points(20_000),
        rotate: true,
        translate: [10.0, -20.0, 30.0],
        seed: 7,
        ..Default::default()
    }
}

/// World → model coordinates (the inverse of world = R·model + T).
fn to_model(gt: &GroundTruth, p: V3) -> V3 {
    let d = sub(p, gt.translation);
    let r = &gt.rotation;
    // R is orthonormal: its inverse is its transpose.
    [0, 1, 2].map(|k| r[0][k] * d[0] + r[1][k] * d[1] + r[2][k] * d[2])
}

fn sorted(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v
}

#[test]
fn box_has_12_edges_and_8_corners_where_they_belong() {
    let scan = generate(&params(Part::Box)).unwrap();
    let gt = &scan.ground_truth;
    assert_eq!(gt.part, "box");
    assert_eq!(gt.edges.len(), 12);
    assert_eq!(gt.corners.len(), 8);
    // The box is 100 x 80 x 60 (largest extent = size = 100), centred on the origin.
    let mut want: Vec<V3> = Vec::new();
    for i in 0..8 {
        let m = [
            if i & 1 == 1 { 50.0 } else { -50.0 },
            if i & 2 == 2 { 40.0 } else { -40.0 },
            if i & 4 == 4 { 30.0 } else { -30.0 },
        ];
        want.push(add(mat_vec(&gt.rotation, m), [10.0, -20.0, 30.0]));
    }
    for w in &want {
        let (d, id) = gt.nearest_corner(*w).unwrap();
        assert!(d < 1e-9, "corner {w:?} missing (nearest {d})");
        assert_eq!(gt.corners[id].edges.len(), 3);
    }
    for e in &gt.edges {
        assert!(e.convex);
        assert!((e.dihedral_deg - 90.0).abs() < 1e-9);
        assert!((dist(e.start, e.end) - e.length).abs() < 1e-9);
        // Ends are corners; the normals are perpendicular to the edge and to each other.
        assert!(gt.nearest_corner(e.start).unwrap().0 < 1e-9);
        assert!(gt.nearest_corner(e.end).unwrap().0 < 1e-9);
        let d = sub(e.end, e.start);
        for n in e.normals {
            assert!(dot(n, d).abs() < 1e-9 * e.length);
        }
        assert!(dot(e.normals[0], e.normals[1]).abs() < 1e-12);
    }
    let lengths = sorted(gt.edges.iter().map(|e| e.length).collect());
    let want_len = sorted([100.0, 80.0, 60.0].iter().flat_map(|&l| [l; 4]).collect());
    for (a, b) in lengths.iter().zip(&want_len) {
        assert!((a - b).abs() < 1e-9);
    }
    assert_eq!(gt.faces.len(), 6);
    let area: f64 = gt.faces.iter().map(|f| f.area).sum();
    assert!((area - 2.0 * (100.0 * 80.0 + 100.0 * 60.0 + 80.0 * 60.0)).abs() < 1e-6);
    // Rotation is a proper rotation.
    let r = &gt.rotation;
    assert!((dot(r[0], cross(r[1], r[2])) - 1.0).abs() < 1e-12);
}

#[test]
fn hexagonal_prism_sides_are_120_degrees_and_octagonal_135() {
    for (sides, want) in [(6usize, 120.0), (8, 135.0)] {
        let p = SynthParams {
            sides,
            ..params(Part::Prism)
        };
        let gt = generate(&p).unwrap().ground_truth;
        assert_eq!(gt.edges.len(), 3 * sides);
        assert_eq!(gt.corners.len(), 2 * sides);
        let side = gt
            .edges
            .iter()
            .filter(|e| (e.dihedral_deg - want).abs() < 1e-9)
            .count();
        let cap = gt
            .edges
            .iter()
            .filter(|e| (e.dihedral_deg - 90.0).abs() < 1e-9)
            .count();
        assert_eq!((side, cap), (sides, 2 * sides), "{sides}-gon");
        assert!(gt.edges.iter().all(|e| e.convex));
    }
}

#[test]
fn wedge_edge_has_the_requested_angle() {
    for angle in [30.0, 45.0, 150.0] {
        let gt = generate(&SynthParams {
            angle,
            ..params(Part::Wedge)
        })
        .unwrap()
        .ground_truth;
        assert_eq!(gt.edges.len(), 9);
        let base = (180.0 - angle) / 2.0;
        let count = |a: f64| {
            gt.edges
                .iter()
                .filter(|e| (e.dihedral_deg - a).abs() < 1e-9)
                .count()
        };
        assert_eq!(count(angle), 1, "{angle}");
        assert_eq!(count(base), 2, "{angle}");
        assert_eq!(count(90.0), 6, "{angle}");
    }
}

#[test]
fn l_block_has_exactly_one_concave_edge_along_the_extrusion() {
    let gt = generate(&params(Part::LBlock)).unwrap().ground_truth;
    assert_eq!(gt.edges.len(), 18);
    assert_eq!(gt.corners.len(), 12);
    let concave: Vec<_> = gt.edges.iter().filter(|e| !e.convex).collect();
    assert_eq!(concave.len(), 1);
    let c = concave[0];
    assert!((c.dihedral_deg - 270.0).abs() < 1e-9);
    // The extrusion depth is 0.5 of the 1.0 long profile: 50 model units.
    assert!((c.length - 50.0).abs() < 1e-9);
    assert!(
        gt.edges
            .iter()
            .filter(|e| e.convex)
            .all(|e| (e.dihedral_deg - 90.0).abs() < 1e-9)
    );
    // Its two faces are different faces; their normals are perpendicular.
    assert_ne!(c.faces[0], c.faces[1]);
    assert!(dot(c.normals[0], c.normals[1]).abs() < 1e-12);
}

#[test]
fn stepped_block_has_concave_and_convex_step_edges() {
    for steps in [2usize, 3, 5] {
        let gt = generate(&SynthParams {
            steps,
            ..params(Part::Step)
        })
        .unwrap()
        .ground_truth;
        let concave = gt.edges.iter().filter(|e| !e.convex).count();
        assert_eq!(concave, steps - 1, "{steps} steps");
        // Profile of 2 + 2 steps vertices: as many long edges, twice as many cap edges.
        assert_eq!(gt.edges.len(), 3 * (2 + 2 * steps), "{steps} steps");
    }
}

#[test]
fn pyramid_apex_joins_four_edges() {
    let gt = generate(&params(Part::Pyramid)).unwrap().ground_truth;
    assert_eq!(gt.edges.len(), 8);
    assert_eq!(gt.corners.len(), 5);
    let apex: Vec<_> = gt.corners.iter().filter(|c| c.edges.len() == 4).collect();
    assert_eq!(apex.len(), 1);
    // The apex is 0.7 of the unit base above its centre; size 100 scales the base to 100.
    let m = to_model(&gt, apex[0].position);
    assert!(dist(m, [0.0, 0.0, 35.0]) < 1e-9, "{m:?}");
}

#[test]
fn sphere_has_no_edges_and_its_points_lie_on_it() {
    let scan = generate(&params(Part::Sphere)).unwrap();
    let gt = &scan.ground_truth;
    assert!(gt.edges.is_empty() && gt.corners.is_empty());
    assert!(gt.distance_to_nearest_edge([0.0; 3]).is_none());
    assert!(gt.nearest_corner([0.0; 3]).is_none());
    assert_eq!(gt.abnormal_points, 0);
    for (p, t) in scan.cloud.positions.iter().zip(&scan.truth) {
        assert!(gt.distance_to_surface(*p) < 1e-9 * 100.0);
        assert_eq!(*p, t.surface);
        assert!(t.edge_distance.is_infinite() && !t.abnormal);
    }
    assert!((scan.cloud.len() as f64 - 20_000.0).abs() < 2.0);
}

/// Without noise or rounding every point is its own truth and lies on the part's surface.
#[test]
fn clean_samples_lie_on_the_surface() {
    for part in [
        Part::Box,
        Part::LBlock,
        Part::Step,
        Part::Wedge,
        Part::Prism,
        Part::Pyramid,
    ] {
        let scan = generate(&params(part.clone())).unwrap();
        let gt = &scan.ground_truth;
        let n = scan.cloud.len();
        assert!(
            (n as f64 - 20_000.0).abs() < 0.01 * 20_000.0,
            "{part:?}: {n} points"
        );
        for (p, t) in scan.cloud.positions.iter().zip(&scan.truth) {
            assert_eq!(*p, t.surface);
            assert!(gt.distance_to_surface(*p) <= 1e-9 * 100.0, "{part:?}");
            // The recorded edge distance is the exact one.
            let (d, e) = gt.distance_to_nearest_edge(*p).unwrap();
            assert!((d - t.edge_distance).abs() < 1e-9, "{part:?}");
            assert!(e as u32 == t.nearest_edge || (d - t.edge_distance).abs() < 1e-12);
            assert!(!t.abnormal && !t.outlier);
            // The point lies on the plane of its face.
            let f = &gt.faces[t.face as usize];
            assert!(dot(sub(*p, f.point), f.normal).abs() < 1e-9 * 100.0);
        }
        assert_eq!(gt.abnormal_points, 0);
    }
}

/// Distance from `p` to the axis-aligned box `[-half, half]`.
fn box_distance(p: V3, half: V3) -> f64 {
    let d = [0, 1, 2].map(|k| (p[k].abs() - half[k]).max(0.0));
    norm(d)
}

/// A box with rounded edges is the box shrunk by r, grown by a ball of radius r (Minkowski
/// sum): every moved point lies at exactly r from the shrunk box, whether it moved onto an
/// edge's cylinder or a corner's ball, and unmoved points are no closer than r.
#[test]
fn rounded_box_points_lie_on_the_rounded_box() {
    let p = SynthParams {
        round: 2.0,
        sampling: Sampling::Points(200_000),
        ..params(Part::Box)
    };
    let scan = generate(&p).unwrap();
    let gt = &scan.ground_truth;
    let r = gt.round_radius;
    assert!((r - 2.0 * gt.spacing).abs() < 1e-12);
    let shrunk = [50.0 - r, 40.0 - r, 30.0 - r];
    let (mut moved, mut near_corner) = (0, 0);
    for (p, t) in scan.cloud.positions.iter().zip(&scan.truth) {
        let m = to_model(gt, *p);
        let d = box_distance(m, shrunk);
        if t.abnormal {
            moved += 1;
            assert!(
                (d - r).abs() < 1e-9,
                "moved point {m:?} at {d} from the shrunk box, r = {r}"
            );
            // The rounding moves a point by less than (√2 − 1)·r on a 90° edge, more only
            // in a corner's ball region.
            let shift = dist(*p, t.surface);
            assert!(shift > 0.0 && shift <= (3f64.sqrt() - 1.0) * r + 1e-9);
            if gt.nearest_corner(t.surface).unwrap().0 < 1.5 * r {
                near_corner += 1;
            }
            // Within the tangent distance of its edge (r for 90°).
            assert!(t.edge_distance < r * 2f64.sqrt() + 1e-9);
        } else {
            assert_eq!(*p, t.surface);
            assert!(d >= r - 1e-9);
        }
    }
    assert!(
        moved > 0 && near_corner > 0,
        "{moved} moved, {near_corner} near corners"
    );
    assert_eq!(moved, gt.abnormal_points);
    // Every corner got a ball blend.
    assert!(gt.corners.iter().all(|c| c.ball_blend));
}

/// On the 30° wedge edge, away from its ends, moved points lie on the fillet circle: at r from
/// the axis, which runs at r / sin(15°) from the edge along the bisector.
#[test]
fn wedge_fillet_points_lie_on_the_predicted_circle() {
    let p = SynthParams {
        round: 1.0,
        sampling: Sampling::Points(100_000),
        ..params(Part::Wedge)
    };
    let scan = generate(&p).unwrap();
    let gt = &scan.ground_truth;
    let r = gt.round_radius;
    let e = gt
        .edges
        .iter()
        .find(|e| (e.dihedral_deg - 30.0).abs() < 1e-9)
        .unwrap();
    let dir = sub(e.end, e.start);
    let len = norm(dir);
    let dir = dir.map(|c| c / len);
    // Bisector into the material: against the sum of the outward normals.
    let s = add(e.normals[0], e.normals[1]);
    let w = s.map(|c| -c / norm(s));
    let axis_off = w.map(|c| c * r / 15f64.to_radians().sin());
    assert!((e.tangent_distance - r / 15f64.to_radians().tan()).abs() < 1e-9);
    let mut checked = 0;
    for (p, t) in scan.cloud.positions.iter().zip(&scan.truth) {
        if t.nearest_edge as usize != e.id || !t.abnormal {
            continue;
        }
        let lambda = dot(sub(t.surface, e.start), dir);
        if lambda < 3.0 * e.tangent_distance || lambda > len - 3.0 * e.tangent_distance {
            continue;
        }
        let centre = add(add(e.start, dir.map(|c| c * lambda)), axis_off);
        assert!((dist(*p, centre) - r).abs() < 1e-9);
        // The move is radial from the axis, in the cross-section: no component along the edge.
        assert!(dot(sub(*p, t.surface), dir).abs() < 1e-9);
        // A convex edge loses material: the point went inwards, towards the axis.
        assert!(dist(*p, centre) < dist(t.surface, centre));
        checked += 1;
    }
    assert!(checked > 100, "{checked}");
}

/// The L-block's concave edge gains material: moved points go outwards (away from the solid),
/// onto a circle whose centre is in the air.
#[test]
fn concave_fillet_adds_material() {
    let p = SynthParams {
        round: 1.5,
        sampling: Sampling::Points(100_000),
        ..params(Part::LBlock)
    };
    let scan = generate(&p).unwrap();
    let gt = &scan.ground_truth;
    let r = gt.round_radius;
    let e = gt.edges.iter().find(|e| !e.convex).unwrap();
    let dir = sub(e.end, e.start).map(|c| c / e.length);
    // For a concave edge the fillet lies on the air side, along the sum of the normals.
    let s = add(e.normals[0], e.normals[1]);
    let w = s.map(|c| c / norm(s));
    let axis_off = w.map(|c| c * r / 45f64.to_radians().sin());
    let mut checked = 0;
    for (p, t) in scan.cloud.positions.iter().zip(&scan.truth) {
        if t.nearest_edge as usize != e.id || !t.abnormal {
            continue;
        }
        let lambda = dot(sub(t.surface, e.start), dir);
        if lambda < 2.0 * r || lambda > e.length - 2.0 * r {
            continue;
        }
        let centre = add(add(e.start, dir.map(|c| c * lambda)), axis_off);
        assert!((dist(*p, centre) - r).abs() < 1e-9);
        // Moved along +w (outwards, into the air) relative to its face point.
        assert!(dot(sub(*p, t.surface), w) > 0.0);
        checked += 1;
    }
    assert!(checked > 100, "{checked}");
}

/// Regression: with a chart tolerance of 1e-9 rad, cos() rounded to exactly 1.0 and the two
/// triangles of a planar quad (normals equal only to the last bit) became separate faces with
/// separate grids. Every planar face of a parametric part must be one face.
#[test]
fn regression_planar_quads_are_one_face_not_two() {
    for (part, faces) in [
        (Part::Box, 6),
        (Part::LBlock, 8),
        (Part::Step, 10),
        (Part::Wedge, 5),
        (Part::Prism, 8),
        (Part::Pyramid, 5),
    ] {
        let gt = generate(&params(part.clone())).unwrap().ground_truth;
        assert_eq!(gt.faces.len(), faces, "{part:?}");
        // Each edge separates two different faces.
        assert!(
            gt.edges.iter().all(|e| e.faces[0] != e.faces[1]),
            "{part:?}"
        );
    }
}
