//! Scan patterns: how a simulated scanner lays its points on the part, beyond the uniform grid.
//!
//! Input: the user's [`ScanPattern`] (part of `SynthParams`), the analysed model, the scan's
//! rotation and seed. Output: a resolved [`Scanner`] — sensor positions and poses, the cut
//! planes of a line scan, the density gradient, the noise model — and the spacing `h` that
//! gives the requested point count under that pattern ([`pitch_weight`]).
//!
//! Patterns (`pattern`):
//! - `uniform` (default): a jittered square grid of pitch `h` on every chart (sample.rs).
//! - `lines`: the part cut by parallel planes `n · x = o + k g` (n drawn from the seed or given
//!   as `line_direction`), `g = line_gap · h`; each triangle is intersected with the planes and
//!   the segments are sampled every `h` along the line with a jitter along it only, so every
//!   point lies on a plane (patterns.rs). A face whose normal makes the angle φ with `n` shows
//!   lines `g / sin φ` apart; a face parallel to the planes gets none.
//! - `grid`: structured light. A pinhole sensor at each view's position looks at the part's
//!   centre and casts one ray per pixel; the pixel pitch is `h` on a plane through the
//!   centre facing the sensor, the field of view just holds the part's bounding sphere. The
//!   first hit of each ray is a point, so self-occlusion is real, faces turned away are never
//!   hit, and on a face seen at incidence θ at distance D the pitch is `h (D / D_c) / cos θ`
//!   along the tilt (sparse on grazing faces).
//! - `view`: one-view (or multi-view) scans by visibility: the uniform grid of every chart,
//!   keeping a sample only when its face turns towards the sensor and the line of sight to
//!   the sensor is free. Scan borders are where a seen face meets one turned away or hidden.
//!
//! Views (`grid` and `view`): `views` sensors, given (`sensors`, world coordinates) or drawn
//! from the seed: the first in a uniform direction, the others turned 30–75° away from it (so
//! the views overlap), all at 4 bounding radii from the centre. View `v` samples with pitch
//! `h · 2^(v / (views − 1))` (1x to 2x: densities 4x apart) and, when there are several views,
//! every view but the first is moved by a small rigid motion drawn from the seed (the
//! registration error of real multi-view scans): a translation of `m h / 2` and a rotation
//! about the centre whose arc at the bounding radius is `m h / 2`, `m = misregistration`, so
//! no point moves more than `m h`. Each point's `PointTruth::view` says which view made it.
//!
//! Density gradient (`density_ratio` R > 1, any pattern): a candidate at `x` is kept with
//! probability `R^(-t)`, `t = (d · x − lo) / (hi − lo)` in [0, 1] across the part along `d`
//! (`density_direction`, drawn or given): the density falls smoothly (exponentially) by R
//! from the `lo` end to the `hi` end. The keep draw is a hash of the sample's place on the
//! pattern, so it does not depend on threads. `h` is then the pitch at the dense end.
//!
//! Noise model: Gaussian, isotropic for `uniform` and `lines`, along the sensor's ray for
//! `grid` and `view` (a depth sensor's error). With `incidence_noise` its sigma is multiplied
//! by `1 / cos θ` (θ between the face normal and the ray to the point's sensor; the first
//! sensor for patterns without views), at most `incidence_cap`: at 60° the noise is twice
//! that at 0°. Isotropic noise then doubles across the face too; noise along the ray (grid,
//! view) doubles along the ray, and its part across the face (the ray's times cos θ) stays
//! `sigma`, as a depth sensor's does.
//!
//! Point count: given N points, `h = sqrt(Σ A_t w_t / N)` over the triangles, `w_t` the
//! pattern's points per `h²` of area on triangle t ([`pitch_weight`]): 1 for uniform,
//! `sin φ / line_gap` for lines, per view `[facing] / c_v²` (view) or the perspective
//! projected area over the area `/ c_v²` (grid), times the mean keep probability of the
//! density gradient. Occlusion is not counted, so a non-convex part seen from one side gives
//! somewhat fewer than N points.

use rand::RngExt;
use rand::SeedableRng;
use rand::rngs::SmallRng;
use serde::{Deserialize, Serialize};

use super::features::Model;
use super::geom::{derive, gauss3};
use crate::geometry::plane_axes;
use crate::geometry::{V3, add, cross, dot, mat_vec, norm, scale, sub, unit};

/// How the scanner lays points on the part (see the module comment).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Pattern {
    #[default]
    Uniform,
    Lines,
    Grid,
    View,
}

impl Pattern {
    pub const NAMES: &'static str = "uniform, lines, grid, view";

    pub fn name(self) -> &'static str {
        match self {
            Pattern::Uniform => "uniform",
            Pattern::Lines => "lines",
            Pattern::Grid => "grid",
            Pattern::View => "view",
        }
    }

    /// Whether the pattern scans from sensors (and gives each point a view).
    pub fn has_views(self) -> bool {
        matches!(self, Pattern::Grid | Pattern::View)
    }
}

impl std::str::FromStr for Pattern {
    type Err = crate::error::Error;
    fn from_str(s: &str) -> crate::error::Result<Self> {
        match s {
            "uniform" => Ok(Pattern::Uniform),
            "lines" => Ok(Pattern::Lines),
            "grid" => Ok(Pattern::Grid),
            "view" => Ok(Pattern::View),
            _ => Err(crate::error::Error::SynthParam {
                name: "pattern",
                value: s.to_owned(),
                allowed: format!("one of {}", Pattern::NAMES),
            }),
        }
    }
}

/// The sampling pattern's settings (all in `SynthParams::scan`; lengths in spacings,
/// positions and directions in world coordinates). The default is the plain uniform scan,
/// which is left out of the ground truth's JSON so older files stay byte for byte the same.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScanPattern {
    pub pattern: Pattern,
    /// Gap between scan lines in along-line spacings, in [1, 100].
    pub line_gap: f64,
    /// Normal of the cut planes (world); `None`: drawn from the seed.
    pub line_direction: Option<V3>,
    /// Sensor positions (world), one per view; empty: drawn from the seed.
    pub sensors: Vec<V3>,
    /// Number of views (sensors) of `grid` and `view` scans, 1 to 16.
    pub views: usize,
    /// Largest displacement by a view's misregistration, in spacings (views > 1 only).
    pub misregistration: f64,
    /// Density ratio between the two ends of the part (1: none), in [1, 100].
    pub density_ratio: f64,
    /// Direction in which the density falls (world); `None`: drawn from the seed.
    pub density_direction: Option<V3>,
    /// Noise sigma grows as 1 / cos(incidence angle).
    pub incidence_noise: bool,
    /// Largest factor of that growth, in [1, 100].
    pub incidence_cap: f64,
}

impl Default for ScanPattern {
    fn default() -> Self {
        ScanPattern {
            pattern: Pattern::Uniform,
            line_gap: 3.0,
            line_direction: None,
            sensors: Vec::new(),
            views: 1,
            misregistration: 0.2,
            density_ratio: 1.0,
            density_direction: None,
            incidence_noise: false,
            incidence_cap: 4.0,
        }
    }
}

impl ScanPattern {
    pub fn is_default(&self) -> bool {
        *self == ScanPattern::default()
    }

    /// Whether a sensor must exist: sensor patterns, and incidence noise for any pattern.
    fn needs_sensor(&self) -> bool {
        self.pattern.has_views() || self.incidence_noise
    }

    /// Checks every field; the error names the field and the allowed range.
    pub fn validate(&self) -> crate::error::Result<()> {
        use super::bad;
        let range = |name, v: f64, lo: f64, hi: f64, unit: &str| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(bad(name, v, format!("must be in [{lo}, {hi}] ({unit})")))
            }
        };
        range("line_gap", self.line_gap, 1.0, 100.0, "along-line spacings")?;
        range(
            "misregistration",
            self.misregistration,
            0.0,
            10.0,
            "spacings",
        )?;
        range(
            "density_ratio",
            self.density_ratio,
            1.0,
            100.0,
            "dense end over sparse end",
        )?;
        range(
            "incidence_cap",
            self.incidence_cap,
            1.0,
            100.0,
            "largest noise factor",
        )?;
        if !(1..=16).contains(&self.views) {
            return Err(bad("views", self.views, "must be 1 to 16"));
        }
        if !self.sensors.is_empty() && self.sensors.len() != self.views {
            return Err(bad(
                "sensors",
                self.sensors.len(),
                format!("give one sensor per view ({} views) or none", self.views),
            ));
        }
        if self.views > 1 && !self.pattern.has_views() {
            return Err(bad(
                "views",
                self.views,
                format!(
                    "several views need the grid or view pattern, not {}",
                    self.pattern.name()
                ),
            ));
        }
        // A setting the pattern would ignore is a mistake in the request, not a no-op.
        if !self.sensors.is_empty() && !self.needs_sensor() {
            return Err(bad(
                "sensors",
                self.sensors.len(),
                "sensors are used by the grid and view patterns and by incidence noise only",
            ));
        }
        if self.line_direction.is_some() && self.pattern != Pattern::Lines {
            return Err(bad(
                "line_direction",
                format!("{:?}", self.line_direction),
                format!("is for the lines pattern, not {}", self.pattern.name()),
            ));
        }
        if self.density_direction.is_some() && self.density_ratio == 1.0 {
            return Err(bad(
                "density_direction",
                format!("{:?}", self.density_direction),
                "needs a density_ratio above 1",
            ));
        }
        for (name, d) in [
            ("line_direction", self.line_direction),
            ("density_direction", self.density_direction),
        ] {
            if let Some(d) = d
                && unit(d).is_none()
            {
                return Err(bad(
                    name,
                    format!("{d:?}"),
                    "must be a finite non-zero vector",
                ));
            }
        }
        if let Some(s) = self
            .sensors
            .iter()
            .find(|s| s.iter().any(|c| !c.is_finite()))
        {
            return Err(bad(
                "sensors",
                format!("{s:?}"),
                "every coordinate must be finite",
            ));
        }
        Ok(())
    }
}

/// A rigid motion `x -> rot x + trans` (model coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    pub rot: [V3; 3],
    pub trans: V3,
}

impl Motion {
    #[inline]
    pub fn apply(&self, p: V3) -> V3 {
        add(mat_vec(&self.rot, p), self.trans)
    }
}

/// One sensor (model coordinates).
#[derive(Debug, Clone)]
pub struct View {
    pub sensor: V3,
    /// The view's pitch (model units): `h` times its density factor.
    pub pitch: f64,
    /// Seed of the view's own grids and rays.
    pub seed: u64,
    /// Misregistration applied to its points (none for the first view).
    pub motion: Option<Motion>,
}

/// The cut planes of a line scan: plane k is `normal · x = offset + k gap` (model).
#[derive(Debug, Clone, Copy)]
pub struct Lines {
    pub normal: V3,
    pub offset: f64,
    pub gap: f64,
}

/// The density gradient: keep probability `exp(-ln_ratio (d · x - lo) / span)`.
#[derive(Debug, Clone, Copy)]
pub struct Density {
    pub dir: V3,
    pub lo: f64,
    pub span: f64,
    pub ln_ratio: f64,
}

impl Density {
    #[inline]
    pub fn keep(&self, p: V3) -> f64 {
        let t = ((dot(self.dir, p) - self.lo) / self.span).clamp(0.0, 1.0);
        (-self.ln_ratio * t).exp()
    }

    /// Mean keep probability over triangle `abc`: the 7-point rule (vertices 1/20, edge
    /// midpoints 2/15, centroid 9/20), exact for cubics; the keep is a smooth exponential of
    /// a linear function, within 1e-3 of the integral for ratios up to 100 on one triangle.
    pub fn mean_keep(&self, a: V3, b: V3, c: V3) -> f64 {
        let mid = |x: V3, y: V3| scale(add(x, y), 0.5);
        let g = scale(add(add(a, b), c), 1.0 / 3.0);
        (self.keep(a) + self.keep(b) + self.keep(c)) / 20.0
            + 2.0 / 15.0 * (self.keep(mid(a, b)) + self.keep(mid(b, c)) + self.keep(mid(c, a)))
            + 9.0 / 20.0 * self.keep(g)
    }
}

/// Everything the samplers need to know about the scanner (model coordinates).
#[derive(Debug, Clone, Default)]
pub struct Scanner {
    pub pattern: Pattern,
    /// The sensors: the views of `grid`/`view` scans, or the one sensor incidence noise
    /// is measured from.
    pub views: Vec<View>,
    pub lines: Option<Lines>,
    pub density: Option<Density>,
    /// `Some(cap)`: noise grows as 1 / cos θ up to `cap`.
    pub incidence_cap: Option<f64>,
    /// Noise along the sensor's ray instead of isotropic.
    pub along_ray: bool,
}

impl Scanner {
    /// The sensor a point of `view` was seen from: its view's, or the first sensor for points
    /// of patterns without views (`u32::MAX`).
    #[inline]
    pub fn sensor_for(&self, view: u32) -> Option<&View> {
        if view == u32::MAX {
            self.views.first()
        } else {
            self.views.get(view as usize)
        }
    }
}

const TAG_SENSOR: u64 = 0x5E_4503;
const TAG_LINES: u64 = 0x11_4E5;
const TAG_DENSITY: u64 = 0xDE_4517;
const TAG_MOTION: u64 = 0x40_7104;
pub(super) const TAG_VIEW: u64 = 0x71_E3;

/// Rotation matrix (rows) of angle `a` about the unit `axis` (Rodrigues' formula).
pub fn axis_angle(axis: V3, a: f64) -> [V3; 3] {
    let (s, c) = a.sin_cos();
    let t = 1.0 - c;
    let [x, y, z] = axis;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

/// A uniform random unit vector.
fn random_unit(rng: &mut SmallRng) -> V3 {
    loop {
        if let Some(u) = unit(gauss3(rng)) {
            return u;
        }
    }
}

/// A world direction in model coordinates (world = R · model + T, so model = Rᵀ world).
fn to_model_dir(rot: &[V3; 3], d: V3) -> V3 {
    let t = [0, 1, 2].map(|k| [rot[0][k], rot[1][k], rot[2][k]]);
    mat_vec(&t, d)
}

/// The part's placement and size, which the sensors are laid out around.
pub struct Frame<'a> {
    pub rotation: &'a [V3; 3],
    pub translation: V3,
    /// Radius of the model's bounding sphere about the origin (the part's centre).
    pub radius: f64,
    pub seed: u64,
}

/// Sensor positions in model coordinates: the given ones, or drawn (module comment).
fn sensor_positions(scan: &ScanPattern, f: &Frame) -> crate::error::Result<Vec<V3>> {
    if !scan.sensors.is_empty() {
        let rt = |w: V3| to_model_dir(f.rotation, sub(w, f.translation));
        let model: Vec<V3> = scan.sensors.iter().map(|&w| rt(w)).collect();
        if let Some((i, s)) = model
            .iter()
            .enumerate()
            .find(|(_, s)| norm(**s) <= 1.01 * f.radius)
        {
            return Err(super::bad(
                "sensors",
                format!("{:?}", scan.sensors[i]),
                format!(
                    "must lie outside the part's bounding sphere (radius {:.6} about the part's centre; this one is {:.6} from it)",
                    f.radius,
                    norm(*s)
                ),
            ));
        }
        return Ok(model);
    }
    let mut rng = SmallRng::seed_from_u64(derive(f.seed, &[TAG_SENSOR]));
    let d0 = random_unit(&mut rng);
    let mut out = vec![scale(d0, 4.0 * f.radius)];
    for _ in 1..scan.views {
        let axis = loop {
            if let Some(a) = unit(cross(d0, random_unit(&mut rng))) {
                break a;
            }
        };
        let angle = (30.0 + 45.0 * rng.random::<f64>()).to_radians();
        out.push(scale(mat_vec(&axis_angle(axis, angle), d0), 4.0 * f.radius));
    }
    Ok(out)
}

/// The scanner before the spacing is known: sensors, cut-plane and density directions.
pub struct Layout {
    pub sensors: Vec<V3>,
    pub line_normal: Option<V3>,
    pub density: Option<Density>,
}

/// Resolves the directions and positions of the pattern (model coordinates).
pub fn layout(scan: &ScanPattern, model: &Model, f: &Frame) -> crate::error::Result<Layout> {
    let sensors = if scan.needs_sensor() {
        sensor_positions(scan, f)?
    } else {
        Vec::new()
    };
    let drawn = |tag: u64, given: Option<V3>| -> V3 {
        match given.and_then(unit) {
            Some(d) => to_model_dir(f.rotation, d),
            None => random_unit(&mut SmallRng::seed_from_u64(derive(f.seed, &[tag]))),
        }
    };
    let line_normal =
        (scan.pattern == Pattern::Lines).then(|| drawn(TAG_LINES, scan.line_direction));
    let density = (scan.density_ratio > 1.0).then(|| {
        let dir = drawn(TAG_DENSITY, scan.density_direction);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in &model.mesh.vertices {
            lo = lo.min(dot(dir, *v));
            hi = hi.max(dot(dir, *v));
        }
        Density {
            dir,
            lo,
            span: (hi - lo).max(1e-300),
            ln_ratio: scan.density_ratio.ln(),
        }
    });
    Ok(Layout {
        sensors,
        line_normal,
        density,
    })
}

/// View `v`'s pitch factor: 1x to 2x over the views.
pub fn view_factor(v: usize, views: usize) -> f64 {
    if views > 1 {
        2f64.powf(v as f64 / (views - 1) as f64)
    } else {
        1.0
    }
}

/// A perspective camera at `sensor` looking at the model origin, with a roll drawn from
/// `seed`: pixel `(x, y)` (in units of the angular pitch) looks along `f + x r + y u`.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    pub sensor: V3,
    pub f: V3,
    pub r: V3,
    pub u: V3,
    /// Distance from the sensor to the centre.
    pub dist: f64,
}

impl Camera {
    pub fn new(sensor: V3, seed: u64) -> Camera {
        let dist = norm(sensor);
        let f = unit(scale(sensor, -1.0)).unwrap_or([0.0, 0.0, -1.0]);
        let (r0, u0) = plane_axes(f);
        let roll = std::f64::consts::TAU * super::geom::two_uniforms(derive(seed, &[TAG_SENSOR])).0;
        let (s, c) = roll.sin_cos();
        let r = add(scale(r0, c), scale(u0, s));
        Camera {
            sensor,
            f,
            r,
            u: cross(f, r),
            dist,
        }
    }

    /// Image coordinates of `q` on the plane at the centre's distance (model units), or
    /// `None` behind the sensor.
    pub fn project(&self, q: V3) -> Option<[f64; 2]> {
        let d = sub(q, self.sensor);
        let z = dot(d, self.f);
        (z > 0.0).then(|| {
            let s = self.dist / z;
            [dot(d, self.r) * s, dot(d, self.u) * s]
        })
    }
}

/// Points per `h²` of area that the pattern puts on triangle `t` of the model
/// (see the module comment), before the density gradient.
pub fn pitch_weight(model: &Model, lay: &Layout, scan: &ScanPattern, t: usize) -> f64 {
    let n = model.tri_normals[t];
    let tri = model.mesh.triangles[t].map(|i| model.mesh.vertices[i as usize]);
    let centroid = scale(add(add(tri[0], tri[1]), tri[2]), 1.0 / 3.0);
    match scan.pattern {
        Pattern::Uniform => 1.0,
        Pattern::Lines => {
            let d = lay.line_normal.unwrap_or([0.0, 0.0, 1.0]);
            norm(cross(n, d)) / scan.line_gap
        }
        Pattern::View => lay
            .sensors
            .iter()
            .enumerate()
            .filter(|(_, s)| dot(n, sub(**s, centroid)) > 0.0)
            .map(|(v, _)| view_factor(v, scan.views).powi(-2))
            .sum(),
        Pattern::Grid => {
            let area = 0.5 * norm(cross(sub(tri[1], tri[0]), sub(tri[2], tri[0])));
            if area.is_nan() || area <= 0.0 {
                return 0.0;
            }
            lay.sensors
                .iter()
                .enumerate()
                .filter(|(_, s)| dot(n, sub(**s, centroid)) > 0.0)
                .map(|(v, &s)| {
                    let cam = Camera::new(s, 0);
                    let q: Option<Vec<[f64; 2]>> = tri.iter().map(|&x| cam.project(x)).collect();
                    let proj = q.map_or(0.0, |q| {
                        0.5 * ((q[1][0] - q[0][0]) * (q[2][1] - q[0][1])
                            - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]))
                            .abs()
                    });
                    proj / area / view_factor(v, scan.views).powi(2)
                })
                .sum()
        }
    }
}

/// The resolved scanner for spacing `h`.
pub fn resolve(scan: &ScanPattern, lay: Layout, h: f64, f: &Frame) -> Scanner {
    let views: Vec<View> = lay
        .sensors
        .iter()
        .enumerate()
        .map(|(v, &sensor)| {
            let seed = if v == 0 {
                f.seed
            } else {
                derive(f.seed, &[TAG_VIEW, v as u64])
            };
            let motion = (v > 0 && scan.misregistration > 0.0).then(|| {
                let mut rng = SmallRng::seed_from_u64(derive(f.seed, &[TAG_MOTION, v as u64]));
                let half = 0.5 * scan.misregistration * h;
                let axis = random_unit(&mut rng);
                let dir = random_unit(&mut rng);
                Motion {
                    rot: axis_angle(axis, half / f.radius.max(1e-300)),
                    trans: scale(dir, half),
                }
            });
            View {
                sensor,
                pitch: h * view_factor(v, scan.views),
                seed,
                motion,
            }
        })
        .collect();
    let lines = lay.line_normal.map(|normal| {
        let gap = scan.line_gap * h;
        let (o, _) = super::geom::two_uniforms(derive(f.seed, &[TAG_LINES, 1]));
        Lines {
            normal,
            offset: o * gap,
            gap,
        }
    });
    Scanner {
        pattern: scan.pattern,
        views,
        lines,
        density: lay.density,
        incidence_cap: scan.incidence_noise.then_some(scan.incidence_cap),
        along_ray: scan.pattern.has_views(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_angle_turns_about_the_axis() {
        let r = axis_angle([0.0, 0.0, 1.0], std::f64::consts::FRAC_PI_2);
        let p = mat_vec(&r, [1.0, 0.0, 0.0]);
        assert!((p[0]).abs() < 1e-15 && (p[1] - 1.0).abs() < 1e-15 && p[2] == 0.0);
        let a = unit([1.0, 2.0, 3.0]).unwrap();
        assert!(crate::geometry::dist(mat_vec(&axis_angle(a, 0.7), a), a) < 1e-15);
    }

    #[test]
    fn density_keep_spans_the_ratio() {
        let d = Density {
            dir: [1.0, 0.0, 0.0],
            lo: 0.0,
            span: 10.0,
            ln_ratio: 4f64.ln(),
        };
        assert_eq!(d.keep([0.0, 5.0, 1.0]), 1.0);
        assert!((d.keep([10.0, 0.0, 0.0]) - 0.25).abs() < 1e-15);
        // Mean over a triangle spanning the whole range against the integral (1 - 1/4) / ln 4
        // of the keep along x (a right triangle over x in [0, 10] weighs x by (10 - x)).
        let exact = {
            let n = 100_000;
            (0..n)
                .map(|i| {
                    let x = (i as f64 + 0.5) / n as f64;
                    2.0 * (1.0 - x) * (-4f64.ln() * x).exp()
                })
                .sum::<f64>()
                / n as f64
        };
        let got = d.mean_keep([0.0; 3], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]);
        assert!((got - exact).abs() < 1e-3, "{got} vs {exact}");
    }

    #[test]
    fn incidence_factor_is_inverse_cosine_capped() {
        use super::super::sample::incidence_factor;
        let n = [0.0, 0.0, 1.0];
        let at = |deg: f64| {
            let a = deg.to_radians();
            incidence_factor(n, [a.sin(), 0.0, -a.cos()], 4.0)
        };
        assert!((at(0.0) - 1.0).abs() < 1e-15);
        assert!((at(60.0) - 2.0).abs() < 1e-12);
        assert_eq!(at(89.0), 4.0);
        assert_eq!(at(90.0), 4.0);
    }

    #[test]
    fn camera_projects_the_centre_to_the_image_centre() {
        let cam = Camera::new([0.0, 0.0, 10.0], 3);
        let c = cam.project([0.0; 3]).unwrap();
        assert!(c[0].abs() < 1e-12 && c[1].abs() < 1e-12);
        // A point 1 unit off-axis on the centre's plane projects 1 unit from the centre.
        let q = cam.project(cam.r).unwrap();
        assert!((q[0] - 1.0).abs() < 1e-12 && q[1].abs() < 1e-12);
        assert!(cam.project([0.0, 0.0, 20.0]).is_none());
    }
}
