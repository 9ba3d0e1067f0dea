//! Corners from planes: where three or more planar faces of the scan meet, their planes'
//! common point is the corner, however short the edges between them (a small hole, a narrow
//! step: too short for the edge stage's slabs) and far more precisely than a fit to the
//! edges' ends, because each plane rests on a whole face of points.
//!
//! Inputs: positions, the neighbour `Grid`, the `Features` (candidate and outlier masks), the
//! `LocalScale`, the planar `Faces`, `EdgeParams` (the widest rounding of a sharp edge).
//! Output: `FaceCorner`s (position, faces, support).
//!
//! Hypotheses come from the edge candidates: each candidate names the faces it sees within
//! `SEE_REACH` radii, and every triple of them is a possible corner. A triple is kept when
//! its planes are well apart, their common point lies among the candidates that named it,
//! each face has points near it, and the scan follows each of the three edges leaving it (a
//! wide fillet between two faces leaves their planes' intersection line out in the air).

use rayon::prelude::*;

use crate::geometry::{add, axpy, cross, dot, norm, scale, solve3, sub};
use crate::neighbours::Grid;
use crate::stages::corners::{CornerFit, EdgeGeometry};
use crate::stages::edges::{EdgeParams, fillet_limit};
use crate::stages::faces::{Faces, NO_FACE, Plane, rounded_crease};
use crate::stages::features::{Features, LocalScale, Scale};

/// A corner where three or more planar faces meet: their planes' common point.
#[derive(Debug, Clone, PartialEq)]
pub struct FaceCorner {
    pub position: [f64; 3],
    /// The faces (ids into `Faces::planes`) that meet here, ascending.
    pub faces: Vec<u32>,
    /// Edge candidates near the corner that see the first three faces around them.
    pub support: usize,
    /// Median local scale of those candidates.
    pub scale: Scale,
}

/// A face triple named by an edge candidate (its id).
type Vote = ([u32; 3], u32);

/// An edge candidate sees a face when at least this many of the face's points lie within
/// `SEE_REACH` of its own radius.
const SEE_POINTS: usize = 3;
pub(crate) const SEE_REACH: f64 = 2.5;
/// Two faces of a corner turn against each other by at least this many degrees: the parts
/// users bring have edges whose faces turn by 20° (an interior angle of 160°); a face split
/// in two turns by a few degrees at most. (Faceted curved surfaces, whose facets meet at
/// creases of this size, are no planar faces: see `faces::folds`.)
pub(crate) const MIN_FACE_ANGLE: f64 = 15.0;
/// One edge candidate in this many names the faces it sees (see [`face_corners`]).
pub(crate) const VOTE_STRIDE: usize = 2;
/// A corner needs this many candidates that see its three faces.
const MIN_SUPPORT: usize = 3;
/// The three faces of a corner stand at least this far from one plane: |det(n1, n2, n3)|,
/// the sine-like measure of how well their intersection is defined (0.17 ≈ sin 10°).
const MIN_DETERMINANT: f64 = 0.17;
/// The corner lies within this many radii of its nearest supporting candidate, and each of
/// its faces has points within `FACE_AT` radii of it: planes of faces that do not meet
/// there intersect somewhere else (a hole's wall and the two faces of an edge that passes
/// a few radii from the hole's rim). Faces reach into their edges' candidate bands
/// (`faces::reach_edges`), so at a true corner each comes as close as its rounding allows.
const ON_CANDIDATES: f64 = 2.5;
const FACE_AT: f64 = 2.0;
/// The faces' points within this many radii of a corner tell which side of each plane the
/// others lie on.
const FACE_NEAR: f64 = 4.0;
/// Corners closer than this many radii are one (the best supported kept, the faces pooled).
const SAME_CORNER: f64 = 2.0;
/// ...and each one's faces pass within this many noise sigmas plus spacings of the other.
const SAME_PLANE_SIGMAS: f64 = 3.0;
const SAME_PLANE_SLACK: f64 = 0.5;
/// Two corners nearer than `SAME_CORNER` whose faces do not pass through each other's
/// point: the one whose farthest face stops more than `FAR_RATIO` times as far from it
/// as the other's is left out; else both are kept when at least `APART_CORNER` radii
/// apart, and the weaker is left out when nearer.
const FAR_RATIO: f64 = 2.0;
const APART_CORNER: f64 = 1.0;

/// The corners where three or more planar faces meet (see [`FaceCorner`]): every triple of
/// faces seen together from edge candidates, their planes intersected, kept where the point
/// is among those candidates and near all three faces.
pub fn face_corners(
    positions: &[[f64; 3]],
    grid: &Grid,
    features: &Features,
    scale: &LocalScale,
    faces: &Faces,
    edges: &EdgeParams,
) -> Vec<FaceCorner> {
    if faces.planes.len() < 3 {
        return Vec::new();
    }
    let candidates = voters(features);
    // (face triple, candidate) for every candidate that sees three faces or more; each
    // worker keeps one list and one scratch of seen faces (sorted below, so the order in which
    // workers fill them does not matter).
    let mut votes: Vec<Vote> = candidates
        .par_iter()
        .fold(
            || (Vec::new(), Vec::new()),
            |(mut out, mut seen): (Vec<Vote>, Vec<(u32, usize)>), &c| {
                faces_seen(positions, grid, faces, scale, c, &mut seen);
                for (a, x) in seen.iter().enumerate() {
                    for (b, y) in seen.iter().enumerate().skip(a + 1) {
                        for z in &seen[b + 1..] {
                            out.push(([x.0, y.0, z.0], c));
                        }
                    }
                }
                (out, seen)
            },
        )
        .map(|(out, _)| out)
        .reduce(Vec::new, |mut a, mut b| {
            a.append(&mut b);
            a
        });
    votes.par_sort_unstable();
    tracing::debug!(
        "plane corners: {} face triples named by {} candidates",
        votes.len(),
        candidates.len()
    );
    // A face split in two is one plane, not two faces of a corner.
    let cos_min = MIN_FACE_ANGLE.to_radians().cos();
    let mut found: Vec<(FaceCorner, f64)> = Vec::new();
    for group in votes.chunk_by(|a, b| a.0 == b.0) {
        let triple = group[0].0;
        let voters: Vec<u32> = group.iter().map(|v| v.1).collect();
        if voters.len() < MIN_SUPPORT {
            continue;
        }
        let planes = triple.map(|f| faces.planes[f as usize]);
        let apart = (0..3)
            .all(|a| (a + 1..3).all(|b| dot(planes[a].normal, planes[b].normal).abs() < cos_min));
        if !apart {
            tracing::trace!(
                "plane corner {triple:?}: {} voters, not apart",
                voters.len()
            );
            continue;
        }
        let det = dot(planes[0].normal, cross(planes[1].normal, planes[2].normal));
        if det.abs() < MIN_DETERMINANT {
            continue;
        }
        let Some(position) = intersect(&planes) else {
            continue;
        };
        let Some(local) = scale.around(voters.iter().copied()) else {
            continue;
        };
        let r = local.radius;
        let nearest = voters
            .iter()
            .map(|&v| norm(sub(positions[v as usize], position)))
            .fold(f64::INFINITY, f64::min);
        if nearest > ON_CANDIDATES * r {
            tracing::trace!(
                "plane corner {triple:?} at {position:?}: {} voters, nearest {:.2} r",
                voters.len(),
                nearest / r
            );
            continue;
        }
        let mut near = [false; 3];
        let mut nearest_face = [f64::INFINITY; 3];
        grid.for_each_within(position, FACE_AT * r, |j, _, d2| {
            let l = faces.label[j as usize];
            for k in 0..3 {
                near[k] |= l == triple[k];
                if l == triple[k] {
                    nearest_face[k] = nearest_face[k].min(d2.sqrt());
                }
            }
        });
        if !near.iter().all(|&x| x) {
            tracing::trace!(
                "plane corner {triple:?} at {position:?}: {} voters, faces near {near:?}",
                voters.len()
            );
            continue;
        }
        if let Some(k) = unfollowed_edge(
            positions, grid, faces, &planes, &triple, position, &local, edges,
        ) {
            tracing::trace!(
                "face corner {triple:?} at {position:?}: {} voters, the scan leaves the edge of faces {:?}",
                voters.len(),
                [triple[(k + 1) % 3], triple[(k + 2) % 3]]
            );
            continue;
        }
        // How near the farthest of its faces comes to the corner.
        let far = nearest_face.iter().copied().fold(0.0, f64::max);
        tracing::trace!(
            "plane corner {triple:?} at {position:?}: {} voters, kept, faces within {:.2} spacings",
            voters.len(),
            far / local.spacing
        );
        found.push((
            FaceCorner {
                position,
                faces: triple.to_vec(),
                support: voters.len(),
                scale: local,
            },
            far,
        ));
    }
    // Best supported first; a corner near one kept already adds its faces to it.
    found.sort_by(|a, b| {
        b.0.support
            .cmp(&a.0.support)
            .then(a.0.faces.cmp(&b.0.faces))
    });
    let mut kept: Vec<(FaceCorner, f64)> = Vec::new();
    for (c, c_far) in found {
        // A corner near a kept one joins it when every face of either passes through the
        // other's point within noise: where four faces meet (a pyramid's apex) all their
        // triples agree.
        let through = |k: &FaceCorner, c: &FaceCorner| {
            let tol = SAME_PLANE_SIGMAS * k.scale.noise + SAME_PLANE_SLACK * k.scale.spacing;
            on_planes(faces, &c.faces, k.position, tol)
        };
        let same = kept.iter_mut().find(|(k, _)| {
            norm(sub(k.position, c.position)) < SAME_CORNER * k.scale.radius.max(c.scale.radius)
        });
        let Some((k, k_far)) = same else {
            kept.push((c, c_far));
            continue;
        };
        if through(k, &c) && through(&c, k) {
            for f in c.faces {
                if !k.faces.contains(&f) {
                    k.faces.push(f);
                }
            }
            continue;
        }
        // A near one that does not is either a corner of its own (a small hole's rim corner
        // beside the part's outer corner, 1.4 radii away on r091 of `bench --random 100
        // --seed 13`) or the point of two walls of a small hole that do not meet (pooling
        // its faces made one corner of four or more faces there, placed by all their
        // planes, its edges duplicated along every pair). A true corner's faces come as
        // near it as its rounding lets them; those two walls stop at their own corners, a
        // side of the hole away (on r094 of seed 1: within 0.5–2.9 spacings of the true
        // corners, 6–7.7 of the others).
        let spacing = k.scale.spacing.min(c.scale.spacing);
        let (kf, cf) = (k_far.max(spacing), c_far.max(spacing));
        if cf > FAR_RATIO * kf {
            continue;
        }
        if kf > FAR_RATIO * cf {
            *k = c;
            *k_far = c_far;
            continue;
        }
        if norm(sub(k.position, c.position)) >= APART_CORNER * k.scale.radius.max(c.scale.radius) {
            kept.push((c, c_far));
        }
    }
    let mut kept: Vec<FaceCorner> = kept.into_iter().map(|(c, _)| c).collect();
    // Where more than three faces meet (a pyramid's apex), all their planes place the corner.
    for k in &mut kept {
        k.faces.sort_unstable();
        if k.faces.len() > 3 {
            let planes: Vec<Plane> = k.faces.iter().map(|&f| faces.planes[f as usize]).collect();
            if let Some(p) = intersect(&planes) {
                let fits = planes
                    .iter()
                    .all(|pl| pl.distance(p).abs() <= SAME_CORNER * k.scale.radius);
                if fits {
                    k.position = p;
                }
            }
        }
    }
    kept
}

/// Whether every plane of `ids` passes within `tolerance` of `p`.
fn on_planes(faces: &Faces, ids: &[u32], p: [f64; 3], tolerance: f64) -> bool {
    ids.iter()
        .all(|&f| faces.planes[f as usize].distance(p).abs() <= tolerance)
}

/// The edge candidates that name faces, for the plane corners and the pair edges: every
/// `VOTE_STRIDE`-th candidate that is no outlier (a corner or an edge has dozens within its
/// reach).
pub(crate) fn voters(features: &Features) -> Vec<u32> {
    (0..features.candidate.len() as u32)
        .filter(|&i| features.candidate[i as usize] && !features.outlier[i as usize])
        .step_by(VOTE_STRIDE)
        .collect()
}

/// Counts one point of face `l` in `seen[from..]` (face, points).
pub(crate) fn tally(seen: &mut Vec<(u32, usize)>, from: usize, l: u32) {
    match seen[from..].iter_mut().find(|s| s.0 == l) {
        Some(s) => s.1 += 1,
        None => seen.push((l, 1)),
    }
}

/// Leaves out of `seen[from..]` the faces with fewer than [`SEE_POINTS`] points.
pub(crate) fn keep_seen(seen: &mut Vec<(u32, usize)>, from: usize) {
    let mut k = 0;
    seen.retain(|s| {
        k += 1;
        k <= from || s.1 >= SEE_POINTS
    });
}

/// The faces edge candidate `c` sees (see [`SEE_POINTS`]), at most the six with the most
/// points there, as (face, points) ascending by face, into `seen`.
pub(crate) fn faces_seen(
    positions: &[[f64; 3]],
    grid: &Grid,
    faces: &Faces,
    scale: &LocalScale,
    c: u32,
    seen: &mut Vec<(u32, usize)>,
) {
    let i = c as usize;
    seen.clear();
    let reach = SEE_REACH * scale.at(i).radius;
    grid.for_each_within(positions[i], reach, |j, _, _| {
        let l = faces.label[j as usize];
        if l != NO_FACE {
            tally(seen, 0, l);
        }
    });
    keep_seen(seen, 0);
    seen.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    seen.truncate(6);
    seen.sort_unstable_by_key(|s| s.0);
}

/// The scan follows a sharp edge, rounded by at most the widest rounding of a sharp edge
/// (`edges::fillet_limit`), within this many pitches plus three noise sigmas: a rounding of
/// radius ρ between faces at a dihedral angle θ keeps the scan ρ·(1/sin(θ/2) − 1) off their
/// planes' intersection line.
const HUG_SLACK: f64 = 0.5;
/// Where along each edge from the corner the gap is measured, in radii: it must be small at
/// every one (nearer, a corner's own blend widens it; farther, a short edge may have ended).
const HUG_AT: [f64; 2] = [1.0, 1.5];

/// The first of the corner's three edges (by the index of the face *not* on it) along which
/// the scan stays farther from the two planes' intersection line than a sharp edge's rounding
/// explains; `None` when the scan follows all three.
#[allow(clippy::too_many_arguments)]
fn unfollowed_edge(
    positions: &[[f64; 3]],
    grid: &Grid,
    faces: &Faces,
    planes: &[Plane; 3],
    triple: &[u32; 3],
    corner: [f64; 3],
    scale: &Scale,
    edges: &EdgeParams,
) -> Option<usize> {
    let r = scale.radius;
    // The three faces' points near the corner, read once for `side` and for the way each
    // edge leaves it (`leaving`, within `CREASE_TO` ≤ `FACE_NEAR` radii).
    let near = triple_near(grid, faces, triple, corner, FACE_NEAR * r);
    // side[m][k]: the summed signed distances of face k's points near the corner from plane
    // m (relative to the corner's): which side of each plane the other faces lie on.
    let mut side = [[0.0f64; 3]; 3];
    for p in &near {
        for (m, plane) in planes.iter().enumerate() {
            if m != p.face {
                side[m][p.face] +=
                    plane.distance(positions[p.id as usize]) - plane.distance(corner);
            }
        }
    }
    let rounding = fillet_limit(edges, scale);
    (0..3).find(|&k| {
        let (ia, ib) = ((k + 1) % 3, (k + 2) % 3);
        let (na, nb, d) = match leaving(
            positions,
            &near,
            [ia, ib],
            [&planes[ia], &planes[ib]],
            corner,
            r,
        ) {
            Some(l) => l,
            None => {
                // Each face's normal turned away from the other face: the interior angle θ
                // between the two half-planes then has cos θ = −n_a · n_b.
                let na = planes[ia].normal.map(|x| -x * side[ia][ib].signum());
                let nb = planes[ib].normal.map(|x| -x * side[ib][ia].signum());
                let mut d = cross(na, nb);
                let len = norm(d);
                if len == 0.0 {
                    return true;
                }
                d = d.map(|x| x / len);
                // Along the edge into the part: towards the side of plane k where faces a
                // and b lie.
                if dot(d, planes[k].normal) * (side[k][ia] + side[k][ib]) < 0.0 {
                    d = d.map(|x| -x);
                }
                (na, nb, d)
            }
        };
        // Each face scatters by its own noise (a face seen at grazing incidence by several
        // times the corner's median).
        let noisier = Scale {
            noise: scale.noise.max(planes[ia].noise).max(planes[ib].noise),
            ..*scale
        };
        let gap = hug_gap(rounding, -dot(na, nb), &noisier);
        // Points of a third planar face do not count: they are where a short edge ends, not
        // a rounding the scan takes (seed 2's r042, scan lines along a small hole's walls:
        // their radius is 27 h and the next wall lies a radius along its 29 h rims). A
        // fillet's points are on no face or on its own strips, and its line keeps them
        // farther than the gap: no point near, not followed.
        let third = |j: u32| faces.on_other_face(j as usize, [triple[ia], triple[ib]]);
        let hugged = HUG_AT.iter().all(|&t| {
            let q = axpy(corner, t * r, d);
            hugs(
                grid,
                q,
                d,
                [&planes[ia], &planes[ib]],
                gap,
                scale.spacing,
                third,
            )
        });
        // A fillet a little wider than the widest rounding keeps the scan off the planes'
        // line by less than `hug_gap` allows each point (its noise sigmas), but the median
        // of dozens of points shows it (see `rounded_crease`). Seen on `bench --random 100
        // --seed 1`'s r003: the faces beside a 7.4 h fillet at 109° met 1.7 h off the scan,
        // the widest rounding allowing 1.1 h; two corners and the edge between them, 47 h
        // from any true corner.
        let (start, end) = (
            axpy(corner, CREASE_FROM * r, d),
            axpy(corner, CREASE_TO * r, d),
        );
        // Each face's trace leaves the edge in its plane, across `d`, on its own side of the
        // other face's plane (against that face's turned normal): `side` has told already
        // where each face's points lie.
        let trace = |own: [f64; 3], other: [f64; 3]| {
            let t = cross(d, own);
            let t = t.map(|x| x / norm(t));
            if dot(t, other) > 0.0 {
                t.map(|x| -x)
            } else {
                t
            }
        };
        let rounded = || {
            let tr = [trace(na, nb), trace(nb, na)];
            let noise = planes[ia].noise.max(planes[ib].noise);
            rounded_crease(positions, grid, noise, &tr, start, end, scale, rounding).is_some()
        };
        !hugged || rounded()
    })
}

/// A point of one of a plane corner's three faces near it.
struct NearPoint {
    /// Index of its face in the corner's triple.
    face: usize,
    id: u32,
    /// Offset from the corner, and its square length.
    offset: [f64; 3],
    d2: f64,
}

/// The points of the faces `triple` within `reach` of `corner`, in the grid's order.
fn triple_near(
    grid: &Grid,
    faces: &Faces,
    triple: &[u32; 3],
    corner: [f64; 3],
    reach: f64,
) -> Vec<NearPoint> {
    let mut near = Vec::new();
    grid.for_each_within(corner, reach, |id, offset, d2| {
        let l = faces.label[id as usize];
        if let Some(face) = triple.iter().position(|&t| t == l) {
            near.push(NearPoint {
                face,
                id,
                offset,
                d2,
            });
        }
    });
    near
}

/// The fewest points of an edge's two faces that show which way it leaves a corner.
const LEAVING_POINTS: usize = 10;

/// The way the edge of faces `pair` (indices into the corner's triple; planes `planes`)
/// leaves the corner, and each face's normal turned away from the other face: `(n_a, n_b,
/// d)`, `d` unit along the edge. Read from the two faces' points of `near` (`triple_near`,
/// reaching at least `CREASE_TO` radii) within `FACE_AT` radii of the planes' line, between
/// `CREASE_FROM` and `CREASE_TO` radii from the corner on either side: the edge goes where
/// each face has at least `LEAVING_POINTS` and twice as many as on the other side, and there
/// each face lies on one side of the other's plane. `None` when neither side has them (faces
/// that stop short of a rounded edge; parallel planes).
///
/// Why not from all the faces' points near the corner: where two of a corner's faces meet
/// at a concave edge, the third face wraps around the corner (the top of an L-shaped
/// block) and its points lie on both sides of each plane. Seen on `bench --random 100 --seed
/// 13`'s r091: the edge of the top and a side face was looked for beyond the corner, out
/// of the part, and the corner, 0.1 h from the true one, was refused.
fn leaving(
    positions: &[[f64; 3]],
    near: &[NearPoint],
    pair: [usize; 2],
    planes: [&Plane; 2],
    corner: [f64; 3],
    r: f64,
) -> Option<([f64; 3], [f64; 3], [f64; 3])> {
    let d = cross(planes[0].normal, planes[1].normal);
    let len = norm(d);
    if len == 0.0 {
        return None;
    }
    let d = scale(d, 1.0 / len);
    // Per way along d (+, −): points of each face, and the summed signed distances of face
    // b's points from plane a and of face a's from plane b.
    let mut count = [[0usize; 2]; 2];
    let mut side = [[0.0f64; 2]; 2];
    let base = planes.map(|p| p.distance(corner));
    let reach2 = (CREASE_TO * r) * (CREASE_TO * r);
    for p in near.iter().filter(|p| p.d2 <= reach2) {
        let Some(f) = pair.iter().position(|&x| x == p.face) else {
            continue;
        };
        let w = p.offset;
        let t = dot(w, d);
        if t.abs() < CREASE_FROM * r || norm(axpy(w, -t, d)) > FACE_AT * r {
            continue;
        }
        let way = usize::from(t < 0.0);
        count[way][f] += 1;
        let other = 1 - f;
        side[way][other] += planes[other].distance(positions[p.id as usize]) - base[other];
    }
    // An edge lies where both of its faces do.
    let count = count.map(|c| c[0].min(c[1]));
    let way = if count[0] >= count[1] { 0 } else { 1 };
    if count[way] < LEAVING_POINTS || count[way] < 2 * count[1 - way] {
        return None;
    }
    let d = if way == 0 { d } else { scale(d, -1.0) };
    let na = planes[0].normal.map(|x| -x * side[way][0].signum());
    let nb = planes[1].normal.map(|x| -x * side[way][1].signum());
    Some((na, nb, d))
}

/// The stretch of each edge leaving a plane corner on which `rounded_crease` judges it, in
/// radii from the corner: clear of the corner's own blend, and long enough for the points
/// within a spacing of the crease to tell (to two radii r003's fillet had fewer than
/// `faces::CREASE_MIN_POINTS`). An edge shorter than that has other faces past its other corner;
/// measured on `bench --random 100` seeds 1, 2, 3 and 7, no true corner was lost.
const CREASE_FROM: f64 = 0.5;
const CREASE_TO: f64 = 3.0;
// `unfollowed_edge` reads the points `leaving` needs once, within `FACE_NEAR` radii.
const _: () = assert!(CREASE_TO <= FACE_NEAR);

/// How far from two planes' intersection line the scan of a sharp edge may stay: the widest
/// rounding (`rounding`, a radius) between faces at the interior angle θ (`cos_theta`) keeps
/// it `rounding · (1/sin(θ/2) − 1)` off the line, plus `HUG_SLACK` pitches and three noise
/// sigmas.
pub(crate) fn hug_gap(rounding: f64, cos_theta: f64, scale: &Scale) -> f64 {
    let half = (0.5 * (1.0 - cos_theta.clamp(-1.0, 1.0))).sqrt().max(1e-3);
    rounding * (1.0 / half - 1.0) + HUG_SLACK * scale.pitch + 3.0 * scale.noise
}

/// Whether the scan follows the intersection line of `planes` (through `q`, unit direction
/// `d`) there: it has points within `gap + spacing` of the line, within `spacing` of `q`
/// along it, and at most one in ten of them lies farther than `gap` from both planes. Scan
/// lines may run along an edge a spacing apart and never come near the line itself; the
/// points they put beside it lie on one face or the other. A fillet's or a chamfer's points
/// there lie off both planes, and a rounding wider than a fillet's keeps the scan farther
/// from the line than `gap + spacing` (no points at all). Points for which `third_face` holds
/// (on a planar face other than the two) are not asked.
pub(crate) fn hugs(
    grid: &Grid,
    q: [f64; 3],
    d: [f64; 3],
    planes: [&Plane; 2],
    gap: f64,
    spacing: f64,
    third_face: impl Fn(u32) -> bool,
) -> bool {
    let base = planes.map(|p| p.distance(q));
    let (mut near, mut off) = (0usize, 0usize);
    grid.for_each_within(q, gap + spacing, |j, w, _| {
        let along = dot(w, d);
        if along.abs() > spacing || third_face(j) {
            return;
        }
        let [a, b] = [0, 1].map(|k| (base[k] + dot(planes[k].normal, w)).abs());
        near += 1;
        off += usize::from(a.min(b) > gap);
    });
    near > 0 && 10 * off <= near
}

/// The least-squares common point of planes (minimising the sum of squared distances), or
/// `None` when they do not fix one point (fewer than three independent normals). Offsets
/// are taken from the first plane's centroid for precision.
pub fn intersect(planes: &[Plane]) -> Option<[f64; 3]> {
    let origin = planes.first()?.centroid;
    let mut a = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    for p in planes {
        let n = p.normal;
        let d = dot(n, sub(p.centroid, origin));
        for r in 0..3 {
            for c in 0..3 {
                a[r][c] += n[r] * n[c];
            }
            b[r] += n[r] * d;
        }
    }
    let x = solve3(&a, &b)?;
    Some(add(origin, x))
}

/// A straight sharp edge where two planar faces meet: from one plane corner of both to
/// another (`face_edges`), or along a stretch the scan follows with a corner at neither,
/// one or both ends (`pair_edges`).
#[derive(Debug, Clone, PartialEq)]
pub struct FaceEdge {
    /// Indices into the plane corners (after `place_edges`: into the reported corners), at
    /// `start` and `end`; `None` where the edge ends without a corner (a scan border, a
    /// face's end).
    pub corners: [Option<usize>; 2],
    pub faces: [u32; 2],
    pub start: [f64; 3],
    pub end: [f64; 3],
    /// Edge candidates within one radius of the edge.
    pub points: usize,
    /// The two faces' directions away from the edge, perpendicular to it (unit; the face
    /// traces of a slab across it), towards each face's points.
    pub traces: [[f64; 3]; 2],
    /// The scale of the corners at its ends (the smaller radius).
    pub scale: Scale,
}

/// The segment between two corners lies along their two faces' intersection line within
/// this sine of an angle (3°).
const ALONG_LINE: f64 = 0.05;

/// The edges between plane corners: two corners sharing two faces, the segment between them
/// along those faces' intersection, and edge candidates along all of it (every radius of its
/// length has one within a radius). Corners of one pair of faces are taken in order along
/// their line, so an edge never jumps over a corner between.
pub fn face_edges(
    positions: &[[f64; 3]],
    grid: &Grid,
    features: &Features,
    faces: &Faces,
    corners: &[FaceCorner],
) -> Vec<FaceEdge> {
    // Every pair of faces with the corners on it.
    let mut on_pair: Vec<([u32; 2], usize)> = Vec::new();
    for (c, corner) in corners.iter().enumerate() {
        for (i, &a) in corner.faces.iter().enumerate() {
            for &b in &corner.faces[i + 1..] {
                on_pair.push(([a, b], c));
            }
        }
    }
    on_pair.sort_unstable();
    let mut out = Vec::new();
    for group in on_pair.chunk_by(|a, b| a.0 == b.0) {
        let pair = group[0].0;
        let ids: Vec<usize> = group.iter().map(|x| x.1).collect();
        if ids.len() < 2 {
            continue;
        }
        let (pa, pb) = (
            faces.planes[pair[0] as usize],
            faces.planes[pair[1] as usize],
        );
        let mut d = cross(pa.normal, pb.normal);
        let len = norm(d);
        if len < 1e-9 {
            continue;
        }
        d = d.map(|x| x / len);
        let mut along: Vec<(f64, usize)> = ids
            .iter()
            .map(|&c| (dot(d, corners[c].position), c))
            .collect();
        along.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        for w in along.windows(2) {
            let (c0, c1) = (w[0].1, w[1].1);
            let (p0, p1) = (corners[c0].position, corners[c1].position);
            let seg = sub(p1, p0);
            let l = norm(seg);
            if l == 0.0 || norm(cross(seg.map(|x| x / l), d)) > ALONG_LINE {
                continue;
            }
            // At the scale of the corner with the smaller radius.
            let sc = if corners[c0].scale.radius <= corners[c1].scale.radius {
                corners[c0].scale
            } else {
                corners[c1].scale
            };
            let r = sc.radius;
            let steps = (l / r).ceil().max(1.0) as usize;
            let mut candidates = 0usize;
            let covered = (0..=steps).all(|s| {
                let t = s as f64 / steps as f64;
                let q = axpy(p0, t, seg);
                let mut n = 0;
                grid.for_each_within(q, r, |j, _, _| {
                    n += usize::from(features.candidate[j as usize]);
                });
                candidates += n;
                n > 0
            });
            if !covered {
                continue;
            }
            let mid = scale(add(p0, p1), 0.5);
            let Some(traces) = traces(positions, grid, faces, pair, d, mid, FACE_NEAR * r) else {
                continue;
            };
            out.push(FaceEdge {
                corners: [Some(c0), Some(c1)],
                faces: pair,
                start: p0,
                end: p1,
                points: candidates,
                traces,
                scale: sc,
            });
        }
    }
    out
}

/// The directions of faces `pair` away from their intersection line (direction `d`) at
/// `at`: in each face's plane, perpendicular to `d`, towards the face's points within
/// `reach` (`None` when a face has none there).
pub(crate) fn traces(
    positions: &[[f64; 3]],
    grid: &Grid,
    faces: &Faces,
    pair: [u32; 2],
    d: [f64; 3],
    at: [f64; 3],
    reach: f64,
) -> Option<[[f64; 3]; 2]> {
    let mut towards = [[0.0; 3]; 2];
    let mut seen = [false; 2];
    grid.for_each_within(at, reach, |j, _, _| {
        let l = faces.label[j as usize];
        for k in 0..2 {
            if l == pair[k] {
                seen[k] = true;
                let off = sub(positions[j as usize], at);
                towards[k] = add(towards[k], off);
            }
        }
    });
    if !seen[0] || !seen[1] {
        return None;
    }
    let mut out = [[0.0; 3]; 2];
    for k in 0..2 {
        let t = cross(d, faces.planes[pair[k] as usize].normal);
        let len = norm(t);
        if len == 0.0 {
            return None;
        }
        let sign = if dot(t, towards[k]) < 0.0 { -1.0 } else { 1.0 };
        out[k] = t.map(|x| sign * x / len);
    }
    Some(out)
}

/// Whether segment c–d lies along segment a–b: both its ends within `tolerance` of a–b's line
/// and the two overlapping, by at least half of the shorter.
pub fn overlaps(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3], tolerance: f64) -> bool {
    overlap(a, b, c, d, tolerance).is_some()
}

/// How long segment c–d overlaps segment a–b along a–b's line, where it lies along it (see
/// [`overlaps`]).
pub fn overlap(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3], tolerance: f64) -> Option<f64> {
    let ab = sub(b, a);
    let l = norm(ab);
    if l == 0.0 {
        return None;
    }
    let u = ab.map(|x| x / l);
    let off = |p: [f64; 3]| {
        let t = dot(sub(p, a), u);
        (t, norm(sub(sub(p, a), u.map(|x| x * t))))
    };
    let ((tc, dc), (td, dd)) = (off(c), off(d));
    if dc > tolerance || dd > tolerance {
        return None;
    }
    let (lo, hi) = (tc.min(td), tc.max(td));
    let overlap = hi.min(l) - lo.max(0.0);
    (overlap > 0.0 && overlap >= 0.5 * (hi - lo).min(l)).then_some(overlap)
}

/// A fitted corner this close to a plane corner, in the plane corner's radii, and within
/// `FITTED_ON_PLANES` spacings (plus `SAME_PLANE_SIGMAS` noise sigmas) of each of its
/// faces' planes, is the same corner.
const SAME_AS_FITTED: f64 = 2.0;
const FITTED_ON_PLANES: f64 = 2.0;

/// Puts the plane corners among the fitted ones: the nearest fitted corner within
/// `SAME_AS_FITTED` radii that no plane corner took yet takes the plane corner's position
/// (the planes rest on whole faces; the fit on its edges' ends); a plane corner with none
/// near is added, without fit errors. Returns each plane corner's index in `corners`.
pub fn place_corners(
    faces: &Faces,
    found: &[FaceCorner],
    corners: &mut Vec<CornerFit>,
) -> Vec<usize> {
    let mut index = Vec::with_capacity(found.len());
    // A fitted corner takes one plane corner's position: two plane corners near one fitted
    // corner (a small hole's rim corner and the outer corner beside it) are two corners.
    // (A plane corner within `APART_CORNER` radii of one placed already is that corner.)
    let mut placed = vec![false; corners.len()];
    for fc in found {
        // A fitted corner of the same corner lies on its faces' planes; one that lies a
        // radius along an edge line from it is another corner, whose edges would be drawn to
        // this one (on scan lines along small walls the radius is 27 h: seed 7's r011, a
        // fitted corner 58 h off, its edges 20–50 h off the part's).
        let tolerance = SAME_PLANE_SIGMAS * fc.scale.noise + FITTED_ON_PLANES * fc.scale.spacing;
        let nearest = corners
            .iter()
            .enumerate()
            .map(|(i, c)| (norm(sub(c.position, fc.position)), i))
            .filter(|&(d, i)| {
                d < SAME_AS_FITTED * fc.scale.radius
                    && (placed[i] || on_planes(faces, &fc.faces, corners[i].position, tolerance))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        // Only the nearest: a fitted corner farther than another is another corner's, and
        // moving it would carry its edges' ends there (seed 7's r011: fitted edges 20–35 h
        // off the part's edges).
        match nearest {
            Some((d, i)) if placed[i] && d < APART_CORNER * fc.scale.radius => index.push(i),
            Some((_, i)) if !placed[i] => {
                corners[i].position = fc.position;
                placed[i] = true;
                index.push(i);
            }
            _ => {
                placed.push(true);
                index.push(corners.len());
                corners.push(CornerFit {
                    vertex: usize::MAX,
                    position: fc.position,
                    scheme1: fc.position,
                    exact: fc.position,
                    errors: [f64::NAN; 3],
                    edges: Vec::new(),
                });
            }
        }
    }
    index
}

/// A plane edge beside the line a fitted edge took (off it by more than the tolerance) and
/// within this cosine of parallel to it (5°) is the same edge: a patch split off a face.
const PARALLEL_COS: f64 = 0.996_194_698_091_745_5;

/// Places the plane edges: a fitted straight edge along one or more (see [`overlaps`], within
/// 1.5 spacings) takes the exact line of the one that overlaps it longest, and reaches from
/// corner to corner where that one or another along the same line has corners (an end
/// without one keeps the fitted end, moved onto the line, or goes as far as a plane edge
/// along the line reaches: never shorter); those plane edges are that edge. A plane edge
/// that runs along a fitted curved edge (a polyline) over half its length or more is that
/// edge and is dropped, and so is one beside the line a fitted edge took and parallel to it
/// (see [`PARALLEL_COS`]). The others, those that overlapped a fitted edge at an angle to the
/// line it took (another line through a short or stray fit) among them, are returned as
/// edges of their own, their `corners` turned into indices of the reported corners
/// (`corner_index`, from [`place_corners`]).
///
/// Why the longest line: a fitted edge may run along several plane edges, its faces' line
/// and short ones between one face and a small patch split off the other (a grazing face of
/// a structured-light view: 37 points parallel to a face of 26,037, a spacing beside it).
/// Taken one after the other, the last one placed the edge, and a 724-spacing edge lay on a
/// 12-spacing patch's line, 1–1.2 spacings off at its ends (`bench --random 100 --seed 37`,
/// r043: rectified / raw 1.05).
pub fn place_edges(
    edges: &[FaceEdge],
    found: &[FaceCorner],
    corner_index: &[usize],
    geometry: &mut [Option<EdgeGeometry>],
) -> Vec<FaceEdge> {
    let tolerance_of =
        |fe: &FaceEdge| 1.5 * fe.corners[0].map_or(fe.scale.spacing, |c| found[c].scale.spacing);
    // Each plane edge's fitted straight edge, and how long they overlap.
    let along: Vec<Option<(usize, f64)>> = edges
        .iter()
        .map(|fe| {
            geometry.iter().enumerate().find_map(|(k, g)| {
                let g = g.as_ref().filter(|g| g.polyline.len() == 2)?;
                overlap(
                    fe.start,
                    fe.end,
                    g.polyline[0],
                    g.polyline[1],
                    tolerance_of(fe),
                )
                .map(|length| (k, length))
            })
        })
        .collect();
    // Plane edges that are a fitted edge (along its line), not edges of their own.
    let mut taken = vec![false; edges.len()];
    for (k, g) in geometry.iter_mut().enumerate() {
        let Some(g) = g.as_mut() else { continue };
        // Its plane edges, longest first (the first of equals).
        let mut mine: Vec<(usize, f64)> = along
            .iter()
            .enumerate()
            .filter_map(|(i, a)| a.filter(|a| a.0 == k).map(|a| (i, a.1)))
            .collect();
        mine.sort_by(|x, y| y.1.total_cmp(&x.1).then(x.0.cmp(&y.0)));
        let Some(&(best, _)) = mine.first() else {
            continue;
        };
        let (start, end) = (edges[best].start, edges[best].end);
        let line = sub(end, start);
        let l2 = dot(line, line);
        let on_line = |p: [f64; 3]| {
            let t = if l2 > 0.0 {
                dot(sub(p, start), line) / l2
            } else {
                0.0
            };
            axpy(start, t, line)
        };
        g.faces = Some(edges[best].traces);
        for &(i, _) in &mine {
            let fe = &edges[i];
            let points = [fe.start, fe.end];
            if i != best
                && points
                    .iter()
                    .any(|&p| norm(sub(p, on_line(p))) > tolerance_of(fe))
            {
                // Beside the line and along it: a patch's line, the same edge.
                let dir = sub(fe.end, fe.start);
                let cos = dot(dir, line) / (norm(dir) * l2.sqrt());
                taken[i] = cos.abs() >= PARALLEL_COS;
                continue;
            }
            taken[i] = true;
            let ends = fe.corners.map(|c| c.map(|c| corner_index[c]));
            // g's end e lies at the plane edge's end `j[e]`.
            let j = if dot(sub(g.polyline[1], g.polyline[0]), sub(fe.end, fe.start)) >= 0.0 {
                [0, 1]
            } else {
                [1, 0]
            };
            for e in 0..2 {
                match ends[j[e]] {
                    // The longest's corners; another's where the fitted end has none yet.
                    // The edge ends exactly at its corner.
                    Some(c) if i == best || g.corners[e].is_none() => {
                        g.polyline[e] = points[j[e]];
                        g.corners[e] = Some(c);
                    }
                    Some(_) => {}
                    // A fitted end at a corner stays there; an open one (a fragment's)
                    // reaches as far as both faces follow the line, never shorter.
                    None => {
                        let fitted = on_line(g.polyline[e]);
                        let reach = on_line(points[j[e]]);
                        let outward = sub(fitted, g.polyline[1 - e]);
                        g.polyline[e] =
                            if g.corners[e].is_none() && dot(sub(reach, fitted), outward) > 0.0 {
                                reach
                            } else {
                                fitted
                            };
                    }
                }
            }
        }
    }
    let mut own = Vec::new();
    for (i, fe) in edges.iter().enumerate() {
        if taken[i] {
            continue;
        }
        // A fitted curved edge (a polyline) along most of it is the same edge, found by its
        // slabs: the plane edge is a chord of it between two faces grown on gently curved
        // patches (the faceted fandisk's strips: 145 edges reported instead of 91, edge
        // length 1.7x the true length). It keeps the fitted polyline.
        let chord = geometry
            .iter()
            .flatten()
            .any(|g| g.polyline.len() > 2 && along_polyline(fe, g, tolerance_of(fe)));
        if !chord {
            own.push(FaceEdge {
                corners: fe.corners.map(|c| c.map(|c| corner_index[c])),
                ..fe.clone()
            });
        }
    }
    own
}

/// Whether most of the plane edge `fe` (at least half of it, sampled every `tolerance`
/// along it, up to 1,024 samples) lies within `tolerance` of the polyline of `g`.
fn along_polyline(fe: &FaceEdge, g: &EdgeGeometry, tolerance: f64) -> bool {
    let length = norm(sub(fe.end, fe.start));
    if tolerance.is_nan() || tolerance <= 0.0 || length == 0.0 {
        return false;
    }
    let n = ((length / tolerance).ceil() as usize).clamp(2, 1024);
    let near = (0..n)
        .filter(|&i| {
            let p = axpy(fe.start, (i as f64 + 0.5) / n as f64, sub(fe.end, fe.start));
            norm(sub(p, g.nearest(p).0)) <= tolerance
        })
        .count();
    2 * near >= n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One fitted edge along `polyline`, no corners.
    fn fitted_edge(polyline: Vec<[f64; 3]>) -> Vec<Option<EdgeGeometry>> {
        vec![Some(EdgeGeometry {
            run: 0,
            polyline,
            corners: [None, None],
            faces: None,
        })]
    }

    /// A plane edge of faces 0 and 1 without corners, spacing 1.
    fn open_edge(start: [f64; 3], end: [f64; 3], traces: [[f64; 3]; 2]) -> FaceEdge {
        FaceEdge {
            corners: [None, None],
            faces: [0, 1],
            start,
            end,
            points: 100,
            traces,
            scale: Scale {
                spacing: 1.0,
                pitch: 1.0,
                noise: 0.01,
                radius: 4.0,
            },
        }
    }

    #[test]
    fn a_plane_edge_along_a_fitted_curved_edge_is_that_edge() {
        // A fitted arc of radius 100 in the xy-plane (polyline every 2°), spacing 1.
        let arc: Vec<[f64; 3]> = (0..=30)
            .map(|k| {
                let a = (2.0 * k as f64).to_radians();
                [100.0 * a.cos(), 100.0 * a.sin(), 0.0]
            })
            .collect();
        let mut geometry = fitted_edge(arc.clone());
        let edge = |start, end| open_edge(start, end, [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
        // A chord of 10° (sagitta 0.38) along the arc, one 3 off it, and one along it over
        // a third of its length only.
        let on = edge(arc[5], arc[10]);
        let off = edge(add(arc[5], [0.0, 0.0, 3.0]), add(arc[10], [0.0, 0.0, 3.0]));
        let beyond = edge(arc[29], axpy(arc[29], 3.0, sub(arc[30], arc[29])));
        let own = place_edges(&[on, off.clone(), beyond.clone()], &[], &[], &mut geometry);
        assert_eq!(own.len(), 2, "{own:?}");
        assert_eq!((own[0].start, own[1].start), (off.start, beyond.start));
        // The fitted arc is left as it was.
        assert_eq!(geometry[0].as_ref().unwrap().polyline, arc);
    }

    #[test]
    fn issue17_a_fitted_edge_takes_the_line_of_the_plane_edge_along_most_of_it() {
        // A fitted straight edge along x, 0.2 off the true line y = z = 0 at one end and
        // 0.2 the other way at the other, spacing 1 (tolerance 1.5). Along it: the faces'
        // line over most of it, a short piece of the same line beyond its end, and a short
        // line 1 beside it (a patch split off a face).
        let geometry = fitted_edge(vec![[0.0, 0.2, 0.0], [100.0, -0.2, 0.0]]);
        let edge = |start, end| open_edge(start, end, [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]);
        let close = |line: &[[f64; 3]], want: [[f64; 3]; 2]| {
            for (p, q) in line.iter().zip(want) {
                assert!(norm(sub(*p, q)) < 1e-9, "{line:?} against {want:?}");
            }
        };
        let main = edge([1.0, 0.0, 0.0], [95.0, 0.0, 0.0]);
        let beyond = edge([94.0, 0.0, 0.0], [103.0, 0.0, 0.0]);
        let patch = edge([90.0, 1.0, 0.0], [98.0, 1.0, 0.0]);
        for order in [[&main, &beyond, &patch], [&patch, &beyond, &main]] {
            let mut g = geometry.clone();
            let own = place_edges(&order.map(|e| e.clone()), &[], &[], &mut g);
            // All three are the fitted edge. It lies on the main line, its open ends where
            // the fit had them or as far as a plane edge along that line reaches.
            assert!(own.is_empty(), "{own:?}");
            close(
                &g[0].as_ref().unwrap().polyline,
                [[0.0, 0.0, 0.0], [103.0, 0.0, 0.0]],
            );
        }
        // Alone, the patch's line is the best there is.
        let mut g = geometry.clone();
        assert!(place_edges(&[patch], &[], &[], &mut g).is_empty());
        close(
            &g[0].as_ref().unwrap().polyline,
            [[0.0, 1.0, 0.0], [100.0, 1.0, 0.0]],
        );
    }

    fn plane(normal: [f64; 3], point: [f64; 3]) -> Plane {
        let l = norm(normal);
        let n = normal.map(|x| x / l);
        Plane {
            normal: n,
            centroid: point,
            points: 100,
            rms: 0.0,
            spacing: 1.0,
            pitch: 1.0,
            noise: 0.0,
        }
    }

    fn face_corner(position: [f64; 3], x_face: u32) -> FaceCorner {
        FaceCorner {
            position,
            faces: vec![0, 1, x_face],
            support: 10,
            scale: Scale {
                spacing: 1.0,
                pitch: 1.0,
                noise: 0.1,
                radius: 4.0,
            },
        }
    }

    fn fitted(position: [f64; 3]) -> CornerFit {
        CornerFit {
            vertex: 0,
            position,
            scheme1: position,
            exact: position,
            errors: [0.0; 3],
            edges: vec![0, 1, 2],
        }
    }

    /// Issue 17: a fitted corner took the position of every plane corner within two radii in
    /// turn, so of a small hole's rim corner and the part's outer corner beside it (1.4 radii
    /// apart) only the last placed was reported. Each fitted corner now takes one plane
    /// corner, the first come; another is a corner of its own, unless within a radius of one
    /// placed already (the same corner). A plane corner takes only the fitted corner nearest
    /// it, and only one on its faces' planes (within two spacings): one a radius along an
    /// edge line is another corner's.
    #[test]
    fn issue17_a_fitted_corner_takes_one_plane_corner() {
        // Faces: y = 0, z = 0, and planes x = 1, 6, 1.5, 50, 16 (faces 2 to 6).
        let mut planes = vec![
            plane([0.0, 1.0, 0.0], [0.0, 0.0, 0.0]),
            plane([0.0, 0.0, 1.0], [0.0, 0.0, 0.0]),
        ];
        for x in [1.0, 6.0, 1.5, 50.0, 16.0] {
            planes.push(plane([1.0, 0.0, 0.0], [x, 0.0, 0.0]));
        }
        let faces = Faces {
            label: Vec::new(),
            planes,
        };
        let mut corners = vec![fitted([0.0, 0.0, 0.0]), fitted([13.0, 0.0, 0.0])];
        let found = [
            face_corner([1.0, 0.0, 0.0], 2),
            face_corner([6.0, 0.0, 0.0], 3),
            face_corner([1.5, 0.0, 0.0], 4),
            face_corner([50.0, 0.0, 0.0], 5),
            // Three from the fitted corner at 13, nearest of all, but off its plane x = 16.
            face_corner([16.0, 0.0, 0.0], 6),
        ];
        let index = place_corners(&faces, &found, &mut corners);
        assert_eq!(index, vec![0, 2, 0, 3, 4]);
        assert_eq!(corners.len(), 5);
        assert_eq!(corners[0].position, [1.0, 0.0, 0.0]);
        assert_eq!(corners[1].position, [13.0, 0.0, 0.0]);
        assert_eq!(corners[2].position, [6.0, 0.0, 0.0]);
        assert!(corners[2].errors.iter().all(|e| e.is_nan()));
        assert_eq!(corners[3].position, [50.0, 0.0, 0.0]);
        assert_eq!(corners[4].position, [16.0, 0.0, 0.0]);
    }

    #[test]
    fn three_planes_meet_in_one_point_and_parallel_ones_nowhere() {
        let p = [
            plane([1.0, 0.0, 0.0], [2.0, 7.0, -3.0]),
            plane([0.0, 1.0, 0.0], [5.0, -1.0, 4.0]),
            plane([1.0, 1.0, 1.0], [2.0, -1.0, 9.0]),
        ];
        let x = intersect(&p).unwrap();
        for pl in &p {
            assert!(pl.distance(x).abs() < 1e-12, "{x:?}");
        }
        assert!(norm(sub(x, [2.0, -1.0, 9.0])) < 1e-12, "{x:?}");
        // Two planes, or three sharing a line, fix no point.
        assert!(intersect(&p[..2]).is_none());
        let pencil = [
            plane([1.0, 0.0, 0.0], [0.0; 3]),
            plane([0.0, 1.0, 0.0], [0.0; 3]),
            plane([1.0, 1.0, 0.0], [0.0; 3]),
        ];
        assert!(intersect(&pencil).is_none());
        // Four planes through one point (a pyramid's apex): the same point.
        let apex = [3.0, 1.0, 2.0];
        let four = [
            [1.0, 0.0, 1.0],
            [-1.0, 0.0, 1.0],
            [0.0, 1.0, 1.0],
            [0.0, -1.0, 1.0],
        ]
        .map(|n| plane(n, apex));
        assert!(norm(sub(intersect(&four).unwrap(), apex)) < 1e-12);
    }

    #[test]
    fn segments_overlap_along_one_line_only() {
        let (a, b) = ([0.0, 0.0, 0.0], [10.0, 0.0, 0.0]);
        assert!(overlaps(a, b, [2.0, 0.1, 0.0], [9.0, -0.1, 0.0], 0.5));
        // Reversed, and longer than a–b but covering it.
        assert!(overlaps(a, b, [12.0, 0.0, 0.0], [-1.0, 0.0, 0.0], 0.5));
        // Off the line, beside it, or touching only at an end.
        assert!(!overlaps(a, b, [2.0, 1.0, 0.0], [9.0, 1.0, 0.0], 0.5));
        assert!(!overlaps(a, b, [11.0, 0.0, 0.0], [20.0, 0.0, 0.0], 0.5));
        assert!(!overlaps(a, b, [9.0, 0.0, 0.0], [20.0, 0.0, 0.0], 0.5));
        // Degenerate a–b or c–d (a fitted edge collapsed onto its corner).
        assert!(!overlaps(a, a, a, b, 0.5));
        assert!(!overlaps(a, b, [5.0, 0.0, 0.0], [5.0, 0.0, 0.0], 0.5));
    }
}
