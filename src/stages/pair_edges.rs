//! Edges from face pairs: where two planar faces meet along a stretch the scan follows, their
//! planes' intersection line is a sharp edge there, whether or not a plane corner ends it.
//!
//! Inputs: positions, the neighbour `Grid`, the `Features` (candidate and outlier masks), the
//! `LocalScale`, the planar `Faces`, the plane corners (`FaceCorner`), the edges between plane
//! corners already found (`FaceEdge`, from `plane_corners::face_edges`) and `EdgeParams` (the
//! widest rounding of a sharp edge). Output: more `FaceEdge`s, each with a plane corner at
//! neither, one or both ends.
//!
//! Why: the edge stage fits slabs across each run of edge candidates; where the sampling
//! leaves a slab few points of one face (scan lines running nearly along the edge, a
//! structured-light grid seeing one face at a grazing angle, a view that sees a face only up
//! to a scan border) or the faces turn by little (an interior angle of 160°), the slab fits
//! fail or are judged no edge, and the plane corners only join corners whose three faces were
//! all seen. Two planar faces rest on thousands of points whatever the sampling pattern, and
//! where they meet the scan shows it: both faces reach the line and the scan hugs it.
//!
//! How: each edge candidate names the faces it sees (as for the plane corners); a pair of
//! faces named together by `MIN_SUPPORT` candidates or more, whose planes turn by at least
//! `plane_corners::MIN_FACE_ANGLE`, is walked along its planes' intersection line in steps
//! of a spacing, over the stretch its candidates cover. A step is on the edge when both faces
//! have points within `FACE_REACH` radii of it across the line and `ALONG_REACH` along it,
//! and the scan passes within the widest rounding
//! of a sharp edge of the line there (`plane_corners::hugs`: a fillet or a chamfer between
//! the faces leaves their line in the air). Runs of such steps, at least `MIN_LENGTH` radii
//! long and not along an edge between plane corners already, are edges, each end brought
//! back to the last point of the side that ends first (`face_extent`); an end within
//! `SNAP` radii of a plane corner of both faces ends at that corner. A face sampled much more
//! sparsely than the candidates beside it (seen at a grazing angle) is asked within reaches
//! widened by its spacing over theirs (`SPARSE_RATIO`).

use rayon::prelude::*;

use crate::geometry::{
    add, axpy, cross, dot, norm, parabola_curvature, point_segment, scale as scale_by, sub,
};
use crate::neighbours::Grid;
use crate::stages::edges::{EdgeParams, fillet_limit};
use crate::stages::faces::{Faces, NO_FACE, Plane, rounded_crease};
use crate::stages::features::{Features, LocalScale};
use crate::stages::plane_corners::{
    FaceCorner, FaceEdge, MIN_FACE_ANGLE, SEE_REACH, faces_seen, hug_gap, hugs, intersect,
    keep_seen, tally, traces, voters,
};

/// A face pair named by a candidate (its id).
type PairVote = ([u32; 2], u32);

/// A pair of faces needs this many candidates that see both.
const MIN_SUPPORT: usize = 6;
/// Candidates farther than this many radii from the pair's line do not place its stretch.
const ON_LINE: f64 = 2.0;
/// Both faces have points within this many radii of a step on the edge, across the line...
const FACE_REACH: f64 = 2.5;
/// ...and within this many radii of the step along it: a face that ends along the line (the
/// edge turns away there: a corner, a curved edge going on as a fillet's border) ends the
/// edge within half a radius, while across the line a face may end radii short of it (a
/// real sensor rounds a box's edge over 4–9 mm, and what it leaves there is candidates).
const ALONG_REACH: f64 = 0.5;
/// The shortest edge kept, in radii: shorter runs are the ends of edges that meet elsewhere
/// (a face pair named around a corner) or noise.
const MIN_LENGTH: f64 = 3.0;
/// Steps off the edge over up to this many radii inside a run are a gap in the scan (noise
/// growing at grazing incidence, a face's labels thinning out), not its end.
const MAX_GAP: f64 = 1.0;
/// An end within this many radii of a plane corner on both faces ends at the corner.
const SNAP: f64 = 2.0;
/// A stretch within this many spacings of an edge between plane corners of the same pair is
/// that edge.
const SAME_EDGE: f64 = 1.5;
/// Each face of an edge whose faces turn by φ (radians) reaches at least this many noise
/// sigmas over φ away from it. A smooth surface (a fillet, a cylinder) passes for planar
/// strips of width w while its sag w²/(8R) keeps their RMS within the faces stage's 1.5
/// sigmas (the RMS of a parabolic sag about its plane is 0.3 of the sag): w ≤ √(40Rσ); and
/// neighbouring strips turn by φ ≈ w/R, so w ≤ 40σ/φ. Seen: 157° "edges" between strips of
/// a random part's 37-spacing fillet in a structured-light view (noise along the ray, so
/// less across an oblique face), 80–100 spacings from any edge of the part. A part's 160°
/// edge at σ = 0.2 spacing needs faces 23 spacings wide.
const STRIP_SIGMAS: f64 = 40.0;

/// Narrow faces flat across (`flat_across`) overrule the strip rule only where they turn by
/// this many degrees or more: the facets of a curved patch are flat too, and a CAD mesh
/// scanned as it is has facet creases up to 32° that are no sharp edge of its part (the
/// anchor of `bench --cad`: four such creases reported, 25–32°, 8–26 spacings from any sharp
/// edge, while its narrow faces' real edges turn by 53–91°). A hole of up to six sides turns
/// by 60° at a vertex on average.
const NARROW_MIN_TURN: f64 = 45.0;

/// The edges where two planar faces meet along a stretch the scan follows, beyond those
/// between plane corners (`existing`); see the module comment.
#[allow(clippy::too_many_arguments)]
pub fn pair_edges(
    positions: &[[f64; 3]],
    grid: &Grid,
    features: &Features,
    scale: &LocalScale,
    faces: &Faces,
    corners: &[FaceCorner],
    existing: &[FaceEdge],
    edges: &EdgeParams,
) -> Vec<FaceEdge> {
    if faces.planes.len() < 2 {
        return Vec::new();
    }
    let candidates = voters(features);
    let sparsest = faces.planes.iter().map(|p| p.spacing).fold(0.0, f64::max);
    // (face pair, candidate) for every candidate that sees two faces or more.
    let mut votes: Vec<PairVote> = candidates
        .par_iter()
        .fold(
            || (Vec::new(), Vec::new()),
            |(mut out, mut seen): (Vec<PairVote>, Vec<(u32, usize)>), &c| {
                faces_seen(positions, grid, faces, scale, c, &mut seen);
                if seen.len() == 1 {
                    sparse_faces_seen(positions, grid, faces, scale, c, sparsest, &mut seen);
                }
                for (a, x) in seen.iter().enumerate() {
                    for y in &seen[a + 1..] {
                        out.push(([x.0, y.0], c));
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
    let groups: Vec<&[PairVote]> = votes
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|g| g.len() >= MIN_SUPPORT)
        .collect();
    let found: Vec<Vec<FaceEdge>> = groups
        .par_iter()
        .map(|group| {
            let voters: Vec<u32> = group.iter().map(|v| v.1).collect();
            pair_stretches(
                positions,
                grid,
                &features.candidate,
                scale,
                faces,
                corners,
                existing,
                edges,
                group[0].0,
                &voters,
            )
        })
        .collect();
    let out: Vec<FaceEdge> = found.into_iter().flatten().collect();
    tracing::debug!(
        "pair edges: {} face pairs named by {} candidates, {} edges",
        groups.len(),
        candidates.len(),
        out.len()
    );
    out
}

/// A face is sparse beside an edge candidate when its points' median spacing is at least
/// this many times the candidate's: a face a structured-light grid or a view sees at a
/// grazing angle beside one it sees square on. Its reaches widen by that ratio, up to
/// `SPARSE_CAP`.
const SPARSE_RATIO: f64 = 2.0;
const SPARSE_CAP: f64 = 6.0;

/// How much a pair edge's reaches widen for `plane` where the scan's spacing is `spacing`
/// (see [`SPARSE_RATIO`]): 1 for a face sampled about as densely.
fn widening(plane: &Plane, spacing: f64) -> f64 {
    let ratio = plane.spacing / spacing;
    if ratio >= SPARSE_RATIO {
        ratio.min(SPARSE_CAP)
    } else {
        1.0
    }
}

/// The sparse faces (see [`SPARSE_RATIO`]) edge candidate `c`, which sees one face, sees
/// within their widened reach, added to `seen` (ascending by face); `sparsest` is the
/// largest spacing of a face. Why: where a view sees one face square on and the other at a
/// grazing angle (seed 1's r048 of `bench --random 100`: 0.78 and 0.03 points per square
/// spacing), the sparse face's own sampling cells begin 15 spacings from the edge, so it
/// grows a face only there, beyond the dense side's reach of a few spacings, and no pair
/// of faces was named along a 175-spacing edge.
fn sparse_faces_seen(
    positions: &[[f64; 3]],
    grid: &Grid,
    faces: &Faces,
    scale: &LocalScale,
    c: u32,
    sparsest: f64,
    seen: &mut Vec<(u32, usize)>,
) {
    let local = scale.at(c as usize);
    let widest = (sparsest / local.spacing).min(SPARSE_CAP);
    if widest < SPARSE_RATIO {
        return;
    }
    let base = SEE_REACH * local.radius;
    let first = seen.len();
    grid.for_each_within(positions[c as usize], base * widest, |j, _, d2| {
        let l = faces.label[j as usize];
        if l == NO_FACE || seen[..first].iter().any(|s| s.0 == l) {
            return;
        }
        let widen = widening(&faces.planes[l as usize], local.spacing);
        if widen > 1.0 && d2 <= (base * widen).powi(2) {
            tally(seen, first, l);
        }
    });
    keep_seen(seen, first);
    seen.sort_unstable_by_key(|s| s.0);
}

/// Open ends of two edges within this many radii of their three faces' common point end
/// there.
const MEET: f64 = 3.0;

/// Corners where pair edges meet: two edges sharing one face, with open ends (no plane
/// corner) near each other, end at the common point of their three faces when that point
/// lies within `MEET` radii of both ends, no farther back along either edge than that, an
/// edge of the third pair of faces reaches within `MEET` radii of it, and no plane corner
/// of those faces is there already. The new corners are appended to
/// `corners` and the ends take them. Why: the plane corners are voted for by edge
/// candidates that see three faces at once, and a structured-light grid or scan lines may
/// leave no candidate there (the corner's rounding falls between the lines) while the
/// edges that meet there run for dozens of spacings on both faces' points.
pub fn meeting_corners(faces: &Faces, corners: &mut Vec<FaceCorner>, edges: &mut [FaceEdge]) {
    // (edge, end) of every open end.
    let open: Vec<(usize, usize)> = edges
        .iter()
        .enumerate()
        .flat_map(|(i, e)| {
            (0..2)
                .filter(move |&k| e.corners[k].is_none())
                .map(move |k| (i, k))
        })
        .collect();
    let end_of = |e: &FaceEdge, k: usize| if k == 0 { e.start } else { e.end };
    let mut added = 0usize;
    for (a, &(i, ki)) in open.iter().enumerate() {
        for &(j, kj) in &open[a + 1..] {
            // An end that took a corner already still names it to the other end (the third
            // edge of a corner pairs with one of the first two).
            if i == j {
                continue;
            }
            let (ei, ej) = (&edges[i], &edges[j]);
            let shared: Vec<u32> = ei
                .faces
                .iter()
                .copied()
                .filter(|f| ej.faces.contains(f))
                .collect();
            if shared.len() != 1 {
                continue;
            }
            let mut triple: Vec<u32> = ei.faces.iter().chain(&ej.faces).copied().collect();
            triple.sort_unstable();
            triple.dedup();
            let reach = MEET * ei.scale.radius.max(ej.scale.radius);
            let (pi, pj) = (end_of(ei, ki), end_of(ej, kj));
            if norm(sub(pi, pj)) > 2.0 * reach {
                continue;
            }
            // Three faces that turn against each other pairwise: a pair nearly parallel fixes
            // no point.
            let planes: Vec<_> = triple.iter().map(|&f| faces.planes[f as usize]).collect();
            let turn_ok = (0..3).all(|x| {
                (x + 1..3).all(|y| {
                    dot(planes[x].normal, planes[y].normal).abs()
                        < MIN_FACE_ANGLE.to_radians().cos()
                })
            });
            if !turn_ok {
                continue;
            }
            let Some(x) = intersect(&planes) else {
                continue;
            };
            // Near both ends, and not back along either edge past its reach.
            let fits = [(ei, ki), (ej, kj)].iter().all(|&(e, k)| {
                let (p, q) = (end_of(e, k), end_of(e, 1 - k));
                let along = sub(p, q);
                let len = norm(along);
                norm(sub(x, p)) <= reach
                    && len > 0.0
                    && dot(sub(x, p), along) / len >= -reach.min(0.5 * len)
            });
            // The third pair of faces meets there too: an edge of theirs reaches the point.
            // Two strips of a fillet meeting a cap face each along an edge cross the cap's
            // plane at no corner of the part.
            let third: Vec<u32> = triple.iter().copied().filter(|f| *f != shared[0]).collect();
            let closed = edges
                .iter()
                .any(|e| e.faces[..] == third[..] && point_segment(x, e.start, e.end).0 <= reach);
            if !fits || !closed {
                continue;
            }
            let taken = corners.iter().position(|c| {
                triple.iter().all(|f| c.faces.contains(f)) && norm(sub(c.position, x)) <= reach
            });
            if taken.is_none() {
                tracing::trace!(
                    "pair edges {:?} and {:?} meet at {x:?} (ends {pi:?}, {pj:?})",
                    ei.faces,
                    ej.faces
                );
            }
            let id = taken.unwrap_or_else(|| {
                corners.push(FaceCorner {
                    position: x,
                    faces: triple.clone(),
                    support: ei.points + ej.points,
                    scale: if ei.scale.radius <= ej.scale.radius {
                        ei.scale
                    } else {
                        ej.scale
                    },
                });
                added += 1;
                corners.len() - 1
            });
            let at = corners[id].position;
            for (e, k) in [(i, ki), (j, kj)] {
                if edges[e].corners[k].is_some() {
                    continue;
                }
                edges[e].corners[k] = Some(id);
                if k == 0 {
                    edges[e].start = at;
                } else {
                    edges[e].end = at;
                }
            }
        }
    }
    tracing::debug!("pair edges: {added} corners where two of them meet");
}

/// The edges of one face pair (see [`pair_edges`]).
#[allow(clippy::too_many_arguments)]
fn pair_stretches(
    positions: &[[f64; 3]],
    grid: &Grid,
    candidate: &[bool],
    scale: &LocalScale,
    faces: &Faces,
    corners: &[FaceCorner],
    existing: &[FaceEdge],
    edges: &EdgeParams,
    pair: [u32; 2],
    voters: &[u32],
) -> Vec<FaceEdge> {
    let (pa, pb) = (
        faces.planes[pair[0] as usize],
        faces.planes[pair[1] as usize],
    );
    let cos_ab = dot(pa.normal, pb.normal);
    if cos_ab.abs() >= MIN_FACE_ANGLE.to_radians().cos() {
        return Vec::new();
    }
    let Some(local) = scale.around(voters.iter().copied()) else {
        return Vec::new();
    };
    let (r, step) = (local.radius, local.spacing);
    if !(r > 0.0 && step > 0.0) {
        return Vec::new();
    }
    let d = cross(pa.normal, pb.normal);
    let d = d.map(|x| x / norm(d));
    // The point of the line nearest the voters' centroid: c + α na + β nb on both planes.
    let n = voters.len() as f64;
    let c = voters.iter().fold([0.0; 3], |acc, &v| {
        add(acc, scale_by(positions[v as usize], 1.0 / n))
    });
    let (da, db) = (pa.distance(c), pb.distance(c));
    let det = 1.0 - cos_ab * cos_ab;
    let alpha = (-da + cos_ab * db) / det;
    let beta = (-db + cos_ab * da) / det;
    let origin = add(
        c,
        add(scale_by(pa.normal, alpha), scale_by(pb.normal, beta)),
    );
    // The stretch the voters near the line cover.
    let on_line: Vec<f64> = voters
        .iter()
        .filter_map(|&v| {
            let w = sub(positions[v as usize], origin);
            let t = dot(w, d);
            (norm(sub(w, scale_by(d, t))) <= ON_LINE * r).then_some(t)
        })
        .collect();
    if on_line.len() < MIN_SUPPORT {
        return Vec::new();
    }
    let lo = on_line.iter().copied().fold(f64::INFINITY, f64::min) - r;
    let hi = on_line.iter().copied().fold(f64::NEG_INFINITY, f64::max) + r;
    let nsteps = ((hi - lo) / step).ceil() as usize + 1;
    // A pair of faces the whole cloud apart with a handful of voters each end: no edge walks
    // a million steps.
    if nsteps > 1_000_000 {
        return Vec::new();
    }
    // The interior angle between the faces, from the directions towards their points at the
    // stretch's middle.
    let mid = axpy(origin, 0.5 * (lo + hi), d);
    let Some(tr) = traces(positions, grid, faces, pair, d, mid, (hi - lo).max(4.0 * r)) else {
        return Vec::new();
    };
    let gap = hug_gap(fillet_limit(edges, &local), dot(tr[0], tr[1]), &local);
    // Stretches of edges between plane corners of this pair: walked already.
    let taken: Vec<(f64, f64)> = existing
        .iter()
        .filter(|e| e.faces == pair)
        .filter(|e| {
            [e.start, e.end].iter().all(|&p| {
                let w = sub(p, origin);
                norm(sub(w, scale_by(d, dot(w, d)))) <= SAME_EDGE * step
            })
        })
        .map(|e| {
            let (s, t) = (dot(sub(e.start, origin), d), dot(sub(e.end, origin), d));
            (s.min(t), s.max(t))
        })
        .collect();
    // Each face's reach: the radius, widened for a sparse face (see `SPARSE_RATIO`).
    let widen = [&pa, &pb].map(|p| widening(p, step));
    let reach = widen.map(|w| r * w);
    let on_edge: Vec<bool> = (0..nsteps)
        .map(|k| {
            let t = lo + k as f64 * step;
            if taken.iter().any(|&(a, b)| t >= a && t <= b) {
                return false;
            }
            let q = axpy(origin, t, d);
            let mut near = [false; 2];
            grid.for_each_within(q, FACE_REACH * reach[0].max(reach[1]), |j, w, d2| {
                let l = faces.label[j as usize];
                let Some(k) = pair.iter().position(|&f| f == l) else {
                    return;
                };
                near[k] |= in_window(w, d2, d, reach[k]).is_some();
            });
            near[0] && near[1] && hugs(grid, q, d, [&pa, &pb], gap, step, |_| false)
        })
        .collect();
    let max_gap_steps = (MAX_GAP * r / step).ceil() as usize;
    let mut out = Vec::new();
    let mut k = 0;
    while k < nsteps {
        if !on_edge[k] {
            k += 1;
            continue;
        }
        // A run from k: steps on the edge with gaps of at most `MAX_GAP` radii.
        let (first, mut last, mut j) = (k, k, k + 1);
        while j < nsteps && j <= last + max_gap_steps + 1 {
            if on_edge[j] {
                last = j;
            }
            j += 1;
        }
        k = last + 1;
        let (t0, t1) = (lo + first as f64 * step, lo + last as f64 * step);
        // A step is on the edge when both faces have points within half a reach along it,
        // so the last step lies up to that far past where a face ends (an unseen corner):
        // each end comes back to the last point of the side that ends first.
        let (t0, t1) = (
            face_extent(grid, faces, pair, origin, d, t0, reach, &tr, false).max(t0),
            face_extent(grid, faces, pair, origin, d, t1, reach, &tr, true).min(t1),
        );
        if t1 - t0 < MIN_LENGTH * r {
            continue;
        }
        let ends = [t0, t1].map(|t| {
            let p = axpy(origin, t, d);
            corners
                .iter()
                .enumerate()
                .filter(|(_, fc)| fc.faces.contains(&pair[0]) && fc.faces.contains(&pair[1]))
                .map(|(i, fc)| (norm(sub(fc.position, p)), i))
                .filter(|&(dist, _)| dist <= SNAP * r)
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
                .map_or((p, None), |(_, i)| (corners[i].position, Some(i)))
        });
        let (start, end) = (ends[0].0, ends[1].0);
        if norm(sub(end, start)) < MIN_LENGTH * r {
            continue;
        }
        let Some(traces) = traces(
            positions,
            grid,
            faces,
            pair,
            d,
            scale_by(add(start, end), 0.5),
            4.0 * reach[0].max(reach[1]),
        ) else {
            continue;
        };
        let mid = scale_by(add(start, end), 0.5);
        let turn = std::f64::consts::PI - dot(traces[0], traces[1]).clamp(-1.0, 1.0).acos();
        // Each face by its own noise: the strip whose RMS hides a sag is that face, and the
        // candidates at the line may see a quieter face (a grazing face of a structured-light
        // view is smoother than the one facing the camera).
        let wide = [&pa, &pb].map(|p| STRIP_SIGMAS * p.noise.max(local.noise) / turn.max(1e-3));
        let steps = widen.map(|w| step * w);
        if !reach_beyond(
            grid,
            faces,
            pair,
            mid,
            d,
            wide,
            steps,
            reach.map(|x| 3.0 * x),
        ) {
            let flat = turn.to_degrees() >= NARROW_MIN_TURN
                && flat_across(
                    positions,
                    grid,
                    faces,
                    pair,
                    &traces,
                    [start, end],
                    wide,
                    turn,
                );
            if !flat {
                tracing::trace!(
                    "pair edge {pair:?} at {mid:?}: a face narrower than {:.1} or {:.1} spacings, \
                     a strip of a smooth surface",
                    wide[0] / step,
                    wide[1] / step
                );
                continue;
            }
            tracing::trace!(
                "pair edge {pair:?} at {mid:?}: turn {:.1}°, faces narrower than {:.1} or {:.1} \
                 spacings, flat across: narrow planar faces",
                turn.to_degrees(),
                wide[0] / step,
                wide[1] / step
            );
        }
        let rounding = fillet_limit(edges, &local);
        if let Some(depth) = rounded_crease(
            positions,
            grid,
            pa.noise.max(pb.noise),
            &traces,
            start,
            end,
            &local,
            rounding,
        ) {
            tracing::trace!(
                "pair edge {pair:?} at {mid:?}: the scan stays {depth:.3} inside the planes' \
                 line, a rounding wider than {rounding:.3}: a crease between strips of a \
                 smooth surface"
            );
            continue;
        }
        if let Some(share) = off_crease(positions, grid, [&pa, &pb], &traces, start, end, &local) {
            tracing::trace!(
                "pair edge {pair:?} at {mid:?}: {:.0} % of the points beside it lie on the other \
                 face's plane: the faces meet elsewhere",
                100.0 * share
            );
            continue;
        }
        tracing::trace!(
            "pair edge {pair:?} from {start:?} to {end:?}: turn {:.1}°, faces {:.1} and {:.1} \
             spacings wide or more, noise {:.4}, spacing {:.4}",
            turn.to_degrees(),
            wide[0] / step,
            wide[1] / step,
            local.noise,
            step
        );
        let mut points = 0usize;
        grid.for_each_near_segment(start, end, r, |i| {
            points += usize::from(candidate[i as usize]);
        });
        out.push(FaceEdge {
            corners: [ends[0].1, ends[1].1],
            faces: pair,
            start,
            end,
            points,
            traces,
            scale: local,
        });
    }
    out
}

/// The offset along the line (unit `d`) of a point at `w` from a step (`d2` = |w|²) that
/// lies in the step's window for a face of `reach`: within `ALONG_REACH` reaches along the
/// line and `FACE_REACH` reaches of the step.
fn in_window(w: [f64; 3], d2: f64, d: [f64; 3], reach: f64) -> Option<f64> {
    let along = dot(w, d);
    (along.abs() <= ALONG_REACH * reach && d2 <= (FACE_REACH * reach).powi(2)).then_some(along)
}

/// How far along the line (`origin` + t `d`) the scan reaches on both sides of it from the
/// step at `t`, within the step's window (`FACE_REACH` and `ALONG_REACH` of each face's
/// `reach`): towards `forward` (larger t) the smaller of the sides' last points, backwards
/// the larger of their first. A side is a face of `pair` with the points on no face whose
/// offset leans towards its trace (`traces`): near a corner whose third face the scan sees,
/// the faces' labels stop a band short of it (the candidates of the other edges), the scan
/// does not. `t` itself when a side has no point in the window.
#[allow(clippy::too_many_arguments)]
fn face_extent(
    grid: &Grid,
    faces: &Faces,
    pair: [u32; 2],
    origin: [f64; 3],
    d: [f64; 3],
    t: f64,
    reach: [f64; 2],
    traces: &[[f64; 3]; 2],
    forward: bool,
) -> f64 {
    let q = axpy(origin, t, d);
    let sign = if forward { 1.0 } else { -1.0 };
    let mut far = [f64::NEG_INFINITY; 2];
    grid.for_each_within(q, FACE_REACH * reach[0].max(reach[1]), |j, w, d2| {
        let l = faces.label[j as usize];
        let k = match pair.iter().position(|&f| f == l) {
            Some(k) => k,
            None if l == NO_FACE => usize::from(dot(w, traces[1]) > dot(w, traces[0])),
            None => return,
        };
        if let Some(along) = in_window(w, d2, d, reach[k]) {
            far[k] = far[k].max(sign * along);
        }
    });
    if far.iter().any(|x| !x.is_finite()) {
        return t;
    }
    t + sign * far[0].min(far[1])
}

/// Points within this many spacings (plus the hug gap) of a pair edge show which face they
/// lie on; at most `MISPLACED` of those that tell lie on the other side of the edge.
const CREASE_BAND: f64 = 3.0;
const MISPLACED: f64 = 0.25;
/// A point tells its face when its distances to the two planes differ by this many sigmas.
const TELL_SIGMAS: f64 = 3.0;

/// The share of the points beside the segment `start`–`end` that lie on the wrong face's
/// plane (nearer plane b on face a's side of the line, or the reverse), when more than
/// `MISPLACED` of those that tell; `None` when the crease is where the line is. At obtuse
/// angles a small error in either plane moves their intersection line by spacings (by the
/// error over the sine of the turn), while both planes still pass near the scan there.
fn off_crease(
    positions: &[[f64; 3]],
    grid: &Grid,
    planes: [&crate::stages::faces::Plane; 2],
    traces: &[[f64; 3]; 2],
    start: [f64; 3],
    end: [f64; 3],
    local: &crate::stages::features::Scale,
) -> Option<f64> {
    let band = CREASE_BAND * local.spacing;
    let tell = TELL_SIGMAS * local.noise;
    let (mut told, mut wrong) = (0usize, 0usize);
    grid.for_each_near_segment(start, end, band, |i| {
        let p = positions[i as usize];
        let w = sub(p, start);
        let on_a = dot(w, traces[0]) > dot(w, traces[1]);
        let (da, db) = (planes[0].distance(p).abs(), planes[1].distance(p).abs());
        if (da - db).abs() <= tell {
            return;
        }
        told += 1;
        wrong += usize::from(on_a != (da < db));
    });
    let share = wrong as f64 / told.max(1) as f64;
    (told >= 10 && share > MISPLACED).then_some(share)
}

/// Whether both faces of `pair` are flat across their widths beside the edge from `ends[0]`
/// to `ends[1]` (`traces`: the faces' directions away from it), so that a face narrower than
/// [`STRIP_SIGMAS`] asks is a narrow planar face (a small hole's wall, a narrow step), not a
/// strip of a smooth surface. Strips of a surface of radius R, each w wide, turn by about
/// w/R to each other and sag across as u²/(2R): a parabola fitted across each face's points
/// (`geometry::parabola_curvature`) finds the coefficient 1/(2R) = `turn / (2(x̄₀ + x̄₁))`
/// there (x̄: how far each face's points lie from the line on average), where a planar face
/// gives zero within its standard error. Hundreds of points tell the two apart
/// where their RMS cannot: a 6-sided hole's wall 4.8 spacings wide at σ = 0.12 spacing fails
/// the strip width (40σ/φ = 5.3 spacings at its 53° turn) while its curvature is 0 ± 0.004
/// per spacing against the 0.1 a strip would show (seed 2's r012 of `bench --random 100`:
/// three of the hole's six edges missed).
///
/// A face is flat when its coefficient lies within half the strips' and the strips' is at
/// least four standard errors (a handful of points cannot tell, and then the strip rule
/// stands).
#[allow(clippy::too_many_arguments)]
fn flat_across(
    positions: &[[f64; 3]],
    grid: &Grid,
    faces: &Faces,
    pair: [u32; 2],
    traces: &[[f64; 3]; 2],
    ends: [[f64; 3]; 2],
    wide: [f64; 2],
    turn: f64,
) -> bool {
    let len = norm(sub(ends[1], ends[0]));
    if len.is_nan() || len <= 0.0 || turn.is_nan() || turn <= 0.0 {
        return false;
    }
    let u = scale_by(sub(ends[1], ends[0]), 1.0 / len);
    let reach = wide[0].max(wide[1]);
    let mut samples: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    grid.for_each_near_segment(ends[0], ends[1], reach, |j| {
        let Some(k) = pair.iter().position(|&f| f == faces.label[j as usize]) else {
            return;
        };
        let p = positions[j as usize];
        let w = sub(p, ends[0]);
        let along = dot(w, u);
        let across = dot(w, traces[k]);
        if (0.0..=len).contains(&along) && (0.0..=reach).contains(&across) {
            samples[k].push((across, faces.planes[pair[k] as usize].distance(p)));
        }
    });
    // Strips of a surface of radius R whose centres lie x̄₀ and x̄₁ from their crease (along
    // them) turn by (x̄₀ + x̄₁)/R: a band of candidates between them widens both.
    let mean = |s: &[(f64, f64)]| s.iter().map(|x| x.0).sum::<f64>() / s.len().max(1) as f64;
    let centres = mean(&samples[0]) + mean(&samples[1]);
    if centres.is_nan() || centres <= 0.0 {
        return false;
    }
    let strip = 0.5 * turn / centres;
    samples.iter().all(|s| {
        parabola_curvature(s).is_some_and(|(c, se)| c.abs() < 0.5 * strip && 4.0 * se < strip)
    })
}

/// Whether each face `pair[k]` has points at least `wide[k]` from the line through `mid`
/// along unit `d`, within `step[k]` of `mid` along it, looking at least `band[k]` out (the
/// edge candidates' band, which no face labels; a sparse face's widened).
#[allow(clippy::too_many_arguments)]
fn reach_beyond(
    grid: &Grid,
    faces: &Faces,
    pair: [u32; 2],
    mid: [f64; 3],
    d: [f64; 3],
    wide: [f64; 2],
    step: [f64; 2],
    band: [f64; 2],
) -> bool {
    let mut far = [false; 2];
    let out = (0..2)
        .map(|k| wide[k].max(band[k]) + step[k])
        .fold(0.0, f64::max);
    grid.for_each_within(mid, out, |j, w, _| {
        let l = faces.label[j as usize];
        let Some(k) = pair.iter().position(|&f| f == l) else {
            return;
        };
        let along = dot(w, d);
        far[k] |= along.abs() <= step[k] && norm(sub(w, scale_by(d, along))) >= wide[k];
    });
    far[0] && far[1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::features::Scale;

    /// Two half-planes meeting along the y axis at the interior angle `angle_deg`, each
    /// scanned in lines parallel to the edge `gap` apart (the first `offset` from the edge),
    /// points every `pitch` along them for y in [0, length]; between them, a circular fillet
    /// of `fillet` radius (0: none) or a chamfer cutting `chamfer` off each face (0: none),
    /// sampled likewise. Points within `band` of the edge line are edge candidates; the rest
    /// are labelled with their face (0, 1; 2 for the chamfer).
    struct Wedge {
        positions: Vec<[f64; 3]>,
        faces: Faces,
        features: Features,
        scale: LocalScale,
    }

    fn wedge(angle_deg: f64, fillet: f64, chamfer: f64) -> Wedge {
        let (gap, pitch, length, width, band) = (3.0, 0.25, 60.0, 30.0, 2.0);
        let half = 0.5 * angle_deg.to_radians();
        // Unit directions in the xz-plane away from the edge along each face.
        let dirs = [
            [half.cos(), 0.0, half.sin()],
            [half.cos(), 0.0, -half.sin()],
        ];
        // Where the faces start: the tangent points of a fillet, the cut of a chamfer.
        let start = if fillet > 0.0 {
            fillet / half.tan()
        } else {
            chamfer
        };
        let mut positions = Vec::new();
        let mut label = Vec::new();
        let mut line = |p0: [f64; 3], l: u32, positions: &mut Vec<[f64; 3]>| {
            let n = (length / pitch) as usize;
            for k in 0..=n {
                positions.push([p0[0], k as f64 * pitch, p0[2]]);
                label.push(l);
            }
        };
        for (f, d) in dirs.iter().enumerate() {
            let mut s = start + 0.4 * gap;
            while s < width {
                line(d.map(|x| x * s), f as u32, &mut positions);
                s += gap;
            }
        }
        if fillet > 0.0 {
            // The arc's centre lies on the bisector, `fillet / sin(half)` from the edge.
            let c = fillet / half.sin();
            let turn = std::f64::consts::PI - 2.0 * half;
            let steps = ((fillet * turn) / gap).ceil().max(2.0) as usize;
            for k in 0..=steps {
                let a = std::f64::consts::PI + (k as f64 / steps as f64 - 0.5) * turn;
                line(
                    [c + fillet * a.cos(), 0.0, fillet * a.sin()],
                    NO_FACE,
                    &mut positions,
                );
            }
        } else if chamfer > 0.0 {
            let (a, b) = (dirs[0].map(|x| x * chamfer), dirs[1].map(|x| x * chamfer));
            let w = norm(sub(a, b));
            let steps = (w / gap).ceil().max(2.0) as usize;
            for k in 0..=steps {
                let t = k as f64 / steps as f64;
                line(axpy(a, t, sub(b, a)), 2, &mut positions);
            }
        }
        let near_edge = |p: &[f64; 3]| (p[0] * p[0] + p[2] * p[2]).sqrt() < start + band;
        let candidate: Vec<bool> = positions.iter().map(near_edge).collect();
        let label: Vec<u32> = label
            .iter()
            .zip(&candidate)
            .map(|(&l, &c)| if c { NO_FACE } else { l })
            .collect();
        let plane = |normal: [f64; 3], on: [f64; 3]| test_plane(normal, on, gap);
        let mut planes = vec![
            plane([-half.sin(), 0.0, half.cos()], dirs[0].map(|x| x * 10.0)),
            plane([half.sin(), 0.0, half.cos()], dirs[1].map(|x| x * 10.0)),
        ];
        if chamfer > 0.0 {
            planes.push(plane([1.0, 0.0, 0.0], [half.cos() * chamfer, 0.0, 0.0]));
        }
        let scale = Scale {
            spacing: gap,
            pitch,
            noise: 0.01,
            radius: 4.0 * gap,
        };
        Wedge::new(positions, label, candidate, planes, scale)
    }

    /// A plane of a thousand points at noise 0.01 whose spacing and pitch are `spacing`.
    fn test_plane(normal: [f64; 3], on: [f64; 3], spacing: f64) -> Plane {
        Plane {
            normal,
            centroid: on,
            points: 1000,
            rms: 0.0,
            spacing,
            pitch: spacing,
            noise: 0.01,
        }
    }

    impl Wedge {
        /// The wedge of `positions` with their face labels and candidate flags, no outliers,
        /// the `planes` and one `scale` for every point.
        fn new(
            positions: Vec<[f64; 3]>,
            label: Vec<u32>,
            candidate: Vec<bool>,
            planes: Vec<Plane>,
            scale: Scale,
        ) -> Wedge {
            let n = positions.len();
            Wedge {
                features: Features {
                    candidate,
                    outlier: vec![false; n],
                    ..Features::default()
                },
                scale: LocalScale::uniform(n, scale),
                faces: Faces { label, planes },
                positions,
            }
        }
    }

    /// A 90° edge along the y axis (y in [0, 60]) between a face seen square on (points
    /// every 1 across and along, out to 30; within 2 of the edge, edge candidates) and one
    /// seen at a grazing angle (every 6, out to 60), whose points within 15 of the edge are
    /// on no face (their sampling cells read the dense side's scale); `sparse_spacing` is the
    /// second face's spacing as its plane records it.
    fn grazing_wedge(sparse_spacing: f64) -> Wedge {
        let dirs = right_dirs();
        let (mut positions, mut label, mut candidate) = (Vec::new(), Vec::new(), Vec::new());
        for (f, (step, width, unlabelled)) in [(1.0, 30.0, 2.0), (6.0, 60.0, 15.0)]
            .into_iter()
            .enumerate()
        {
            let mut x = 0.5 * step;
            while x < width {
                let mut y = 0.0;
                while y <= 60.0 {
                    positions.push(axpy([0.0, y, 0.0], x, dirs[f]));
                    label.push(if x < unlabelled { NO_FACE } else { f as u32 });
                    candidate.push(f == 0 && x < unlabelled);
                    y += step;
                }
                x += step;
            }
        }
        right_wedge(
            positions,
            label,
            candidate,
            [10.0, 30.0],
            [1.0, sparse_spacing],
        )
    }

    /// Unit directions in the xz-plane away from a 90° edge along the y axis, along each face.
    fn right_dirs() -> [[f64; 3]; 2] {
        let half = std::f64::consts::FRAC_PI_4;
        [
            [half.cos(), 0.0, half.sin()],
            [half.cos(), 0.0, -half.sin()],
        ]
    }

    /// The wedge of `positions` on the faces of [`right_dirs`]: face k's plane through the
    /// point `at[k]` along its direction, with spacing `spacing[k]`; spacing 1 and radius 4
    /// for every point.
    fn right_wedge(
        positions: Vec<[f64; 3]>,
        label: Vec<u32>,
        candidate: Vec<bool>,
        at: [f64; 2],
        spacing: [f64; 2],
    ) -> Wedge {
        let half = std::f64::consts::FRAC_PI_4;
        let dirs = right_dirs();
        let planes = vec![
            test_plane(
                [-half.sin(), 0.0, half.cos()],
                dirs[0].map(|x| x * at[0]),
                spacing[0],
            ),
            test_plane(
                [half.sin(), 0.0, half.cos()],
                dirs[1].map(|x| x * at[1]),
                spacing[1],
            ),
        ];
        let scale = Scale {
            spacing: 1.0,
            pitch: 1.0,
            noise: 0.01,
            radius: 4.0,
        };
        Wedge::new(positions, label, candidate, planes, scale)
    }

    #[test]
    fn issue17_a_face_seen_at_a_grazing_angle_meets_the_one_seen_square_on() {
        // Seed 1's r048 of `bench --random 100`: the grazing face grew a face only 15 h from
        // the edge, beyond the dense side's reach, and no edge was found along 175 h.
        let w = grazing_wedge(6.0);
        let found = edges_of(&w);
        assert_eq!(found.len(), 1, "{found:?}");
        let e = &found[0];
        assert_eq!(e.faces, [0, 1]);
        assert!(norm(sub(e.end, e.start)) > 50.0, "{e:?}");
        for p in [e.start, e.end] {
            assert!(off_axis(p) < 1e-6, "{p:?} off the edge line");
        }
        // A face that sparse only by its spacing's reading stays at the dense side's reach.
        let w = grazing_wedge(1.5);
        assert!(edges_of(&w).is_empty());
    }

    fn edges_of(w: &Wedge) -> Vec<FaceEdge> {
        let grid = Grid::new(&w.positions, 12.0).unwrap();
        pair_edges(
            &w.positions,
            &grid,
            &w.features,
            &w.scale,
            &w.faces,
            &[],
            &[],
            &EdgeParams::default(),
        )
    }

    #[test]
    fn issue17_an_edge_at_an_unseen_corner_ends_where_its_faces_do() {
        // Seed 2's r086 and r095 of `bench --random 100`: where a one-view scan does not see
        // a corner's third face, edges ran 2.1–3.6 h past the corner, along the scan border.
        // A 90° edge along the y axis; both faces sampled every 1, out to 20 from the edge,
        // face 1 up to y = 40, face 0 up to y = 40 + x (its angle at the corner is 135°, so
        // it reaches past the corner away from the edge); within 2 of the edge, candidates
        // on no face.
        let dirs = right_dirs();
        let (mut positions, mut label, mut candidate) = (Vec::new(), Vec::new(), Vec::new());
        for (f, dir) in dirs.iter().enumerate() {
            let mut x = 0.5;
            while x < 20.0 {
                let end = if f == 0 { 40.0 + x } else { 40.0 };
                let mut y = 0.0;
                while y <= end {
                    positions.push(axpy([0.0, y, 0.0], x, *dir));
                    label.push(if x < 2.0 { NO_FACE } else { f as u32 });
                    candidate.push(x < 2.0);
                    y += 1.0;
                }
                x += 1.0;
            }
        }
        let w = right_wedge(positions, label, candidate, [10.0, 10.0], [1.0, 1.0]);
        let found = edges_of(&w);
        assert_eq!(found.len(), 1, "{found:?}");
        let e = &found[0];
        let (y0, y1) = (e.start[1].min(e.end[1]), e.start[1].max(e.end[1]));
        // The faces' last points are 1 apart: the edge ends within a spacing of y = 40, not
        // half a reach (2) past the last step with both faces in its window.
        assert!((39.0..=40.5).contains(&y1), "ends at y = {y1}: {e:?}");
        assert!(y0 <= 2.5, "starts at y = {y0}: {e:?}");
    }

    /// Distance of `p` from the y axis (the wedge's edge line).
    fn off_axis(p: [f64; 3]) -> f64 {
        (p[0] * p[0] + p[2] * p[2]).sqrt()
    }

    /// Two faces 4.8 wide meeting along the y axis at `turn_deg`, sampled every 0.2 across
    /// (from 0.4 off the line) and 0.25 along y in [0, 20], each point off its face by a
    /// deterministic ±`sigma`; `sag(x)` bends each face along its normal at x across it.
    /// Returns `flat_across` on the stretch y in [2, 18].
    fn strips_flat(turn_deg: f64, sigma: f64, sag: impl Fn(f64) -> f64) -> bool {
        let half = 0.5 * (180.0 - turn_deg).to_radians();
        let dirs = [
            [half.cos(), 0.0, half.sin()],
            [half.cos(), 0.0, -half.sin()],
        ];
        // Normals pointing away from the material below the xy-plane's bisector.
        let normals = [
            [-half.sin(), 0.0, half.cos()],
            [-half.sin(), 0.0, -half.cos()],
        ];
        let mut positions = Vec::new();
        let mut label = Vec::new();
        let mut k = 0usize;
        for f in 0..2 {
            for i in 0..23 {
                let x = 0.4 + 0.2 * i as f64;
                for j in 0..=80 {
                    k += 1;
                    let noise = if (k * 7919) % 13 < 6 { sigma } else { -sigma };
                    let off = noise + sag(x);
                    let p = axpy(
                        axpy([0.0, 0.25 * j as f64, 0.0], x, dirs[f]),
                        off,
                        normals[f],
                    );
                    positions.push(p);
                    label.push(f as u32);
                }
            }
        }
        let plane = |f: usize| Plane {
            normal: normals[f],
            centroid: scale_by(dirs[f], 2.6),
            points: 23 * 81,
            rms: sigma,
            spacing: 0.2,
            pitch: 0.2,
            noise: sigma,
        };
        let faces = Faces {
            label,
            planes: vec![plane(0), plane(1)],
        };
        let grid = Grid::new(&positions, 1.0).unwrap();
        flat_across(
            &positions,
            &grid,
            &faces,
            [0, 1],
            &dirs,
            [[0.0, 2.0, 0.0], [0.0, 18.0, 0.0]],
            [10.0, 10.0],
            turn_deg.to_radians(),
        )
    }

    #[test]
    fn issue17_a_narrow_planar_face_is_flat_across_and_a_strip_of_an_arc_is_not() {
        // Seed 2's r012: a hexagonal hole's walls 4.8 spacings wide, turning by 53° at
        // σ = 0.12 spacing, narrower than the strip rule's 40σ/φ = 5.2: planar all the same.
        assert!(strips_flat(53.0, 0.12, |_| 0.0));
        // Rounded ends (the hole's own edges bend the outer 0.6 of each face by up to 0.1)
        // do not make it a strip.
        let rounded = |x: f64| {
            let s = (x - 0.4).min(4.8 - x).max(0.0);
            if s < 0.6 {
                (0.6 - s).powi(2) / 3.6
            } else {
                0.0
            }
        };
        assert!(strips_flat(53.0, 0.12, rounded));
        // Strips of an arc: centres 2.6 from the crease turn by 53° when R = 5.2 / φ; each
        // sags by (x − 2.6)²/(2R) about its chord.
        let r = 5.2 / 53f64.to_radians();
        assert!(!strips_flat(53.0, 0.12, |x| -(x - 2.6).powi(2) / (2.0 * r)));
        assert!(!strips_flat(53.0, 0.12, |x| (x - 2.6).powi(2) / (2.0 * r)));
        // Too much noise to tell: the strip rule stands.
        assert!(!strips_flat(53.0, 1.5, |_| 0.0));
    }

    #[test]
    fn faces_scanned_in_lines_along_their_edge_meet_on_one_edge() {
        // Scan lines 3 apart run along the edge, the nearest 1.2 from it on each face: no
        // point comes near the edge line, and a slab across it sees every line as one point.
        for angle in [90.0, 150.0, 160.0] {
            let w = wedge(angle, 0.0, 0.0);
            let found = edges_of(&w);
            assert_eq!(found.len(), 1, "{angle}°: {found:?}");
            let e = &found[0];
            assert_eq!(e.faces, [0, 1]);
            assert_eq!(e.corners, [None, None]);
            assert!(off_axis(e.start) < 1e-9 && off_axis(e.end) < 1e-9, "{e:?}");
            let (y0, y1) = (e.start[1].min(e.end[1]), e.start[1].max(e.end[1]));
            assert!(
                y0 < 1.0 && y1 > 59.0,
                "{angle}°: covers {y0}..{y1} of 0..60"
            );
            // The faces' directions away from the edge, at the angle between them.
            let cos = dot(e.traces[0], e.traces[1]);
            assert!((cos.acos().to_degrees() - angle).abs() < 1e-6, "{cos}");
        }
    }

    #[test]
    fn a_fillet_or_a_chamfer_between_two_faces_is_no_edge_of_theirs() {
        // A fillet of radius 20 (the scan keeps 8.3 off the line at 90°).
        let found = edges_of(&wedge(90.0, 20.0, 0.0));
        assert!(found.is_empty(), "{found:?}");
        // A chamfer cutting 10 off each face: its own two edges, not the two faces' line.
        let found = edges_of(&wedge(90.0, 0.0, 10.0));
        assert!(found.iter().all(|e| e.faces != [0, 1]), "{found:?}");
        assert!(found.iter().all(|e| off_axis(e.start) > 9.0), "{found:?}");
    }

    #[test]
    fn issue17_faces_that_end_radii_short_of_their_line_across_it_still_meet() {
        // box.ply's 50 mm edge: the sensor rounds a real box edge over 4–9 mm, so the points
        // there are edge candidates and the faces' labels end 1.7 radii (20, radius 12)
        // from the line; the scan still hugs it, and the faces turn by 90°.
        let mut w = wedge(90.0, 0.0, 0.0);
        for (i, p) in w.positions.iter().enumerate() {
            if off_axis(*p) < 20.0 {
                w.faces.label[i] = NO_FACE;
                w.features.candidate[i] = true;
            }
        }
        let found = edges_of(&w);
        assert_eq!(found.len(), 1, "{found:?}");
        let e = &found[0];
        let (y0, y1) = (e.start[1].min(e.end[1]), e.start[1].max(e.end[1]));
        assert!(y0 < 1.0 && y1 > 59.0, "covers {y0}..{y1} of 0..60");
    }

    #[test]
    fn issue17_an_edge_ends_within_half_a_radius_of_where_a_face_ends_along_it() {
        // Face 1 (and its candidates) ends at y = 45; face 0 goes on to 60. Both faces reach
        // 2.5 radii across the line, but along it the edge may not outrun a face: the cap of
        // a filleted block goes on past the end of its straight edge with the top face, and
        // a ball of 2.5 radii let that edge run on 2.2 spacings off the true, curving edge
        // (tests/curved_edges.rs, `a_wide_fillet_is_no_sharp_edge_and_its_points_stay`).
        let mut w = wedge(90.0, 0.0, 0.0);
        // Face 1 runs along (cos 45°, 0, −sin 45°): below the xy-plane.
        let on_face_1 = |p: &[f64; 3]| p[2] < 0.0;
        let keep: Vec<bool> = w
            .positions
            .iter()
            .map(|p| !(on_face_1(p) && p[1] > 45.0))
            .collect();
        fn pick<T>(v: &mut Vec<T>, keep: &[bool]) {
            let mut k = keep.iter();
            v.retain(|_| *k.next().unwrap());
        }
        pick(&mut w.positions, &keep);
        pick(&mut w.faces.label, &keep);
        pick(&mut w.features.candidate, &keep);
        pick(&mut w.features.outlier, &keep);
        w.scale = LocalScale::uniform(w.positions.len(), w.scale.around(0..1).unwrap());
        let found = edges_of(&w);
        assert_eq!(found.len(), 1, "{found:?}");
        let e = &found[0];
        let (y0, y1) = (e.start[1].min(e.end[1]), e.start[1].max(e.end[1]));
        let (r, step) = (12.0, 3.0);
        assert!(y0 < 1.0, "starts at {y0}");
        // (Face 1 ended at 30 until stop 48: once its ends came back to the faces' points,
        // that edge was 2.5 radii long, shorter than `MIN_LENGTH`.)
        assert!(
            y1 > 45.0 - step && y1 <= 45.0 + 0.5 * r + step,
            "ends at {y1}, face 1 at 45"
        );
    }

    /// Points of the profile `curve(s)` (in the xz-plane) for s in [-w, w], every `step`,
    /// extruded along y over [0, 20].
    fn extrude(curve: impl Fn(f64) -> [f64; 2], w: f64, step: f64) -> Vec<[f64; 3]> {
        let n = (2.0 * w / step) as usize;
        let mut out = Vec::new();
        for i in 0..=n {
            let [x, z] = curve(-w + i as f64 * step);
            for k in 0..=(20.0 / step) as usize {
                out.push([x, k as f64 * step, z]);
            }
        }
        out
    }

    /// The crease test on the y axis for faces along ±x that bend down by half of
    /// `turn_deg` each (a convex edge, its material below), their planes through the axis,
    /// at noise 0.01.
    fn crease(positions: &[[f64; 3]], turn_deg: f64, rounding: f64) -> Option<f64> {
        let h = 0.5 * turn_deg.to_radians();
        let traces = [[h.cos(), 0.0, -h.sin()], [-h.cos(), 0.0, -h.sin()]];
        let grid = Grid::new(positions, 1.0).unwrap();
        let local = Scale {
            spacing: 0.2,
            pitch: 0.2,
            noise: 0.01,
            radius: 0.8,
        };
        rounded_crease(
            positions,
            &grid,
            0.01,
            &traces,
            [0.0, 2.0, 0.0],
            [0.0, 18.0, 0.0],
            &local,
            rounding,
        )
    }

    #[test]
    fn a_crease_between_strips_of_a_wide_arc_is_rounder_than_a_sharp_edge() {
        // Issue 17 (r014 of `--random 100 --seed 1`): two strips of a fillet of radius R
        // meet at a 23° crease; the arc stays about R(1/cos(φ/2) − 1) = 0.16 inside the
        // planes' line at R = 7.4 (chord planes through the crease's tangent line here).
        let (r, phi) = (7.4f64, 23.0f64.to_radians());
        let arc = |s: f64| {
            let a = s / r;
            [r * a.sin(), r * a.cos() - r / (0.5 * phi).cos()]
        };
        // The planes' line is at z = 0: the arc's top lies R/cos(φ/2) − R below it.
        // Sampled every 0.2 across, the points within a spacing of the crease sit at
        // offsets 0 and ±0.2, where the wedge itself falls 0.04 below the crease.
        let strips = extrude(arc, 3.0, 0.2);
        let depth = crease(&strips, 23.0, 2.0).expect("a crease of a wide arc");
        let at = |v: f64| r / (0.5 * phi).cos() - (r * r - v * v).sqrt() - v * (0.5 * phi).tan();
        assert!((depth - at(0.2)).abs() < 1e-3, "{depth} {}", at(0.2));
        // A sharp edge at the same turn, and one rounded by less than the widest rounding
        // (radius 2: 0.04 inside the line), are sharp.
        let h = 0.5 * phi;
        let sharp = |s: f64| [s * h.cos(), -s.abs() * h.sin()];
        assert_eq!(crease(&extrude(sharp, 3.0, 0.2), 23.0, 2.0), None);
        let rho = 1.5;
        let rounded = |s: f64| {
            // The arc up to its tangent points, a turn of h each way; the faces beyond them.
            if s.abs() >= rho * h {
                sharp(s.signum() * (s.abs() - rho * h + rho * h.tan()))
            } else {
                let a = s / rho;
                [rho * a.sin(), rho * a.cos() - rho / h.cos()]
            }
        };
        assert_eq!(crease(&extrude(rounded, 3.0, 0.2), 23.0, 2.0), None);
    }

    #[test]
    fn three_pair_edges_that_end_near_their_faces_common_point_end_at_a_corner() {
        // The corner of a box at the origin: faces x = 0, y = 0, z = 0 (ids 0, 1, 2), its
        // three edges along the axes from 10 out to 0.5-1.2 short of the corner (open ends
        // where the corner's rounding stopped the walk).
        let plane = |normal: [f64; 3]| Plane {
            normal,
            centroid: normal.map(|_| 0.0),
            points: 1000,
            rms: 0.0,
            spacing: 0.2,
            pitch: 0.2,
            noise: 0.01,
        };
        let faces = Faces {
            label: Vec::new(),
            planes: vec![
                plane([1.0, 0.0, 0.0]),
                plane([0.0, 1.0, 0.0]),
                plane([0.0, 0.0, 1.0]),
            ],
        };
        let scale = Scale {
            spacing: 0.2,
            pitch: 0.2,
            noise: 0.01,
            radius: 0.8,
        };
        let edge = |faces: [u32; 2], axis: usize, short: f64| {
            let at = |t: f64| {
                let mut p = [0.0; 3];
                p[axis] = t;
                p
            };
            FaceEdge {
                corners: [None, None],
                faces,
                start: at(10.0),
                end: at(short),
                points: 40,
                traces: [[0.0; 3]; 2],
                scale,
            }
        };
        // Edge along z between faces x = 0 and y = 0, and so on.
        let all = vec![
            edge([0, 1], 2, 0.5),
            edge([0, 2], 1, 1.2),
            edge([1, 2], 0, 0.9),
        ];
        let mut edges = all.clone();
        let mut corners = Vec::new();
        meeting_corners(&faces, &mut corners, &mut edges);
        assert_eq!(corners.len(), 1, "{corners:?}");
        assert_eq!(corners[0].faces, vec![0, 1, 2]);
        assert!(
            norm(corners[0].position) < 1e-12,
            "{:?}",
            corners[0].position
        );
        for e in &edges {
            assert_eq!(e.corners, [None, Some(0)]);
            assert!(norm(e.end) < 1e-12);
        }
        // Two of the edges only: faces 1 and 2 may not meet there (strips of a fillet that
        // each meet a cap face cross its plane at no corner).
        let mut two = all[..2].to_vec();
        let mut corners = Vec::new();
        meeting_corners(&faces, &mut corners, &mut two);
        assert!(corners.is_empty() && two.iter().all(|e| e.corners == [None, None]));
        // Ends farther than `MEET` radii (2.4) from the point: no corner.
        let mut far = vec![
            edge([0, 1], 2, 3.0),
            edge([0, 2], 1, 3.0),
            edge([1, 2], 0, 3.0),
        ];
        let mut corners = Vec::new();
        meeting_corners(&faces, &mut corners, &mut far);
        assert!(corners.is_empty(), "{corners:?}");
    }

    #[test]
    fn faces_that_turn_by_less_than_the_least_angle_are_one_surface() {
        // 170°: a turn of 10°, less than MIN_FACE_ANGLE.
        assert!(edges_of(&wedge(170.0, 0.0, 0.0)).is_empty());
    }
}
