//! Found edges that are not sharp edges of the part, but lie where the scan only looks like
//! one: on the borders of a scan that does not see the whole part (`border_points`,
//! [`found_length_near`]), and on the facet creases of a faceted CAD mesh ([`creases`]).
//!
//! Input: the per-point truth of a scan (noise-free place on the part, face id), the ground
//! truth (faces, the sampled surface mesh), the found edges as segments, the required true
//! stretches (module [`super::seen`]). Output: which points lie on a scan border, the facet
//! creases of the sampled mesh below the sharp angle, and the found edge length within a
//! tolerance of a set of places (borders, creases) but not of a required true edge.
//!
//! Scan borders. A one-view scan keeps the uniform grid where the sensor sees it, so a seen
//! face ends where it turns away, meets a face turned away or falls into a shadow. A point is
//! on a border when its neighbourhood on its own surface is one-sided: among the points within
//! [`BORDER_RADIUS`] pitches of it (noise-free places) whose face continues its own (the same
//! face, or one whose normal is within [`super::seen::SIDE_ANGLE_DEG`]: a curved patch's next
//! facet), the centroid lies more than [`BORDER_SHIFT`] radii away from it in its face's
//! plane. Inside a uniformly sampled face the centroid is within a few hundredths of the
//! radius; on a straight border it is `4 / (3π) = 0.42` radii away; the threshold 0.2 keeps
//! the points within about 0.4 radii (1 pitch) of the border. A true sharp edge cuts its faces
//! the same way, so its points are "border" too: the found length that counts is the part
//! not within the edge tolerance of a required true stretch (a seen sharp edge).

use crate::geometry::{V3, add, dot, norm, reject, scale, triangle_normal};
use crate::neighbours::Grid;
use crate::synth::{GroundTruth, PointTruth, TruthSurface};

use super::score::{SegmentSet, midpoints};
use super::seen::within_side_angle;

/// Neighbourhood radius of the border test, in pitches of the scan.
pub const BORDER_RADIUS: f64 = 2.5;
/// A point is on a border when its neighbours' centroid is this many radii away from it.
pub const BORDER_SHIFT: f64 = 0.2;
/// Mesh edges whose normals differ by less than this are flat, not creases (radians).
const FLAT: f64 = 1e-3;

/// Whether faces `a` and `b` continue each other (same face, or normals within the side
/// angle; lines of normals, as a mesh file may wind a chart against its neighbours).
fn continues(gt: &GroundTruth, a: u32, b: u32) -> bool {
    if a == b {
        return true;
    }
    match (gt.faces.get(a as usize), gt.faces.get(b as usize)) {
        (Some(fa), Some(fb)) => within_side_angle(dot(fa.normal, fb.normal).abs()),
        _ => false,
    }
}

/// Which points lie on a scan border (see the module comment); `pitch` is the largest grid
/// pitch of the scan's views (model units). Outliers and points without a face are not.
pub fn border_points(gt: &GroundTruth, truth: &[PointTruth], pitch: f64) -> Vec<bool> {
    let r = BORDER_RADIUS * pitch;
    let usable = |t: &PointTruth| !t.outlier && t.face != u32::MAX;
    let places: Vec<V3> = truth.iter().map(|t| t.surface).collect();
    // The neighbour grid's radius query, not a segment set of zero-length segments: no list
    // per point.
    let Ok(grid) = Grid::new(&places, r) else {
        return vec![false; truth.len()];
    };
    truth
        .iter()
        .map(|t| {
            if !usable(t) {
                return false;
            }
            let Some(face) = gt.faces.get(t.face as usize) else {
                return false;
            };
            let (mut sum, mut n) = ([0.0; 3], 0usize);
            grid.for_each_within(t.surface, r, |j, d, _| {
                let q = &truth[j as usize];
                if usable(q) && continues(gt, t.face, q.face) {
                    sum = add(sum, d);
                    n += 1;
                }
            });
            // The point itself is one of them; alone, it has no side to speak of.
            if n < 2 {
                return false;
            }
            let c = scale(sum, 1.0 / n as f64);
            let across = reject(c, face.normal);
            norm(across) > BORDER_SHIFT * r
        })
        .collect()
}

/// The places (noise-free) of the points flagged in `on_border`, as a set answering "is a
/// border point within `reach`" for [`found_length_near`], and how many they are.
pub fn border_set(truth: &[PointTruth], on_border: &[bool], reach: f64) -> (SegmentSet, usize) {
    let places: Vec<(V3, V3)> = truth
        .iter()
        .zip(on_border)
        .filter(|(_, b)| **b)
        .map(|(t, _)| (t.surface, t.surface))
        .collect();
    let count = places.len();
    (SegmentSet::new(places, reach), count)
}

/// The manifold edges of the sampled mesh whose faces' normals differ by more than flat but
/// at most `sharp_deg` (the facet creases of a faceted curved patch), as segments (world).
/// Empty for the sphere.
pub fn creases(gt: &GroundTruth, sharp_deg: f64) -> Vec<(V3, V3)> {
    let TruthSurface::Mesh {
        vertices,
        triangles,
    } = &gt.surface
    else {
        return Vec::new();
    };
    let normal = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|v| vertices[v as usize]);
        triangle_normal(a, b, c)
    };
    let mut by_edge: std::collections::BTreeMap<(u32, u32), Vec<usize>> = Default::default();
    for (i, t) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            by_edge.entry((a.min(b), a.max(b))).or_default().push(i);
        }
    }
    let cos_sharp = sharp_deg.to_radians().cos();
    let cos_flat = FLAT.cos();
    by_edge
        .into_iter()
        .filter_map(|((a, b), tris)| {
            let [t0, t1] = tris.as_slice() else {
                return None; // a boundary or non-manifold edge
            };
            let (n0, n1) = (normal(&triangles[*t0])?, normal(&triangles[*t1])?);
            // Lines of normals (see `continues`).
            let c = dot(n0, n1).abs();
            (c < cos_flat && c >= cos_sharp).then(|| (vertices[a as usize], vertices[b as usize]))
        })
        .collect()
}

/// The length of the found segments within `near`'s reach of one of its segments but not
/// within `except`'s reach of one of its own (sampled every `step`: the midpoints of pieces
/// at most `step` long).
pub fn found_length_near(
    found: &[(V3, V3)],
    near: &SegmentSet,
    except: &SegmentSet,
    step: f64,
) -> f64 {
    let mut total = 0.0;
    for (p, weight) in midpoints(found, step) {
        if near.nearest_within(p).is_some() && except.nearest_within(p).is_none() {
            total += weight;
        }
    }
    total
}
