//! Small known-answer clouds for the stages' unit tests (compiled only in tests). The full
//! scan simulator with ground truth is `synth`; these exist so a stage's tests do not depend
//! on it.

use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};

/// Standard normal sample (Box–Muller).
pub fn gauss(rng: &mut SmallRng) -> f64 {
    let u: f64 = rng.random::<f64>().max(1e-300);
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// Two half-planes meeting along the y axis (y in [0, 40)) with the given angle between them
/// (degrees), jittered grid of pitch `h`, isotropic noise `sigma`. Returns the points and each
/// point's true distance to the edge line (before noise).
pub fn dihedral(
    angle: f64,
    h: f64,
    sigma: f64,
    half_width: f64,
    seed: u64,
) -> (Vec<[f64; 3]>, Vec<f64>) {
    let mut rng = SmallRng::seed_from_u64(seed);
    let a = angle.to_radians();
    let dirs = [[1.0, 0.0, 0.0], [a.cos(), 0.0, a.sin()]];
    let (mut pts, mut dist) = (Vec::new(), Vec::new());
    let n_s = (half_width / h) as usize;
    let n_y = (40.0 / h) as usize;
    for d in dirs {
        for i in 0..n_s {
            for j in 0..n_y {
                let s = (i as f64 + rng.random::<f64>()) * h;
                let y = (j as f64 + rng.random::<f64>()) * h;
                let p = [s * d[0], y, s * d[2]];
                pts.push(p.map(|c| c + sigma * gauss(&mut rng)));
                dist.push(s);
            }
        }
    }
    (pts, dist)
}

/// An axis-aligned box [0, a] x [0, b] x [0, c] sampled on a jittered grid of pitch `h` on
/// each face, isotropic noise `sigma`. Its 12 edges and 8 corners are the answer.
pub fn box_scan(dims: [f64; 3], h: f64, sigma: f64, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut pts = Vec::new();
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0.0, dims[axis]] {
            let (nu, nv) = ((dims[u] / h) as usize, (dims[v] / h) as usize);
            for i in 0..nu {
                for j in 0..nv {
                    let mut p = [0.0; 3];
                    p[axis] = side;
                    p[u] = (i as f64 + rng.random::<f64>()) * dims[u] / nu as f64;
                    p[v] = (j as f64 + rng.random::<f64>()) * dims[v] / nv as f64;
                    pts.push(p.map(|c| c + sigma * gauss(&mut rng)));
                }
            }
        }
    }
    pts
}
