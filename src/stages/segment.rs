//! Segmentation: candidate edge points → edge runs by line propagation → vertices where runs
//! meet.
//!
//! Inputs: positions, `Features` (candidate mask, edge direction and normal-tensor scores),
//! `Scale`, `SegmentParams`. Output: `Segments` — runs (their candidate points and an ordered
//! centre line, open or closed), vertices (an approximate position and the run ends that
//! meet there), and a per-point run label.
//!
//! The propagation is the paper's §2.1 carried to 3D point bands: a run starts at the most
//! edge-like candidate, fits a line to the candidates around it, and extends step by step
//! along its direction, taking the candidates ahead that lie in a tube around the line and
//! whose own edge direction agrees. It stops where no such candidates are left — at a corner
//! the candidates ahead belong to other edges and their directions disagree, or are
//! corner-like — or where the local tangent turns faster than a gently curving edge can.
//! The steps' fronts give the run's path; its candidates, binned by arc length along that
//! path, give the centre line, so a run follows a curving edge (a fillet's outline, a hole's
//! rim) and may close on itself.
//!
//! Then, in order: straight runs that overlap or continue each other along one line are
//! merged (noise breaks a band into pieces); run ends that face each other across a small gap
//! are joined; runs too sparse to be an edge's band are dropped; run ends whose end tangents
//! pass close to each other meet at a vertex. A vertex where no two runs leave at an angle
//! between `corner_angle` and its supplement is no corner: runs meeting there with a bend
//! below `corner_angle` are one edge, and are joined; what stays unjoined keeps free ends.

use rayon::prelude::*;

use crate::geometry::polyline::Polyline;
use crate::geometry::{
    add, closest_between_rays, dot, nearest_point_to_lines, neg, norm, pca_line,
    perpendicular_basis, point_line_distance, sub,
};
use crate::neighbours::Grid;
use crate::stages::features::{Features, Scale};

/// Settings of the segment stage (validated by `config`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SegmentParams {
    /// A candidate joins a run when its edge direction is within this angle of the run's
    /// (degrees).
    pub direction_tolerance: f64,
    /// A run stops when its local direction turns by more than this per neighbourhood radius
    /// it advances (degrees); gentle curves turn less and are followed.
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
    /// Two runs meeting end to end with a turn below this angle (degrees) are one edge that
    /// bends there, not two edges at a corner.
    pub corner_angle: f64,
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
            corner_angle: 30.0,
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
    /// Centre line from one end to the other: centroids of the run's candidates in windows
    /// one radius long along the run, its first and last points at the run's extreme
    /// candidates. It follows a curving run; a closed run's last point connects to its first.
    pub centreline: Vec<[f64; 3]>,
    /// The run goes round a closed curve (a hole's rim): it has no ends and no vertices.
    pub closed: bool,
    /// The vertex at each end (`[start, end]` of the centre line), if any.
    pub vertices: [Option<usize>; 2],
}

impl Run {
    /// The centre line as an arc-length parametrised polyline; `None` only for a run whose
    /// centre line collapsed to a point (never produced by `segment`).
    pub fn polyline(&self) -> Option<Polyline> {
        Polyline::new(&self.centreline, self.closed)
    }

    /// Length along the centre line.
    pub fn length(&self) -> f64 {
        self.polyline().map_or(0.0, |p| p.length())
    }

    /// End point and outward unit tangent of end `e` (0 = start, 1 = end). A straight run
    /// (its centre line within half a radius `r` of its best line) ends on that line, which all
    /// its points determine; a curving run by its tangent over its last three radii.
    pub fn end(&self, e: usize, r: f64) -> ([f64; 3], [f64; 3]) {
        let line = self.polyline().filter(|_| !self.is_straight(0.5 * r));
        match line {
            Some(p) => {
                let (point, chord) = p.end(e, 3.0 * r);
                // The chord of the last radii lags behind the curve by half their arc (11° on a
                // rim eight radii across): take the tangent of a quadratic through them.
                let cl = &self.centreline;
                let near: Vec<usize> = (0..cl.len())
                    .filter(|&i| norm(sub(cl[i], point)) <= 4.0 * r)
                    .collect();
                let tangent = pca_line(cl, &near)
                    .and_then(|(c, d)| {
                        let d = if dot(d, chord) < 0.0 { neg(d) } else { d };
                        quadratic_end(cl, &near, c, d, dot(sub(point, c), d))
                    })
                    .map_or(chord, |(_, t)| t);
                (point, tangent)
            }
            None => {
                let (first, last) = (
                    self.centreline.first().copied().unwrap_or(self.origin),
                    self.centreline.last().copied().unwrap_or(self.origin),
                );
                let (p, other) = if e == 0 { (first, last) } else { (last, first) };
                let v = sub(p, self.origin);
                let on = add(
                    self.origin,
                    self.direction.map(|c| c * dot(v, self.direction)),
                );
                // The best line is unoriented: point it out of this end.
                let out = if dot(sub(p, other), self.direction) < 0.0 {
                    neg(self.direction)
                } else {
                    self.direction
                };
                (on, out)
            }
        }
    }

    /// Whether the centre line stays within `tol` of the run's best line.
    fn is_straight(&self, tol: f64) -> bool {
        self.centreline.iter().all(|&p| {
            let v = sub(p, self.origin);
            norm(sub(v, self.direction.map(|c| c * dot(v, self.direction)))) <= tol
        })
    }
}

/// Where two or more runs meet.
#[derive(Debug, Clone, PartialEq)]
pub struct Vertex {
    /// Least-squares point nearest to the end tangent lines of the meeting runs.
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

impl Segments {
    /// Runs and vertices of a cloud of `n` points, with each point's run label.
    fn new(runs: Vec<Run>, vertices: Vec<Vertex>, n: usize) -> Segments {
        let mut label = vec![NO_RUN; n];
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
    if cand.len() < 3 {
        return Segments::new(Vec::new(), Vec::new(), positions.len());
    }
    let cand_pos: Vec<[f64; 3]> = cand.iter().map(|&i| positions[i as usize]).collect();
    let Ok(grid) = Grid::new(&cand_pos, r) else {
        return Segments::new(Vec::new(), Vec::new(), positions.len());
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
            max_turn: params.turn_angle.to_radians(),
        };
        let Some(grown) = grower.grow(seed as usize, &taken) else {
            taken[seed as usize] = true;
            continue;
        };
        let mut members = grown.members;
        members.sort_unstable();
        let Some(run) = make_run(
            &cand_pos,
            &members,
            &grown.path,
            grown.closed,
            r,
            params.min_length * r,
        ) else {
            // A rejected run (too short: a stray seed on a flank or in a corner region) must
            // not punch a hole in the band a better seed will grow along; only its seed retires.
            taken[seed as usize] = true;
            continue;
        };
        for &m in &members {
            taken[m] = true;
        }
        absorb(
            &run,
            &grid,
            &cand_pos,
            &dirs,
            r,
            params.absorb * r,
            cos_dir,
            &mut taken,
        );
        let mut ids: Vec<u32> = members.iter().map(|&m| cand[m]).collect();
        ids.sort_unstable();
        runs.push(Run { points: ids, ..run });
    }
    let grown = runs.len();
    let runs = merge_collinear(runs, positions, r, params);
    let merged = runs.len();
    let joins = continuation_joins(&runs, r, params);
    let runs = chain(runs, &joins, positions);
    let chained = runs.len();
    let runs = drop_sparse(runs, params.min_density);
    tracing::debug!(
        "segment: {grown} runs grown, {merged} after merging straight pieces, {chained} after \
         {} end-to-end joins, {} dense enough",
        joins.len(),
        runs.len()
    );
    let (runs, vertices) = connect(runs, positions, r, params);
    Segments::new(runs, vertices, positions.len())
}

/// The vertices of a set of runs: ends grouped where they meet, runs that only bend there
/// joined (then the remaining ends grouped again: their geometry is unchanged by a join),
/// and what still does not turn dropped.
fn connect(
    runs: Vec<Run>,
    positions: &[[f64; 3]],
    r: f64,
    params: &SegmentParams,
) -> (Vec<Run>, Vec<Vertex>) {
    let (runs, vertices) = find_vertices(runs, r, params);
    let smooth = smooth_vertices(&runs, &vertices, r, params);
    let (runs, vertices) = if smooth.is_empty() {
        (runs, vertices)
    } else {
        let runs = chain(runs, &smooth, positions);
        find_vertices(runs, r, params)
    };
    let (runs, vertices) = detach_duplicates(runs, vertices, r);
    drop_straight_vertices(runs, vertices, r, params)
}

/// Two runs leaving a vertex within this angle of each other (degrees) run side by side: one
/// is a stray piece along the other (a fillet's tangent line beside an arc), not a second edge
/// of the corner. (The sharpest corner of a part, where a 30° wedge meets its end face, has
/// its edges 30° apart.)
const SAME_WAY: f64 = 15.0;

/// Detaches from each vertex the ends of shorter runs that leave it the same way as a longer
/// one (see [`SAME_WAY`]): such a pair has no corner between them, and a face only a sliver
/// wide would keep the longer run's slabs far from the vertex.
fn detach_duplicates(
    mut runs: Vec<Run>,
    mut vertices: Vec<Vertex>,
    r: f64,
) -> (Vec<Run>, Vec<Vertex>) {
    let cos_same = SAME_WAY.to_radians().cos();
    let lengths: Vec<f64> = runs.iter().map(Run::length).collect();
    for (v, vertex) in vertices.iter_mut().enumerate() {
        let mut ends = vertex.ends.clone();
        ends.sort_by(|a, b| lengths[b.0].total_cmp(&lengths[a.0]).then(a.cmp(b)));
        let mut kept: Vec<((usize, usize), [f64; 3])> = Vec::new();
        for end in ends {
            let t = runs[end.0].end(end.1, r).1;
            if kept.iter().any(|(_, u)| dot(t, *u) > cos_same) {
                if runs[end.0].vertices[end.1] == Some(v) {
                    runs[end.0].vertices[end.1] = None;
                }
            } else {
                kept.push((end, t));
            }
        }
        vertex.ends.retain(|e| kept.iter().any(|(k, _)| k == e));
    }
    (runs, vertices)
}

/// `segments` without the runs marked in `drop` (runs the edge stage found to be no sharp
/// edge: a fillet, a gently bending surface), their vertices found again: a virtual vertex
/// where straight edges ran into a fillet's arc goes with the fillet's runs, and the edges
/// of the part's own corners meet as they should.
pub fn without_runs(
    positions: &[[f64; 3]],
    segments: Segments,
    drop: &[bool],
    scale: &Scale,
    params: &SegmentParams,
) -> Segments {
    let runs: Vec<Run> = segments
        .runs
        .into_iter()
        .zip(drop)
        .filter(|(_, d)| !**d)
        .map(|(run, _)| run)
        .collect();
    let (runs, vertices) = connect(runs, positions, scale.radius, params);
    Segments::new(runs, vertices, segments.label.len())
}

/// Marks the agreeing candidates on an accepted run's flanks as taken: the run's band is
/// wider than its tube where the edge is rounded or noisy, and they must not seed a parallel
/// shadow run. Only beside the run, never beyond its ends: there lie corner regions and the
/// other edges' bands.
#[allow(clippy::too_many_arguments)]
fn absorb(
    run: &Run,
    grid: &Grid,
    cand_pos: &[[f64; 3]],
    dirs: &[[f64; 3]],
    r: f64,
    reach: f64,
    cos_dir: f64,
    taken: &mut [bool],
) {
    let Some(line) = run.polyline() else { return };
    // Beyond an end: ahead of the end point along its outward tangent (any segment's capsule
    // near an end reaches past it).
    let ends = (!run.closed).then(|| [run.end(0, r), run.end(1, r)]);
    for k in 0..line.segments() {
        let (a, b) = line.segment(k);
        let d = sub(b, a);
        let d = d.map(|c| c / norm(d));
        grid.for_each_near_segment(a, b, reach, |j| {
            let j = j as usize;
            let beyond = ends.is_some_and(|ends| {
                ends.iter()
                    .any(|&(p, out)| dot(sub(cand_pos[j], p), out) > 0.0)
            });
            if !beyond && dot(dirs[j], d).abs() >= cos_dir {
                taken[j] = true;
            }
        });
    }
}

/// What one growth gives: the members (candidate indices), the path of the growth fronts
/// from one end to the other, and whether the path closed on itself.
struct Grown {
    members: Vec<usize>,
    path: Vec<[f64; 3]>,
    closed: bool,
}

/// Steps in the window whose direction decides a turn and whose curve the growth follows.
const LONG_WINDOW: usize = 8;

/// Point and unit tangent at `u` of the quadratic `p(u) = c + u·d + (a + b·u + k·u²)` fitted
/// (least squares, per perpendicular axis) to the points `ids`, `u` their position along
/// `d` from `c`; `None` when the points do not spread along `d` enough to fit it.
fn quadratic_end(
    pos: &[[f64; 3]],
    ids: &[usize],
    c: [f64; 3],
    d: [f64; 3],
    u: f64,
) -> Option<([f64; 3], [f64; 3])> {
    // Centre-line samples are averages already; raw candidates need a few more to steady
    // the fit.
    let min_points = 4;
    let (e1, e2) = perpendicular_basis(d);
    let scale = ids
        .iter()
        .map(|&i| dot(sub(pos[i], c), d).abs())
        .fold(0.0, f64::max);
    if scale.is_nan() || scale <= 0.0 || ids.len() < min_points {
        return None;
    }
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    let mut b = [nalgebra::Vector3::<f64>::zeros(); 2];
    for &i in ids {
        let v = sub(pos[i], c);
        let x = dot(v, d) / scale;
        let basis = nalgebra::Vector3::new(1.0, x, x * x);
        m += basis * basis.transpose();
        b[0] += basis * dot(v, e1);
        b[1] += basis * dot(v, e2);
    }
    let chol = nalgebra::linalg::Cholesky::new(m)?;
    let (f1, f2) = (chol.solve(&b[0]), chol.solve(&b[1]));
    let x = u / scale;
    let at = |f: &nalgebra::Vector3<f64>| f[0] + f[1] * x + f[2] * x * x;
    let slope = |f: &nalgebra::Vector3<f64>| (f[1] + 2.0 * f[2] * x) / scale;
    let p = add(
        c,
        add(
            d.map(|k| k * u),
            add(e1.map(|k| k * at(&f1)), e2.map(|k| k * at(&f2))),
        ),
    );
    let t = add(
        d,
        add(e1.map(|k| k * slope(&f1)), e2.map(|k| k * slope(&f2))),
    );
    let l = norm(t);
    (l.is_finite() && p.iter().all(|v| v.is_finite())).then(|| (p, t.map(|k| k / l)))
}

struct Grower<'a> {
    pos: &'a [[f64; 3]],
    dirs: &'a [[f64; 3]],
    grid: &'a Grid,
    r: f64,
    tube: f64,
    cos_dir: f64,
    /// Largest turn of the tangent per radius advanced (radians).
    max_turn: f64,
}

impl Grower<'_> {
    /// The run grown from `seed`, or `None` when the seed has too few agreeing neighbours to
    /// define a direction.
    fn grow(&self, seed: usize, taken: &[bool]) -> Option<Grown> {
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
        // The fronts of each direction's steps, in order away from the seed.
        let mut fronts: [Vec<[f64; 3]>; 2] = [Vec::new(), Vec::new()];
        // Where the other direction will start: a growth that comes round to it has closed
        // a loop (a hole's rim) and must stop before it laps the run's own flanks.
        let back = start
            .iter()
            .map(|&m| dot(sub(self.pos[m], o), d0))
            .fold(0.0, f64::min);
        let loop_start = add(o, d0.map(|c| c * back));
        let mut closed = false;
        for (side, sign) in [1.0, -1.0].into_iter().enumerate() {
            if closed {
                break;
            }
            let mut travelled = 0.0;
            let mut dir = d0.map(|c| c * sign);
            let mut steady = dir;
            let t_end = start
                .iter()
                .map(|&m| dot(sub(self.pos[m], o), dir))
                .fold(0.0, f64::max);
            let mut front = add(o, dir.map(|c| c * t_end));
            fronts[side].push(front);
            // The last steps: the window that gives the local direction and curve.
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
                    tracing::trace!("run growth: no candidates ahead of {front:?}");
                    break;
                }
                // The window's best line (its chord) gives a steady direction to tell a turn
                // from noise. The front and the tangent there come from a quadratic through the
                // window: the chord lags behind a curving edge by half the window's arc (22° on
                // a rim five radii across), and a line along it would leave its tube.
                let window: Vec<usize> = recent.iter().flatten().chain(&step).copied().collect();
                let Some((wc, wl)) = pca_line(self.pos, &window) else {
                    break;
                };
                let wl = if dot(wl, steady) < 0.0 { neg(wl) } else { wl };
                let u_front = step
                    .iter()
                    .map(|&j| dot(sub(self.pos[j], wc), wl))
                    .fold(f64::NEG_INFINITY, f64::max);
                let (new_front, wd) = quadratic_end(self.pos, &window, wc, wl, u_front)
                    .unwrap_or((add(wc, wl.map(|c| c * u_front)), wl));
                // The tangent turned too fast for a gently curving edge: a corner. The turn is
                // measured per radius advanced, so a long step on a hole's rim is not a corner.
                let advance = dot(sub(new_front, front), wl).max(self.r);
                let turn = dot(wl, steady).clamp(-1.0, 1.0).acos();
                if turn > self.max_turn * advance / self.r {
                    tracing::trace!(
                        "run growth: turned {:.1}° over {:.2} radii at {front:?}",
                        turn.to_degrees(),
                        advance / self.r
                    );
                    break;
                }
                is_member.extend(step.iter().copied());
                members.extend(step.iter().copied());
                // A step that does not advance (a dense clump) ends the run.
                if dot(sub(new_front, front), wl) < 0.05 * self.r {
                    break;
                }
                travelled += norm(sub(new_front, front));
                front = new_front;
                fronts[side].push(front);
                if side == 0
                    && travelled >= 6.0 * self.r
                    && norm(sub(front, loop_start)) <= 2.0 * self.r
                {
                    closed = true;
                    break;
                }
                dir = wd;
                steady = wl;
                recent.push_back(step);
                if recent.len() > LONG_WINDOW {
                    recent.pop_front();
                }
            }
        }
        let [plus, minus] = fronts;
        let mut path: Vec<[f64; 3]> = minus.into_iter().rev().collect();
        path.extend(plus);
        if closed {
            path.insert(0, loop_start);
        }
        Some(Grown {
            members,
            path,
            closed,
        })
    }
}

/// Builds a run from its members and the path they were grown along: its best line, and its
/// centre line (the members' centroids in windows one radius long along the path, from the
/// extreme member to the extreme member). `None` when an open run is shorter than
/// `min_length` or the path is degenerate.
fn make_run(
    pos: &[[f64; 3]],
    members: &[usize],
    path: &[[f64; 3]],
    closed: bool,
    r: f64,
    min_length: f64,
) -> Option<Run> {
    let (o, d) = pca_line(pos, members)?;
    // A path too short to follow (a growth that never stepped) is the best line itself.
    let path = Polyline::new(path, closed).or_else(|| {
        let ts = members.iter().map(|&m| dot(sub(pos[m], o), d));
        let (t0, t1) = ts.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
            (a.min(t), b.max(t))
        });
        Polyline::new(
            &[add(o, d.map(|c| c * t0)), add(o, d.map(|c| c * t1))],
            false,
        )
    })?;
    let closed = path.closed();
    let s: Vec<f64> = members.iter().map(|&m| path.project(pos[m]).0).collect();
    let (s0, s1) = if closed {
        (0.0, path.length())
    } else {
        s.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            })
    };
    if !closed && s1 - s0 < min_length {
        return None;
    }
    let nwin = (((s1 - s0) / r).ceil() as usize).max(if closed { 3 } else { 1 });
    let width = (s1 - s0) / nwin as f64;
    let mut acc = vec![([0.0f64; 3], 0.0f64, 0usize); nwin];
    for (k, &m) in members.iter().enumerate() {
        let w = (((s[k] - s0) / width).max(0.0) as usize).min(nwin - 1);
        acc[w].0 = add(acc[w].0, pos[m]);
        acc[w].1 += s[k];
        acc[w].2 += 1;
    }
    let bins: Vec<([f64; 3], f64)> = acc
        .into_iter()
        .filter(|a| a.2 > 0)
        .map(|(p, s, n)| (p.map(|c| c / n as f64), s / n as f64))
        .collect();
    let mut centreline: Vec<[f64; 3]> = bins.iter().map(|b| b.0).collect();
    if !closed {
        // The end windows' centroids lie half a window inside the run: carry them out to the
        // extreme members along the path's end tangents.
        let (first, last) = (bins[0], bins[bins.len() - 1]);
        let t0 = path.tangent(first.1, r);
        let t1 = path.tangent(last.1, r);
        centreline.insert(0, add(first.0, t0.map(|c| c * (s0 - first.1))));
        centreline.push(add(last.0, t1.map(|c| c * (s1 - last.1))));
    }
    let closed = closed && Polyline::new(&centreline, true).is_some();
    Polyline::new(&centreline, closed)?;
    Some(Run {
        points: Vec::new(),
        origin: o,
        direction: d,
        centreline,
        closed,
        vertices: [None, None],
    })
}

/// Merges straight runs that lie along one line and overlap or leave a gap of at most
/// `vertex_reach` radii: noise can break one straight edge's band into pieces, even side by
/// side, and a real vertex always has a turn. Curved runs are joined end to end instead
/// ([`continuation_joins`]).
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
    let extent = |run: &Run| {
        run.centreline
            .iter()
            .map(|&p| dot(sub(p, run.origin), run.direction))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(t), b.max(t))
            })
    };
    loop {
        let mut merged = None;
        'outer: for a in 0..runs.len() {
            for b in a + 1..runs.len() {
                let (ra, rb) = (&runs[a], &runs[b]);
                if ra.closed || rb.closed {
                    continue;
                }
                if !ra.is_straight(params.tube * r) || !rb.is_straight(params.tube * r) {
                    continue;
                }
                let len = |r: &Run| {
                    let (t0, t1) = extent(r);
                    t1 - t0
                };
                // Measure against the longer run: its direction is the better known.
                let (ra, rb) = if len(ra) >= len(rb) {
                    (ra, rb)
                } else {
                    (rb, ra)
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
                let (a0, a1) = extent(ra);
                let (s0, s1) = extent(rb);
                let tb = [s0, s1].map(|s| t + s * dot(rb.direction, ra.direction));
                let (b0, b1) = (tb[0].min(tb[1]), tb[0].max(tb[1]));
                let gap = (b0 - a1).max(a0 - b1);
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
        // One straight run: rebuilt along the best line of all its points.
        match make_run(positions, &members, &[], false, r, 0.0) {
            Some(run) => runs[a] = Run { points, ..run },
            None => runs[a].points = points,
        }
    }
}

/// A join of two run ends ((run, end), (run, end)): the runs continue each other there.
type Join = ((usize, usize), (usize, usize));

/// Pairs of run ends that face each other across a gap of at most `vertex_reach` radii, with
/// end tangents within the direction tolerance of opposite and each end within the tube of the
/// other's end tangent line: one edge broken where noise thinned its band or where it bent a
/// little faster than the growth follows. Each end joins at most one other, nearest first. A
/// run's two ends can join each other: the run closes.
fn continuation_joins(runs: &[Run], r: f64, params: &SegmentParams) -> Vec<Join> {
    let cos_par = params
        .turn_angle
        .max(params.direction_tolerance)
        .to_radians()
        .cos();
    let ends: Vec<(usize, usize)> = (0..runs.len())
        .filter(|&k| !runs[k].closed)
        .flat_map(|k| [(k, 0), (k, 1)])
        .collect();
    let geo: Vec<([f64; 3], [f64; 3])> = ends.iter().map(|&(k, e)| runs[k].end(e, r)).collect();
    let lengths: Vec<f64> = runs.iter().map(Run::length).collect();
    let reach = params.vertex_reach * r;
    let tube = params.tube * r;
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for a in 0..ends.len() {
        for b in a + 1..ends.len() {
            let ((ka, _), (kb, _)) = (ends[a], ends[b]);
            let ((pa, ta), (pb, tb)) = (geo[a], geo[b]);
            let g = sub(pb, pa);
            let gap = norm(g);
            if gap > reach || dot(ta, tb) > -cos_par {
                continue;
            }
            // A run closing on itself must be long against the gap it closes.
            if ka == kb && lengths[ka] < 4.0 * gap.max(2.0 * r) {
                continue;
            }
            // Ahead of each other (a little overlap allowed), and each end near the other's
            // tangent line, measured from the longer run's end.
            if dot(g, ta) < -r || dot(g, tb) > r {
                continue;
            }
            let (p, t, q) = if lengths[ka] >= lengths[kb] {
                (pa, ta, pb)
            } else {
                (pb, tb, pa)
            };
            let v = sub(q, p);
            if norm(sub(v, t.map(|c| c * dot(v, t)))) > tube {
                continue;
            }
            pairs.push((gap, a, b));
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut used = vec![false; ends.len()];
    let mut joins = Vec::new();
    for (_, a, b) in pairs {
        if !used[a] && !used[b] {
            used[a] = true;
            used[b] = true;
            joins.push((ends[a], ends[b]));
        }
    }
    joins
}

/// The outward end tangents of a vertex's runs.
fn end_tangents(runs: &[Run], v: &Vertex, r: f64) -> Vec<[f64; 3]> {
    v.ends.iter().map(|&(k, e)| runs[k].end(e, r).1).collect()
}

/// Whether some two runs of a vertex leave it at an angle between `corner_angle` and its
/// supplement: the edges turn there. Runs that only continue each other (or overlap) do not.
fn turns(tangents: &[[f64; 3]], cos_corner: f64) -> bool {
    (0..tangents.len())
        .any(|i| (i + 1..tangents.len()).any(|j| dot(tangents[i], tangents[j]).abs() < cos_corner))
}

/// Joins at vertices where the runs do not turn (see [`turns`]): two runs meeting with a bend
/// below `corner_angle`, or pieces of one curve whose ends met in a gap (a hole's rim broken
/// in three). The most nearly opposite ends are joined first. Two runs alone at a vertex are
/// a bend as long as their turn stays below `corner_angle` plus what the tightest curve the
/// growth follows (`turn_angle` per radius) turns across the gap between their ends: an arc
/// broken where it is tightest turns there without a corner.
fn smooth_vertices(runs: &[Run], vertices: &[Vertex], r: f64, params: &SegmentParams) -> Vec<Join> {
    let cos_corner = params.corner_angle.to_radians().cos();
    let mut joins = Vec::new();
    for v in vertices {
        let t = end_tangents(runs, v, r);
        if v.ends.len() == 2 && v.ends[0].0 != v.ends[1].0 {
            let (a, b) = (v.ends[0], v.ends[1]);
            let gap = norm(sub(runs[a.0].end(a.1, r).0, runs[b.0].end(b.1, r).0));
            let allowed =
                params.corner_angle.to_radians() + params.turn_angle.to_radians() * gap / r;
            let turn = (-dot(t[0], t[1])).clamp(-1.0, 1.0).acos();
            if turn < allowed.min(std::f64::consts::FRAC_PI_2) {
                joins.push((a, b));
            }
            continue;
        }
        if turns(&t, cos_corner) {
            continue;
        }
        // Outward tangents: a straight continuation has them opposite.
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for i in 0..t.len() {
            for j in i + 1..t.len() {
                let c = dot(t[i], t[j]);
                if c <= -cos_corner && v.ends[i].0 != v.ends[j].0 {
                    pairs.push((c, i, j));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut used = vec![false; t.len()];
        for (_, i, j) in pairs {
            if !used[i] && !used[j] {
                used[i] = true;
                used[j] = true;
                joins.push((v.ends[i], v.ends[j]));
            }
        }
    }
    joins
}

/// Drops the vertices whose runs do not turn there (what [`smooth_vertices`] could not join:
/// runs overlapping near one point): no corner.
fn drop_straight_vertices(
    mut runs: Vec<Run>,
    vertices: Vec<Vertex>,
    r: f64,
    params: &SegmentParams,
) -> (Vec<Run>, Vec<Vertex>) {
    let cos_corner = params.corner_angle.to_radians().cos();
    let keep: Vec<bool> = vertices
        .iter()
        .map(|v| turns(&end_tangents(&runs, v, r), cos_corner))
        .collect();
    let mut id = vec![None; vertices.len()];
    let mut kept = Vec::new();
    for (v, vertex) in vertices.into_iter().enumerate() {
        if keep[v] {
            id[v] = Some(kept.len());
            kept.push(vertex);
        }
    }
    for run in &mut runs {
        run.vertices = run.vertices.map(|v| v.and_then(|v| id[v]));
    }
    (runs, kept)
}

/// Joins runs end to end along `joins` into chains (a chain whose ends join is closed) and
/// returns the chained runs: centre lines concatenated in order, points united, vertices
/// cleared (they are found afterwards). Runs in no join stay as they are.
fn chain(runs: Vec<Run>, joins: &[Join], positions: &[[f64; 3]]) -> Vec<Run> {
    if joins.is_empty() {
        return runs;
    }
    let n = runs.len();
    let mut partner: Vec<[Option<(usize, usize)>; 2]> = vec![[None, None]; n];
    for &((ka, ea), (kb, eb)) in joins {
        partner[ka][ea] = Some((kb, eb));
        partner[kb][eb] = Some((ka, ea));
    }
    let mut done = vec![false; n];
    let mut out = Vec::new();
    for k in 0..n {
        if done[k] {
            continue;
        }
        // Walk back from k's start to the chain's first run (or round a loop back to k).
        let mut first = (k, true);
        let mut closed = false;
        loop {
            let (run, forward) = first;
            let entry = if forward { 0 } else { 1 };
            let Some((prev, exit)) = partner[run][entry] else {
                break;
            };
            let elem = (prev, exit == 1);
            if elem.0 == k {
                closed = true;
                break;
            }
            first = elem;
        }
        // Then forward, collecting the runs in order with their orientation.
        let mut order = vec![first];
        loop {
            let (run, forward) = order[order.len() - 1];
            let exit = if forward { 1 } else { 0 };
            let Some((next, entry)) = partner[run][exit] else {
                break;
            };
            if next == first.0 {
                closed = true;
                break;
            }
            order.push((next, entry == 0));
        }
        for &(run, _) in &order {
            done[run] = true;
        }
        if order.len() == 1 && !closed {
            out.push(runs[order[0].0].clone());
            continue;
        }
        let mut centreline: Vec<[f64; 3]> = Vec::new();
        let mut points: Vec<u32> = Vec::new();
        for &(run, forward) in &order {
            let cl = &runs[run].centreline;
            if forward {
                centreline.extend(cl.iter().copied());
            } else {
                centreline.extend(cl.iter().rev().copied());
            }
            points.extend(runs[run].points.iter().copied());
        }
        points.sort_unstable();
        points.dedup();
        let ids: Vec<usize> = points.iter().map(|&p| p as usize).collect();
        let Some((origin, direction)) = pca_line(positions, &ids) else {
            out.extend(order.iter().map(|&(run, _)| runs[run].clone()));
            continue;
        };
        let closed = closed && Polyline::new(&centreline, true).is_some();
        out.push(Run {
            points,
            origin,
            direction,
            centreline,
            closed,
            vertices: [None, None],
        });
    }
    out
}

/// Drops runs whose candidates per unit length fall below `share` of the median run's: a
/// real edge's band is as wide along its whole length, while stray agreeing candidates in a
/// corner region or on a curved patch are a thin trail.
fn drop_sparse(runs: Vec<Run>, share: f64) -> Vec<Run> {
    let density = |r: &Run| r.points.len() as f64 / r.length().max(f64::MIN_POSITIVE);
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

/// Groups run ends whose end tangent lines meet near them into vertices.
fn find_vertices(mut runs: Vec<Run>, r: f64, params: &SegmentParams) -> (Vec<Run>, Vec<Vertex>) {
    for run in &mut runs {
        run.vertices = [None, None];
    }
    let ends: Vec<(usize, usize)> = (0..runs.len())
        .filter(|&k| !runs[k].closed)
        .flat_map(|k| [(k, 0), (k, 1)])
        .collect();
    // End point and outward direction of each end.
    let geo: Vec<([f64; 3], [f64; 3])> = ends.iter().map(|&(k, e)| runs[k].end(e, r)).collect();
    let reach = params.vertex_reach * r;
    let gap = params.vertex_gap * r;
    // Each pair of ends whose rays meet, with how far beyond the two ends they meet.
    let mut pairs: Vec<(f64, usize, usize)> = (0..ends.len())
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
                    .then_some((sa.abs() + sb.abs() + dist, a, b))
            })
        })
        .collect();
    // Whether the lines of these ends pass within `tol` of one point, each no farther than
    // the reach beyond its end. Both ends of a short piece of run near a corner may take
    // part: the vertex absorbs it.
    let meet = |members: &[usize], tol: f64| -> bool {
        let lines: Vec<([f64; 3], [f64; 3])> = members.iter().map(|&e| geo[e]).collect();
        nearest_point_to_lines(&lines).is_some_and(|position| {
            lines.iter().all(|&(p, d)| {
                let s = dot(sub(position, p), d);
                (-reach - gap..=reach + gap).contains(&s)
                    && point_line_distance(position, (p, d)) <= tol
            })
        })
    };
    // Ends that meet, directly or through others, form a vertex. When their lines do not all
    // pass near one point, the group may be several corners close together (issue 17): it is
    // split when ends joining nearest meeting first, each group only while its lines still
    // meet, give every end a partner. Grouping every meeting pair transitively joined the
    // rims and walls of a small hole, whose lines all meet within the reach of each other's
    // ends, into one vertex of 6-7 edges in its middle: its short edges then had no room for
    // slabs, and none of its corners was found (a 15-25 spacing hole: 12 of 14 corners).
    // A group that splits into lone ends is one corner seen through noisy end lines and
    // short pieces of run: splitting those as well cost real corners (seed 2 of bench
    // --random: two more spurious corners and edges).
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut whole = UnionFind::new(ends.len());
    for &(_, a, b) in &pairs {
        whole.union(a, b);
    }
    // Per group of ends that meet through others: its ends and its meeting pairs.
    type Group = (Vec<usize>, Vec<(usize, usize)>);
    let mut groups: std::collections::BTreeMap<usize, Group> = Default::default();
    for e in 0..ends.len() {
        groups.entry(whole.find(e)).or_default().0.push(e);
    }
    for &(_, a, b) in &pairs {
        groups.entry(whole.find(a)).or_default().1.push((a, b));
    }
    // The ends of each vertex: a group whole, or its parts where it splits, in the order of
    // their first ends.
    let mut vertex_ends: Vec<Vec<usize>> = Vec::new();
    for (members, group_pairs) in groups.into_values() {
        if members.len() > 2
            && !meet(&members, 2.0 * gap)
            && let Some(parts) = split_vertex(&members, &group_pairs, |m: &[usize]| meet(m, gap))
        {
            vertex_ends.extend(parts);
            continue;
        }
        vertex_ends.push(members);
    }
    vertex_ends.sort_by_key(|m| m[0]);
    let mut vertices = Vec::new();
    for members in vertex_ends {
        if members.len() < 2 {
            continue;
        }
        let lines: Vec<([f64; 3], [f64; 3])> =
            members.iter().map(|&e| (geo[e].0, geo[e].1)).collect();
        let Some(position) = nearest_point_to_lines(&lines) else {
            continue;
        };
        // Grouped through others, two ends may share a vertex whose lines meet far from
        // them (nearly parallel rays): such a vertex is no meeting point.
        if members
            .iter()
            .any(|&e| norm(sub(position, geo[e].0)) > reach + gap)
        {
            continue;
        }
        let id = vertices.len();
        tracing::trace!(
            "vertex {id} at {position:?}: run ends {:?}",
            members
                .iter()
                .map(|&e| (ends[e], dot(sub(position, geo[e].0), geo[e].1)))
                .collect::<Vec<_>>()
        );
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

/// Splits a group of run ends (`members`, ascending ids into the caller's ends) by joining
/// the `pairs` (sorted nearest meeting first) only while `meet` accepts the joined ends; the
/// parts, each ascending, or `None` when an end is left without a partner or nothing splits.
fn split_vertex(
    members: &[usize],
    pairs: &[(usize, usize)],
    meet: impl Fn(&[usize]) -> bool,
) -> Option<Vec<Vec<usize>>> {
    let local = |e: usize| members.binary_search(&e).ok();
    let mut uf = UnionFind::new(members.len());
    let mut parts: Vec<Vec<usize>> = members.iter().map(|&e| vec![e]).collect();
    for &(a, b) in pairs {
        let (ra, rb) = (uf.find(local(a)?), uf.find(local(b)?));
        if ra == rb {
            continue;
        }
        let both: Vec<usize> = parts[ra].iter().chain(&parts[rb]).copied().collect();
        if !meet(&both) {
            continue;
        }
        uf.union(ra, rb);
        let root = uf.find(ra);
        parts[root] = both;
        parts[if root == ra { rb } else { ra }].clear();
    }
    parts.retain(|p| !p.is_empty());
    if parts.len() < 2 || parts.iter().any(|p| p.len() < 2) {
        return None;
    }
    for p in &mut parts {
        p.sort_unstable();
    }
    Some(parts)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Progress;
    use crate::stages::features::{FeatureParams, features};
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
        let local = crate::stages::scale::local_scale(&pts, spacing, &fp.scale_rules()).unwrap();
        let grid = Grid::new(&pts, local.summary().radius).unwrap();
        let f = features(&pts, &grid, &local, &fp, &Progress::hidden());
        // As the pipeline does: runs grown at the candidates' scale.
        let scale = local
            .around((0..pts.len() as u32).filter(|&i| f.candidate[i as usize]))
            .unwrap();
        (segment(&pts, &f, &scale, &SegmentParams::default()), scale)
    }

    #[test]
    fn box_gives_twelve_runs_and_eight_three_way_vertices() {
        for sigma in [0.0, 0.15, 0.5, 1.0] {
            // 120 x 90 x 60 pitches: at sigma = 0.5 (0.6 spacings measured) the local scale
            // makes neighbourhoods 6 spacings wide, and on the 80 x 60 x 40 box of before a
            // short face's two edges then met in one five-ended vertex.
            let dims = [60.0, 45.0, 30.0];
            let (seg, scale) = run_on(dims, 0.5, sigma * 0.5);
            let edges = box_edges(dims);
            let summary: Vec<String> = seg
                .runs
                .iter()
                .map(|r| {
                    format!(
                        "{} pts len {:.1} v {:?}",
                        r.points.len(),
                        r.length(),
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
                // refines it): within 6 degrees of the edge (a short run at sigma = 0.5
                // spacing, whose neighbourhoods are 5 spacings wide: 5.3°).
                assert!(
                    best.2 > 6f64.to_radians().cos(),
                    "sigma {sigma}: run of {} points, length {:.2}, direction off by {}",
                    run.points.len(),
                    run.length(),
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

    /// A straight run from `a` to `b` (its centre line sampled every half unit).
    fn straight_run(a: [f64; 3], b: [f64; 3]) -> Run {
        let d = sub(b, a);
        let len = norm(d);
        let n = (len / 0.5).ceil() as usize;
        Run {
            points: Vec::new(),
            origin: add(a, d.map(|c| 0.5 * c)),
            direction: d.map(|c| c / len),
            centreline: (0..=n)
                .map(|i| add(a, d.map(|c| c * i as f64 / n as f64)))
                .collect(),
            closed: false,
            vertices: [None, None],
        }
    }

    /// Issue 17: the rims and walls of a square hole 4 radii across (its lines all meet
    /// within the reach of 5 radii of each other's ends) give its four corners, each with
    /// the three runs that end there, not one vertex of twelve ends in the middle.
    #[test]
    fn issue17_a_small_hole_keeps_its_corners_apart() {
        let r = 1.0;
        let side = 4.0;
        let corners = [
            [0.0, 0.0, 0.0],
            [side, 0.0, 0.0],
            [side, side, 0.0],
            [0.0, side, 0.0],
        ];
        // Runs stop short of their corners, as the candidates of a rounded corner do.
        let short = 0.6;
        let mut runs = Vec::new();
        for k in 0..4 {
            let (a, b) = (corners[k], corners[(k + 1) % 4]);
            let d = sub(b, a).map(|c| c / side);
            runs.push(straight_run(
                add(a, d.map(|c| c * short)),
                sub(b, d.map(|c| c * short)),
            ));
        }
        for c in corners {
            runs.push(straight_run(
                sub(c, [0.0, 0.0, short]),
                sub(c, [0.0, 0.0, 30.0]),
            ));
        }
        let (runs, vertices) = find_vertices(runs, r, &SegmentParams::default());
        assert_eq!(vertices.len(), 4, "{vertices:?}");
        for v in &vertices {
            assert_eq!(v.ends.len(), 3, "{v:?}");
            let nearest = corners
                .iter()
                .map(|c| norm(sub(*c, v.position)))
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < 1e-9, "vertex at {:?}", v.position);
        }
        for run in &runs[..4] {
            assert!(run.vertices[0].is_some() && run.vertices[1].is_some());
            assert_ne!(run.vertices[0], run.vertices[1]);
        }
    }
}
