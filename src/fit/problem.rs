//! What the 2D profile fit and the 3D vertex fit share: the local frame they compute in, the
//! prepared search problem the searchers run on, and the helpers that pick the candidates
//! and rectify points.
//!
//! Every fit first maps its input to a frame centred on the approximate corner and scaled by
//! the points' RMS radius. All arithmetic (propagation, fits, swarm) happens there and results
//! are mapped back. This is what makes the fits independent of units and of where the part
//! sits: a part in mm and the same part in m give the same corner, scaled, and a scan with a
//! georeferenced offset loses no digits.

use super::line::Line;
use crate::geometry::{axpy, dot, norm2, sub};

/// The similarity map between the input coordinates and a fit's local frame:
/// local = (input − origin) / unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame<const D: usize> {
    pub origin: [f64; D],
    pub unit: f64,
}

impl<const D: usize> Frame<D> {
    /// Input coordinates of a local point.
    #[inline]
    pub fn to_input(&self, q: &[f64; D]) -> [f64; D] {
        axpy(self.origin, self.unit, q)
    }

    /// Local coordinates of an input point.
    #[inline]
    pub fn to_local(&self, p: &[f64; D]) -> [f64; D] {
        let inv = 1.0 / self.unit;
        std::array::from_fn(|k| (p[k] - self.origin[k]) * inv)
    }

    /// A local length (error, distance, noise) in input units.
    #[inline]
    pub fn length_to_input(&self, x: f64) -> f64 {
        x * self.unit
    }

    /// A local line in input coordinates.
    pub fn line_to_input(&self, l: &Line<D>) -> Line<D> {
        Line {
            point: self.to_input(&l.point),
            direction: l.direction,
        }
    }
}

/// A prepared search problem in a fit's local frame: the objective with the slopes fixed,
/// the swarm's starting points, its frame and the scale of its initial velocities, and the
/// point-to-line assignment. The searchers ([`super::pso::pso`], [`super::ga::ga`],
/// [`super::scheme1::scheme1`], the exact solvers) all run on this, which is how the
/// experiment times each one separately.
#[derive(Clone, Copy, Debug)]
pub struct Problem<'a, const D: usize, O> {
    /// Error of a corner with the local slopes (paper Eq. 11 / 13, local units).
    pub objective: &'a O,
    /// Starting particles = Scheme 1 candidates (data points, local frame).
    pub candidates: &'a [[f64; D]],
    /// The swarm's orthonormal frame (rows), attached to the corner's side directions.
    pub basis: [[f64; D]; D],
    /// Extent of the candidates (RMS radius, local units): the initial velocity's scale.
    pub scale: f64,
    /// Where the local side fits meet (their intersection in 2D, the least-squares point of
    /// the lines in 3D), local frame: the piecewise estimate, which
    /// [`super::FitParams::seed_with_intersection`] adds to the starting swarm.
    pub meeting: Option<[f64; D]>,
    /// All input points in the local frame.
    pub points: &'a [[f64; D]],
    /// Per line: indices of the points scored against it.
    pub assigned: &'a [Vec<usize>],
    /// The map back to input coordinates.
    pub frame: Frame<D>,
}

impl<const D: usize, O> Problem<'_, D, O> {
    /// The swarm's starting positions: the candidates, and the local fits' meeting point when
    /// `seed_with_intersection` asks for it.
    pub fn initial_swarm(&self, seed_with_intersection: bool, into: &mut Vec<[f64; D]>) {
        into.clear();
        into.extend_from_slice(self.candidates);
        if seed_with_intersection && let Some(q) = self.meeting {
            into.push(q);
        }
    }
}

/// RMS distance of `pts[idx]` from their centroid.
pub(crate) fn rms_radius<const D: usize>(
    pts: &[[f64; D]],
    idx: impl Iterator<Item = usize> + Clone,
) -> f64 {
    let mut n = 0usize;
    let mut c = [0.0; D];
    for i in idx.clone() {
        n += 1;
        for k in 0..D {
            c[k] += pts[i][k];
        }
    }
    if n == 0 {
        return 0.0;
    }
    for x in c.iter_mut() {
        *x /= n as f64;
    }
    (idx.map(|i| norm2(sub(pts[i], c))).sum::<f64>() / n as f64).sqrt()
}

/// Grows `cand` (indices, no duplicates) to at least `min` entries with the points nearest to
/// the centroid of the current candidates (the corner region with C and D), then caps it at
/// `max` keeping the ones nearest to that centroid. `flag` and `order` are scratch.
pub(crate) fn grow_and_cap<const D: usize>(
    pts: &[[f64; D]],
    cand: &mut Vec<usize>,
    min: usize,
    max: Option<usize>,
    flag: &mut Vec<bool>,
    order: &mut Vec<usize>,
) {
    let n = pts.len();
    let mut centre = [0.0; D];
    for &i in cand.iter() {
        for k in 0..D {
            centre[k] += pts[i][k] / cand.len() as f64;
        }
    }
    let r2 = |i: usize| norm2(sub(pts[i], centre));
    if cand.len() < min.min(n) {
        flag.clear();
        flag.resize(n, false);
        for &i in cand.iter() {
            flag[i] = true;
        }
        order.clear();
        order.extend((0..n).filter(|&i| !flag[i]));
        let need = min.min(n) - cand.len();
        if need < order.len() {
            order.select_nth_unstable_by(need, |&a, &b| r2(a).total_cmp(&r2(b)).then(a.cmp(&b)));
            order.truncate(need);
        }
        order.sort_by(|&a, &b| r2(a).total_cmp(&r2(b)).then(a.cmp(&b)));
        cand.extend_from_slice(order);
    }
    if let Some(max) = max
        && cand.len() > max
    {
        // Keep the nearest `max`, in their original order.
        order.clear();
        order.extend_from_slice(cand);
        order.sort_by(|&a, &b| r2(a).total_cmp(&r2(b)).then(a.cmp(&b)));
        order.truncate(max);
        flag.clear();
        flag.resize(n, false);
        for &i in order.iter() {
            flag[i] = true;
        }
        cand.retain(|&i| flag[i]);
    }
}

/// Nearest point to `p` on the rays from `q` along the unit `dirs` (the constrained sides as
/// half-lines from the corner): where a point of the abnormal zone is moved to. Returns the
/// foot and the index of the ray.
pub(crate) fn nearest_on_rays<const D: usize>(
    p: &[f64; D],
    q: &[f64; D],
    dirs: &[[f64; D]],
) -> ([f64; D], usize) {
    let v = sub(p, q);
    let mut best = (*q, 0, f64::INFINITY);
    for (j, d) in dirs.iter().enumerate() {
        let t = dot(v, d).max(0.0);
        let foot = axpy(q, t, d);
        let e = norm2(sub(p, foot));
        if e < best.2 {
            best = (foot, j, e);
        }
    }
    (best.0, best.1)
}
