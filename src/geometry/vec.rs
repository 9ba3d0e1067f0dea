//! Vector arithmetic on `[f64; N]` (N = 2 or 3), the one vocabulary of the crate.
//!
//! Every function takes its vectors as `impl Borrow<[f64; N]>`, so a caller passes arrays or
//! references alike (`sub(a, b)` and `sub(&a, &b)` are the same call); it compiles to the same
//! code as either. Each formula is written out in the order the crate's results depend on
//! (e.g. `dot` is `a0*b0 + a1*b1 + a2*b2`, summed left to right), so replacing a hand-written
//! copy by these never moves a bit.

use std::borrow::Borrow;

/// A point or vector in 3D.
pub type V3 = [f64; 3];

#[inline]
pub fn add<const N: usize>(a: impl Borrow<[f64; N]>, b: impl Borrow<[f64; N]>) -> [f64; N] {
    let (a, b) = (a.borrow(), b.borrow());
    std::array::from_fn(|k| a[k] + b[k])
}

#[inline]
pub fn sub<const N: usize>(a: impl Borrow<[f64; N]>, b: impl Borrow<[f64; N]>) -> [f64; N] {
    let (a, b) = (a.borrow(), b.borrow());
    std::array::from_fn(|k| a[k] - b[k])
}

#[inline]
pub fn neg<const N: usize>(a: impl Borrow<[f64; N]>) -> [f64; N] {
    a.borrow().map(|x| -x)
}

/// `a * s`, component-wise.
#[inline]
pub fn scale<const N: usize>(a: impl Borrow<[f64; N]>, s: f64) -> [f64; N] {
    a.borrow().map(|x| x * s)
}

/// `a / s`, component-wise: not the same bits as `scale(a, 1.0 / s)`, which rounds twice.
#[inline]
pub fn div<const N: usize>(a: impl Borrow<[f64; N]>, s: f64) -> [f64; N] {
    a.borrow().map(|x| x / s)
}

/// `a + s * b`.
#[inline]
pub fn axpy<const N: usize>(
    a: impl Borrow<[f64; N]>,
    s: f64,
    b: impl Borrow<[f64; N]>,
) -> [f64; N] {
    let (a, b) = (a.borrow(), b.borrow());
    std::array::from_fn(|k| a[k] + s * b[k])
}

/// `a · b`, summed left to right from the first product.
#[inline]
pub fn dot<const N: usize>(a: impl Borrow<[f64; N]>, b: impl Borrow<[f64; N]>) -> f64 {
    let (a, b) = (a.borrow(), b.borrow());
    let mut s = a[0] * b[0];
    for k in 1..N {
        s += a[k] * b[k];
    }
    s
}

#[inline]
pub fn norm2<const N: usize>(a: impl Borrow<[f64; N]>) -> f64 {
    let a = a.borrow();
    dot(a, a)
}

#[inline]
pub fn norm<const N: usize>(a: impl Borrow<[f64; N]>) -> f64 {
    norm2(a).sqrt()
}

#[inline]
pub fn dist<const N: usize>(a: impl Borrow<[f64; N]>, b: impl Borrow<[f64; N]>) -> f64 {
    norm(sub(a, b))
}

#[inline]
pub fn dist2<const N: usize>(a: impl Borrow<[f64; N]>, b: impl Borrow<[f64; N]>) -> f64 {
    norm2(sub(a, b))
}

/// `a` scaled to unit length; `None` for a zero, subnormal-length or non-finite vector (below
/// 1e-300 the reciprocal of the length would overflow).
#[inline]
pub fn unit<const N: usize>(a: impl Borrow<[f64; N]>) -> Option<[f64; N]> {
    let a = a.borrow();
    let n = norm(a);
    (n > 1e-300 && n.is_finite()).then(|| scale(a, 1.0 / n))
}

#[inline]
pub fn finite<const N: usize>(a: impl Borrow<[f64; N]>) -> bool {
    a.borrow().iter().all(|x| x.is_finite())
}

#[inline]
pub fn cross(a: impl Borrow<V3>, b: impl Borrow<V3>) -> V3 {
    let (a, b) = (a.borrow(), b.borrow());
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Component of `v` perpendicular to the unit vector `d`.
#[inline]
pub fn reject<const N: usize>(v: impl Borrow<[f64; N]>, d: impl Borrow<[f64; N]>) -> [f64; N] {
    let (v, d) = (v.borrow(), d.borrow());
    axpy(v, -dot(v, d), d)
}

/// Angle between two vectors in radians, via atan2 of |a×b| and a·b (accurate near 0 and π,
/// unlike acos of the dot product).
pub fn angle(a: impl Borrow<V3>, b: impl Borrow<V3>) -> f64 {
    let (a, b) = (a.borrow(), b.borrow());
    norm(cross(a, b)).atan2(dot(a, b))
}

/// 3x3 matrix (rows) times vector.
#[inline]
pub fn mat_vec(m: &[V3; 3], v: impl Borrow<V3>) -> V3 {
    let v = v.borrow();
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// The axis-aligned bounding box (lower, upper corner) of `points`; `(+∞, −∞)` for none. NaN
/// coordinates are passed over (`f64::min`/`max` keep the other operand).
pub fn bounds(points: &[V3]) -> (V3, V3) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn by_value_and_by_reference_are_one_function() {
        let (a, b) = ([1.0, 2.0, 3.0], [-4.0, 0.5, 2.0]);
        assert_eq!(sub(a, b), sub(a, b));
        assert_eq!(sub(a, b), [5.0, 1.5, 1.0]);
        assert_eq!(dot(a, b), 3.0);
        assert_eq!(cross(a, b), [2.5, -14.0, 8.5]);
        assert_eq!(axpy([1.0, 1.0], 2.0, [0.5, -1.0]), [2.0, -1.0]);
        assert_eq!(div([3.0, 6.0, 9.0], 3.0), [1.0, 2.0, 3.0]);
        assert_eq!(neg([1.0, -2.0]), [-1.0, 2.0]);
        assert_eq!(dist([0.0, 3.0], [4.0, 0.0]), 5.0);
        assert_eq!(reject([1.0, 1.0, 0.0], [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]);
        assert_eq!(
            mat_vec(&[[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 2.0]], a),
            [2.0, 1.0, 6.0]
        );
    }

    #[test]
    fn unit_rejects_zero_tiny_and_non_finite_vectors() {
        assert_eq!(unit([0.0, 0.0, -2.0]), Some([0.0, 0.0, -1.0]));
        let u = unit([3.0, 0.0, 4.0]).unwrap();
        assert!((u[0] - 0.6).abs() < 1e-15 && (u[2] - 0.8).abs() < 1e-15);
        assert_eq!(unit([0.0, 0.0]), None);
        assert_eq!(unit([1e-310, 0.0]), None);
        assert_eq!(unit([f64::INFINITY, 0.0]), None);
        assert_eq!(unit([f64::NAN, 0.0]), None);
        assert!(finite([1.0, 2.0]) && !finite([1.0, f64::NAN]));
    }

    #[test]
    fn angle_is_accurate_near_zero() {
        let a = [1.0, 0.0, 0.0];
        let b = [1.0, 1e-9, 0.0];
        assert!((angle(a, b) - 1e-9).abs() < 1e-20);
        assert!((angle(a, [-1.0, 0.0, 0.0]) - std::f64::consts::PI).abs() < 1e-15);
    }
}
