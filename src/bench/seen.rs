//! Which stretches of the true sharp edges a scan lets a tool find: those where both faces of
//! the edge were sampled nearby. A scan that does not see the whole part (one view, scan
//! borders) leaves edges with one face or none; such a stretch is not required, and a found
//! edge along it is a false positive (a scan border is not a sharp edge).
//!
//! Input: the ground truth, the per-point truth (noise-free position, face id, outlier flag)
//! and the scan's coarsest pitch ([`pitch`]: the spacing `h` of a uniform scan). Output:
//! [`Stretches`] — the required pieces of the true edge segments, each with the id of the
//! edge it comes from, and the length left out — and which true corners are required.
//!
//! Rule (distances in pitches). Each true edge is cut into cells of [`CELL`] pitches. A point
//! that is no outlier and lies (noise-free) within [`RADIUS`] pitches of the edge marks, for the side of the edge it was sampled
//! on, every cell within that distance of it. Its side is the face whose id it carries, or, for
//! a point of another face (a curved mesh's neighbouring patch), the edge face whose normal is
//! within [`SIDE_ANGLE_DEG`] of its own face's normal (the end face of a box edge is neither).
//! A cell is seen when both sides marked it; the required stretches are the runs of seen
//! cells. When every cell is seen the edge is required whole, as the same segment (so scans
//! that see everything are scored exactly as before this rule).
//!
//! Corners ([`required_corners`]). A true corner is required when every face meeting at it is
//! sampled near it: each of its edges is required up to the corner (its end cell seen). A
//! one-view scan of a box that sees three faces sees one corner with all three; the corners
//! on the silhouette show one or two faces, the hidden one none, and no tool can place a
//! corner whose faces it never saw. Deriving the corners from the edge stretches, not from a
//! separate distance test, keeps the two consistent: a first version (a point of each side
//! within 5 h of the corner) left one of the suite's anchor corners unrequired on a uniform
//! scan whose edges were all required.

use crate::geometry::{V3, dist, dot, norm, sub};
use crate::synth::{GroundTruth, PointTruth};

use super::score::SegmentSet;

/// A side counts as sampled near a place of the edge when a point of it lies within this many
/// spacings. A uniform scan has points within about 0.7 h of every place of a face, but a
/// small face of a curved mesh may have only a handful (the anchor's 3.7 h edge between
/// facets at 152°: 6 points of its narrow side within 3 h left 4 h of it "unseen"; 5 h sees
/// every edge of the fixed suite whole).
pub const RADIUS: f64 = 5.0;
/// Cell length along the edge, in spacings.
pub const CELL: f64 = 0.5;
/// A point of a face other than the edge's two counts for the side whose normal is within
/// this angle of its face's normal.
pub const SIDE_ANGLE_DEG: f64 = 30.0;

/// Whether two lines of normals whose |cosine| is `cos_abs` lie within [`SIDE_ANGLE_DEG`].
pub fn within_side_angle(cos_abs: f64) -> bool {
    cos_abs >= SIDE_ANGLE_DEG.to_radians().cos()
}

/// The required stretches of the true edges.
#[derive(Debug, Clone, PartialEq)]
pub struct Stretches {
    pub segments: Vec<(V3, V3)>,
    /// The true edge (index into `GroundTruth::edges`) of each segment.
    pub edge: Vec<usize>,
    /// Total length of the true edges not required (model units).
    pub unseen_length: f64,
}

impl Stretches {
    /// Every true edge required whole (a scan that sees the whole part).
    pub fn all(gt: &GroundTruth) -> Stretches {
        Stretches {
            segments: gt.edges.iter().map(|e| (e.start, e.end)).collect(),
            edge: (0..gt.edges.len()).collect(),
            unseen_length: 0.0,
        }
    }
}

/// The side (0 or 1) of edge `e` a point of face `face` belongs to, if any.
fn side(gt: &GroundTruth, e: usize, face: u32) -> Option<usize> {
    let edge = &gt.edges[e];
    let f = face as usize;
    if let Some(k) = edge.faces.iter().position(|&g| g == f) {
        return Some(k);
    }
    let n = gt.faces.get(f)?.normal;
    // Lines of normals: a mesh file may wind a chart against its neighbours (the anchor's
    // face beside a 2 h concave edge has the opposite normal of the edge's own face).
    let c = [dot(n, edge.normals[0]).abs(), dot(n, edge.normals[1]).abs()];
    let k = if c[0] >= c[1] { 0 } else { 1 };
    within_side_angle(c[k]).then_some(k)
}

/// Whether each true corner of `gt` is required (see the module comment): every edge meeting
/// at it is required up to it (a stretch of `required` ends there). The corner's own sides
/// are then seen beside it, by the same test as the edges' so the two rules cannot disagree;
/// a corner without edges is required (it has no face that could be unseen). `pitch` is the
/// one `required` was computed with.
pub fn required_corners(gt: &GroundTruth, required: &Stretches, pitch: f64) -> Vec<bool> {
    // A seen end cell starts its stretch exactly at the edge's end; half a cell absorbs the
    // rounding of the cell arithmetic.
    let tol = 0.5 * CELL * pitch;
    gt.corners
        .iter()
        .map(|c| {
            c.edges.iter().all(|&e| {
                required
                    .edge
                    .iter()
                    .zip(&required.segments)
                    .any(|(&k, &(a, b))| {
                        k == e && (dist(a, c.position) <= tol || dist(b, c.position) <= tol)
                    })
            })
        })
        .collect()
}

/// The coarsest pitch of the scan's pattern (model units), the unit of the seen rule's
/// distances: the spacing `h` of a uniform scan, the gap between scan lines, the largest
/// grid pitch of the views, times the square root of the density ratio (the pitch at the
/// sparse end of a gradient). A face sampled only along lines 10 h apart is then seen between
/// its lines, as it is on the uniform scan of the same part.
pub fn pitch(gt: &GroundTruth) -> f64 {
    let mut p = gt.spacing;
    if let Some(l) = &gt.lines {
        p = p.max(l.gap);
    }
    p = gt.sensors.iter().map(|s| s.pitch).fold(p, f64::max);
    if let Some(d) = &gt.density {
        p *= d.ratio.max(1.0).sqrt();
    }
    p
}

/// The required stretches of `gt`'s edges given the scan's points (see the module comment);
/// `h` is the scan's [`pitch`].
pub fn required(gt: &GroundTruth, truth: &[PointTruth], h: f64) -> Stretches {
    if gt.edges.is_empty() {
        return Stretches::all(gt);
    }
    let r = RADIUS * h;
    let cell = CELL * h;
    let set = SegmentSet::new(gt.edges.iter().map(|e| (e.start, e.end)).collect(), r);
    let cells: Vec<usize> = gt
        .edges
        .iter()
        .map(|e| ((e.length / cell).ceil() as usize).max(1))
        .collect();
    // marks[e][side][cell]
    let mut marks: Vec<[Vec<bool>; 2]> = cells
        .iter()
        .map(|&n| [vec![false; n], vec![false; n]])
        .collect();
    for t in truth {
        if t.outlier || t.face == u32::MAX {
            continue;
        }
        for (e, _) in set.all_within(t.surface) {
            let Some(k) = side(gt, e, t.face) else {
                continue;
            };
            let edge = &gt.edges[e];
            let len = dist(edge.start, edge.end);
            if len <= 0.0 {
                continue;
            }
            let u = sub(edge.end, edge.start).map(|c| c / len);
            let w = sub(t.surface, edge.start);
            let along = dot(w, u);
            let across = norm(sub(w, u.map(|c| c * along)));
            let reach = (r * r - across * across).max(0.0).sqrt();
            let (s0, s1) = ((along - reach).max(0.0), (along + reach).min(len));
            if s0 > s1 {
                continue;
            }
            let n = cells[e];
            let i0 = ((s0 / cell).floor() as usize).min(n - 1);
            let i1 = ((s1 / cell).floor() as usize).min(n - 1);
            for m in &mut marks[e][k][i0..=i1] {
                *m = true;
            }
        }
    }
    let mut out = Stretches {
        segments: Vec::new(),
        edge: Vec::new(),
        unseen_length: 0.0,
    };
    for (e, edge) in gt.edges.iter().enumerate() {
        let [m0, m1] = &marks[e];
        let seen: Vec<bool> = m0.iter().zip(m1).map(|(a, b)| *a && *b).collect();
        if seen.iter().all(|&s| s) {
            out.segments.push((edge.start, edge.end));
            out.edge.push(e);
            continue;
        }
        let len = edge.length;
        let at = |s: f64| {
            let t = if len > 0.0 {
                (s / len).clamp(0.0, 1.0)
            } else {
                0.0
            };
            [0, 1, 2].map(|k| edge.start[k] + t * (edge.end[k] - edge.start[k]))
        };
        let mut kept = 0.0;
        let mut i = 0;
        while i < seen.len() {
            if !seen[i] {
                i += 1;
                continue;
            }
            let j = (i..seen.len()).find(|&j| !seen[j]).unwrap_or(seen.len());
            let (s0, s1) = (i as f64 * cell, (j as f64 * cell).min(len));
            out.segments.push((at(s0), at(s1)));
            out.edge.push(e);
            kept += s1 - s0;
            i = j;
        }
        out.unseen_length += (len - kept).max(0.0);
    }
    out
}
