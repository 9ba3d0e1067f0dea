//! The constrained multi-line objective of the paper (§2, Eq. 11–14).
//!
//! k ≥ 2 lines keep the slopes of their local fits (the paper's L2, L4) and all pass through
//! one candidate corner q; the error of q is the sum over all points of the distance from each
//! point to its own side's line (Eq. 11 in 2D, Eq. 13 in 3D), and the paper's fitness is
//! 1 / error (Eq. 12, 14). The searchers minimise the error, which is the same thing.
//!
//! Inputs: unit line directions and, per line, the points assigned to it. Outputs: error(q).
//! The point data is stored pre-projected onto each line's normal space (one number per point
//! in 2D, two in 3D), so one evaluation is a tight loop over flat arrays.
//! [`JointSlopes`] is the non-convex variant used for the joint refinement: the slopes are
//! re-fitted through q (total least squares about q) at every evaluation.

use crate::geometry::{dot, norm, perp_basis, reject, sub, sym_eigen, unit};

/// Something the searchers can minimise: the fitting error of a candidate corner.
pub trait Objective<const D: usize> {
    /// The error of candidate `q` (sum of point-to-line distances). Never negative; `+inf`
    /// for a non-finite `q`.
    fn error(&self, q: &[f64; D]) -> f64;
}

/// The fixed-slope objectives of both dimensions ([`FixedSlopes2`], Eq. 11, and
/// [`FixedSlopes3`], Eq. 13), set up one line at a time: what the fit shared by the 2D and 3D
/// cases needs to build its problem.
pub trait FixedSlopes<const D: usize>: Objective<D> {
    /// Empties the objective, keeping its buffers.
    fn clear(&mut self);

    /// Adds a line with unit `direction` and the points that belong to it. Returns `false`
    /// (and adds nothing) when the direction is not a finite non-zero vector.
    fn add_line<'a>(
        &mut self,
        direction: &[f64; D],
        points: impl IntoIterator<Item = &'a [f64; D]>,
    ) -> bool;
}

/// Fitness as the paper defines it (Eq. 12, 14): the reciprocal of the error.
pub fn fitness(error: f64) -> f64 {
    1.0 / error
}

/// Lanes of the evaluation loops: independent partial sums let the compiler vectorise them
/// (one running sum is a serial chain of dependent additions).
const LANES: usize = 8;

/// Σ √((x_i − bx)² + (y_i − by)²).
#[inline]
fn sum_dist2(x: &[f64], y: &[f64], bx: f64, by: f64) -> f64 {
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let mut acc = [0.0; LANES];
    let full = n - n % LANES;
    for (cx, cy) in x[..full]
        .chunks_exact(LANES)
        .zip(y[..full].chunks_exact(LANES))
    {
        for l in 0..LANES {
            let dx = cx[l] - bx;
            let dy = cy[l] - by;
            acc[l] += (dx * dx + dy * dy).sqrt();
        }
    }
    let mut s = 0.0;
    for i in full..n {
        let dx = x[i] - bx;
        let dy = y[i] - by;
        s += (dx * dx + dy * dy).sqrt();
    }
    for v in acc {
        s += v;
    }
    s
}

/// k lines in 2D with fixed directions through a common point.
///
/// error(q) = Σ_j Σ_{i ∈ side j} |n_j · p_i − n_j · q| with n_j the unit normal of line j.
/// With k = 2 this separates into two one-dimensional problems in u = n_1·q and v = n_2·q,
/// which is why its exact minimum is a pair of medians (see `exact`).
///
/// Each line's values n_j · p_i are kept sorted with their prefix sums, so one evaluation
/// costs a binary search per line instead of a pass over the points:
/// Σ |a_i − u| = u·k − S_k + (S_n − S_k) − u·(n − k), with k the number of values below u and
/// S_k the sum of those k values.
#[derive(Clone, Debug, Default)]
pub struct FixedSlopes2 {
    pub(crate) normals: Vec<[f64; 2]>,
    pub(crate) starts: Vec<usize>,
    /// n_j · p_i for every point, grouped by line, sorted within each line.
    pub(crate) a: Vec<f64>,
    /// Per line, the running sums of the values minus the line's middle value (0, a_0 − m,
    /// a_0 + a_1 − 2m, ...; one more entry than values), starting at `starts[j] + j`. Centring
    /// keeps the sums as small as the residuals, so the formula does not cancel digits when
    /// the noise is tiny compared with the coordinates.
    pub(crate) prefix: Vec<f64>,
    /// The middle value m of each line.
    pub(crate) mid: Vec<f64>,
}

impl FixedSlopes<2> for FixedSlopes2 {
    fn clear(&mut self) {
        self.normals.clear();
        self.starts.clear();
        self.a.clear();
        self.prefix.clear();
        self.mid.clear();
    }

    fn add_line<'a>(
        &mut self,
        direction: &[f64; 2],
        points: impl IntoIterator<Item = &'a [f64; 2]>,
    ) -> bool {
        let Some(d) = unit(direction) else {
            return false;
        };
        let n = [-d[1], d[0]];
        if self.starts.is_empty() {
            self.starts.push(0);
        }
        self.normals.push(n);
        let from = self.a.len();
        self.a.extend(points.into_iter().map(|p| dot(n, p)));
        self.a[from..].sort_unstable_by(f64::total_cmp);
        let m = self
            .a
            .get(from + (self.a.len() - from) / 2)
            .copied()
            .unwrap_or(0.0);
        self.mid.push(m);
        let mut run = 0.0;
        self.prefix.push(0.0);
        for &v in &self.a[from..] {
            run += v - m;
            self.prefix.push(run);
        }
        self.starts.push(self.a.len());
        true
    }
}

impl FixedSlopes2 {
    /// Number of lines.
    pub fn lines(&self) -> usize {
        self.normals.len()
    }

    /// Number of points over all lines.
    pub fn points(&self) -> usize {
        self.a.len()
    }

    /// Unit normal of line `j`.
    pub fn normal(&self, j: usize) -> [f64; 2] {
        self.normals[j]
    }

    /// The normal coordinates n_j · p of the points of line `j` (sorted).
    pub fn values(&self, j: usize) -> &[f64] {
        &self.a[self.starts[j]..self.starts[j + 1]]
    }
}

impl Objective<2> for FixedSlopes2 {
    #[inline]
    fn error(&self, q: &[f64; 2]) -> f64 {
        if !(q[0].is_finite() && q[1].is_finite()) {
            return f64::INFINITY;
        }
        let mut total = 0.0;
        for j in 0..self.normals.len() {
            let u = dot(self.normals[j], q);
            let vals = self.values(j);
            let n = vals.len();
            let k = vals.partition_point(|&v| v < u);
            let p0 = self.starts[j] + j;
            let (sk, sn) = (self.prefix[p0 + k], self.prefix[p0 + n]);
            let uc = u - self.mid[j];
            // Clamped: rounding can leave a tiny negative sum at an exact fit.
            total += (uc * k as f64 - sk + (sn - sk) - uc * (n - k) as f64).max(0.0);
        }
        total
    }
}

/// k lines in 3D with fixed directions through a common point.
///
/// error(q) = Σ_j Σ_{i ∈ side j} |P_j (p_i − q)| with P_j the projection onto the plane
/// normal to line j: a sum of Euclidean norms, convex in q. Each point is stored by its two
/// coordinates in an orthonormal basis (e1_j, e2_j) of that plane.
#[derive(Clone, Debug, Default)]
pub struct FixedSlopes3 {
    pub(crate) dirs: Vec<[f64; 3]>,
    pub(crate) bases: Vec<([f64; 3], [f64; 3])>,
    pub(crate) starts: Vec<usize>,
    pub(crate) ax: Vec<f64>,
    pub(crate) ay: Vec<f64>,
}

impl FixedSlopes<3> for FixedSlopes3 {
    fn clear(&mut self) {
        self.dirs.clear();
        self.bases.clear();
        self.starts.clear();
        self.ax.clear();
        self.ay.clear();
    }

    fn add_line<'a>(
        &mut self,
        direction: &[f64; 3],
        points: impl IntoIterator<Item = &'a [f64; 3]>,
    ) -> bool {
        let Some(d) = unit(direction) else {
            return false;
        };
        let (e1, e2) = perp_basis(&d);
        if self.starts.is_empty() {
            self.starts.push(0);
        }
        self.dirs.push(d);
        self.bases.push((e1, e2));
        for p in points {
            self.ax.push(dot(e1, p));
            self.ay.push(dot(e2, p));
        }
        self.starts.push(self.ax.len());
        true
    }
}

impl FixedSlopes3 {
    /// Number of lines.
    pub fn lines(&self) -> usize {
        self.dirs.len()
    }

    /// Number of points over all lines.
    pub fn points(&self) -> usize {
        self.ax.len()
    }

    /// Unit direction of line `j`.
    pub fn direction(&self, j: usize) -> [f64; 3] {
        self.dirs[j]
    }
}

impl Objective<3> for FixedSlopes3 {
    #[inline]
    fn error(&self, q: &[f64; 3]) -> f64 {
        if !(q[0].is_finite() && q[1].is_finite() && q[2].is_finite()) {
            return f64::INFINITY;
        }
        let mut total = 0.0;
        for j in 0..self.dirs.len() {
            let (e1, e2) = &self.bases[j];
            let bx = dot(e1, q);
            let by = dot(e2, q);
            let r = self.starts[j]..self.starts[j + 1];
            total += sum_dist2(&self.ax[r.clone()], &self.ay[r], bx, by);
        }
        total
    }
}

/// The joint objective: for candidate q, each side's line is re-fitted *through q* (the total
/// least-squares direction about q, i.e. the principal axis of Σ (p − q)(p − q)ᵀ), and the
/// error is the sum of distances to those lines. Slopes and corner then move together; the
/// function is not convex, so a searcher (PSO) minimises it.
#[derive(Clone, Debug, Default)]
pub struct JointSlopes<const D: usize> {
    pub(crate) starts: Vec<usize>,
    pub(crate) pts: Vec<[f64; D]>,
    /// Per line: number of points, Σ p, Σ p pᵀ (so the scatter about any q costs O(1)).
    pub(crate) sums: Vec<(f64, [f64; D], [[f64; D]; D])>,
}

impl<const D: usize> JointSlopes<D> {
    /// Empties the objective, keeping its buffers.
    pub fn clear(&mut self) {
        self.starts.clear();
        self.pts.clear();
        self.sums.clear();
    }

    /// Adds a side (its points).
    pub fn add_side<'a>(&mut self, points: impl IntoIterator<Item = &'a [f64; D]>) {
        if self.starts.is_empty() {
            self.starts.push(0);
        }
        let mut s = [0.0; D];
        let mut s2 = [[0.0; D]; D];
        let before = self.pts.len();
        for p in points {
            for i in 0..D {
                s[i] += p[i];
                for j in 0..D {
                    s2[i][j] += p[i] * p[j];
                }
            }
            self.pts.push(*p);
        }
        self.sums.push(((self.pts.len() - before) as f64, s, s2));
        self.starts.push(self.pts.len());
    }

    /// Number of sides.
    pub fn lines(&self) -> usize {
        self.sums.len()
    }

    /// The direction of side `j`'s line re-fitted through `q`; `None` when all of its points
    /// coincide with q.
    pub fn direction_at(&self, j: usize, q: &[f64; D]) -> Option<[f64; D]> {
        let (n, s, s2) = &self.sums[j];
        // Σ (p − q)(p − q)ᵀ = Σ p pᵀ − q sᵀ − s qᵀ + n q qᵀ.
        let m: [[f64; D]; D] = std::array::from_fn(|a| {
            std::array::from_fn(|b| s2[a][b] - q[a] * s[b] - s[a] * q[b] + n * q[a] * q[b])
        });
        let (vals, vecs) = sym_eigen(&m);
        (vals[0] > 0.0).then_some(vecs[0]).and_then(unit)
    }
}

impl<const D: usize> Objective<D> for JointSlopes<D> {
    fn error(&self, q: &[f64; D]) -> f64 {
        if !q.iter().all(|x| x.is_finite()) {
            return f64::INFINITY;
        }
        let mut total = 0.0;
        for j in 0..self.sums.len() {
            let pts = &self.pts[self.starts[j]..self.starts[j + 1]];
            // No direction means all points are at q: zero distance to any line through q.
            if let Some(d) = self.direction_at(j, q) {
                for p in pts {
                    total += norm(reject(sub(p, q), d));
                }
            }
        }
        total
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::line::Line;

    #[test]
    fn fixed_slopes_match_direct_point_line_distances() {
        let d1 = unit([1.0, 0.3]).unwrap();
        let d2 = unit([-0.2, 1.0]).unwrap();
        let s1 = [[1.0, 2.0], [3.0, -1.0], [0.5, 0.5]];
        let s2 = [[-1.0, 4.0], [2.0, 2.0]];
        let mut obj = FixedSlopes2::default();
        assert!(obj.add_line(&d1, &s1));
        assert!(obj.add_line(&d2, &s2));
        for q in [[0.0, 0.0], [1.5, -2.5], [10.0, 3.0]] {
            let l1 = Line {
                point: q,
                direction: d1,
            };
            let l2 = Line {
                point: q,
                direction: d2,
            };
            let want: f64 = s1.iter().map(|p| l1.distance(p)).sum::<f64>()
                + s2.iter().map(|p| l2.distance(p)).sum::<f64>();
            assert!((obj.error(&q) - want).abs() < 1e-12, "{q:?}");
        }
        assert_eq!(obj.error(&[f64::NAN, 0.0]), f64::INFINITY);

        let e = [
            unit([1.0, 0.2, -0.1]).unwrap(),
            unit([0.0, 1.0, 0.4]).unwrap(),
            [0.0, 0.0, 1.0],
        ];
        let sides: [&[[f64; 3]]; 3] = [
            &[[1.0, 2.0, 3.0], [0.0, -1.0, 2.0]],
            &[[4.0, 0.0, 1.0]],
            &[[1.0, 1.0, 1.0], [-2.0, 0.5, 7.0]],
        ];
        let mut obj3 = FixedSlopes3::default();
        for (d, s) in e.iter().zip(sides) {
            obj3.add_line(d, s);
        }
        for q in [[0.0, 0.0, 0.0], [1.0, -2.0, 5.0]] {
            let want: f64 = e
                .iter()
                .zip(sides)
                .map(|(d, s)| {
                    let l = Line {
                        point: q,
                        direction: *d,
                    };
                    s.iter().map(|p| l.distance(p)).sum::<f64>()
                })
                .sum();
            assert!((obj3.error(&q) - want).abs() < 1e-12);
        }
    }

    #[test]
    fn prefix_sum_evaluation_matches_the_direct_sum() {
        use rand::rngs::SmallRng;
        use rand::{RngExt, SeedableRng};
        let mut rng = SmallRng::seed_from_u64(3);
        for n in [1usize, 2, 7, 40] {
            let mut obj = FixedSlopes2::default();
            let d = [[0.6, 0.8], [-0.8, 0.6]];
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|i| [(i % 3) as f64 * 0.5, rng.random::<f64>() * 4.0 - 2.0])
                .collect();
            obj.add_line(&d[0], &pts);
            obj.add_line(&d[1], &pts);
            for _ in 0..50 {
                let q = [
                    rng.random::<f64>() * 8.0 - 4.0,
                    rng.random::<f64>() * 8.0 - 4.0,
                ];
                let direct: f64 = (0..2)
                    .map(|j| {
                        let u = dot(obj.normal(j), q);
                        pts.iter()
                            .map(|p| (dot(obj.normal(j), p) - u).abs())
                            .sum::<f64>()
                    })
                    .sum();
                assert!(
                    (obj.error(&q) - direct).abs() < 1e-12 * (1.0 + direct),
                    "n {n}"
                );
            }
            // At a data value itself (a tie at the split point).
            let q = pts[0];
            let direct: f64 = (0..2)
                .map(|j| {
                    let u = dot(obj.normal(j), q);
                    pts.iter()
                        .map(|p| (dot(obj.normal(j), p) - u).abs())
                        .sum::<f64>()
                })
                .sum();
            assert!((obj.error(&q) - direct).abs() < 1e-12 * (1.0 + direct));
        }
    }

    #[test]
    fn joint_slopes_refit_through_q() {
        // Points exactly on two lines through (1, 1): the joint error there is zero, and the
        // re-fitted directions are the true ones.
        let mut j = JointSlopes::<2>::default();
        let a: Vec<[f64; 2]> = (1..6)
            .map(|i| [1.0 + i as f64, 1.0 + 0.5 * i as f64])
            .collect();
        let b: Vec<[f64; 2]> = (1..6)
            .map(|i| [1.0 - 0.3 * i as f64, 1.0 + i as f64])
            .collect();
        j.add_side(&a);
        j.add_side(&b);
        assert!(j.error(&[1.0, 1.0]) < 1e-12);
        assert!(j.error(&[1.2, 0.9]) > 0.1);
        let d = j.direction_at(0, &[1.0, 1.0]).unwrap();
        assert!((d[1] / d[0] - 0.5).abs() < 1e-12);
    }
}
