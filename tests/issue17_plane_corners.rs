//! Issue 17 (unseen parts, accuracy): on random parts, corners at the ends of short edges (a
//! small through-hole, a chamfer, a stacked block: edges of 10–25 spacings, too short for the
//! edge stage's slabs) were lost — corner recall 0.49 over 30 random parts — and the corners
//! found were 3.2x as far from the truth as the plane-intersection oracle. Corners where planar
//! faces meet are now placed by the faces' planes (`stages::faces`, `stages::plane_corners`).
//!
//! Checked on random parts drawn from seeds this file fixes (the bench's `--random` draws
//! others): the corners whose edges are all at least 10 spacings long are found, within a
//! tenth of a spacing; the short edges between them are reported; nothing is reported on a
//! smooth sphere.

mod synth_common;

use sharpedge::geometry::dist;
use sharpedge::outcome::Outcome;
use sharpedge::synth::{GroundTruth, Part};

fn run(part: Part, points: usize, noise: f64, seed: u64) -> (Outcome, GroundTruth) {
    synth_common::run_part(part, points, noise, 1.0, seed)
}

#[test]
fn corners_of_short_edges_on_random_parts_are_found_where_their_faces_meet() {
    let (mut wanted, mut found) = (0usize, 0usize);
    let mut errors: Vec<f64> = Vec::new();
    let mut short_edges = (0usize, 0usize);
    for seed in [3u64, 8, 21, 34] {
        let (out, gt) = run(Part::Random, 150_000, 0.15, seed);
        let h = gt.spacing;
        let length = |e: usize| gt.edges[e].length / h;
        for c in &gt.corners {
            let shortest = c
                .edges
                .iter()
                .map(|&e| length(e))
                .fold(f64::INFINITY, f64::min);
            if shortest < 10.0 {
                continue;
            }
            wanted += 1;
            let nearest = out
                .corners
                .iter()
                .map(|f| dist(f.position, c.position))
                .fold(f64::INFINITY, f64::min);
            if nearest < 3.0 * h {
                found += 1;
                errors.push(nearest / h);
            }
        }
        // Short true edges (10–25 spacings) between two such corners are reported end to end.
        let wanted_corner = |p: [f64; 3]| {
            gt.corners.iter().any(|c| {
                dist(c.position, p) < 1e-6 * h && c.edges.iter().all(|&e| length(e) >= 10.0)
            })
        };
        for e in gt.edges.iter().filter(|e| {
            (10.0..25.0).contains(&(e.length / h)) && wanted_corner(e.start) && wanted_corner(e.end)
        }) {
            short_edges.0 += 1;
            let covered = out.edges.iter().any(|f| {
                dist(f.start, e.start).min(dist(f.end, e.start)) < 2.0 * h
                    && dist(f.start, e.end).min(dist(f.end, e.end)) < 2.0 * h
            });
            short_edges.1 += usize::from(covered);
        }
    }
    assert!(wanted >= 40, "the draws hold {wanted} corners only");
    let recall = found as f64 / wanted as f64;
    assert!(
        recall >= 0.9,
        "corner recall {recall:.3} ({found} of {wanted})"
    );
    errors.sort_by(f64::total_cmp);
    let median = errors[errors.len() / 2];
    assert!(median <= 0.1, "median corner error {median:.3} spacings");
    assert!(
        short_edges.0 >= 5,
        "the draws hold {} short edges",
        short_edges.0
    );
    let share = short_edges.1 as f64 / short_edges.0 as f64;
    assert!(
        share >= 0.8,
        "{} of {} short edges reported end to end",
        short_edges.1,
        short_edges.0
    );
}

#[test]
fn a_sphere_has_no_planar_face_and_no_corner() {
    let (out, _) = run(Part::Sphere, 100_000, 0.15, 5);
    assert!(out.corners.is_empty(), "{:?}", out.corners);
    assert!(out.edges.is_empty(), "{} edges", out.edges.len());
}

/// The true corners found within 3 spacings, and the found corners farther than 3 spacings
/// from every true corner.
fn corner_score(out: &Outcome, gt: &GroundTruth) -> (usize, usize) {
    let h = gt.spacing;
    let near = |p: [f64; 3], q: &mut dyn Iterator<Item = [f64; 3]>| {
        q.map(|q| dist(p, q)).fold(f64::INFINITY, f64::min) < 3.0 * h
    };
    let found = gt
        .corners
        .iter()
        .filter(|c| near(c.position, &mut out.corners.iter().map(|f| f.position)))
        .count();
    let spurious = out
        .corners
        .iter()
        .filter(|f| !near(f.position, &mut gt.corners.iter().map(|c| c.position)))
        .count();
    (found, spurious)
}

/// Seed 1's r089 of `bench --random 100` (here sampled uniformly): a plate with a
/// four-sided hole through it, whose walls meet at 43° inside. Face growth stops at every
/// edge's candidate band, so the walls stopped radii short of their rims and the 8 rim
/// corners had no face triple to vote for (16 of 26 corners found). Faces now reach into the
/// bands (`faces::reach_edges`).
#[test]
fn issue17_the_rim_corners_of_a_hole_with_an_acute_wall_are_found() {
    let (out, gt) = synth_common::run_part(Part::Random, 62_804, 0.1, 0.81, 13773340563672390672);
    let (found, spurious) = corner_score(&out, &gt);
    // Without the reach: 23 of 26.
    assert!(
        found + 1 >= gt.corners.len(),
        "{found} of {} corners found",
        gt.corners.len()
    );
    assert!(spurious <= 1, "{spurious} spurious corners");
}

/// Seed 1's r063: a hole whose rim passes 9 spacings from an edge of the part. Once faces
/// reach their edges, the hole's wall came within 4 radii of the point where its plane
/// meets that edge's two faces, and a corner was reported there (two of them); a corner now
/// needs each face within 2 radii.
#[test]
fn issue17_no_corner_where_a_holes_wall_plane_meets_a_nearby_edge() {
    let (out, gt) = synth_common::run_part(Part::Random, 103_740, 0.011, 1.78, 4108049579026812151);
    let (found, spurious) = corner_score(&out, &gt);
    assert_eq!(spurious, 0, "{found} of {} found", gt.corners.len());
    assert!(
        found + 2 >= gt.corners.len(),
        "{found} of {} found",
        gt.corners.len()
    );
}
