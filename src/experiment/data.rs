//! Test data made the way the paper made it (§4): "noisy discrete data points were generated
//! by using a random number generator on the basis of perturbation from the specified line
//! segments", with the abnormality of its Figure 1 near the corner.
//!
//! 2D: two segments of length 10 meet at the true corner (10, 10) at an opening angle drawn
//! from [60°, 150°], in a random orientation. Each carries 20–60 evenly spaced points
//! perturbed by isotropic Gaussian noise σ ∈ [0.05, 0.3]. Near the corner the scan is
//! abnormal (the paper's Figure 1 and §1: "a limited number of laser rays likely miss the exact
//! location of corner or edge points"): the points within a zone of length z ∈ [0.5, 2] get
//! κ ∈ [1, 3] times the noise, and the points within g ∈ [0, 1.5] spacings of the apex are
//! missing. Optionally ([`Abnormality::rounding`], not in the paper) the corner is rounded with
//! a fillet of radius drawn from [0, rounding], so no point lies near the apex at all. The
//! profile is handed over unordered, with an approximate corner off the true one by up to 0.5
//! (what the pipeline's feature stage knows).
//!
//! 3D: k = 2, 3 or 4 segments of length 10 from the true vertex (10, 10, 10): two at an angle in
//! [60°, 150°], three along a randomly rotated and perturbed box corner, or four around a
//! pyramid apex. Same point counts, noise and abnormal zone; the optional rounding blunts the
//! vertex by pulling the points near it towards the inside of the corner.
//!
//! Input: an RNG (one per trial). Output: a [`Trial2`] / [`Trial3`] with the points, the
//! truth and the drawn parameters.

use rand::{Rng, RngExt};

use crate::fit::standard_normal;
use crate::geometry::{axpy, cross, div, norm};

/// The drawn parameters of one trial.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialParams {
    /// Opening angle between the sides in degrees (2D and k = 2); for k ≥ 3 the smallest
    /// pairwise angle.
    pub angle_deg: f64,
    /// Number of lines meeting at the corner.
    pub lines: usize,
    /// Points per side.
    pub points_per_side: Vec<usize>,
    /// Noise σ.
    pub noise: f64,
    /// Length of the abnormal zone along each side, from the corner.
    pub zone: f64,
    /// Noise factor in the abnormal zone.
    pub abnormal_noise: f64,
    /// Fillet radius (2D) or blunting length (3D); 0 in the paper's data.
    pub rounding: f64,
}

/// A generated 2D profile.
#[derive(Clone, Debug)]
pub struct Trial2 {
    pub points: Vec<[f64; 2]>,
    pub truth: [f64; 2],
    pub approx: [f64; 2],
    /// True side directions (unit, pointing away from the corner).
    pub dirs: [[f64; 2]; 2],
    pub params: TrialParams,
}

/// A generated 3D vertex.
#[derive(Clone, Debug)]
pub struct Trial3 {
    pub sides: Vec<Vec<[f64; 3]>>,
    pub truth: [f64; 3],
    pub approx: [f64; 3],
    pub dirs: Vec<[f64; 3]>,
    pub params: TrialParams,
}

/// Length of each side.
pub const SIDE_LENGTH: f64 = 10.0;

fn uniform<R: Rng + ?Sized>(rng: &mut R, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

fn shuffle<T, R: Rng + ?Sized>(v: &mut [T], rng: &mut R) {
    for i in (1..v.len()).rev() {
        let j = rng.random_range(0..=i);
        v.swap(i, j);
    }
}

/// How abnormal the zone at the corner is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Abnormality {
    /// Largest rounding: fillet radius (2D) or blunting length (3D), drawn from [0, max].
    /// The paper's data has none (0): points are perturbed from the segments themselves.
    pub rounding: f64,
}

impl Default for Abnormality {
    fn default() -> Self {
        Abnormality { rounding: 0.0 }
    }
}

/// A 2D trial.
pub fn trial_2d<R: Rng + ?Sized>(rng: &mut R, abn: &Abnormality) -> Trial2 {
    let truth = [10.0, 10.0];
    let angle = uniform(rng, 60.0, 150.0);
    let half = angle.to_radians() / 2.0;
    let phi = uniform(rng, 0.0, std::f64::consts::TAU);
    let dirs = [
        [(phi - half).cos(), (phi - half).sin()],
        [(phi + half).cos(), (phi + half).sin()],
    ];
    let counts = [
        rng.random_range(20..=60usize),
        rng.random_range(20..=60usize),
    ];
    let sigma = uniform(rng, 0.05, 0.3);
    let zone = uniform(rng, 0.5, 2.0);
    let kappa = uniform(rng, 1.0, 3.0);
    let gap = uniform(rng, 0.0, 1.5);
    let rho = abn.rounding * rng.random::<f64>();
    // Fillet tangent to both sides: centre on the bisector at ρ / sin(half) from the corner,
    // tangent points at ρ / tan(half) along each side.
    let bis = [phi.cos(), phi.sin()];
    let t_f = rho / half.tan();
    let centre = [
        truth[0] + bis[0] * rho / half.sin(),
        truth[1] + bis[1] * rho / half.sin(),
    ];
    let mut points = Vec::with_capacity(counts[0] + counts[1]);
    for (j, &n) in counts.iter().enumerate() {
        let d = dirs[j];
        let h = SIDE_LENGTH / n as f64;
        for i in 0..n {
            let t = (i as f64 + 0.5) * h;
            // The scanner misses the apex itself.
            if t < gap * h {
                continue;
            }
            let mut p = [truth[0] + t * d[0], truth[1] + t * d[1]];
            if t < t_f {
                // On the arc, between the tangent point (s = 1) and its middle (s = 0).
                let s = t / t_f;
                let tangent = [truth[0] + t_f * d[0], truth[1] + t_f * d[1]];
                let a1 = (tangent[1] - centre[1]).atan2(tangent[0] - centre[0]);
                let am = (-bis[1]).atan2(-bis[0]);
                let mut da = a1 - am;
                while da > std::f64::consts::PI {
                    da -= std::f64::consts::TAU;
                }
                while da < -std::f64::consts::PI {
                    da += std::f64::consts::TAU;
                }
                let a = am + s * da;
                p = [centre[0] + rho * a.cos(), centre[1] + rho * a.sin()];
            }
            let sg = if t < zone.max(t_f) {
                sigma * kappa
            } else {
                sigma
            };
            p[0] += sg * standard_normal(rng);
            p[1] += sg * standard_normal(rng);
            points.push(p);
        }
    }
    shuffle(&mut points, rng);
    let r = 0.5 * rng.random::<f64>().sqrt();
    let a = uniform(rng, 0.0, std::f64::consts::TAU);
    Trial2 {
        points,
        truth,
        approx: [truth[0] + r * a.cos(), truth[1] + r * a.sin()],
        dirs,
        params: TrialParams {
            angle_deg: angle,
            lines: 2,
            points_per_side: counts.to_vec(),
            noise: sigma,
            zone,
            abnormal_noise: kappa,
            rounding: rho,
        },
    }
}

fn random_unit3<R: Rng + ?Sized>(rng: &mut R) -> [f64; 3] {
    loop {
        let v = [
            standard_normal(rng),
            standard_normal(rng),
            standard_normal(rng),
        ];
        let n = norm(v);
        if n > 1e-6 {
            return div(v, n);
        }
    }
}

/// `v` divided by its length (the generated data's own rounding: a division per component,
/// not `geometry::unit`'s multiplication by the reciprocal).
fn normalised(v: [f64; 3]) -> [f64; 3] {
    div(v, norm(v))
}

/// A random orthonormal frame (rows).
fn random_frame<R: Rng + ?Sized>(rng: &mut R) -> [[f64; 3]; 3] {
    let a = random_unit3(rng);
    let mut b = random_unit3(rng);
    while cross(a, b).iter().map(|x| x * x).sum::<f64>() < 1e-3 {
        b = random_unit3(rng);
    }
    let c = normalised(cross(a, b));
    let b = cross(c, a);
    [a, b, c]
}

fn tilt<R: Rng + ?Sized>(rng: &mut R, d: [f64; 3], max: f64) -> [f64; 3] {
    let e = random_unit3(rng);
    let s = max * rng.random::<f64>();
    normalised(axpy(d, s, e))
}

/// A 3D trial.
pub fn trial_3d<R: Rng + ?Sized>(rng: &mut R, abn: &Abnormality) -> Trial3 {
    let truth = [10.0, 10.0, 10.0];
    let f = random_frame(rng);
    let u = rng.random::<f64>();
    let dirs: Vec<[f64; 3]> = if u < 0.2 {
        let half = uniform(rng, 60.0, 150.0).to_radians() / 2.0;
        vec![
            normalised(std::array::from_fn(|k| {
                half.cos() * f[0][k] + half.sin() * f[1][k]
            })),
            normalised(std::array::from_fn(|k| {
                half.cos() * f[0][k] - half.sin() * f[1][k]
            })),
        ]
    } else if u < 0.8 {
        // Box corner: the three frame axes, each tilted by up to ~0.35 rad.
        (0..3).map(|a| tilt(rng, f[a], 0.35)).collect()
    } else {
        // Pyramid apex: four edges around the axis f[2] at polar angle β.
        let beta = uniform(rng, 25.0, 60.0).to_radians();
        let az0 = uniform(rng, 0.0, std::f64::consts::TAU);
        (0..4)
            .map(|i| {
                let az = az0 + i as f64 * std::f64::consts::FRAC_PI_2;
                let d = std::array::from_fn(|k| {
                    beta.sin() * (az.cos() * f[0][k] + az.sin() * f[1][k]) + beta.cos() * f[2][k]
                });
                tilt(rng, normalised(d), 0.1)
            })
            .collect()
    };
    let mut min_angle = 180.0f64;
    for a in 0..dirs.len() {
        for b in a + 1..dirs.len() {
            let c: f64 = (0..3).map(|k| dirs[a][k] * dirs[b][k]).sum();
            min_angle = min_angle.min(c.clamp(-1.0, 1.0).acos().to_degrees());
        }
    }
    let sigma = uniform(rng, 0.05, 0.3);
    let zone = uniform(rng, 0.5, 2.0);
    let kappa = uniform(rng, 1.0, 3.0);
    let gap = uniform(rng, 0.0, 1.5);
    let blunting = abn.rounding * rng.random::<f64>();
    let inward = normalised(std::array::from_fn(|k| {
        dirs.iter().map(|d| d[k]).sum::<f64>()
    }));
    let blunt = uniform(rng, 0.3, 1.0);
    let mut counts = Vec::with_capacity(dirs.len());
    let mut sides = Vec::with_capacity(dirs.len());
    for d in &dirs {
        let n = rng.random_range(20..=60usize);
        counts.push(n);
        let h = SIDE_LENGTH / n as f64;
        let mut side: Vec<[f64; 3]> = (0..n)
            .map(|i| (i as f64 + 0.5) * h)
            // The scanner misses the vertex itself.
            .filter(|&t| t >= gap * h)
            .map(|t| {
                // Blunting: near the vertex the edge points are pulled inside the corner.
                let pull = if t < blunting {
                    blunt * (blunting - t)
                } else {
                    0.0
                };
                let sg = if t < zone.max(blunting) {
                    sigma * kappa
                } else {
                    sigma
                };
                std::array::from_fn(|k| {
                    truth[k] + t * d[k] + pull * inward[k] + sg * standard_normal(rng)
                })
            })
            .collect();
        shuffle(&mut side, rng);
        sides.push(side);
    }
    let off = random_unit3(rng);
    let r = 0.5 * rng.random::<f64>().cbrt();
    Trial3 {
        sides,
        truth,
        approx: std::array::from_fn(|k| truth[k] + r * off[k]),
        params: TrialParams {
            angle_deg: min_angle,
            lines: dirs.len(),
            points_per_side: counts,
            noise: sigma,
            zone,
            abnormal_noise: kappa,
            rounding: blunting,
        },
        dirs,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand::rngs::SmallRng;

    #[test]
    fn generated_2d_points_follow_their_segments() {
        for seed in 0..20 {
            let t = trial_2d(
                &mut SmallRng::seed_from_u64(seed),
                &Abnormality { rounding: 1.0 },
            );
            let n: usize = t.params.points_per_side.iter().sum();
            assert!(t.points.len() <= n && t.points.len() + 4 >= n);
            // Every point is near one of the two segments (within 6 noise levels + rounding).
            let tol = 6.0 * t.params.noise * t.params.abnormal_noise + t.params.rounding;
            for p in &t.points {
                let near = t.dirs.iter().any(|d| {
                    let v = [p[0] - 10.0, p[1] - 10.0];
                    let s = (v[0] * d[0] + v[1] * d[1]).clamp(0.0, SIDE_LENGTH);
                    let e = [v[0] - s * d[0], v[1] - s * d[1]];
                    (e[0] * e[0] + e[1] * e[1]).sqrt() < tol
                });
                assert!(near, "seed {seed}: {p:?}");
            }
            let a = (t.dirs[0][0] * t.dirs[1][0] + t.dirs[0][1] * t.dirs[1][1]).acos();
            assert!((a.to_degrees() - t.params.angle_deg).abs() < 1e-9);
        }
    }

    #[test]
    fn generated_3d_sides_leave_the_vertex_along_their_directions() {
        for seed in 0..20 {
            let t = trial_3d(
                &mut SmallRng::seed_from_u64(seed),
                &Abnormality { rounding: 1.0 },
            );
            assert!((2..=4).contains(&t.dirs.len()));
            assert!(
                t.params.angle_deg > 20.0,
                "seed {seed}: {}",
                t.params.angle_deg
            );
            for (side, d) in t.sides.iter().zip(&t.dirs) {
                let mean_t = side
                    .iter()
                    .map(|p| (0..3).map(|k| (p[k] - 10.0) * d[k]).sum::<f64>())
                    .sum::<f64>()
                    / side.len() as f64;
                assert!(
                    (mean_t - SIDE_LENGTH / 2.0).abs() < 1.0,
                    "seed {seed}: {mean_t}"
                );
            }
        }
    }
}
