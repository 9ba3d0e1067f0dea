//! Segmentation: candidate edge points → edge runs by line propagation → vertices where runs
//! meet.
//!
//! Inputs: positions, `Features` (candidate mask, edge direction and normal-tensor scores),
//! `Scale`, `SegmentParams`. Output: `Segments` — runs (their candidate points and a centre
//! line or polyline), vertices (an approximate position and the run ends that meet there),
//! and a per-point run label.
//!
//! The propagation is the paper's §2.1 carried to 3D point bands: a run starts at the most
//! edge-like candidate, fits a line to the candidates around it, and extends step by step
//! along its direction, taking the candidates ahead that lie in a tube around the line and
//! whose own edge direction agrees. It stops where no such candidates are left — at a corner
//! the candidates ahead belong to other edges and their directions disagree, or are
//! corner-like — or where the local tangent turns faster than a gently curving edge can.
//! Runs whose ends face each other across a small gap are merged; runs whose extended lines
//! pass close to each other near their ends meet at a vertex.

use rayon::prelude::*;

use crate::features::{Features, Scale};
use crate::neighbours::Grid;

/// Settings of the segment stage (validated by `config`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SegmentParams {
    /// A candidate joins a run when its edge direction is within this angle of the run's
    /// (degrees).
    pub direction_tolerance: f64,
    /// A run stops when its local direction turns by more than this between two consecutive
    /// windows (degrees); gentle curves turn less per window and are followed.
    pub turn_angle: f64,
    /// Half-width of the tube around a run's line that candidates must lie in, in
    /// neighbourhood radii.
    pub tube: f64,
    /// Shortest run kept, in neighbourhood radii.
    pub min_length: f64,
    /// Candidates whose normal tensor's smallest eigenvalue exceeds this share of its middle
    /// one are corner-like: they never join a run.
    pub corner_ratio: f64,
    /// Run ends meet at a vertex when their lines pass within this many radii of each other,
    /// no further than `vertex_reach` radii beyond the ends.
    pub vertex_gap: f64,
    pub vertex_reach: f64,
    /// Agreeing candidates within this many radii of an accepted run are part of its band.
    pub absorb: f64,
    /// Runs with fewer candidates per unit length than this share of the median run are
    /// dropped.
    pub min_density: f64,
}

impl Default for SegmentParams {
    fn default() -> Self {
        SegmentParams {
            direction_tolerance: 25.0,
            turn_angle: 12.0,
            tube: 1.0,
            min_length: 3.0,
            corner_ratio: 0.3,
            vertex_gap: 1.0,
            vertex_reach: 5.0,
            min_density: 0.3,
            absorb: 3.0,
        }
    }
}

/// Label of a point that belongs to no run.
pub const NO_RUN: u32 = u32::MAX;

/// One edge run.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// Candidate points of the run, sorted by id.
    pub points: Vec<u32>,
    /// A point on the run's best line (the centroid of its points).
    pub origin: [f64; 3],
    /// Unit direction of the run's best line.
    pub direction: [f64; 3],
    /// Extent of the run's points along `direction`, relative to `origin`.
    pub t_range: [f64; 2],
    /// Centre-line samples from one end to the other (window centroids); a straight run has
    /// the same shape as its line, a curving run follows the curve.
    pub centreline: Vec<[f64; 3]>,
    /// The vertex at each end (`[start, end]` in the order of `t_range`), if any.
    pub vertices: [Option<usize>; 2],
}

/// Where two or more runs meet.
#[derive(Debug, Clone, PartialEq)]
pub struct Vertex {
    /// Least-squares point nearest to the lines of the meeting runs.
    pub position: [f64; 3],
    /// (run id, end: 0 = start, 1 = end).
    pub ends: Vec<(usize, usize)>,
}

#[derive(Debug, Clone, Default)]
pub struct Segments {
    pub runs: Vec<Run>,
    pub vertices: Vec<Vertex>,
    /// Run id of every point, or `NO_RUN`.
    pub label: Vec<u32>,
}

/// Finds the edge runs and vertices of a cloud.
pub fn segment(
    positions: &[[f64; 3]],
    features: &Features,
    scale: &Scale,
    params: &SegmentParams,
) -> Segments {
    let r = scale.radius;
    let cand: Vec<u32> = (0..positions.len() as u32)
        .filter(|&i| {
            let i = i as usize;
            features.candidate[i]
                && f64::from(features.corner[i])
                    <= params.corner_ratio * f64::from(features.split[i])
        })
        .collect();
    let mut label = vec![NO_RUN; positions.len()];
    if cand.len() < 3 {
        return Segments {
            runs: Vec::new(),
            vertices: Vec::new(),
            label,
        };
    }
    let cand_pos: Vec<[f64; 3]> = cand.iter().map(|&i| positions[i as usize]).collect();
    let Ok(grid) = Grid::new(&cand_pos, r) else {
        return Segments {
            runs: Vec::new(),
            vertices: Vec::new(),
            label,
        };
    };
    let dirs: Vec<[f64; 3]> = cand
        .iter()
        .map(|&i| features.direction[i as usize].map(f64::from))
        .collect();

    // Seeds: the most clearly two-sided candidates first (ties by id: deterministic).
    let mut seeds: Vec<u32> = (0..cand.len() as u32).collect();
    seeds.sort_by(|&a, &b| {
        let (sa, sb) = (
            features.split[cand[a as usize] as usize],
            features.split[cand[b as usize] as usize],
        );
        sb.total_cmp(&sa).then(a.cmp(&b))
    });

    let cos_dir = params.direction_tolerance.to_radians().cos();
    let cos_turn = params.turn_angle.to_radians().cos();
    let tube = params.tube * r;
    let mut taken = vec![false; cand.len()];
    let mut runs: Vec<Run> = Vec::new();
    for &seed in &seeds {
        if taken[seed as usize] {
            continue;
        }
        let grower = Grower {
            pos: &cand_pos,
            dirs: &dirs,
            grid: &grid,
            r,
            tube,
            cos_dir,
            cos_turn,
        };
        let Some(mut members) = grower.grow(seed as usize, &taken) else {
            taken[seed as usize] = true;
            continue;
        };
        members.sort_unstable();
        let Some(run) = make_run(&cand_pos, &members, r, params.min_length * r) else {
            // A rejected run (too short: a stray seed on a flank or in a corner region) must
            // not punch a hole in the band a better seed will grow along; only its seed retires.
            taken[seed as usize] = true;
            continue;
        };
        for &m in &members {
            taken[m] = true;
        }
        {
            // The run's band is wider than its tube where the edge is rounded or noisy: the
            // agreeing candidates on its flanks belong to it too and must not seed a parallel
            // shadow run.
            let reach = params.absorb * r;
            let cl = &run.centreline;
            for w in 0..cl.len().max(1) {
                let (a, b) = (cl[w.min(cl.len() - 1)], cl[(w + 1).min(cl.len() - 1)]);
                grid.for_each_near_segment(a, b, reach, |j| {
                    let j = j as usize;
                    // Only beside the run, never beyond its ends: there lie corner regions and
                    // the other edges' bands.
                    let t = dot(sub(cand_pos[j], run.origin), run.direction);
                    if t >= run.t_range[0]
                        && t <= run.t_range[1]
                        && dot(dirs[j], run.direction).abs() >= cos_dir
                    {
                        taken[j] = true;
                    }
                });
            }
            let mut ids: Vec<u32> = members.iter().map(|&m| cand[m]).collect();
            ids.sort_unstable();
            runs.push(Run { points: ids, ..run });
        }
    }
    let runs = merge_collinear(runs, positions, r, params);
    let runs = drop_sparse(runs, params.min_density);
    let (runs, vertices) = find_vertices(runs, r, params);
    for (k, run) in runs.iter().enumerate() {
        for &p in &run.points {
            label[p as usize] = k as u32;
        }
    }
    Segments {
        runs,
        vertices,
        label,
    }
}

struct Grower<'a> {
    pos: &'a [[f64; 3]],
    dirs: &'a [[f64; 3]],
    grid: &'a Grid,
    r: f64,
    tube: f64,
    cos_dir: f64,
    cos_turn: f64,
}

impl Grower<'_> {
    /// Candidate indices of the run grown from `seed`, or `None` when the seed has too few
    /// agreeing neighbours to define a direction.
    fn grow(&self, seed: usize, taken: &[bool]) -> Option<Vec<usize>> {
        let d_seed = self.dirs[seed];
        if norm(d_seed) < 0.5 {
            return None;
        }
        // Initial line: the agreeing candidates around the seed.
        let mut start: Vec<usize> = Vec::new();
        self.grid
            .for_each_within(self.pos[seed], self.r, |j, _, _| {
                let j = j as usize;
                if !taken[j] && dot(self.dirs[j], d_seed).abs() >= self.cos_dir {
                    start.push(j);
                }
            });
        if start.len() < 4 {
            return None;
        }
        let (o, d0) = pca_line(self.pos, &start)?;
        if dot(d0, d_seed).abs() < self.cos_dir {
            return None;
        }
        let mut members = start.clone();
        let mut is_member: std::collections::HashSet<usize> = start.iter().copied().collect();
        for sign in [1.0, -1.0] {
            let mut dir = d0.map(|c| c * sign);
            let t_end = start
                .iter()
                .map(|&m| dot(sub(self.pos[m], o), dir))
                .fold(0.0, f64::max);
            let mut front = add(o, dir.map(|c| c * t_end));
            // The last few steps: the window that gives the local tangent.
            let mut recent: std::collections::VecDeque<Vec<usize>> = [start.clone()].into();
            loop {
                // Look one radius ahead; bridge a hole in the band (noise can thin it) by
                // looking up to two more radii further before ending the run.
                let mut step: Vec<usize> = Vec::new();
                for ahead in [0.75, 1.5, 2.25] {
                    let q = add(front, dir.map(|c| c * ahead * self.r));
                    self.grid.for_each_within(q, self.r, |j, _, _| {
                        let j = j as usize;
                        if taken[j] || is_member.contains(&j) {
                            return;
                        }
                        let v = sub(self.pos[j], front);
                        let t = dot(v, dir);
                        let perp = norm(sub(v, dir.map(|c| c * t)));
                        if t > 0.0
                            && perp <= self.tube
                            && dot(self.dirs[j], dir).abs() >= self.cos_dir
                        {
                            step.push(j);
                        }
                    });
                    if step.len() >= 2 {
                        break;
                    }
                }
                step.sort_unstable();
                step.dedup();
                if step.len() < 2 {
                    break;
                }
                let window: Vec<usize> = recent.iter().flatten().chain(&step).copied().collect();
                let Some((wc, wd)) = pca_line(self.pos, &window) else {
                    break;
                };
                let wd = if dot(wd, dir) < 0.0 { neg(wd) } else { wd };
                // The tangent turned too fast for a gently curving edge: a corner.
                if dot(wd, dir) < self.cos_turn {
                    break;
                }
                let t_new = step
                    .iter()
                    .map(|&j| dot(sub(self.pos[j], wc), wd))
                    .fold(f64::NEG_INFINITY, f64::max);
                let new_front = add(wc, wd.map(|c| c * t_new));
                is_member.extend(step.iter().copied());
                members.extend(step.iter().copied());
                // A step that does not advance (a dense clump) ends the run.
                if dot(sub(new_front, front), wd) < 0.05 * self.r {
                    break;
                }
                front = new_front;
                dir = wd;
                recent.push_back(step);
                if recent.len() > 8 {
                    recent.pop_front();
                }
            }
        }
        Some(members)
    }
}

/// Builds the run's line, extent and centre line; `None` when shorter than `min_length`.
fn make_run(pos: &[[f64; 3]], members: &[usize], r: f64, min_length: f64) -> Option<Run> {
    let (o, d) = pca_line(pos, members)?;
    let ts: Vec<f64> = members.iter().map(|&m| dot(sub(pos[m], o), d)).collect();
    let t0 = ts.iter().copied().fold(f64::INFINITY, f64::min);
    let t1 = ts.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if t1 - t0 < min_length {
        return None;
    }
    // Centre line: centroids of windows one radius long (by position along the best line;
    // a gently curving run is still a graph over its chord).
    let nwin = (((t1 - t0) / r).ceil() as usize).max(1);
    let mut acc = vec![([0.0f64; 3], 0usize); nwin];
    for (k, &m) in members.iter().enumerate() {
        let w = (((ts[k] - t0) / r) as usize).min(nwin - 1);
        acc[w].0 = add(acc[w].0, pos[m]);
        acc[w].1 += 1;
    }
    let centreline = acc
        .into_iter()
        .filter(|a| a.1 > 0)
        .map(|(s, n)| s.map(|c| c / n as f64))
        .collect();
    Some(Run {
        points: Vec::new(),
        origin: o,
        direction: d,
        t_range: [t0, t1],
        centreline,
        vertices: [None, None],
    })
}

/// Merges runs that continue each other: nearly parallel, collinear within the tube, ends
/// facing each other across a gap of at most `vertex_reach` radii. Noise can break one edge's
/// band into pieces; a real vertex always has a turn.
fn merge_collinear(
    mut runs: Vec<Run>,
    positions: &[[f64; 3]],
    r: f64,
    params: &SegmentParams,
) -> Vec<Run> {
    // The lateral-offset and gap checks below decide collinearity; the angle only has to
    // allow a short piece whose direction is poorly determined.
    let cos_par = params
        .turn_angle
        .max(params.direction_tolerance)
        .to_radians()
        .cos();
    loop {
        let mut merged = None;
        'outer: for a in 0..runs.len() {
            for b in a + 1..runs.len() {
                let len = |r: &Run| r.t_range[1] - r.t_range[0];
                // Measure against the longer run: its direction is the better known.
                let (ra, rb) = if len(&runs[a]) >= len(&runs[b]) {
                    (&runs[a], &runs[b])
                } else {
                    (&runs[b], &runs[a])
                };
                if dot(ra.direction, rb.direction).abs() < cos_par {
                    continue;
                }
                // Distance of b's centroid to a's line, and the gap along a's direction.
                let off = sub(rb.origin, ra.origin);
                let t = dot(off, ra.direction);
                let perp = norm(sub(off, ra.direction.map(|c| c * t)));
                if perp > params.tube * r {
                    continue;
                }
                let tb: Vec<f64> = [rb.t_range[0], rb.t_range[1]]
                    .iter()
                    .map(|&s| t + s * dot(rb.direction, ra.direction))
                    .collect();
                let (b0, b1) = (tb[0].min(tb[1]), tb[0].max(tb[1]));
                let gap = (b0 - ra.t_range[1]).max(ra.t_range[0] - b1);
                if gap <= params.vertex_reach * r {
                    merged = Some((a, b));
                    break 'outer;
                }
            }
        }
        let Some((a, b)) = merged else { return runs };
        let rb = runs.remove(b);
        let ra = &runs[a];
        let mut points = ra.points.clone();
        points.extend(rb.points);
        points.sort_unstable();
        let members: Vec<usize> = points.iter().map(|&p| p as usize).collect();
        match make_run(positions, &members, r, 0.0) {
            Some(run) => runs[a] = Run { points, ..run },
            None => runs[a].points = points,
        }
    }
}

/// Drops runs whose candidates per unit length fall below `share` of the median run's: a
/// real edge's band is as wide along its whole length, while stray agreeing candidates in a
/// corner region or on a curved patch are a thin trail.
fn drop_sparse(runs: Vec<Run>, share: f64) -> Vec<Run> {
    let density =
        |r: &Run| r.points.len() as f64 / (r.t_range[1] - r.t_range[0]).max(f64::MIN_POSITIVE);
    let mut d: Vec<f64> = runs.iter().map(density).collect();
    if d.is_empty() {
        return runs;
    }
    let mid = d.len() / 2;
    let median = *d.select_nth_unstable_by(mid, f64::total_cmp).1;
    runs.into_iter()
        .filter(|r| density(r) >= share * median)
        .collect()
}

/// Groups run ends whose lines meet near them into vertices.
fn find_vertices(mut runs: Vec<Run>, r: f64, params: &SegmentParams) -> (Vec<Run>, Vec<Vertex>) {
    let ends: Vec<(usize, usize)> = (0..runs.len()).flat_map(|k| [(k, 0), (k, 1)]).collect();
    // End point and outward direction of each end.
    let geo: Vec<([f64; 3], [f64; 3])> = ends
        .iter()
        .map(|&(k, e)| {
            let run = &runs[k];
            let p = add(run.origin, run.direction.map(|c| c * run.t_range[e]));
            let out = if e == 0 {
                neg(run.direction)
            } else {
                run.direction
            };
            (p, out)
        })
        .collect();
    let reach = params.vertex_reach * r;
    let gap = params.vertex_gap * r;
    let mut uf = UnionFind::new(ends.len());
    let pairs: Vec<(usize, usize)> = (0..ends.len())
        .into_par_iter()
        .flat_map_iter(|a| {
            let geo = &geo;
            let ends = &ends;
            (a + 1..ends.len()).filter_map(move |b| {
                if ends[a].0 == ends[b].0 {
                    return None;
                }
                let ((pa, da), (pb, db)) = (geo[a], geo[b]);
                let (sa, sb, dist) = closest_between_rays(pa, da, pb, db)?;
                (dist <= gap && (-reach..=reach).contains(&sa) && (-reach..=reach).contains(&sb))
                    .then_some((a, b))
            })
        })
        .collect();
    for (a, b) in pairs {
        uf.union(a, b);
    }
    let mut groups: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for e in 0..ends.len() {
        groups.entry(uf.find(e)).or_default().push(e);
    }
    let mut vertices = Vec::new();
    for (_, members) in groups {
        if members.len() < 2 {
            continue;
        }
        let lines: Vec<([f64; 3], [f64; 3])> =
            members.iter().map(|&e| (geo[e].0, geo[e].1)).collect();
        let Some(position) = nearest_point_to_lines(&lines) else {
            continue;
        };
        let id = vertices.len();
        for &e in &members {
            let (k, end) = ends[e];
            runs[k].vertices[end] = Some(id);
        }
        vertices.push(Vertex {
            position,
            ends: members.iter().map(|&e| ends[e]).collect(),
        });
    }
    (runs, vertices)
}

/// Parameters along two rays (p + s·d) of their closest points and the distance between
/// them; `None` for (nearly) parallel rays, which never meet at a vertex.
/// Formula: the standard closest-points-of-two-lines solution (e.g. Eberly, "Distance Between
/// Two Lines", Geometric Tools).
pub fn closest_between_rays(
    pa: [f64; 3],
    da: [f64; 3],
    pb: [f64; 3],
    db: [f64; 3],
) -> Option<(f64, f64, f64)> {
    let w = sub(pa, pb);
    let b = dot(da, db);
    let denom = 1.0 - b * b;
    if denom < 1e-6 {
        return None;
    }
    let (d, e) = (dot(da, w), dot(db, w));
    let sa = (b * e - d) / denom;
    let sb = (e - b * d) / denom;
    let ca = add(pa, da.map(|c| c * sa));
    let cb = add(pb, db.map(|c| c * sb));
    Some((sa, sb, norm(sub(ca, cb))))
}

/// The point minimising the sum of squared distances to the lines (point, unit direction);
/// `None` when the lines are all parallel.
pub fn nearest_point_to_lines(lines: &[([f64; 3], [f64; 3])]) -> Option<[f64; 3]> {
    let mut a = nalgebra::Matrix3::<f64>::zeros();
    let mut b = nalgebra::Vector3::<f64>::zeros();
    for (p, d) in lines {
        let d = nalgebra::Vector3::from(*d);
        let m = nalgebra::Matrix3::identity() - d * d.transpose();
        a += m;
        b += m * nalgebra::Vector3::from(*p);
    }
    // Parallel lines make `a` singular in the shared direction.
    let eig = nalgebra::SymmetricEigen::new(a);
    if eig
        .eigenvalues
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        < 1e-6 * lines.len() as f64
    {
        return None;
    }
    let x = a.lu().solve(&b)?;
    Some([x[0], x[1], x[2]])
}

/// Best line through the points (centroid, unit principal direction).
pub fn pca_line(pos: &[[f64; 3]], ids: &[usize]) -> Option<([f64; 3], [f64; 3])> {
    if ids.len() < 2 {
        return None;
    }
    let n = ids.len() as f64;
    let mut c = [0.0; 3];
    for &i in ids {
        c = add(c, pos[i]);
    }
    c = c.map(|v| v / n);
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    for &i in ids {
        let v = nalgebra::Vector3::from(sub(pos[i], c));
        m += v * v.transpose();
    }
    let eig = nalgebra::SymmetricEigen::new(m);
    let k = (0..3).max_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))?;
    if eig.eigenvalues[k] <= 0.0 {
        return None;
    }
    let v = eig.eigenvectors.column(k);
    // A fixed sign convention keeps results independent of the eigen solver's choice.
    let mut d = [v[0], v[1], v[2]];
    let big = (0..3)
        .max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
        .unwrap_or(0);
    if d[big] < 0.0 {
        d = neg(d);
    }
    Some((c, d))
}

struct UnionFind {
    parent: Vec<usize>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n).collect(),
        }
    }
    fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            self.parent[x] = self.parent[self.parent[x]];
            x = self.parent[x];
        }
        x
    }
    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        // The smaller root wins: the grouping does not depend on the order of unions.
        if ra != rb {
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            self.parent[hi] = lo;
        }
    }
}

pub(crate) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
pub(crate) fn neg(a: [f64; 3]) -> [f64; 3] {
    [-a[0], -a[1], -a[2]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::{FeatureParams, estimate_scale, features};
    use crate::progress::Progress;
    use crate::testdata::box_scan;

    /// A fixed rotation (not axis-aligned) so nothing lines up with the grid.
    fn rotate(p: [f64; 3]) -> [f64; 3] {
        let (a, b) = (0.5f64, 0.8f64);
        let (ca, sa, cb, sb) = (a.cos(), a.sin(), b.cos(), b.sin());
        let q = [ca * p[0] - sa * p[1], sa * p[0] + ca * p[1], p[2]];
        [q[0], cb * q[1] - sb * q[2], sb * q[1] + cb * q[2]]
    }

    fn box_edges(d: [f64; 3]) -> Vec<([f64; 3], [f64; 3])> {
        let mut e = Vec::new();
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for cu in [0.0, d[u]] {
                for cv in [0.0, d[v]] {
                    let mut a = [0.0; 3];
                    a[u] = cu;
                    a[v] = cv;
                    let mut b = a;
                    b[axis] = d[axis];
                    e.push((rotate(a), rotate(b)));
                }
            }
        }
        e
    }

    fn run_on(dims: [f64; 3], h: f64, sigma: f64) -> (Segments, Scale) {
        let pts: Vec<[f64; 3]> = box_scan(dims, h, sigma, 3)
            .into_iter()
            .map(rotate)
            .collect();
        let fp = FeatureParams::default();
        let spacing = crate::neighbours::mean_spacing(&pts, 20_000).unwrap();
        let scale = estimate_scale(&pts, spacing, &fp, 20_000).unwrap();
        let grid = Grid::new(&pts, scale.radius).unwrap();
        let f = features(&pts, &grid, &scale, &fp, &Progress::hidden());
        (segment(&pts, &f, &scale, &SegmentParams::default()), scale)
    }

    #[test]
    fn box_gives_twelve_runs_and_eight_three_way_vertices() {
        for sigma in [0.0, 0.15, 0.5, 1.0] {
            let dims = [40.0, 30.0, 20.0];
            let (seg, scale) = run_on(dims, 0.5, sigma * 0.5);
            let edges = box_edges(dims);
            let summary: Vec<String> = seg
                .runs
                .iter()
                .map(|r| {
                    format!(
                        "{} pts len {:.1} v {:?}",
                        r.points.len(),
                        r.t_range[1] - r.t_range[0],
                        r.vertices
                    )
                })
                .collect();
            assert_eq!(
                seg.runs.len(),
                12,
                "sigma {sigma}: {scale:?}\n{}",
                summary.join("\n")
            );
            // Every run lies along one true edge, and every edge has one run.
            let mut hit = vec![0; 12];
            for run in &seg.runs {
                let best = edges
                    .iter()
                    .enumerate()
                    .map(|(k, (a, b))| {
                        let d = sub(*b, *a);
                        let d = d.map(|c| c / norm(d));
                        let off = sub(run.origin, *a);
                        let perp = norm(sub(off, d.map(|c| c * dot(off, d))));
                        (k, perp, dot(d, run.direction).abs())
                    })
                    .min_by(|x, y| x.1.total_cmp(&y.1))
                    .unwrap();
                assert!(
                    best.1 < scale.radius,
                    "run {:?} is {} from its edge",
                    run.origin,
                    best.1
                );
                // A run's line is the band's axis, a first approximation (the edge stage
                // refines it): within 5 degrees of the edge.
                assert!(
                    best.2 > 5f64.to_radians().cos(),
                    "sigma {sigma}: run of {} points, length {:.2}, direction off by {}",
                    run.points.len(),
                    run.t_range[1] - run.t_range[0],
                    best.2.acos().to_degrees()
                );
                hit[best.0] += 1;
            }
            assert!(hit.iter().all(|&h| h == 1), "sigma {sigma}: {hit:?}");
            assert_eq!(seg.vertices.len(), 8, "sigma {sigma}: {:?}", seg.vertices);
            for v in &seg.vertices {
                assert_eq!(
                    v.ends.len(),
                    3,
                    "sigma {sigma} {v:?}\n{}",
                    summary.join("\n")
                );
            }
        }
    }
}
