//! Straight-line fits to point sets: total least squares in 2D and 3D (the orientation-free
//! default), and the paper's explicit forms (y = a·x + b in 2D; x = a·z + b, y = c·z + d in
//! 3D from its Eq. 2–8) with the rotation it prescribes when a line is perpendicular to the
//! axis the form regresses on.
//!
//! Input: a slice of points (or a slice of points plus an index list). Output: a [`Line`]
//! through the centroid with a unit direction, or an error for fewer than two points,
//! non-finite coordinates, or points that do not determine a direction. [`LineAcc`] is the
//! running-sum version the line propagation grows one point at a time.

use serde::{Deserialize, Serialize};

use crate::geometry::{axpy, dot, finite, norm, reject, scale, sub, sym_eigen, unit};
use crate::{Error, Result};

/// A line through `point` with unit `direction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line<const D: usize> {
    pub point: [f64; D],
    pub direction: [f64; D],
}

/// A 2D line.
pub type Line2 = Line<2>;
/// A 3D line.
pub type Line3 = Line<3>;

impl<const D: usize> Default for Line<D> {
    /// The default line (through the origin, along the first axis), for buffers filled later.
    fn default() -> Self {
        let mut direction = [0.0; D];
        if D > 0 {
            direction[0] = 1.0;
        }
        Line {
            point: [0.0; D],
            direction,
        }
    }
}

impl<const D: usize> Line<D> {
    /// Signed position of the foot of `p` along the line, measured from `point`.
    #[inline]
    pub fn param(&self, p: &[f64; D]) -> f64 {
        dot(sub(p, self.point), self.direction)
    }

    /// The foot of the perpendicular from `p` (its orthogonal projection onto the line).
    #[inline]
    pub fn project(&self, p: &[f64; D]) -> [f64; D] {
        axpy(self.point, self.param(p), self.direction)
    }

    /// Euclidean distance from `p` to the line (the paper's Eq. 11 in 2D, Eq. 13 in 3D).
    #[inline]
    pub fn distance(&self, p: &[f64; D]) -> f64 {
        norm(reject(sub(p, self.point), self.direction))
    }

    /// The same line with its direction reversed when it points away from `towards`.
    pub fn oriented(mut self, towards: &[f64; D]) -> Self {
        if dot(towards, self.direction) < 0.0 {
            self.direction = scale(self.direction, -1.0);
        }
        self
    }
}

/// How the local side lines (the paper's L2 and L4) are fitted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LineForm {
    /// Total least squares (principal axis of the points): orientation-free, the default.
    #[default]
    Tls,
    /// The paper's explicit form: y = a·x + b in 2D, x = a·z + b and y = c·z + d in 3D
    /// (Eq. 2–8), after the axis swap / rotation that keeps the regression axis along the
    /// line, reversed afterwards.
    Paper,
}

/// Running sums for a line fit, so points can be added one at a time in O(1).
///
/// Sums are kept relative to a reference point (the first point added) so that a large common
/// offset does not cancel digits in the scatter matrix.
#[derive(Clone, Copy, Debug)]
pub struct LineAcc<const D: usize> {
    origin: [f64; D],
    n: usize,
    sum: [f64; D],
    sum2: [[f64; D]; D],
}

impl<const D: usize> Default for LineAcc<D> {
    fn default() -> Self {
        LineAcc {
            origin: [0.0; D],
            n: 0,
            sum: [0.0; D],
            sum2: [[0.0; D]; D],
        }
    }
}

impl<const D: usize> LineAcc<D> {
    /// Number of points added.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True when no point was added.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Adds one point.
    pub fn push(&mut self, p: &[f64; D]) {
        if self.n == 0 {
            self.origin = *p;
        }
        let d = sub(p, self.origin);
        self.n += 1;
        for i in 0..D {
            self.sum[i] += d[i];
            for j in 0..D {
                self.sum2[i][j] += d[i] * d[j];
            }
        }
    }

    /// Centroid of the points added so far.
    pub fn centroid(&self) -> [f64; D] {
        axpy(self.origin, 1.0 / self.n.max(1) as f64, self.sum)
    }

    /// Scatter matrix about the centroid (sum of outer products of centred points).
    pub fn scatter(&self) -> [[f64; D]; D] {
        let n = self.n.max(1) as f64;
        std::array::from_fn(|i| {
            std::array::from_fn(|j| self.sum2[i][j] - self.sum[i] * self.sum[j] / n)
        })
    }

    /// Total-least-squares line of the points so far: eigenvalues of the scatter matrix
    /// (descending) and the line along the largest one. `None` with fewer than two points or
    /// when the points coincide.
    pub fn fit(&self) -> Option<([f64; D], Line<D>)> {
        if self.n < 2 {
            return None;
        }
        let (vals, vecs) = sym_eigen(&self.scatter());
        if vals[0].is_nan() || vals[0] <= 0.0 || !finite(vecs[0]) {
            return None;
        }
        Some((
            vals,
            Line {
                point: self.centroid(),
                direction: unit(vecs[0])?,
            },
        ))
    }

    /// One step of power iteration on the scatter matrix from `dir`: a cheap update of the
    /// principal direction while points are being added one by one (the direction changes
    /// little per point, and for line-like data the eigenvalue gap makes one step enough).
    pub fn power_step(&self, dir: &[f64; D]) -> Option<[f64; D]> {
        let s = self.scatter();
        let v: [f64; D] = std::array::from_fn(|i| dot(s[i], dir));
        unit(v)
    }
}

fn check_points<const D: usize>(what: &'static str, pts: &[[f64; D]]) -> Result<()> {
    if pts.len() < 2 {
        return Err(Error::TooFewPoints {
            what,
            needed: 2,
            got: pts.len(),
        });
    }
    if let Some(i) = pts.iter().position(|p| !finite(p)) {
        return Err(Error::Degenerate {
            what,
            why: format!(
                "point {i} has a non-finite coordinate {:?}; remove it first",
                pts[i]
            ),
        });
    }
    Ok(())
}

/// Total-least-squares line of `pts` (principal axis through the centroid), in 2D or 3D.
///
/// Errors: fewer than 2 points, a non-finite coordinate, or all points identical.
pub fn fit_line<const D: usize>(pts: &[[f64; D]]) -> Result<Line<D>> {
    const WHAT: &str = "line fit";
    check_points(WHAT, pts)?;
    let mut acc = LineAcc::default();
    for p in pts {
        acc.push(p);
    }
    acc.fit().map(|(_, l)| l).ok_or_else(|| Error::Degenerate {
        what: WHAT,
        why: format!(
            "all {} points coincide; a line needs two distinct points",
            pts.len()
        ),
    })
}

/// The paper's 2D form y = a·x + b by ordinary least squares, without any rotation.
///
/// Errors: as [`fit_line`], plus a vertical line (the x values do not spread), which this
/// form cannot represent; [`fit_line_2d_paper`] swaps the axes for it.
pub fn fit_line_2d_paper_raw(pts: &[[f64; 2]]) -> Result<(f64, f64)> {
    const WHAT: &str = "paper's 2D line form y = a*x + b";
    check_points(WHAT, pts)?;
    let (a, b) = regress(pts, 0, 1).ok_or_else(|| Error::Degenerate {
        what: WHAT,
        why: "the line is vertical (x does not vary), so y = a*x + b has no solution; \
              swap the axes first (fit_line_2d_paper does this)"
            .into(),
    })?;
    Ok((a, b))
}

/// The paper's 2D form, regressing on whichever axis the line runs along (y on x, or x on y
/// for steep lines — the 2D analogue of the paper's rotation), returned as a [`Line2`].
pub fn fit_line_2d_paper(pts: &[[f64; 2]]) -> Result<Line2> {
    const WHAT: &str = "paper's 2D line form";
    check_points(WHAT, pts)?;
    let (sxx, syy) = spreads(pts);
    let (u, v) = if sxx >= syy { (0, 1) } else { (1, 0) };
    let (a, b) = regress(pts, u, v).ok_or_else(|| Error::Degenerate {
        what: WHAT,
        why: format!(
            "all {} points coincide; a line needs two distinct points",
            pts.len()
        ),
    })?;
    // Point at the mean of the regressor, direction (1, a) in the (u, v) axes.
    let mu = pts.iter().map(|p| p[u]).sum::<f64>() / pts.len() as f64;
    let mut point = [0.0; 2];
    point[u] = mu;
    point[v] = a * mu + b;
    let mut dir = [0.0; 2];
    dir[u] = 1.0;
    dir[v] = a;
    Ok(Line {
        point,
        direction: unit(dir).ok_or_else(|| Error::Degenerate {
            what: WHAT,
            why: format!("slope {a} is not finite"),
        })?,
    })
}

/// Coefficients (a, b, c, d) of the paper's 3D form x = a·z + b, y = c·z + d (Eq. 2), from the
/// normal equations Eq. 5–6 (solved with centred sums, which is the same solution with less
/// cancellation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperLine3 {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub d: f64,
}

impl PaperLine3 {
    /// The line as point + unit direction; the direction is (a, c, 1) normalised (Eq. 13's v).
    pub fn to_line(&self, z0: f64) -> Line3 {
        let dir = [self.a, self.c, 1.0];
        let n = norm(dir);
        Line {
            point: [self.a * z0 + self.b, self.c * z0 + self.d, z0],
            direction: scale(dir, 1.0 / n),
        }
    }
}

/// The paper's 3D form by Eq. 6, without rotation.
///
/// Errors: as [`fit_line`], plus a line perpendicular to the z axis (z does not vary over the
/// points relative to x and y), which the form cannot represent; [`fit_line_3d_paper`]
/// applies the paper's rotation for it.
pub fn fit_line_3d_paper_raw(pts: &[[f64; 3]]) -> Result<PaperLine3> {
    const WHAT: &str = "paper's 3D line form x = a*z + b, y = c*z + d";
    check_points(WHAT, pts)?;
    match (regress(pts, 2, 0), regress(pts, 2, 1)) {
        (Some((a, b)), Some((c, d))) => Ok(PaperLine3 { a, b, c, d }),
        _ => Err(Error::Degenerate {
            what: WHAT,
            why: "the line is perpendicular to the z axis (z does not vary), so x = a*z + b \
                  has no solution; rotate the points first (fit_line_3d_paper does this)"
                .into(),
        }),
    }
}

/// Which rotation [`fit_line_3d_paper`] applied before fitting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PaperRotation {
    /// The line already runs along z.
    None,
    /// 90° about x: y became z.
    AboutX,
    /// 90° about y: x became z.
    AboutY,
}

/// The paper's 3D form with its rotation (§2.2: "if one line is perpendicular to the z axis, a
/// rotation ... about x or y axis needs to be performed ... another reverse rotation"). The
/// axis of largest spread is rotated onto z, so the form is also used well away from the
/// exactly perpendicular case, where it would be ill-conditioned.
pub fn fit_line_3d_paper(pts: &[[f64; 3]]) -> Result<(Line3, PaperRotation)> {
    const WHAT: &str = "paper's 3D line form";
    check_points(WHAT, pts)?;
    let var = |k: usize| {
        let m = pts.iter().map(|p| p[k]).sum::<f64>() / pts.len() as f64;
        pts.iter().map(|p| (p[k] - m) * (p[k] - m)).sum::<f64>()
    };
    let (vx, vy, vz) = (var(0), var(1), var(2));
    let rot = if vz >= vx && vz >= vy {
        PaperRotation::None
    } else if vy >= vx {
        PaperRotation::AboutX
    } else {
        PaperRotation::AboutY
    };
    // Rotations by +90°: about x (x, y, z) -> (x, -z, y); about y (x, y, z) -> (z, y, -x).
    let fwd = |p: &[f64; 3]| match rot {
        PaperRotation::None => *p,
        PaperRotation::AboutX => [p[0], -p[2], p[1]],
        PaperRotation::AboutY => [p[2], p[1], -p[0]],
    };
    let back = |p: &[f64; 3]| match rot {
        PaperRotation::None => *p,
        PaperRotation::AboutX => [p[0], p[2], -p[1]],
        PaperRotation::AboutY => [-p[2], p[1], p[0]],
    };
    let rotated: Vec<[f64; 3]> = pts.iter().map(fwd).collect();
    let z0 = rotated.iter().map(|p| p[2]).sum::<f64>() / rotated.len() as f64;
    let line = fit_line_3d_paper_raw(&rotated)
        .map_err(|_| Error::Degenerate {
            what: WHAT,
            why: format!(
                "all {} points coincide; a line needs two distinct points",
                pts.len()
            ),
        })?
        .to_line(z0);
    Ok((
        Line {
            point: back(&line.point),
            direction: back(&line.direction),
        },
        rot,
    ))
}

/// Fits a line to `pts` in the chosen form (2D or 3D).
pub fn fit_line_form<const D: usize>(pts: &[[f64; D]], form: LineForm) -> Result<Line<D>> {
    match (form, D) {
        (LineForm::Tls, _) => fit_line(pts),
        (LineForm::Paper, 2) => {
            let p2: Vec<[f64; 2]> = pts.iter().map(|p| [p[0], p[1]]).collect();
            let l = fit_line_2d_paper(&p2)?;
            Ok(Line {
                point: std::array::from_fn(|k| l.point[k]),
                direction: std::array::from_fn(|k| l.direction[k]),
            })
        }
        (LineForm::Paper, 3) => {
            let p3: Vec<[f64; 3]> = pts.iter().map(|p| [p[0], p[1], p[2]]).collect();
            let (l, _) = fit_line_3d_paper(&p3)?;
            Ok(Line {
                point: std::array::from_fn(|k| l.point[k]),
                direction: std::array::from_fn(|k| l.direction[k]),
            })
        }
        _ => Err(Error::Degenerate {
            what: "paper's line form",
            why: format!("defined for 2D and 3D points, not {D}D; use LineForm::Tls"),
        }),
    }
}

/// Spreads (sums of squared deviations) of x and y.
fn spreads(pts: &[[f64; 2]]) -> (f64, f64) {
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p[0]).sum::<f64>() / n;
    let my = pts.iter().map(|p| p[1]).sum::<f64>() / n;
    let sxx = pts.iter().map(|p| (p[0] - mx) * (p[0] - mx)).sum();
    let syy = pts.iter().map(|p| (p[1] - my) * (p[1] - my)).sum();
    (sxx, syy)
}

/// Ordinary least squares of coordinate `v` on coordinate `u`: v = a·u + b. `None` when `u`
/// does not spread relative to the points' overall spread.
fn regress<const D: usize>(pts: &[[f64; D]], u: usize, v: usize) -> Option<(f64, f64)> {
    let n = pts.len() as f64;
    let mean: [f64; D] = std::array::from_fn(|k| pts.iter().map(|p| p[k]).sum::<f64>() / n);
    let mut suu = 0.0;
    let mut suv = 0.0;
    let mut total = 0.0;
    for p in pts {
        let d = sub(p, mean);
        suu += d[u] * d[u];
        suv += d[u] * d[v];
        total += dot(d, d);
    }
    if suu.is_nan() || suu <= 1e-24 * total || total == 0.0 {
        return None;
    }
    let a = suv / suu;
    Some((a, mean[v] - a * mean[u]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::cross;
    use rand::rngs::SmallRng;
    use rand::{RngExt, SeedableRng};

    fn noisy_line3(dir: [f64; 3], n: usize, sigma: f64, seed: u64) -> Vec<[f64; 3]> {
        let mut rng = SmallRng::seed_from_u64(seed);
        (0..n)
            .map(|i| {
                let t = i as f64 * 0.1 - 3.0;
                std::array::from_fn(|k| {
                    [1.0, -2.0, 0.5][k] + t * dir[k] + sigma * (rng.random::<f64>() - 0.5)
                })
            })
            .collect()
    }

    fn same_dir(a: &[f64; 3], b: &[f64; 3]) -> f64 {
        norm(cross(a, b))
    }

    #[test]
    fn tls_recovers_exact_lines_in_2d_and_3d() {
        let d2 = [0.6, 0.8];
        let pts: Vec<[f64; 2]> = (0..10)
            .map(|i| [2.0 + i as f64 * d2[0], -1.0 + i as f64 * d2[1]])
            .collect();
        let l = fit_line(&pts).unwrap();
        assert!(
            (l.direction[0].abs() - 0.6).abs() < 1e-14
                && (l.direction[1].abs() - 0.8).abs() < 1e-14
        );
        assert!(pts.iter().all(|p| l.distance(p) < 1e-13));
        let d3 = unit([1.0, 2.0, 3.0]).unwrap();
        let p3 = noisy_line3(d3, 30, 0.0, 1);
        let l3 = fit_line(&p3).unwrap();
        assert!(same_dir(&l3.direction, &d3) < 1e-14);
    }

    #[test]
    fn paper_form_agrees_with_tls_where_both_apply() {
        let d = unit([0.3, -0.2, 1.0]).unwrap();
        let pts = noisy_line3(d, 60, 1e-3, 7);
        let tls = fit_line(&pts).unwrap();
        let raw = fit_line_3d_paper_raw(&pts).unwrap().to_line(0.0);
        let (rot, how) = fit_line_3d_paper(&pts).unwrap();
        assert_eq!(how, PaperRotation::None);
        assert!(same_dir(&tls.direction, &raw.direction) < 1e-4);
        assert!(same_dir(&tls.direction, &rot.direction) < 1e-4);
        assert!(rot.distance(&tls.point) < 1e-4);
        // Noise-free: identical lines.
        let exact = noisy_line3(d, 20, 0.0, 7);
        let (l, _) = fit_line_3d_paper(&exact).unwrap();
        assert!(same_dir(&l.direction, &d) < 1e-13);
        assert!(exact.iter().all(|p| l.distance(p) < 1e-12));
    }

    #[test]
    fn paper_form_survives_lines_along_each_axis() {
        for (axis, want) in [
            ([1.0, 0.0, 0.0], PaperRotation::AboutY),
            ([0.0, 1.0, 0.0], PaperRotation::AboutX),
            ([0.0, 0.0, 1.0], PaperRotation::None),
        ] {
            let pts = noisy_line3(axis, 40, 0.0, 3);
            let (l, how) = fit_line_3d_paper(&pts).unwrap();
            assert_eq!(how, want, "axis {axis:?}");
            assert!(
                same_dir(&l.direction, &axis) < 1e-14,
                "axis {axis:?}: {:?}",
                l.direction
            );
            assert!(pts.iter().all(|p| l.distance(p) < 1e-12));
        }
        // Without the rotation, a line along x or y is refused with a message saying why.
        let along_x = noisy_line3([1.0, 0.0, 0.0], 10, 0.0, 3);
        let err = fit_line_3d_paper_raw(&along_x).unwrap_err().to_string();
        assert!(err.contains("perpendicular to the z axis"), "{err}");
    }

    #[test]
    fn paper_2d_form_refuses_vertical_lines_unless_swapped() {
        let vertical: Vec<[f64; 2]> = (0..5).map(|i| [3.0, i as f64]).collect();
        let err = fit_line_2d_paper_raw(&vertical).unwrap_err().to_string();
        assert!(err.contains("vertical"), "{err}");
        let l = fit_line_2d_paper(&vertical).unwrap();
        assert!(l.direction[0].abs() < 1e-15 && (l.direction[1].abs() - 1.0).abs() < 1e-15);
        assert!((l.point[0] - 3.0).abs() < 1e-15);
        let (a, b) = fit_line_2d_paper_raw(&[[0.0, 1.0], [1.0, 3.0], [2.0, 5.0]]).unwrap();
        assert!((a - 2.0).abs() < 1e-14 && (b - 1.0).abs() < 1e-14);
    }

    #[test]
    fn degenerate_input_is_an_error_not_a_nan() {
        assert!(matches!(
            fit_line::<2>(&[[1.0, 1.0]]),
            Err(Error::TooFewPoints { got: 1, .. })
        ));
        let same = [[1.0, 2.0, 3.0]; 4];
        let e = fit_line(&same).unwrap_err().to_string();
        assert!(e.contains("coincide"), "{e}");
        assert!(fit_line_3d_paper(&same).is_err());
        let nan = [[0.0, 0.0], [f64::NAN, 1.0], [2.0, 2.0]];
        let e = fit_line(&nan).unwrap_err().to_string();
        assert!(e.contains("point 1") && e.contains("non-finite"), "{e}");
    }
}
