//! Small pure geometry and randomness helpers for the simulator: 3-vector arithmetic on
//! `[f64; 3]`, point–segment and point–triangle distances, uniform random rotations, a
//! counter-based hash for per-node jitter, and Gaussian deviates.
//!
//! Degenerate inputs are handled explicitly: a zero-length segment is a point, a zero-area
//! triangle falls back to its edges, `normalize` of a zero vector returns `None`.

use rand::RngExt;

pub type V3 = [f64; 3];

#[inline]
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline]
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
pub fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
/// `a + s * b`
#[inline]
pub fn axpy(a: V3, s: f64, b: V3) -> V3 {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}
#[inline]
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
#[inline]
pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
#[inline]
pub fn dist(a: V3, b: V3) -> f64 {
    norm(sub(a, b))
}
#[inline]
pub fn dist2(a: V3, b: V3) -> f64 {
    let d = sub(a, b);
    dot(d, d)
}

/// Unit vector along `a`, or `None` when `a` is (numerically) zero or not finite.
pub fn normalize(a: V3) -> Option<V3> {
    let n = norm(a);
    (n > 1e-300 && n.is_finite()).then(|| scale(a, 1.0 / n))
}

/// Angle between two vectors in radians, via atan2 of |a×b| and a·b (accurate near 0 and π,
/// unlike acos of the dot product).
pub fn angle(a: V3, b: V3) -> f64 {
    norm(cross(a, b)).atan2(dot(a, b))
}

/// `(distance, t)` from `p` to the segment `a + t (b - a)`, `t` in [0, 1]; a zero-length
/// segment is the point `a` (t = 0).
pub fn point_segment(p: V3, a: V3, b: V3) -> (f64, f64) {
    let ab = sub(b, a);
    let l2 = dot(ab, ab);
    let t = if l2 > 0.0 {
        (dot(sub(p, a), ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (dist(p, axpy(a, t, ab)), t)
}

/// Closest point to `p` on triangle `abc`: Ericson, *Real-Time Collision Detection* (2005),
/// §5.1.5 `ClosestPtPointTriangle` (Voronoi regions of vertices, edges, face). Degenerate
/// triangles need no special case: the region tests then select a vertex or an edge.
pub fn closest_on_triangle(p: V3, a: V3, b: V3, c: V3) -> V3 {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return axpy(a, v, ab);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return axpy(a, w, ac);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return axpy(b, w, sub(c, b));
    }
    let denom = va + vb + vc;
    if denom.abs() < 1e-300 || !denom.is_finite() {
        // Zero area but p projects inside: the closest of the three edges is exact.
        let cands = [
            axpy(a, point_segment(p, a, b).1, ab),
            axpy(a, point_segment(p, a, c).1, ac),
            axpy(b, point_segment(p, b, c).1, sub(c, b)),
        ];
        return cands
            .into_iter()
            .min_by(|x, y| dist2(p, *x).total_cmp(&dist2(p, *y)))
            .unwrap_or(a);
    }
    let v = vb / denom;
    let w = vc / denom;
    add(a, add(scale(ab, v), scale(ac, w)))
}

/// Distance from `p` to triangle `abc`.
pub fn point_triangle(p: V3, a: V3, b: V3, c: V3) -> f64 {
    dist(p, closest_on_triangle(p, a, b, c))
}

/// Unit normal of triangle `abc` (counter-clockwise = outward), `None` if degenerate.
pub fn triangle_normal(a: V3, b: V3, c: V3) -> Option<V3> {
    normalize(cross(sub(b, a), sub(c, a)))
}

/// 3x3 matrix (rows) times vector.
#[inline]
pub fn mat_vec(m: &[V3; 3], v: V3) -> V3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

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
    use rand::SeedableRng;
    use rand::rngs::SmallRng;

    #[test]
    fn segment_distance_cases() {
        let (a, b) = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
        assert_eq!(point_segment([1.0, 1.0, 0.0], a, b), (1.0, 0.5));
        assert_eq!(point_segment([-3.0, 4.0, 0.0], a, b), (5.0, 0.0));
        assert_eq!(point_segment([3.0, 0.0, 0.0], a, b), (1.0, 1.0));
        assert_eq!(point_segment([0.0, 3.0, 4.0], a, a), (5.0, 0.0));
    }

    /// The closed form against a dense brute-force sampling of the triangle.
    #[test]
    fn triangle_closest_point_matches_brute_force() {
        let mut rng = SmallRng::seed_from_u64(7);
        for _ in 0..200 {
            let mut r = || -> V3 { [rng.random(), rng.random(), rng.random()] };
            let (a, b, c, p) = (r(), r(), r(), scale(r(), 3.0));
            let d = point_triangle(p, a, b, c);
            let mut best = f64::INFINITY;
            let n = 200;
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    let q = add(a, add(scale(sub(b, a), u), scale(sub(c, a), v)));
                    best = best.min(dist(p, q));
                }
            }
            assert!(d <= best + 1e-12 && best - d < 1e-2, "{d} vs {best}");
        }
    }

    #[test]
    fn degenerate_triangle_falls_back_to_edges() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
        assert!((point_triangle([1.5, 1.0, 0.0], a, b, c) - 1.0).abs() < 1e-15);
        assert!(triangle_normal(a, b, c).is_none());
    }

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

    #[test]
    fn angle_is_accurate_near_zero() {
        let a = [1.0, 0.0, 0.0];
        let b = [1.0, 1e-9, 0.0];
        assert!((angle(a, b) - 1e-9).abs() < 1e-20);
        assert!((angle(a, [-1.0, 0.0, 0.0]) - std::f64::consts::PI).abs() < 1e-15);
    }
}
