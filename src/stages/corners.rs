//! Corner fit (the paper's 3D case, per vertex, in parallel) and the final edge geometry.
//!
//! Inputs: the `Segments` (vertices and the run ends meeting there), the `EdgeFit`s,
//! `CornerParams`, `FitParams`, the seed. Outputs: one `CornerFit` per vertex (or why it
//! failed) and, per edge, its final geometry: the polyline from vertex to vertex (G0: the
//! edges of a vertex end exactly at it, no gap, no overshoot).
//!
//! At a vertex, each meeting edge contributes its rectified edge points (the slab corners of
//! the edge stage, which already lie on the sharp edge, not on the rounded scan). The paper's
//! constrained multi-line fit then searches the one point all those 3D lines pass through,
//! with their slopes kept from the local fits (Eq. 13–14), by particle swarm; Scheme 1 and
//! the exact optimum (a Weiszfeld-type iteration) are kept beside it.

use rand::SeedableRng;
use rand::rngs::SmallRng;
use rayon::prelude::*;

use crate::fit::{FitParams, fit_corner_3d};
use crate::geometry::{
    add, axpy, cross, dot, nearest_point_to_lines, neg, norm, pca_line, point_line_distance, sub,
    unit,
};
use crate::left_out::{LeftOut, Reason};
use crate::stages::edges::{EdgeParams, EdgeResult, Surface, fillet_limit};
use crate::stages::faces::rounded_crease;
use crate::stages::features::Scale;
use crate::stages::segment::Segments;

/// Settings of the corner stage (validated by `config`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CornerParams {
    /// On a curved edge, rectified edge points farther than this many neighbourhood radii
    /// from the vertex are not used (a curve is only locally straight). A straight edge gives
    /// all its rectified points: its direction is then known far better (on a box at 500k
    /// points, mean vertex error 0.017–0.027 h against 0.040–0.049 h with 25 radii).
    pub reach: f64,
}

impl Default for CornerParams {
    fn default() -> Self {
        CornerParams { reach: 25.0 }
    }
}

/// The fitted corner of one vertex.
#[derive(Debug, Clone)]
pub struct CornerFit {
    pub vertex: usize,
    /// The corner by PSO (the reported position), Scheme 1 and exactly.
    pub position: [f64; 3],
    pub scheme1: [f64; 3],
    pub exact: [f64; 3],
    /// Errors (sum of point-to-line distances) of Scheme 1, PSO and exact.
    pub errors: [f64; 3],
    /// The edges (run ids) that meet here.
    pub edges: Vec<usize>,
}

/// What the corner stage made of one vertex: its corner (the swarm's fit, or where its edges'
/// end lines meet when the fit failed but they agree), and why the vertex gave no fitted
/// corner, if it did not.
#[derive(Debug, Clone, Default)]
pub struct CornerOutcome {
    pub corner: Option<CornerFit>,
    pub left_out: Option<LeftOut>,
}

/// Fits every vertex with at least two fitted edges, in parallel, each with its own RNG from
/// (seed, vertex id).
pub fn fit_corners(
    surface: &Surface,
    segments: &Segments,
    edges: &[EdgeResult],
    params: &CornerParams,
    edge_params: &EdgeParams,
    fit: &FitParams,
    seed: u64,
) -> Vec<CornerOutcome> {
    let mut fit = fit.clone();
    // Rectified edge points scatter far less than the raw points: the fit measures their
    // noise itself instead of taking the cloud's. They already stop short of the vertex, so
    // there is no abnormal zone for the propagation to find, only a heavier-tailed scatter
    // than raw noise (one slab's corner can miss by a few sigmas): a wide tolerance keeps the
    // propagation to its real job here, stopping where a curved edge turns. Measured on a
    // pyramid at 500k points: with 3σ one vertex in five lost its sides (8.9 h error).
    fit.propagation.noise = None;
    fit.propagation.tolerance = fit.propagation.tolerance.max(6.0);
    (0..segments.vertices.len())
        .into_par_iter()
        .map(|v| {
            let mut rng = SmallRng::seed_from_u64(
                seed.rotate_left(17) ^ (v as u64).wrapping_mul(0xD1B5_4A32_D192_ED03),
            );
            fit_vertex(
                surface,
                segments,
                edges,
                v,
                params,
                edge_params,
                &fit,
                &mut rng,
            )
        })
        .collect()
}

/// A corner lies on the end lines of all its edges: one farther than this many spacings from
/// one of them is not where they meet (measured: fitted corners on the synthetic parts lie
/// within 0.1 spacing; a vertex joining runs that do not end at a common point — a hole's rim
/// broken in two, a misread short edge — gave corners 5 to 40 spacings off).
const CORNER_ON_LINES: f64 = 2.0;

/// A corner lies where its edges' runs end: one farther than this many neighbourhood radii
/// from their vertex is where the lines of edges meet that do not end there (the segment
/// stage joins run ends whose lines pass each other at most `segment.vertex_reach` = 5 radii
/// beyond them). Issue 17: a run that followed a face's outline round three of its corners
/// ended beside the far end of the next edge; their end lines met at the outline's other
/// corner, 250 spacings away, and that edge collapsed to a point. On `bench --random 100
/// --seed 1`, 867 of 871 fitted corners lay within 2.2 radii of their vertex.
const CORNER_NEAR_VERTEX: f64 = 5.0;

/// Slack, in spacings, of the distance from a corner to its nearest scan point beyond what the
/// measured roundings explain.
const CORNER_ON_SCAN: f64 = 2.0;

/// The same slack for a corner of only two edges (issue 17: corner precision). Two straight
/// edges running into a fillet's arc meet 0.41 R off it for 90° faces, 3 h for a 7.4 h fillet,
/// and the sharp edges' own roundings bring scan points to within about 2 h of that point:
/// with two spacings of slack, such virtual corners were 2 of 3 spurious corners on `bench
/// --random 100` (in parts with fillets: 168 of 190 over five seeds). A corner of three or
/// more edges is fitted to all of them; a fillet gives the two edges beside it no third.
/// Measured on seed 1: one spacing left 36 → 24 spurious corners and missed none more; half
/// a spacing 21, one true corner missed.
const CORNER_ON_SCAN_TWO_EDGES: f64 = 1.0;

/// Where a corner of two edges would have its third: how far inside the line of the two
/// edges' other faces the scan turns, when more than the widest rounding of a sharp edge
/// explains (`faces::rounded_crease`); `None` when it hugs the line (a sharp third
/// edge the edge stage missed) or nothing tells.
///
/// Why: a straight edge of a cap running into a fillet of the walls meets the next cap edge
/// beyond the fillet's rim at a corner of two edges, 0.64 R off the scan for a 40° fillet
/// of radius R, too near for the scan-support test; the walls there meet through the fillet.
/// Issue 17: 136 of the 166 spurious corners over seeds 1, 2, 3, 53 and 71 of `bench
/// --random 100` were in parts with fillets. Each edge's faces come from its slab nearest
/// the corner; the face whose normals agree best is the one they share, the other two meet
/// on the third line, which runs from the corner along both of their traces.
fn filleted_third_edge(
    surface: &Surface,
    edges: &[EdgeResult],
    ids: &[usize],
    corner: [f64; 3],
    scale: &Scale,
    edge_params: &EdgeParams,
) -> Option<f64> {
    struct Side {
        normals: [[f64; 3]; 2],
        traces: [[f64; 3]; 2],
        tangent: [f64; 3],
    }
    let side = |k: usize| -> Option<Side> {
        let e = edges[k].as_ref().ok()?;
        let s = e
            .slabs
            .iter()
            .min_by(|a, b| norm(sub(a.corner, corner)).total_cmp(&norm(sub(b.corner, corner))))?;
        let mut normals = [[0.0; 3]; 2];
        for (n, f) in normals.iter_mut().zip(s.faces) {
            *n = unit(cross(s.tangent, f))?;
        }
        // The edge's direction away from the corner.
        let away = sub(s.corner, corner);
        let tangent = if dot(away, s.tangent) < 0.0 {
            neg(s.tangent)
        } else {
            s.tangent
        };
        Some(Side {
            normals,
            traces: s.faces,
            tangent,
        })
    };
    let (a, b) = (side(ids[0])?, side(ids[1])?);
    let mut shared = (f64::NEG_INFINITY, 0, 0);
    for i in 0..2 {
        for j in 0..2 {
            let c = dot(a.normals[i], b.normals[j]).abs();
            if c > shared.0 {
                shared = (c, i, j);
            }
        }
    }
    let (oa, ob) = (1 - shared.1, 1 - shared.2);
    // The third line runs where the other faces go from the shared one.
    let mut d = unit(cross(a.normals[oa], b.normals[ob]))?;
    if dot(d, a.traces[oa]) + dot(d, b.traces[ob]) < 0.0 {
        d = neg(d);
    }
    // Each face leaves the third line along its own edge (projected across the line).
    let across = |t: [f64; 3]| unit(axpy(t, -dot(t, d), d));
    let traces = [across(a.tangent)?, across(b.tangent)?];
    let r = scale.radius;
    let start = axpy(corner, r, d);
    let end = axpy(corner, 4.0 * r, d);
    rounded_crease(
        surface.positions,
        surface.grid,
        scale.noise,
        &traces,
        start,
        end,
        scale,
        fillet_limit(edge_params, scale),
    )
}

/// The line through the (up to six) rectified points of one edge nearest to `near`: where the
/// edge leaves its vertex.
fn end_line(points: &[[f64; 3]], near: [f64; 3]) -> Option<([f64; 3], [f64; 3])> {
    let mut by_distance: Vec<(f64, usize)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| (norm(sub(*p, near)), i))
        .collect();
    by_distance.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let ids: Vec<usize> = by_distance.iter().take(6).map(|x| x.1).collect();
    pca_line(points, &ids)
}

#[allow(clippy::too_many_arguments)]
fn fit_vertex(
    surface: &Surface,
    segments: &Segments,
    edges: &[EdgeResult],
    v: usize,
    params: &CornerParams,
    edge_params: &EdgeParams,
    fit: &FitParams,
    rng: &mut SmallRng,
) -> CornerOutcome {
    let vertex = &segments.vertices[v];
    // The scale of the surface the corner's edges run through.
    let scale = &surface.scale_around(
        vertex
            .ends
            .iter()
            .flat_map(|&(run, _)| segments.runs[run].points.iter().copied()),
    );
    let approx = vertex.position;
    let reach = params.reach * scale.radius;
    let mut sides: Vec<Vec<[f64; 3]>> = Vec::new();
    let mut ids: Vec<usize> = Vec::new();
    for &(run, _) in &vertex.ends {
        let Ok(edge) = &edges[run] else { continue };
        let pts: Vec<[f64; 3]> = edge
            .slabs
            .iter()
            .map(|s| s.corner)
            .filter(|p| edge.straight || norm(sub(*p, approx)) <= reach)
            .collect();
        if pts.len() >= 3 {
            sides.push(pts);
            ids.push(run);
        }
    }
    if sides.len() < 2 {
        return CornerOutcome {
            corner: None,
            left_out: Some(LeftOut::vertex(
                Reason::EdgesLeftOut,
                format!(
                    "corner {v}: {} of its {} edges have enough rectified points near it",
                    sides.len(),
                    vertex.ends.len()
                ),
            )),
        };
    }
    let lines: Vec<Option<([f64; 3], [f64; 3])>> =
        sides.iter().map(|s| end_line(s, approx)).collect();
    // The first edge whose end line misses `p`, and by how much.
    let off = |p: [f64; 3]| {
        lines.iter().zip(&ids).find_map(|(l, &k)| {
            let d = point_line_distance(p, (*l)?);
            (d > CORNER_ON_LINES * scale.spacing).then_some((k, d / scale.spacing))
        })
    };
    let far = |p: [f64; 3]| {
        let d = norm(sub(p, approx));
        (d > CORNER_NEAR_VERTEX * scale.radius).then(|| {
            format!(
                "corner {v}: its edges' lines meet {:.1} radii from where they end (more than \
                 {CORNER_NEAR_VERTEX}): they do not end at one corner",
                d / scale.radius
            )
        })
    };
    // A corner of the part is where its scan comes close: at most as far as the roundings
    // measured on its edges leave the surface from their sharp edge, R (1 / sin(β/2) − 1), plus
    // two spacings (one for a corner of two edges) and three sigmas. Two straight edges
    // running into a fillet's arc meet at a virtual corner the scan never comes near (0.41 R
    // away for 90°).
    let slack = if ids.len() == 2 {
        CORNER_ON_SCAN_TWO_EDGES
    } else {
        CORNER_ON_SCAN
    };
    let allowed = ids
        .iter()
        .filter_map(|&k| edges[k].as_ref().ok())
        .map(|e| {
            let half = (0.5 * e.dihedral_deg.to_radians()).clamp(0.05, 1.5);
            let radius = e.zone * half.tan();
            radius * (1.0 / half.sin() - 1.0)
        })
        .fold(0.0, f64::max)
        + slack * scale.spacing
        + 3.0 * scale.noise;
    let unsupported = |p: [f64; 3]| {
        let mut near = false;
        surface.grid.for_each_near_segment(p, p, allowed, |i| {
            near |= !surface.outlier[i as usize];
        });
        (!near).then(|| {
            format!(
                "corner {v}: no scan point within {:.1} spacings of where its edges meet: a \
                 virtual corner (edges running into a fillet), not one of the part",
                allowed / scale.spacing
            )
        })
    };
    // A corner of two edges whose third would be a fillet (see `filleted_third_edge`).
    let filleted = |p: [f64; 3]| {
        let depth = (ids.len() == 2)
            .then(|| filleted_third_edge(surface, edges, &ids, p, scale, edge_params))
            .flatten()?;
        Some(format!(
            "corner {v}: its edges' other faces meet through a rounding wider than a sharp \
             edge's (the scan stays {:.1} spacings inside their line): a fillet between them, \
             whose rim their edges follow, not a corner",
            depth / scale.spacing
        ))
    };
    let refs: Vec<&[[f64; 3]]> = sides.iter().map(|s| s.as_slice()).collect();
    let failure = match fit_corner_3d(&refs, approx, fit, rng) {
        Ok(f) => match off(f.searches.pso.point) {
            None if let Some(why) = far(f.searches.pso.point) => why,
            None if let Some(why) =
                unsupported(f.searches.pso.point).or_else(|| filleted(f.searches.pso.point)) =>
            {
                return CornerOutcome {
                    corner: None,
                    left_out: Some(LeftOut::vertex(Reason::VirtualCorner, why)),
                };
            }
            None => {
                return CornerOutcome {
                    corner: Some(CornerFit {
                        vertex: v,
                        position: f.searches.pso.point,
                        scheme1: f.searches.scheme1.point,
                        exact: f.searches.exact.point,
                        errors: [
                            f.searches.scheme1.error,
                            f.searches.pso.error,
                            f.searches.exact.error,
                        ],
                        edges: ids,
                    }),
                    left_out: None,
                };
            }
            Some((k, d)) => {
                let p = f.searches.pso.point;
                tracing::debug!(
                    "corner {v} at {p:.4?}, vertex {approx:.4?}, edges {ids:?}: {d:.1} spacings \
                     off edge {k}'s end line"
                );
                format!(
                    "corner {v}: the fitted corner lies {d:.1} spacings off edge {k}'s end line \
                 (more than {CORNER_ON_LINES}): its edges do not meet at one point"
                )
            }
        },
        Err(e) => format!("corner {v}: {e}"),
    };
    // The fit failed or does not fit its edges: where their end lines meet, if they do and
    // there are three or more of them (two lines always pass near some point; where the
    // swarm found no consistent corner for two edges, that point was seen 8 to 50 spacings
    // from any corner of the anchor).
    let known: Vec<([f64; 3], [f64; 3])> = lines.iter().flatten().copied().collect();
    let corner = (known.len() >= 3)
        .then(|| nearest_point_to_lines(&known))
        .flatten()
        .filter(|&p| off(p).is_none() && far(p).is_none() && unsupported(p).is_none())
        .map(|p| CornerFit {
            vertex: v,
            position: p,
            scheme1: p,
            exact: p,
            errors: [f64::NAN; 3],
            edges: ids.clone(),
        });
    CornerOutcome {
        corner,
        left_out: Some(LeftOut::vertex(Reason::Failed, failure)),
    }
}

/// The final shape of one edge: its polyline from start to end, ending exactly at its
/// corners.
#[derive(Debug, Clone)]
pub struct EdgeGeometry {
    pub run: usize,
    pub polyline: Vec<[f64; 3]>,
    /// Corner ids (into the fitted corners) at the start and end.
    pub corners: [Option<usize>; 2],
    /// The face traces (unit, perpendicular to the edge, one along each face) of the plane
    /// edge whose line a straight edge took (`plane_corners::place_edges`): from the faces'
    /// planes, where the slabs' mean traces come from local fits.
    pub faces: Option<[[f64; 3]; 2]>,
}

impl EdgeGeometry {
    /// The point of the polyline nearest to `p`, and the unit direction of that piece.
    pub fn nearest(&self, p: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let mut best = (f64::INFINITY, self.polyline[0], [1.0, 0.0, 0.0]);
        for w in self.polyline.windows(2) {
            let d = sub(w[1], w[0]);
            let len2 = dot(d, d);
            if len2 <= 0.0 {
                continue;
            }
            let t = (dot(sub(p, w[0]), d) / len2).clamp(0.0, 1.0);
            let q = add(w[0], d.map(|x| x * t));
            let dist = norm(sub(p, q));
            if dist < best.0 {
                best = (dist, q, d.map(|x| x / len2.sqrt()));
            }
        }
        (best.1, best.2)
    }
}

/// Builds each fitted edge's final polyline: a straight edge is its line through its corners
/// (from corner to corner, or from a corner along the fitted direction to the last rectified
/// point), a curving edge the smoothed rectified points with the corners as end points.
/// `corner_of_vertex[v]` is the fitted corner id of vertex v, if it was fitted.
pub fn edge_geometry(
    segments: &Segments,
    edges: &[EdgeResult],
    corners: &[CornerFit],
    corner_of_vertex: &[Option<usize>],
) -> Vec<Option<EdgeGeometry>> {
    edges
        .iter()
        .enumerate()
        .map(|(k, e)| {
            let e = e.as_ref().ok()?;
            let run = &segments.runs[k];
            let ends = [0, 1].map(|j| {
                let v = run.vertices[j]?;
                let c = corner_of_vertex[v]?;
                corners[c].edges.contains(&k).then_some(c)
            });
            let (o, d) = e.line;
            let t_of = |p: [f64; 3]| dot(sub(p, o), d);
            // An open end ends where both faces' points near the edge do: a run that turns
            // onto a scan border at an unseen corner reaches past the corner.
            let clip = |s: &crate::stages::edges::SlabFit, e: usize| {
                let off = if e == 0 {
                    s.support[0].max(0.0)
                } else {
                    s.support[1].min(0.0)
                };
                if off.is_finite() {
                    add(s.corner, s.tangent.map(|x| x * off))
                } else {
                    s.corner
                }
            };
            let first = e.slabs.first().map(|s| clip(s, 0)).unwrap_or(o);
            let last = e.slabs.last().map(|s| clip(s, 1)).unwrap_or(o);
            let polyline = if e.straight {
                let at = |t: f64| add(o, d.map(|x| x * t));
                match ends {
                    [Some(a), Some(b)] => vec![corners[a].position, corners[b].position],
                    [Some(a), None] => {
                        let p = corners[a].position;
                        vec![p, add(p, d.map(|x| x * (t_of(last) - t_of(p))))]
                    }
                    [None, Some(b)] => {
                        let p = corners[b].position;
                        vec![add(p, d.map(|x| x * (t_of(first) - t_of(p)))), p]
                    }
                    [None, None] => vec![at(t_of(first)), at(t_of(last))],
                }
            } else {
                let mut pts = crate::stages::edges::smooth_polyline(
                    &e.slabs.iter().map(|s| s.corner).collect::<Vec<_>>(),
                    2,
                    run.closed,
                );
                if run.closed && !pts.is_empty() {
                    // A closed edge ends where it starts.
                    pts.push(pts[0]);
                }
                if let Some(a) = ends[0] {
                    pts.insert(0, corners[a].position);
                }
                if let Some(b) = ends[1] {
                    pts.push(corners[b].position);
                }
                pts
            };
            Some(EdgeGeometry {
                run: k,
                polyline,
                corners: ends,
                faces: None,
            })
        })
        .collect()
}
