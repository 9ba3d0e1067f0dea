//! Randomness helpers for the simulator: uniform random rotations, a counter-based hash for
//! per-node jitter, and Gaussian deviates. (Its vector arithmetic and distances are the crate's
//! one vocabulary in [`crate::geometry`].)

use rand::RngExt;

use crate::geometry::V3;

/// A rotation matrix drawn uniformly from SO(3): Shoemake, "Uniform random rotations",
/// Graphics Gems III (1992): a unit quaternion from three uniforms.
pub fn random_rotation(rng: &mut impl rand::Rng) -> [V3; 3] {
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let tau = std::f64::consts::TAU;
    let (s1, s2) = ((1.0 - u1).sqrt(), u1.sqrt());
    let (w, x, y, z) = (
        s1 * (tau * u2).sin(),
        s1 * (tau * u2).cos(),
        s2 * (tau * u3).sin(),
        s2 * (tau * u3).cos(),
    );
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// SplitMix64 finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mixer, used to derive
/// independent seeds and per-node jitter from (seed, ids) without any shared state.
#[inline]
pub fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A seed derived from a base seed and a sequence of ids (order matters).
pub fn derive(seed: u64, ids: &[u64]) -> u64 {
    ids.iter().fold(mix(seed), |h, &id| mix(h ^ id))
}

/// Two uniforms in [0, 1) from one 64-bit hash (32 bits each).
#[inline]
pub fn two_uniforms(h: u64) -> (f64, f64) {
    const S: f64 = 1.0 / 4_294_967_296.0;
    ((h >> 32) as f64 * S, (h & 0xFFFF_FFFF) as f64 * S)
}

/// Two independent standard normal deviates (Box–Muller, 1958).
pub fn gauss2(rng: &mut impl rand::Rng) -> (f64, f64) {
    // 1 - u is in (0, 1], so the logarithm is finite.
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random();
    let r = (-2.0 * u1.ln()).sqrt();
    let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
    (r * c, r * s)
}

/// A 3-vector of independent standard normal deviates.
pub fn gauss3(rng: &mut impl rand::Rng) -> V3 {
    let (a, b) = gauss2(rng);
    let (c, _) = gauss2(rng);
    [a, b, c]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{cross, dot};
    use rand::SeedableRng;
    use rand::rngs::SmallRng;

    #[test]
    fn rotation_is_orthonormal_with_determinant_one() {
        let mut rng = SmallRng::seed_from_u64(3);
        for _ in 0..100 {
            let r = random_rotation(&mut rng);
            for i in 0..3 {
                for j in 0..3 {
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((dot(r[i], r[j]) - want).abs() < 1e-12);
                }
            }
            assert!((dot(r[0], cross(r[1], r[2])) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn gaussian_moments() {
        let mut rng = SmallRng::seed_from_u64(11);
        let n = 200_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n / 2 {
            let (a, b) = gauss2(&mut rng);
            s += a + b;
            s2 += a * a + b * b;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var - 1.0).abs() < 0.01, "{var}");
    }
}
