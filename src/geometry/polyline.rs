//! Arc-length parametrised 3D polylines, open or closed: the centre line of an edge run and
//! of an edge, which may curve (a fillet's outline, a hole's rim) and may close on itself.
//!
//! Input: ordered vertices. Output: positions and tangents at an arc length `s`, and the
//! projection of a point (its `s` and distance). An open polyline continues straight beyond
//! its ends along its end tangents, so a point just past an end still gets a meaningful `s`
//! (negative, or above the length); a closed one wraps `s` into `[0, length)`.
//!
//! Degenerate input is explicit: repeated vertices are dropped, a single vertex is a point
//! (`new` refuses fewer than two distinct vertices), and a closed polyline needs three.

use crate::geometry::{add, dot, norm, pca_line, sub};

/// An arc-length parametrised polyline.
#[derive(Debug, Clone, PartialEq)]
pub struct Polyline {
    points: Vec<[f64; 3]>,
    /// Arc length at each vertex (`cum[0] = 0`); for a closed polyline one more entry, the
    /// length at the closing vertex (= `points[0]` again).
    cum: Vec<f64>,
    closed: bool,
}

impl Polyline {
    /// A polyline through `points` in order; `None` with fewer than two distinct vertices (three
    /// when closed). Consecutive duplicates are dropped.
    pub fn new(points: &[[f64; 3]], closed: bool) -> Option<Polyline> {
        let mut pts: Vec<[f64; 3]> = Vec::with_capacity(points.len());
        for &p in points {
            if !p.iter().all(|x| x.is_finite()) {
                return None;
            }
            if pts.last().is_none_or(|&q| norm(sub(p, q)) > 0.0) {
                pts.push(p);
            }
        }
        if closed && pts.len() > 1 && norm(sub(pts[0], pts[pts.len() - 1])) == 0.0 {
            pts.pop();
        }
        if pts.len() < if closed { 3 } else { 2 } {
            return None;
        }
        let mut cum = Vec::with_capacity(pts.len() + 1);
        cum.push(0.0);
        for w in pts.windows(2) {
            cum.push(cum[cum.len() - 1] + norm(sub(w[1], w[0])));
        }
        if closed {
            cum.push(cum[cum.len() - 1] + norm(sub(pts[0], pts[pts.len() - 1])));
        }
        Some(Polyline {
            points: pts,
            cum,
            closed,
        })
    }

    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    pub fn closed(&self) -> bool {
        self.closed
    }

    pub fn length(&self) -> f64 {
        self.cum[self.cum.len() - 1]
    }

    /// Number of segments (a closed polyline has one more, back to the start).
    pub fn segments(&self) -> usize {
        self.cum.len() - 1
    }

    /// End points of segment `k`.
    pub fn segment(&self, k: usize) -> ([f64; 3], [f64; 3]) {
        let n = self.points.len();
        (self.points[k], self.points[(k + 1) % n])
    }

    /// Arc length of vertex `k` (for a closed polyline `k` may be `points().len()`, the start
    /// again at the full length).
    pub fn vertex_s(&self, k: usize) -> f64 {
        self.cum[k]
    }

    fn wrap(&self, s: f64) -> f64 {
        if self.closed {
            s.rem_euclid(self.length())
        } else {
            s
        }
    }

    /// Position at arc length `s` (beyond the ends of an open polyline: along its end
    /// tangents).
    pub fn at(&self, s: f64) -> [f64; 3] {
        let s = self.wrap(s);
        let k = self.segment_at(s);
        let (a, b) = self.segment(k);
        let len = self.cum[k + 1] - self.cum[k];
        let u = (s - self.cum[k]) / len;
        add(a, sub(b, a).map(|x| x * u))
    }

    /// Unit tangent at `s`: the direction of the best line through the vertices within
    /// `half` of `s` along the curve (at least the segment's two ends), oriented with the
    /// polyline. Averaging over a window keeps one noisy vertex from tilting a slab.
    pub fn tangent(&self, s: f64, half: f64) -> [f64; 3] {
        let s = self.wrap(s);
        let n = self.points.len();
        let k = self.segment_at(s);
        let (a, b) = self.segment(k);
        let seg = sub(b, a);
        let seg = seg.map(|x| x / norm(seg));
        // Arc length from s to vertex i, the short way round on a closed polyline.
        let along = |i: usize| {
            let d = self.cum[i] - s;
            if self.closed {
                let l = self.length();
                d - l * (d / l).round()
            } else {
                d
            }
        };
        let mut window: Vec<[f64; 3]> = vec![a, b];
        // Backwards from vertex k, forwards from vertex k + 1, while within `half`.
        let (mut lo, mut hi) = (k as isize, (k + 1) as isize);
        while window.len() < n {
            let prev = lo - 1;
            if prev < 0 && !self.closed {
                break;
            }
            let i = prev.rem_euclid(n as isize) as usize;
            if along(i).abs() > half {
                break;
            }
            window.push(self.points[i]);
            lo = prev;
        }
        while window.len() < n {
            let next = hi + 1;
            if next >= n as isize && !self.closed {
                break;
            }
            let i = next.rem_euclid(n as isize) as usize;
            if along(i).abs() > half {
                break;
            }
            window.push(self.points[i]);
            hi = next;
        }
        let ids: Vec<usize> = (0..window.len()).collect();
        match pca_line(&window, &ids) {
            Some((_, d)) if window.len() > 2 => {
                if dot(d, seg) < 0.0 {
                    d.map(|x| -x)
                } else {
                    d
                }
            }
            _ => seg,
        }
    }

    /// Index of the segment holding arc length `s` (already wrapped); the end segments for
    /// `s` beyond an open polyline's ends.
    fn segment_at(&self, s: f64) -> usize {
        let last = self.segments() - 1;
        self.cum[1..self.segments()]
            .partition_point(|&c| c <= s)
            .min(last)
    }

    /// Arc length of the point of the polyline nearest to `p`, and the distance to it. An open
    /// polyline's first and last segments extend beyond its ends (so `s` may be negative or
    /// exceed the length); `segments` limits the search to those segment indices when given.
    pub fn project_among(&self, p: [f64; 3], segments: &[usize]) -> (f64, f64) {
        let last = self.segments() - 1;
        let mut best = (0.0, f64::INFINITY);
        for &k in segments {
            let (a, b) = self.segment(k);
            let d = sub(b, a);
            let len2 = dot(d, d);
            let mut u = dot(sub(p, a), d) / len2;
            let lo = if k == 0 && !self.closed {
                f64::NEG_INFINITY
            } else {
                0.0
            };
            let hi = if k == last && !self.closed {
                f64::INFINITY
            } else {
                1.0
            };
            u = u.clamp(lo, hi);
            let q = add(a, d.map(|x| x * u));
            let dist = norm(sub(p, q));
            if dist < best.1 {
                best = (self.cum[k] + u * len2.sqrt(), dist);
            }
        }
        best
    }

    /// [`Self::project_among`] over every segment.
    pub fn project(&self, p: [f64; 3]) -> (f64, f64) {
        let all: Vec<usize> = (0..self.segments()).collect();
        self.project_among(p, &all)
    }

    /// The polyline's vertices in reverse order (`s` becomes `length − s`).
    pub fn reversed(&self) -> Polyline {
        let mut pts = self.points.clone();
        pts.reverse();
        Polyline::new(&pts, self.closed).unwrap_or_else(|| self.clone())
    }

    /// End point and outward unit tangent of an open polyline's start (`end` = 0) or end
    /// (`end` = 1); the tangent is taken over the last `half` of the curve.
    pub fn end(&self, end: usize, half: f64) -> ([f64; 3], [f64; 3]) {
        if end == 0 {
            let t = self.tangent(0.0, half);
            (self.points[0], t.map(|x| -x))
        } else {
            let l = self.length();
            (self.points[self.points.len() - 1], self.tangent(l, half))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        norm(sub(a, b)) <= tol
    }

    #[test]
    fn refuses_degenerate_input() {
        assert!(Polyline::new(&[], false).is_none());
        assert!(Polyline::new(&[[1.0, 2.0, 3.0]], false).is_none());
        assert!(Polyline::new(&[[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]], false).is_none());
        assert!(Polyline::new(&[[0.0; 3], [1.0, 0.0, 0.0]], true).is_none());
        assert!(Polyline::new(&[[0.0; 3], [f64::NAN, 0.0, 0.0]], false).is_none());
        // Repeated vertices are dropped, not fatal.
        let p = Polyline::new(&[[0.0; 3], [0.0; 3], [2.0, 0.0, 0.0]], false).unwrap();
        assert_eq!(p.points().len(), 2);
        assert_eq!(p.length(), 2.0);
    }

    #[test]
    fn positions_and_projections_on_an_open_polyline() {
        let p = Polyline::new(&[[0.0; 3], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0]], false).unwrap();
        assert_eq!(p.length(), 3.0);
        assert!(close(p.at(0.5), [0.5, 0.0, 0.0], 1e-12));
        assert!(close(p.at(2.0), [1.0, 1.0, 0.0], 1e-12));
        // Beyond the ends: along the end tangents.
        assert!(close(p.at(-1.0), [-1.0, 0.0, 0.0], 1e-12));
        assert!(close(p.at(4.0), [1.0, 3.0, 0.0], 1e-12));
        let (s, d) = p.project([0.3, 0.5, 0.0]);
        assert!((s - 0.3).abs() < 1e-12 && (d - 0.5).abs() < 1e-12);
        let (s, d) = p.project([1.5, 1.5, 0.0]);
        assert!((s - 2.5).abs() < 1e-12 && (d - 0.5).abs() < 1e-12);
        let (s, d) = p.project([-2.0, 0.1, 0.0]);
        assert!((s + 2.0).abs() < 1e-12 && (d - 0.1).abs() < 1e-12);
        let (s, _) = p.project([1.0, 5.0, 0.0]);
        assert!((s - 6.0).abs() < 1e-12);
        let (e0, t0) = p.end(0, 0.1);
        let (e1, t1) = p.end(1, 0.1);
        assert!(close(e0, [0.0; 3], 0.0) && close(t0, [-1.0, 0.0, 0.0], 1e-12));
        assert!(close(e1, [1.0, 2.0, 0.0], 0.0) && close(t1, [0.0, 1.0, 0.0], 1e-12));
    }

    #[test]
    fn a_closed_circle_wraps_and_projects_against_brute_force() {
        let n = 64;
        let pts: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let a = i as f64 / n as f64 * std::f64::consts::TAU;
                [a.cos(), a.sin(), 0.5]
            })
            .collect();
        let p = Polyline::new(&pts, true).unwrap();
        assert_eq!(p.segments(), n);
        let chord = 2.0 * (std::f64::consts::PI / n as f64).sin();
        assert!((p.length() - n as f64 * chord).abs() < 1e-12);
        assert!(close(p.at(p.length()), pts[0], 1e-12));
        assert!(close(
            p.at(-0.5 * chord),
            p.at(p.length() - 0.5 * chord),
            1e-12
        ));
        // Tangent of a circle: perpendicular to the radius, counter-clockwise.
        for k in [0, 5, 63] {
            let s = p.vertex_s(k) + 0.5 * chord;
            let t = p.tangent(s, 3.0 * chord);
            let q = p.at(s);
            assert!(dot(t, [q[0], q[1], 0.0]).abs() < 1e-3, "k {k}: {t:?}");
            assert!(t[0] * q[1] - t[1] * q[0] < 0.0, "k {k}: clockwise {t:?}");
        }
        // Projection against a brute-force search over fine samples.
        for (i, q) in [[1.3, 0.2, 0.4], [-0.2, -0.7, 0.5], [0.99, -0.05, 0.6]]
            .into_iter()
            .enumerate()
        {
            let (s, d) = p.project(q);
            let mut best = (0.0, f64::INFINITY);
            let m = 200_000;
            for j in 0..m {
                let sj = p.length() * j as f64 / m as f64;
                let dj = norm(sub(q, p.at(sj)));
                if dj < best.1 {
                    best = (sj, dj);
                }
            }
            assert!((d - best.1).abs() < 1e-6, "case {i}: {d} vs {}", best.1);
            assert!((s - best.0).abs() < 1e-4, "case {i}: {s} vs {}", best.0);
        }
    }

    #[test]
    fn reversal_maps_s_to_length_minus_s() {
        let p = Polyline::new(&[[0.0; 3], [3.0, 0.0, 0.0], [3.0, 4.0, 0.0]], false).unwrap();
        let r = p.reversed();
        for s in [0.0, 1.0, 3.5, 7.0] {
            assert!(close(p.at(s), r.at(p.length() - s), 1e-12));
        }
    }
}
