//! `sharpedge merge DIR --out OUT`: the tiles' partial results joined into one result.
//!
//! Input: the plan folder with the tiles' partial outputs (`tiles/NNNN/partial.json`,
//! `tiles/NNNN/rectified.ply`, `tiles/NNNN.failed`). Output, in OUT, published as one set
//! (`io::output_set`): report.json, features.ply and edges.geojson as `run` writes them, and
//! the rectified points as one PLY per tile (`rectified_NNNN.ply`: the points the tile owns,
//! in input order, each with its input index `scalar_index`) listed by `rectified.json`.
//!
//! Why one file per tile for the rectified points: at 10^9 points the cloud is ~30 GB; one
//! file would have to be written by one process after all tiles (a k-way merge of the tiles'
//! files by input index: hours of single-stream I/O on the critical path), while the tiles'
//! own files are written in parallel by the workers and are the spatial pieces viewers and
//! GIS tools load a large cloud by anyway. Merge rewrites each tile's file only to give its
//! points the merged edge ids, one tile at a time (memory: one tile).
//!
//! Edges: each tile reports every edge it found, including the parts of edges it saw only in
//! its halo and edges cut by its halo box (a cut end there is no end of the edge). Edges of
//! different tiles that are the same edge (parallel, within a spacing of each other, and
//! overlapping along their course) form one group; the merged edge's ends are, of the ends
//! of its members at each extreme, the one whose tile owns it (nearest to that tile's
//! region: a cut end lies a halo's width outside its tile, a true end inside its owner), so
//! each end comes from the tile that saw it with its whole halo. A straight edge is the
//! segment between those ends; a curved one the members' polylines, each clipped to its own
//! tile's region, chained end to end. Its rectified edge points are each member's points in
//! its own tile's region. Where no tile owning an end reported the edge (a run judged
//! differently next to a tile's read box), the cut end is continued along the line to the
//! corner beyond it; an end left without a corner takes one within `SNAP_RADII` radii on its
//! line; groups that became the same segment are one edge.
//!
//! Corners: a tile's corner is kept when the tile owns its position; one that no tile kept
//! (the tiles' fits of a corner on a seam fell on either side of it) is kept once, from the
//! tile nearest to owning it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::run::{PARTIAL_FILE, Partial, RECTIFIED_FILE, errors_from};
use super::{Bounds, Plan, failed_file, tile_dir};
use crate::cloud::Column;
use crate::config::Settings;
use crate::error::{Error, Result};
use crate::geometry::{dist, dot, norm, sub};
use crate::io::{self, PlyWriteOptions};
use crate::outcome::{CornerOut, EdgeKind, EdgeOut, Timing, link_corners};
use crate::stages::convexity::Votes;

/// Members closer to parallel than this are candidates for one edge.
const PARALLEL_DEG: f64 = 5.0;

/// An edge end without a corner takes a corner this many radii away on its line (the
/// segment stage's `vertex_reach` is 5).
const SNAP_RADII: f64 = 3.0;

/// Options of [`merge`].
#[derive(Debug, Clone)]
pub struct MergeOptions {
    pub out: PathBuf,
    /// Write what the finished tiles give even when some are missing or failed.
    pub partial: bool,
}

/// What [`merge`] did.
#[derive(Debug, Clone)]
pub struct MergeSummary {
    pub tiles: usize,
    pub missing: Vec<usize>,
    pub failed: Vec<(usize, String)>,
    pub points: u64,
    pub edges: usize,
    pub corners: usize,
    /// Edges made of the pieces of several tiles.
    pub joined: usize,
    pub outputs: Vec<PathBuf>,
}

/// The state of each tile: its partial output, or why there is none.
enum TileState {
    Done(Box<Partial>),
    Failed(String),
    Missing,
}

fn load_tiles(plan: &Plan, dir: &Path) -> Result<Vec<TileState>> {
    (0..plan.tiles.len())
        .map(|t| {
            let failed = failed_file(dir, t);
            if failed.is_file() {
                let msg = std::fs::read_to_string(&failed)
                    .map_err(|e| Error::io(&failed, "cannot read", e))?;
                return Ok(TileState::Failed(msg.trim().to_string()));
            }
            let path = tile_dir(dir, t).join(PARTIAL_FILE);
            if !path.is_file() {
                return Ok(TileState::Missing);
            }
            let text =
                std::fs::read_to_string(&path).map_err(|e| Error::io(&path, "cannot read", e))?;
            let p: Partial = serde_json::from_str(&text).map_err(|e| Error::Plan {
                path: path.clone(),
                what: format!(
                    "line {}: not a tile's partial output: {e}; run the tile again",
                    e.line()
                ),
            })?;
            if p.tile != t {
                return Err(Error::Plan {
                    path,
                    what: format!(
                        "holds tile {} where tile {t} belongs; run tile {t} again",
                        p.tile
                    ),
                });
            }
            Ok(TileState::Done(Box::new(p)))
        })
        .collect()
}

/// Distance from `p` to the box `b` (0 inside; sides may be infinite).
fn box_distance(b: &Bounds, p: [f64; 3]) -> f64 {
    let mut s = 0.0;
    for k in 0..3 {
        let d = (b[0][k] - p[k]).max(p[k] - b[1][k]).max(0.0);
        s += d * d;
    }
    s.sqrt()
}

/// Distance from `p` to the segment a–b and the parameter of the nearest point.
fn segment_distance(a: [f64; 3], b: [f64; 3], p: [f64; 3]) -> (f64, f64) {
    let ab = sub(b, a);
    let l2 = dot(ab, ab);
    let t = if l2 > 0.0 {
        (dot(sub(p, a), ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]];
    (dist(p, q), t)
}

/// Distance from `p` to a polyline.
fn polyline_distance(line: &[[f64; 3]], p: [f64; 3]) -> f64 {
    if line.len() == 1 {
        return dist(line[0], p);
    }
    line.windows(2)
        .map(|w| segment_distance(w[0], w[1], p).0)
        .fold(f64::INFINITY, f64::min)
}

/// The parts of a polyline inside a box (sides may be infinite), as polylines.
fn clip_polyline(line: &[[f64; 3]], b: &Bounds) -> Vec<Vec<[f64; 3]>> {
    let mut out: Vec<Vec<[f64; 3]>> = Vec::new();
    let mut current: Vec<[f64; 3]> = Vec::new();
    for w in line.windows(2) {
        let (a, c) = (w[0], w[1]);
        // Liang–Barsky: the parameter range of a→c inside the box.
        let d = sub(c, a);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        let mut empty = false;
        for k in 0..3 {
            for (lim, sign) in [(b[0][k], -1.0), (b[1][k], 1.0)] {
                if lim.is_infinite() {
                    continue;
                }
                // sign·(a + t d - lim) <= 0
                let num = sign * (lim - a[k]);
                let den = sign * d[k];
                if den == 0.0 {
                    if num < 0.0 {
                        empty = true;
                    }
                } else {
                    let t = num / den;
                    if den > 0.0 {
                        t1 = t1.min(t);
                    } else {
                        t0 = t0.max(t);
                    }
                }
            }
        }
        if empty || t0 > t1 {
            if !current.is_empty() {
                out.push(std::mem::take(&mut current));
            }
            continue;
        }
        let at = |t: f64| [a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]];
        let (p0, p1) = (at(t0), at(t1));
        if current.is_empty() {
            current.push(p0);
        } else if t0 > 0.0 {
            out.push(std::mem::take(&mut current));
            current.push(p0);
        }
        current.push(p1);
        if t1 < 1.0 {
            out.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        out.push(current);
    }
    out.into_iter().filter(|p| p.len() >= 2).collect()
}

/// One tile's edge as a member of a merged edge.
struct Member<'a> {
    tile: usize,
    edge: &'a super::run::PartEdge,
    region: Bounds,
    /// Unit direction start→end (of the chord for a polyline).
    dir: [f64; 3],
    /// Lateral tolerance: the tile's spacing.
    tol: f64,
    /// Gap tolerance along the course: the tile's radius.
    gap: f64,
}

impl Member<'_> {
    fn straight(&self) -> bool {
        self.edge.polyline.len() == 2
    }
    fn ends(&self) -> [[f64; 3]; 2] {
        [self.edge.start, self.edge.end]
    }
}

/// Whether two members of different tiles are one edge.
fn same_edge(a: &Member, b: &Member) -> bool {
    let tol = a.tol.max(b.tol);
    let gap = a.gap.max(b.gap);
    if dot(a.dir, b.dir).abs() < PARALLEL_DEG.to_radians().cos() {
        return false;
    }
    if a.straight() && b.straight() {
        // Each one's ends within `tol` of the other's line, and the two overlapping (or
        // touching within `gap`) along it.
        let on_line = |m: &Member, p: [f64; 3]| {
            let v = sub(p, m.edge.start);
            let along = dot(v, m.dir);
            norm([
                v[0] - along * m.dir[0],
                v[1] - along * m.dir[1],
                v[2] - along * m.dir[2],
            ]) <= tol
        };
        if !(b.ends().iter().all(|&p| on_line(a, p)) && a.ends().iter().all(|&p| on_line(b, p))) {
            return false;
        }
        let s = |p: [f64; 3]| dot(sub(p, a.edge.start), a.dir);
        let (a0, a1) = (0.0, s(a.edge.end));
        let (b0, b1) = {
            let (x, y) = (s(b.edge.start), s(b.edge.end));
            (x.min(y), x.max(y))
        };
        return b0 <= a1 + gap && a0 <= b1 + gap;
    }
    // Curved: some vertices of each near the other's polyline.
    let near = |m: &Member, other: &Member| {
        m.edge
            .polyline
            .iter()
            .any(|&p| polyline_distance(&other.edge.polyline, p) <= tol)
    };
    near(a, b) && near(b, a)
}

/// Union–find.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

#[derive(Serialize)]
struct InputReport<'a> {
    path: String,
    format: &'a str,
    points: u64,
}

#[derive(Serialize)]
struct Counts {
    points: u64,
    candidates: u64,
    outliers: u64,
    runs: usize,
    edges: usize,
    corners: usize,
    moved: u64,
    left_out: usize,
    failed_fits: usize,
}

#[derive(Serialize)]
struct ScaleReport {
    spacing: f64,
    pitch: f64,
    noise: f64,
    radius: f64,
}

#[derive(Serialize)]
struct LeftOutReport {
    by_reason: BTreeMap<String, usize>,
    candidates: Vec<serde_json::Value>,
}

#[derive(Serialize)]
struct FailedTile {
    tile: usize,
    error: String,
}

#[derive(Serialize)]
struct TilesReport {
    plan: String,
    count: usize,
    done: usize,
    missing: Vec<usize>,
    failed: Vec<FailedTile>,
    halo: f64,
    /// Edges joined from the pieces of several tiles.
    joined_edges: usize,
}

#[derive(Serialize)]
struct Report<'a> {
    sharpedge: &'static str,
    input: InputReport<'a>,
    scale: ScaleReport,
    counts: Counts,
    timings: Vec<Timing>,
    edges: &'a [EdgeOut],
    corners: &'a [CornerOut],
    left_out: LeftOutReport,
    config: &'a Settings,
    tiles: TilesReport,
}

/// The merged edges and corners, and the map from each tile's edge ids to merged ones.
struct Joined {
    edges: Vec<EdgeOut>,
    corners: Vec<CornerOut>,
    /// Per tile: merged edge id of each of its edge ids.
    edge_map: Vec<Vec<Option<usize>>>,
    joined: usize,
}

fn join(plan: &Plan, partials: &[Option<&Partial>]) -> Joined {
    let grid = plan.grid;
    // Corners: kept by their owner; then those no tile kept, once.
    let mut corners: Vec<CornerOut> = Vec::new();
    let mut corner_map: Vec<Vec<Option<usize>>> = partials
        .iter()
        .map(|p| vec![None; p.map_or(0, |p| p.corners.len())])
        .collect();
    let mut orphans: Vec<(f64, usize, usize)> = Vec::new();
    for (t, p) in partials.iter().enumerate() {
        let Some(p) = p else { continue };
        for (k, c) in p.corners.iter().enumerate() {
            if grid.owner(c.position) == t {
                corner_map[t][k] = Some(corners.len());
                corners.push(CornerOut {
                    id: corners.len(),
                    position: c.position,
                    edges: Vec::new(),
                    error: c.error.map(errors_from),
                    scheme1: c.scheme1,
                    exact: c.exact,
                });
            } else {
                orphans.push((box_distance(&grid.region(t), c.position), t, k));
            }
        }
    }
    orphans.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    for &(_, t, k) in &orphans {
        let Some(p) = partials[t] else { continue };
        let c = &p.corners[k];
        let tol = p.scale[3].max(p.scale[0]);
        let near = corners
            .iter()
            .position(|m| dist(m.position, c.position) <= tol);
        match near {
            Some(m) => corner_map[t][k] = Some(m),
            None => {
                corner_map[t][k] = Some(corners.len());
                corners.push(CornerOut {
                    id: corners.len(),
                    position: c.position,
                    edges: Vec::new(),
                    error: c.error.map(errors_from),
                    scheme1: c.scheme1,
                    exact: c.exact,
                });
            }
        }
    }

    // Edges: members grouped into merged edges.
    let mut members: Vec<Member> = Vec::new();
    for (t, p) in partials.iter().enumerate() {
        let Some(p) = p else { continue };
        for e in &p.edges {
            let chord = sub(e.end, e.start);
            let l = norm(chord);
            let dir = if l > 0.0 {
                chord.map(|x| x / l)
            } else {
                e.direction
            };
            members.push(Member {
                tile: t,
                edge: e,
                region: grid.region(t),
                dir,
                tol: p.scale[0],
                gap: p.scale[3],
            });
        }
    }
    let n = members.len();
    let mut parent: Vec<usize> = (0..n).collect();
    // Candidates by bounding box overlap, swept along x.
    let boxes: Vec<Bounds> = members
        .iter()
        .map(|m| {
            let (lo, hi) = crate::geometry::bounds(&m.edge.polyline);
            let pad = m.tol.max(m.gap);
            [lo.map(|x| x - pad), hi.map(|x| x + pad)]
        })
        .collect();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| boxes[a][0][0].total_cmp(&boxes[b][0][0]));
    for (i, &a) in order.iter().enumerate() {
        for &b in &order[i + 1..] {
            if boxes[b][0][0] > boxes[a][1][0] {
                break;
            }
            if members[a].tile == members[b].tile
                || (0..3)
                    .any(|k| boxes[b][0][k] > boxes[a][1][k] || boxes[a][0][k] > boxes[b][1][k])
            {
                continue;
            }
            if same_edge(&members[a], &members[b]) {
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                if ra != rb {
                    parent[ra.max(rb)] = ra.min(rb);
                }
            }
        }
    }
    let mut groups: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for i in 0..n {
        let r = find(&mut parent, i);
        groups.entry(r).or_default().push(i);
    }
    let mut edge_map: Vec<Vec<Option<usize>>> = partials
        .iter()
        .map(|p| vec![None; p.map_or(0, |p| p.edges.len())])
        .collect();
    let mut edges: Vec<EdgeOut> = Vec::new();
    let mut joined = 0;
    for group in groups.values() {
        let id = edges.len();
        let tiles: std::collections::BTreeSet<usize> =
            group.iter().map(|&i| members[i].tile).collect();
        let Some(edge) = merge_group(group, &members, &corner_map, &corners, id) else {
            continue;
        };
        if tiles.len() > 1 {
            joined += 1;
        }
        for &i in group {
            edge_map[members[i].tile][members[i].edge.id] = Some(id);
        }
        edges.push(edge);
    }
    // Groups that became the same edge (a stretch that no tile reported split a long edge
    // in two, and both halves were continued to the same corners) are one edge.
    let mut same: Vec<Option<usize>> = vec![None; edges.len()];
    for j in 0..edges.len() {
        let close = |a: [f64; 3], b: [f64; 3]| dist(a, b) <= 1e-9 * (1.0 + norm(a));
        let dup = (0..j).find(|&i| {
            same[i].is_none()
                && edges[i].polyline.len() == 2
                && edges[j].polyline.len() == 2
                && ((close(edges[i].start, edges[j].start) && close(edges[i].end, edges[j].end))
                    || (close(edges[i].start, edges[j].end) && close(edges[i].end, edges[j].start)))
        });
        same[j] = dup;
    }
    if same.iter().any(Option::is_some) {
        let mut renumber = vec![0usize; edges.len()];
        let mut kept: Vec<EdgeOut> = Vec::new();
        for (j, e) in std::mem::take(&mut edges).into_iter().enumerate() {
            match same[j] {
                Some(i) => {
                    let target = renumber[i];
                    renumber[j] = target;
                    let k = &mut kept[target];
                    k.points += e.points;
                    k.rectified.extend(e.rectified);
                }
                None => {
                    renumber[j] = kept.len();
                    let mut e = e;
                    e.id = kept.len();
                    kept.push(e);
                }
            }
        }
        edges = kept;
        for id in edge_map.iter_mut().flatten().flatten() {
            *id = renumber[*id];
        }
        joined = joined.min(edges.len());
    }
    // Corners list the edges that end at them.
    link_corners(&edges, &mut corners);
    for c in &mut corners {
        c.edges.sort_unstable();
    }
    Joined {
        edges,
        corners,
        edge_map,
        joined,
    }
}

/// The merged edge of a group of members (`None` when no member has a part in its own tile's
/// region: then it is no tile's edge).
fn merge_group(
    group: &[usize],
    members: &[Member],
    corner_map: &[Vec<Option<usize>>],
    corners: &[CornerOut],
    id: usize,
) -> Option<EdgeOut> {
    let first = &members[group[0]];
    let axis = members
        .iter()
        .enumerate()
        .filter(|(i, _)| group.contains(i))
        .map(|(_, m)| m)
        .max_by(|a, b| dist(a.edge.start, a.edge.end).total_cmp(&dist(b.edge.start, b.edge.end)))
        .map_or(first.dir, |m| m.dir);
    let origin = first.edge.start;
    let s = |p: [f64; 3]| dot(sub(p, origin), axis);
    // Every member end: (position along the axis, trust = distance to its tile's region,
    // tile, member, which end).
    let mut ends: Vec<(f64, f64, usize, usize, usize)> = Vec::new();
    for &i in group {
        let m = &members[i];
        for (k, p) in m.ends().into_iter().enumerate() {
            ends.push((s(p), box_distance(&m.region, p), m.tile, i, k));
        }
    }
    let lo = ends.iter().map(|e| e.0).fold(f64::INFINITY, f64::min);
    let hi = ends.iter().map(|e| e.0).fold(f64::NEG_INFINITY, f64::max);
    let gap = group.iter().map(|&i| members[i].gap).fold(0.0, f64::max);
    // At each extreme, the end whose tile is nearest to owning it.
    let pick = |at: f64| {
        ends.iter()
            .filter(|e| (e.0 - at).abs() <= gap)
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.2.cmp(&b.2)))
            .copied()
    };
    let (start_end, end_end) = (pick(lo)?, pick(hi)?);
    let end_point = |e: (f64, f64, usize, usize, usize)| members[e.3].ends()[e.4];
    let end_corner = |e: (f64, f64, usize, usize, usize)| {
        let m = &members[e.3];
        m.edge.corners[e.4].and_then(|c| corner_map[m.tile].get(c).copied().flatten())
    };
    let closed_single = group.len() == 1 && first.edge.closed;
    // The members' rectified edge points and polyline parts in their own tile's region.
    let mut rectified: Vec<[f64; 3]> = Vec::new();
    let mut pieces: Vec<Vec<[f64; 3]>> = Vec::new();
    let mut points = 0.0;
    let mut weights = 0.0;
    let mut dihedral = 0.0;
    let mut errors = [0.0f64; 3];
    let mut has_errors = false;
    let mut best_votes = (0usize, [0usize; 2]);
    for &i in group {
        let m = &members[i];
        let own: Vec<[f64; 3]> = m
            .edge
            .rectified
            .iter()
            .copied()
            .filter(|&p| box_distance(&m.region, p) == 0.0)
            .collect();
        let share = if m.edge.rectified.is_empty() {
            // A plane edge (no slabs): its share by length inside the region.
            let inside: f64 = clip_polyline(&m.edge.polyline, &m.region)
                .iter()
                .map(|p| p.windows(2).map(|w| dist(w[0], w[1])).sum::<f64>())
                .sum();
            let total: f64 = m.edge.polyline.windows(2).map(|w| dist(w[0], w[1])).sum();
            if total > 0.0 { inside / total } else { 1.0 }
        } else {
            own.len() as f64 / m.edge.rectified.len() as f64
        };
        points += m.edge.points as f64 * share;
        if let Some(d) = m.edge.dihedral_deg {
            dihedral += d * share;
            weights += share;
        }
        if let Some(e) = m.edge.error {
            has_errors = true;
            for k in 0..3 {
                errors[k] += e[k] * share;
            }
        }
        if own.len() >= best_votes.0 {
            best_votes = (own.len(), m.edge.votes);
        }
        rectified.extend(own);
        pieces.extend(clip_polyline(&m.edge.polyline, &m.region));
    }
    if pieces.is_empty() && rectified.is_empty() {
        return None;
    }
    let (mut start, mut end) = (end_point(start_end), end_point(end_end));
    let all_straight = group.iter().all(|&i| members[i].straight());
    let (mut start_corner, mut end_corner_id) = (end_corner(start_end), end_corner(end_end));
    // An extreme that is a cut end (outside its tile's region: no tile that owns the end
    // reported the edge, e.g. its run was judged differently next to that tile's read box)
    // is continued along the line to the nearest corner beyond it, as `run` extends edges to
    // their corners.
    if all_straight && !closed_single {
        let tol = group.iter().map(|&i| members[i].gap).fold(0.0, f64::max);
        // The nearest corner on the line beyond `from` (away from `other`), up to `reach`.
        let beyond = |from: [f64; 3], other: [f64; 3], reach: f64| -> Option<usize> {
            let d = sub(from, other);
            let l = norm(d);
            if l == 0.0 {
                return None;
            }
            let u = d.map(|x| x / l);
            corners
                .iter()
                .filter_map(|c| {
                    let v = sub(c.position, from);
                    let along = dot(v, u);
                    let lateral = norm([
                        v[0] - along * u[0],
                        v[1] - along * u[1],
                        v[2] - along * u[2],
                    ]);
                    (along > -tol && along <= reach && lateral <= tol).then_some((along, c.id))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, id)| id)
        };
        // A cut end goes to the corner beyond however far; an end its owner left without a
        // corner takes one within `SNAP_RADII` radii on its line (the tile's vertex search
        // missed what the untiled run's found).
        let reach = |trust: f64| {
            if trust > 0.0 {
                f64::INFINITY
            } else {
                SNAP_RADII * tol
            }
        };
        if start_corner.is_none()
            && let Some(c) = beyond(start, end, reach(start_end.1))
        {
            start = corners[c].position;
            start_corner = Some(c);
        }
        if end_corner_id.is_none()
            && let Some(c) = beyond(end, start, reach(end_end.1))
        {
            end = corners[c].position;
            end_corner_id = Some(c);
        }
    }
    let polyline = if closed_single {
        first.edge.polyline.clone()
    } else if all_straight || pieces.is_empty() {
        vec![start, end]
    } else {
        chain(pieces, start, end)
    };
    rectified.sort_by(|a, b| s(*a).total_cmp(&s(*b)));
    let rms = (rectified
        .iter()
        .map(|&p| polyline_distance(&polyline, p).powi(2))
        .sum::<f64>()
        / rectified.len().max(1) as f64)
        .sqrt();
    let d = sub(end, start);
    let l = norm(d);
    let direction = if l > 0.0 { d.map(|x| x / l) } else { axis };
    let votes = Votes {
        convex: best_votes.1[0],
        concave: best_votes.1[1],
    };
    let corners = if closed_single {
        [None, None]
    } else {
        [start_corner, end_corner_id]
    };
    Some(EdgeOut {
        id,
        kind: EdgeKind::Sharp,
        start: if closed_single {
            first.edge.start
        } else {
            start
        },
        end: if closed_single { first.edge.end } else { end },
        direction: if closed_single {
            first.edge.direction
        } else {
            direction
        },
        points: points.round() as usize,
        rms,
        corners,
        convex: votes.decide(),
        convex_votes: votes,
        dihedral_deg: (weights > 0.0).then(|| dihedral / weights),
        polyline,
        closed: closed_single,
        rectified,
        error: has_errors.then(|| errors_from(errors)),
    })
}

/// Polyline pieces chained into one polyline from `start` to `end`: from the piece nearest
/// `start`, each next piece is the one with an end nearest the chain's tail.
fn chain(mut pieces: Vec<Vec<[f64; 3]>>, start: [f64; 3], end: [f64; 3]) -> Vec<[f64; 3]> {
    let mut out: Vec<[f64; 3]> = vec![start];
    while !pieces.is_empty() {
        let tail = out[out.len() - 1];
        let (k, flip) = pieces
            .iter()
            .enumerate()
            .flat_map(|(k, p)| {
                [
                    (k, false, dist(p[0], tail)),
                    (k, true, dist(p[p.len() - 1], tail)),
                ]
            })
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .map(|(k, f, _)| (k, f))
            .unwrap_or((0, false));
        let mut p = pieces.swap_remove(k);
        if flip {
            p.reverse();
        }
        for q in p {
            if dist(q, out[out.len() - 1]) > 0.0 {
                out.push(q);
            }
        }
    }
    if dist(out[out.len() - 1], end) > 0.0 {
        out.push(end);
    }
    out
}

/// Merges the plan's tiles into `opts.out`.
pub fn merge(plan_dir: &Path, opts: &MergeOptions) -> Result<MergeSummary> {
    let clock = Instant::now();
    let plan = Plan::load(plan_dir)?;
    let states = load_tiles(&plan, plan_dir)?;
    let missing: Vec<usize> = states
        .iter()
        .enumerate()
        .filter(|(_, s)| matches!(s, TileState::Missing))
        .map(|(i, _)| i)
        .collect();
    let failed: Vec<(usize, String)> = states
        .iter()
        .enumerate()
        .filter_map(|(i, s)| match s {
            TileState::Failed(m) => Some((i, m.clone())),
            _ => None,
        })
        .collect();
    if (!missing.is_empty() || !failed.is_empty()) && !opts.partial {
        return Err(Error::Incomplete {
            path: plan_dir.to_path_buf(),
            total: plan.tiles.len(),
            missing,
            failed,
        });
    }
    for (t, m) in &failed {
        tracing::warn!("tile {t} failed and is left out: {m}");
    }
    if !missing.is_empty() {
        tracing::warn!(
            "{} tiles are missing and left out: {missing:?}",
            missing.len()
        );
    }
    let settings = crate::config::parse(&plan.config_text, &plan.config)?;
    let partials: Vec<Option<&Partial>> = states
        .iter()
        .map(|s| match s {
            TileState::Done(p) => Some(p.as_ref()),
            _ => None,
        })
        .collect();
    let joined = join(&plan, &partials);

    // The output set: report, features, edges, the rectified index and one file per tile.
    let done: Vec<usize> = (0..partials.len())
        .filter(|&t| partials[t].is_some())
        .collect();
    let tile_names: Vec<String> = done
        .iter()
        .map(|t| format!("rectified_{t:04}.ply"))
        .collect();
    let mut names: Vec<&str> = vec![
        "report.json",
        "features.ply",
        "edges.geojson",
        "rectified.json",
    ];
    names.extend(tile_names.iter().map(String::as_str));
    std::fs::create_dir_all(&opts.out)
        .map_err(|e| Error::io(&opts.out, "cannot create output folder", e))?;
    let staging = io::output_set::stage(&opts.out, &names)?;
    let ply = PlyWriteOptions {
        encoding: settings.output.encoding,
        precision: io::Precision::F64,
    };
    let mut index_files = Vec::new();
    let mut points = 0u64;
    for (k, &t) in done.iter().enumerate() {
        let src = tile_dir(plan_dir, t).join(RECTIFIED_FILE);
        let mut cloud = io::read(&src, &io::ReadOptions::default())?;
        let map = &joined.edge_map[t];
        for a in &mut cloud.attributes {
            if a.name == "scalar_edge_id"
                && let Column::I32(v) = &mut a.values
            {
                for l in v.iter_mut() {
                    *l = if *l < 0 {
                        -1
                    } else {
                        map.get(*l as usize)
                            .copied()
                            .flatten()
                            .map_or(-1, |m| m as i32)
                    };
                }
            }
        }
        let labels: Vec<i32> = cloud
            .attribute("scalar_edge_id")
            .and_then(|a| match &a.values {
                Column::I32(v) => Some(v.clone()),
                _ => None,
            })
            .unwrap_or_default();
        for a in &mut cloud.attributes {
            let channel = match a.name.as_str() {
                "red" => 0,
                "green" => 1,
                "blue" => 2,
                _ => continue,
            };
            if let Column::U8(v) = &mut a.values {
                for (x, &l) in v.iter_mut().zip(&labels) {
                    *x = crate::report::colour(if l < 0 { u32::MAX } else { l as u32 })[channel];
                }
            }
        }
        let refs: Vec<&crate::cloud::Attribute> = cloud.attributes.iter().collect();
        io::write_ply(&staging.file(4 + k), &cloud.positions, &refs, &[], &ply)?;
        points += cloud.len() as u64;
        index_files.push(serde_json::json!({
            "tile": t,
            "file": tile_names[k],
            "points": cloud.len(),
            "core": plan.tiles[t].core,
        }));
    }
    let index = serde_json::json!({
        "input": plan.input.display().to_string(),
        "points": points,
        "order": "each file holds the points its tile owns, in input order; scalar_index is a \
                  point's 0-based index in the input",
        "files": index_files,
    });
    put_json(&staging.file(3), &index)?;
    crate::report::write_features_of(&staging.file(1), &joined.edges, &joined.corners, &ply)?;
    crate::lidar_out::write_edges_of(&staging.file(2), &joined.edges, &joined.corners, None)?;

    // report.json: the tiles' counts over the points they own, summed.
    let done_partials: Vec<&Partial> = partials.iter().flatten().copied().collect();
    let sum = |f: &dyn Fn(&Partial) -> u64| done_partials.iter().map(|p| f(p)).sum::<u64>();
    let mut by_reason: BTreeMap<String, usize> = BTreeMap::new();
    let mut candidates = Vec::new();
    for p in &done_partials {
        for l in &p.left_out {
            if let Some(r) = l.get("reason").and_then(|r| r.as_str()) {
                *by_reason.entry(r.to_string()).or_insert(0) += 1;
            }
            let mut l = l.clone();
            if let Some(o) = l.as_object_mut() {
                o.insert("tile".into(), serde_json::json!(p.tile));
            }
            candidates.push(l);
        }
    }
    let failed_fits = by_reason.get("failed").copied().unwrap_or(0);
    let judged = by_reason.values().sum::<usize>() - failed_fits;
    // The scale: medians over the tiles of their medians.
    let median = |k: usize| {
        let mut v: Vec<f64> = done_partials
            .iter()
            .filter(|p| p.core.points > 0)
            .map(|p| p.scale[k])
            .collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    let mut stage_time: Vec<(String, f64)> = Vec::new();
    for p in &done_partials {
        for (s, t) in &p.timings {
            match stage_time.iter_mut().find(|(n, _)| n == s) {
                Some(e) => e.1 += t,
                None => stage_time.push((s.clone(), *t)),
            }
        }
    }
    let mut timings: Vec<Timing> = stage_time
        .into_iter()
        .filter_map(|(s, t)| stage_name(&s).map(|stage| Timing { stage, seconds: t }))
        .collect();
    timings.push(Timing {
        stage: "merge",
        seconds: clock.elapsed().as_secs_f64(),
    });
    let report = Report {
        sharpedge: env!("CARGO_PKG_VERSION"),
        input: InputReport {
            path: plan.input.display().to_string(),
            format: &plan.format,
            points: plan.points,
        },
        scale: ScaleReport {
            spacing: median(0),
            pitch: median(1),
            noise: median(2),
            radius: median(3),
        },
        counts: Counts {
            points: sum(&|p| p.core.points),
            candidates: sum(&|p| p.core.candidates),
            outliers: sum(&|p| p.core.outliers),
            runs: done_partials.iter().map(|p| p.runs).sum(),
            edges: joined.edges.len(),
            corners: joined.corners.len(),
            moved: sum(&|p| p.core.moved),
            left_out: judged,
            failed_fits,
        },
        timings,
        edges: &joined.edges,
        corners: &joined.corners,
        left_out: LeftOutReport {
            by_reason,
            candidates,
        },
        config: &settings,
        tiles: TilesReport {
            plan: plan_dir.display().to_string(),
            count: plan.tiles.len(),
            done: done.len(),
            missing: missing.clone(),
            failed: failed
                .iter()
                .map(|(t, e)| FailedTile {
                    tile: *t,
                    error: e.clone(),
                })
                .collect(),
            halo: plan.halo,
            joined_edges: joined.joined,
        },
    };
    let value = serde_json::to_value(&report)
        .map_err(|e| Error::io(staging.file(0), "cannot write report", e.into()))?;
    put_json(&staging.file(0), &value)?;
    let outputs = staging.publish()?;
    Ok(MergeSummary {
        tiles: plan.tiles.len(),
        missing,
        failed,
        points,
        edges: joined.edges.len(),
        corners: joined.corners.len(),
        joined: joined.joined,
        outputs,
    })
}

/// The stage names of `run` (timings carry `&'static str`).
fn stage_name(s: &str) -> Option<&'static str> {
    const STAGES: [&str; 13] = [
        "read",
        "scale",
        "neighbours",
        "features",
        "faces",
        "segment",
        "edges",
        "corners",
        "plane corners",
        "rectify",
        "convexity",
        "write",
        "tile",
    ];
    STAGES.iter().find(|&&n| n == s).copied()
}

fn put_json(path: &Path, value: &impl Serialize) -> Result<()> {
    let text =
        crate::json::pretty(value).map_err(|e| Error::io(path, "cannot write", e.into()))? + "\n";
    io::write_atomic(path, |w| {
        w.write_all(text.as_bytes())
            .map_err(|e| Error::io(path, "cannot write", e))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_keeps_the_parts_inside_with_their_cut_points() {
        let b: Bounds = [[0.0, f64::NEG_INFINITY, -1.0], [1.0, f64::INFINITY, 1.0]];
        let line = [[-1.0, 0.0, 0.0], [2.0, 3.0, 0.0]];
        let parts = clip_polyline(&line, &b);
        assert_eq!(parts.len(), 1);
        assert_eq!(parts[0], vec![[0.0, 1.0, 0.0], [1.0, 2.0, 0.0]]);
        // In, out, in again: two parts.
        let zig = [[0.5, 0.0, 0.0], [1.5, 0.0, 0.0], [0.5, 1.0, 0.0]];
        let parts = clip_polyline(&zig, &b);
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[0], vec![[0.5, 0.0, 0.0], [1.0, 0.0, 0.0]]);
        assert_eq!(parts[1], vec![[1.0, 0.5, 0.0], [0.5, 1.0, 0.0]]);
        assert!(clip_polyline(&[[5.0, 0.0, 0.0], [6.0, 0.0, 0.0]], &b).is_empty());
    }

    #[test]
    fn chained_pieces_run_from_start_to_end() {
        let pieces = vec![
            vec![[2.0, 0.0, 0.0], [3.0, 0.0, 0.0]],
            vec![[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
        ];
        let c = chain(pieces, [0.0, 0.0, 0.0], [3.0, 0.0, 0.0]);
        assert_eq!(
            c,
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [3.0, 0.0, 0.0]
            ]
        );
    }
}
