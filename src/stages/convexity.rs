//! Convex or concave: on which side of each fitted edge the material lies.
//!
//! Inputs: the scanned surface (positions, outlier mask, grid, scale), the `EdgeResult`s of
//! the edge stage (each slab's corner and the directions of its two faces) and the sensor
//! positions when known. Output: per run, [`Convexity`]: convex (material inside the smaller
//! angle between the faces), concave, or undecided, with the votes behind it.
//!
//! A scan's normals are unoriented and locally a convex and a concave edge look alike (two
//! half-planes): the side of the material is a global fact, measured two ways.
//! - **Rays through the rest of the scan.** From a few slabs' corners, rays go into the
//!   smaller angle (inside the wedge) and into the larger one, away from the edge's own faces
//!   and rounding. On a part scanned all round, a ray starting in the material leaves it
//!   through an odd number of scanned surfaces and one starting in the air through an even
//!   number. A pair of rays (one each side, mirrored) votes only when it is consistent: odd
//!   inside and even outside is convex, the reverse concave. An open scan (one view: the
//!   back is missing) gives even/even pairs, no vote, rather than a wrong one.
//! - **The sensors**, when known: every face was seen from its outer side by some sensor;
//!   at a convex edge the outer sides face away from the smaller angle, at a concave one
//!   towards it. Each slab votes for the one of the two the sensors allow (one sensor outside
//!   both face planes: convex; inside both: concave), none when they allow both or neither.
//!
//! The edge is decided by the sensors' votes when they give a two-thirds majority of at least
//! [`MIN_VOTES`], else likewise by the rays' when at least half of the pairs voted, undecided
//! otherwise.

use rayon::prelude::*;
use serde::Serialize;

use crate::geometry::{add, axpy, cross, dot, norm, reject, scale, sub, unit};
use crate::stages::edges::{EdgeFit, EdgeResult, Surface};
use crate::stages::features::Scale;
use crate::stages::plane_corners::FaceEdge;

/// Slabs per edge whose corners send rays (evenly spread along the edge).
const SLABS: usize = 5;

/// Fewest votes an edge is decided on.
pub const MIN_VOTES: usize = 3;

/// What decided an edge's side of the material.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Votes {
    pub convex: usize,
    pub concave: usize,
}

impl Votes {
    /// Convex or concave by a two-thirds majority of at least `MIN_VOTES`; `None` otherwise.
    pub fn decide(self) -> Option<bool> {
        let n = self.convex + self.concave;
        if n < MIN_VOTES {
            return None;
        }
        if 3 * self.convex >= 2 * n {
            Some(true)
        } else if 3 * self.concave >= 2 * n {
            Some(false)
        } else {
            None
        }
    }
}

/// Per run: its votes (rays and sensors) and how many mirrored pairs of rays were cast; runs
/// without an edge have none.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Convexity {
    pub rays: Votes,
    pub sensors: Votes,
    pub pairs: usize,
}

impl Convexity {
    pub fn votes(&self) -> Votes {
        Votes {
            convex: self.rays.convex + self.sensors.convex,
            concave: self.rays.concave + self.sensors.concave,
        }
    }

    /// The sensors' decision when they give one, else the rays': rays through an open scan
    /// can meet another object standing in front of the edge (seen on a frame of stacked
    /// boxes), a sensor's side of the faces cannot mislead.
    ///
    /// The rays count only when at least half of the pairs voted: around an edge of a scan
    /// closed all round nearly every pair does (measured: 15 of 15 on most edges of the suite
    /// and random parts), while through an open scan most pairs see no surface on either side
    /// and the few that vote disagree (aerial lidar: 4 to 10 of 15, split 3 to 1 or worse).
    pub fn convex(&self) -> Option<bool> {
        let rays = self.rays.convex + self.rays.concave;
        self.sensors.decide().or_else(|| {
            (2 * rays >= self.pairs)
                .then(|| self.rays.decide())
                .flatten()
        })
    }
}

/// The side of the material of every fitted edge and of every edge placed by planes (see the
/// module comment); `sensors` may be empty.
pub fn convexity(
    surface: &Surface,
    fits: &[EdgeResult],
    plane_edges: &[FaceEdge],
    sensors: &[[f64; 3]],
) -> (Vec<Convexity>, Vec<Convexity>) {
    let Some(bounds) = bounds(surface.positions) else {
        return (
            vec![Convexity::default(); fits.len()],
            vec![Convexity::default(); plane_edges.len()],
        );
    };
    // Each edge on its own: the result does not depend on the thread count.
    let fitted = fits
        .par_iter()
        .map(|f| match f {
            Ok(e) => edge_convexity(surface, e, sensors, bounds),
            Err(_) => Convexity::default(),
        })
        .collect();
    let planar = plane_edges
        .par_iter()
        .map(|e| segment_convexity(surface, e, sensors, bounds))
        .collect();
    (fitted, planar)
}

fn bounds(p: &[[f64; 3]]) -> Option<([f64; 3], [f64; 3])> {
    (!p.is_empty()).then(|| crate::geometry::bounds(p))
}

/// The parameter where the ray `o + t d` leaves the box `b` (0 when it starts outside).
fn exit(o: [f64; 3], d: [f64; 3], b: ([f64; 3], [f64; 3])) -> f64 {
    let mut t = f64::INFINITY;
    for k in 0..3 {
        if d[k] > 1e-12 {
            t = t.min((b.1[k] - o[k]) / d[k]);
        } else if d[k] < -1e-12 {
            t = t.min((b.0[k] - o[k]) / d[k]);
        }
    }
    t.max(0.0)
}

/// A slab's frame: the bisector `b` of the faces (into the smaller angle), the unit `w`
/// across it in the profile plane (towards face 1), the half-angle between the faces, and
/// the normals of the face planes pointing into the smaller angle.
struct Wedge {
    b: [f64; 3],
    w: [f64; 3],
    half: f64,
    inner_normals: [[f64; 3]; 2],
}

fn wedge(faces: [[f64; 3]; 2]) -> Option<Wedge> {
    let b = unit(add(faces[0], faces[1]))?;
    let w = unit(sub(faces[1], faces[0]))?;
    let half = 0.5 * dot(faces[0], faces[1]).clamp(-1.0, 1.0).acos();
    // Each face's normal in the profile plane, towards the other face.
    let inner_normals =
        [(faces[0], faces[1]), (faces[1], faces[0])].map(|(f, g)| unit(reject(g, f)).unwrap_or(b));
    Some(Wedge {
        b,
        w,
        half,
        inner_normals,
    })
}

fn edge_convexity(
    surface: &Surface,
    e: &EdgeFit,
    sensors: &[[f64; 3]],
    bounds: ([f64; 3], [f64; 3]),
) -> Convexity {
    let n = e.slabs.len();
    let picks: Vec<usize> = if n <= SLABS {
        (0..n).collect()
    } else {
        (0..SLABS).map(|i| (2 * i + 1) * n / (2 * SLABS)).collect()
    };
    let samples: Vec<([f64; 3], [[f64; 3]; 2])> = picks
        .iter()
        .map(|&i| (e.slabs[i].corner, e.slabs[i].faces))
        .collect();
    sample_convexity(surface, &samples, &e.scale, e.zone, sensors, bounds)
}

/// The side of the material of a straight edge placed by two planar faces
/// (`stages::plane_corners`), voted at `SLABS` points spread along it as for a fitted edge.
fn segment_convexity(
    surface: &Surface,
    e: &FaceEdge,
    sensors: &[[f64; 3]],
    bounds: ([f64; 3], [f64; 3]),
) -> Convexity {
    let along = sub(e.end, e.start);
    let samples: Vec<([f64; 3], [[f64; 3]; 2])> = (0..SLABS)
        .map(|i| {
            let t = (2 * i + 1) as f64 / (2 * SLABS) as f64;
            (axpy(e.start, t, along), e.traces)
        })
        .collect();
    sample_convexity(surface, &samples, &e.scale, 0.0, sensors, bounds)
}

/// Votes from points on an edge (each with its two face traces): `sc` is the surface's scale
/// there and `zone` the half-width of its rounding.
fn sample_convexity(
    surface: &Surface,
    samples: &[([f64; 3], [[f64; 3]; 2])],
    sc: &Scale,
    zone: f64,
    sensors: &[[f64; 3]],
    bounds: ([f64; 3], [f64; 3]),
) -> Convexity {
    // A tube half a neighbourhood wide: a ray through a surface meets several of its points
    // (a spacing wide would slip between scan lines), and two surfaces closer than its width
    // count as one.
    let tube = 0.5 * sc.radius + 2.0 * sc.noise;
    let mut out = Convexity::default();
    for &(corner, faces) in samples {
        let Some(wg) = wedge(faces) else { continue };
        match sensor_side(&wg, corner, sensors) {
            Some(true) => out.sensors.convex += 1,
            Some(false) => out.sensors.concave += 1,
            None => {}
        }
        // Mirrored pairs of rays: along the bisector, and turned halfway towards each face
        // (inside) or halfway towards each face's far side (outside).
        let inside_turn = 0.5 * wg.half;
        let outside_turn = 0.5 * (std::f64::consts::PI - wg.half);
        for sign in [-1.0, 0.0, 1.0] {
            let dir = |base: [f64; 3], turn: f64| {
                add(
                    scale(base, (sign * turn).cos()),
                    scale(wg.w, (sign * turn).sin()),
                )
            };
            let din = dir(wg.b, inside_turn);
            let dout = dir(scale(wg.b, -1.0), outside_turn);
            // The ray keeps clear of the edge's own faces and rounding from where its tube
            // no longer reaches them: its angle to the nearer face is `half - turn` inside.
            let clear = |angle: f64| {
                (tube + 3.0 * sc.noise) / angle.min(0.5 * std::f64::consts::PI).sin().max(0.05)
                    + zone
                    + tube
            };
            let start_in = clear(wg.half - inside_turn * sign.abs());
            let start_out = clear(std::f64::consts::PI - wg.half - outside_turn * sign.abs());
            out.pairs += 1;
            let inner = crossings(surface, corner, din, start_in, tube, bounds);
            let outer = crossings(surface, corner, dout, start_out, tube, bounds);
            match (inner % 2, outer % 2) {
                (1, 0) => out.rays.convex += 1,
                (0, 1) => out.rays.concave += 1,
                _ => {}
            }
        }
    }
    out
}

/// What the sensors tell of one slab: both faces were scanned, so each face was seen from
/// its outer side by some sensor. Convex, each face's outer side is away from the smaller
/// angle; concave, towards it. A side is told when only one of the two is possible with the
/// sensors given (one sensor outside both face planes: convex; inside both: concave; between
/// them it saw a single face either way, and several sensors all round allow both).
fn sensor_side(wg: &Wedge, corner: [f64; 3], sensors: &[[f64; 3]]) -> Option<bool> {
    let mut outer = [false; 2];
    let mut inner = [false; 2];
    for &p in sensors {
        let v = sub(p, corner);
        for f in 0..2 {
            let d = dot(wg.inner_normals[f], v);
            outer[f] |= d < 0.0;
            inner[f] |= d > 0.0;
        }
    }
    let convex = outer[0] && outer[1];
    let concave = inner[0] && inner[1];
    (convex != concave).then_some(convex)
}

/// How many scanned surfaces the ray from `o` along unit `d` meets beyond `start`, up to where
/// it leaves the cloud's bounding box: the points within `tube` of it (outliers left out),
/// grouped along the ray where they lie less than two tube widths apart.
fn crossings(
    surface: &Surface,
    o: [f64; 3],
    d: [f64; 3],
    start: f64,
    tube: f64,
    bounds: ([f64; 3], [f64; 3]),
) -> usize {
    let end = exit(o, d, bounds) + tube;
    if end <= start {
        return 0;
    }
    let a = add(o, scale(d, start));
    let b = add(o, scale(d, end));
    let mut ts: Vec<f64> = Vec::new();
    surface.grid.for_each_near_segment(a, b, tube, |i| {
        let i = i as usize;
        if surface.outlier[i] {
            return;
        }
        let v = sub(surface.positions[i], o);
        let t = dot(v, d);
        if t >= start && norm(cross(v, d)) <= tube {
            ts.push(t);
        }
    });
    ts.sort_by(f64::total_cmp);
    let gap = 2.0 * tube;
    let mut count = 0;
    let mut last = f64::NEG_INFINITY;
    for t in ts {
        if t - last > gap {
            count += 1;
        }
        last = t;
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn votes_need_a_two_thirds_majority_of_three() {
        let v = |convex, concave| Votes { convex, concave }.decide();
        assert_eq!(v(2, 0), None);
        assert_eq!(v(3, 0), Some(true));
        assert_eq!(v(4, 2), Some(true));
        assert_eq!(v(3, 2), None);
        assert_eq!(v(1, 5), Some(false));
    }

    #[test]
    fn sensors_decide_before_rays() {
        let c = |rays: (usize, usize), sensors: (usize, usize)| {
            Convexity {
                rays: Votes {
                    convex: rays.0,
                    concave: rays.1,
                },
                sensors: Votes {
                    convex: sensors.0,
                    concave: sensors.1,
                },
                pairs: 12,
            }
            .convex()
        };
        assert_eq!(c((0, 6), (6, 0)), Some(true));
        assert_eq!(c((0, 6), (1, 0)), Some(false));
        assert_eq!(c((0, 0), (0, 0)), None);
        // Fewer than half of the pairs voted: an open scan, the rays tell nothing.
        assert_eq!(c((0, 5), (0, 0)), None);
    }

    #[test]
    fn wedge_of_a_right_angle() {
        let w = wedge([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).unwrap();
        let h = 0.5f64.sqrt();
        assert!(norm(sub(w.b, [h, h, 0.0])) < 1e-12);
        assert!(norm(sub(w.w, [-h, h, 0.0])) < 1e-12);
        assert!((w.half - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        // Face 0 (along x) has the normal +y into the angle, face 1 (along y) +x.
        assert!(norm(sub(w.inner_normals[0], [0.0, 1.0, 0.0])) < 1e-12);
        assert!(norm(sub(w.inner_normals[1], [1.0, 0.0, 0.0])) < 1e-12);
        // Flat (the faces do not turn): no wedge.
        assert!(wedge([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]).is_none());
    }

    #[test]
    fn sensors_tell_the_side_only_when_one_side_is_possible() {
        // Faces along +x and +y from the origin: the smaller angle is the first quadrant.
        let w = wedge([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).unwrap();
        let c = [0.0; 3];
        // Seen from outside both face planes (a box's edge from the front): convex.
        assert_eq!(sensor_side(&w, c, &[[-1.0, -1.0, 5.0]]), Some(true));
        // From inside the angle (a box standing on a table, seen from above): concave.
        assert_eq!(sensor_side(&w, c, &[[2.0, 3.0, 0.0]]), Some(false));
        // Between the planes a sensor sees one face either way: nothing told.
        assert_eq!(sensor_side(&w, c, &[[2.0, -1.0, 0.0]]), None);
        // Sensors all round allow both.
        assert_eq!(
            sensor_side(&w, c, &[[-1.0, -1.0, 0.0], [2.0, 3.0, 0.0]]),
            None
        );
        assert_eq!(sensor_side(&w, c, &[]), None);
    }

    #[test]
    fn rays_leave_a_box_where_it_ends() {
        let b = ([0.0, 0.0, 0.0], [2.0, 1.0, 1.0]);
        assert!((exit([0.5, 0.5, 0.5], [1.0, 0.0, 0.0], b) - 1.5).abs() < 1e-12);
        assert!((exit([0.5, 0.5, 0.5], [0.0, -1.0, 0.0], b) - 0.5).abs() < 1e-12);
        assert_eq!(exit([3.0, 0.5, 0.5], [1.0, 0.0, 0.0], b), 0.0);
    }
}
