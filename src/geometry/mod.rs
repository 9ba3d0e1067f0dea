//! The geometry layer below every stage: vector arithmetic on `[f64; N]`, lines, rays,
//! segments and triangles, and small dense linear algebra. Nothing here knows about clouds,
//! stages or files; the stages, the fit, the simulator and the bench all speak this one
//! vocabulary.
//!
//! Points stay `[f64; 3]` (the design's `Vec<[f64; 3]>` data), and the arithmetic is our own
//! small functions on those arrays rather than nalgebra's `Vector3`/`Point3`, decided by a
//! benchmark (`cargo bench --bench geometry`) of the two hot paths written both ways:
//! the features stage's moments of neighbour offsets (its own `add_moments`, 2,000 points x 32
//! neighbours) take 143 / 191 µs with ours against 193 / 247 µs with nalgebra's `Vector3` and
//! outer product (two runs, the second on a busier machine); the fit's inner loop (201 points
//! to 3 lines in 3D, 100 to 2 in 2D) is a tie within the shared machine's noise: 3D 2.75 /
//! 2.85 / 3.52 / 2.74 µs ours against 2.30 / 2.98 / 3.45 / 2.78 µs nalgebra in four runs, 2D
//! 0.80 / 1.23 / 1.00 / 0.86 µs against 0.77 / 1.10 / 1.02 / 0.87 µs (2 shared cores,
//! 2026-11-25).
//! Beyond speed, our own functions keep every result bit for bit (each formula sums in the
//! order the crate's outputs were made with; nalgebra's `dot` and `norm` are free to reorder),
//! and need no conversion at the boundary of the `[f64; 3]` data. nalgebra stays for what it
//! is good at: the general eigen solver and LU solve in [`lines::nearest_point_to_lines`] and
//! [`lines::pca_line`].

pub mod eigen3;
pub mod linalg;
pub mod lines;
pub mod moments;
pub mod polyline;
pub mod triangles;
pub mod vec;

pub use linalg::{parabola_curvature, perp_basis, solve2, solve3, sym_eigen};
pub use lines::{
    closest_between_rays, nearest_point_to_lines, pca_line, perpendicular_basis, plane_axes,
    point_line_distance, point_segment,
};
pub use triangles::{closest_on_triangle, point_triangle, triangle_normal};
pub use vec::{
    V3, add, angle, axpy, bounds, cross, dist, dist2, div, dot, finite, mat_vec, neg, norm, norm2,
    reject, scale, sub, unit,
};
