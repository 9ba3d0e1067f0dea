//! Random parts (`--part random --seed S`): closed triangle meshes drawn from the seed alone,
//! so that no fixed list of parts can be tuned against.
//!
//! Input: the seed. Output: a [`RandomPart`] — a closed, outward-wound triangle mesh in unit
//! proportions (largest extent of the base profile 1; the scan scales it like every part),
//! which of its edges are smooth although their triangles meet at an angle (the facets of a
//! wide fillet), where those fillets are, and a [`RandomDraw`] that says what was drawn.
//!
//! The part is an extrusion of a random simple polygon, built from its turning angles so that
//! every vertical edge's opening angle (the angle between its two faces, 180° minus the angle
//! between their normals) is drawn directly. Distribution (all uniform unless said):
//! - base profile: `n` in 4..=9 vertices, `k` concave ones in 0..=min(3, n − 3), at random
//!   places; a concave vertex turns by −[20°, 160°]; the convex turns are proportional to
//!   weights in [0.3, 1] and sum to 360° plus the concave turns, each within [20°, 160°]
//!   (else the draw is repeated). Interior angles are 180° minus the turn: convex vertical
//!   edges open 20°–160°, concave ones 20°–160° on the air side (material 200°–340°). Edge
//!   lengths [0.4, 1], the last two solved so the polygon closes (each at least 0.25);
//!   non-adjacent sides at least 0.08 of the profile's extent apart. Scaled to extent 1.
//! - chamfers: each convex vertex with an interior angle in [60°, 140°] is chamfered with
//!   probability 0.15 (at most 2): a cut of [0.05, 0.09] along both sides, a face whose two
//!   edges open 90° + α/2 (135° at a 90° vertex).
//! - fillets: each convex vertex with an interior angle in [70°, 150°] that is not chamfered is
//!   filleted with probability 0.15 (at most 2): radius [0.05, 0.10] (about 5–45 spacings for
//!   a part of size 100 at 30,000–500,000 points), an arc of one facet per 3° of turn (at
//!   least 8). A fillet is not a sharp edge: its facets' edges are smooth, its ends (the
//!   tangent lines) are chart borders but not sharp. Cuts and tangent distances take at most
//!   0.35 of each side.
//! - height [0.25, 0.7]; with probability 0.4 the side walls lean by [3°, 12°] (inwards with
//!   probability 0.7, else outwards): the top profile is the bottom one offset by
//!   height · tan(lean), so cap edges open 90° ∓ lean. A lean the profile cannot take (a side
//!   shrinking below 0.3 of itself or turning over) is halved, then dropped.
//! - a stacked block with probability 0.5: a convex polygon of 3..=6 vertices drawn like the
//!   base (no concave vertex), extent [0.2, 0.4], height [0.1, 0.3], on the top face at least
//!   0.05 from its border: concave edges where it stands, corners with mixed edges.
//! - through-holes with probability 0.5: 1 or 2 convex polygons of 3..=6 vertices, extent
//!   [0.08, 0.18], vertical, at least 0.04 from the outer border (at the bottom and the top),
//!   from each other and from the stacked block.
//!
//! Caps with holes are triangulated by `earcutr` (the Mapbox earcut algorithm). Every draw is
//! checked: each edge shared by exactly two triangles in opposite directions, positive volume,
//! no zero-area triangle, every sharp edge opening within [20°, 160°]; a draw that fails is
//! repeated with the next attempt's stream (the attempt number is in [`RandomDraw`]). Non
//! self-intersection holds by construction: profiles are simple with clearances, holes and the
//! block lie inside with clearances, walls are vertical or offset within a checked profile.

use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;

use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use serde::{Deserialize, Serialize};

use super::geom::derive;
use crate::error::{Error, Result};
use crate::geometry::{V3, cross, dot, triangle_normal};
use crate::io::mesh::Mesh;

type P2 = [f64; 2];

const TAG_RANDOM_PART: u64 = 0x4A9D_0F17;
/// Draws tried before giving up (the tests see at most a few dozen over 200 seeds).
const MAX_ATTEMPTS: u64 = 2000;
/// Every sharp edge of a random part opens within this range (degrees).
pub const MIN_OPENING_DEG: f64 = 20.0;
pub const MAX_OPENING_DEG: f64 = 160.0;
/// Two triangles whose normals differ by more than this meet at a sharp edge (as for the
/// other parametric parts: every non-coplanar edge).
const SHARP_RAD: f64 = 1e-6;

/// What was drawn, for the ground truth and the bench's case list. Lengths in the profile's
/// unit proportions (before the scan scales the part).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RandomDraw {
    /// Which attempt of the seed's stream passed the checks (0 = the first).
    pub attempt: u64,
    pub sides: usize,
    pub concave: usize,
    pub height: f64,
    /// Lean of the side walls in degrees (positive inwards), 0 when straight.
    pub taper_deg: f64,
    pub chamfers: usize,
    /// Fillet radii.
    pub fillets: Vec<f64>,
    /// Vertex count of each through-hole.
    pub holes: Vec<usize>,
    /// Vertex count of the stacked block, if any.
    pub stack: Option<usize>,
}

/// A wide fillet of a vertical edge: its facets' mesh vertices at the bottom and the top, in
/// arc order (the first and last are the tangent lines).
#[derive(Debug, Clone, PartialEq)]
pub struct FilletGeom {
    pub radius: f64,
    /// Interior angle of the vertex it rounds (degrees): the edge it replaces.
    pub angle_deg: f64,
    pub bottom: Vec<u32>,
    pub top: Vec<u32>,
}

/// A random part: the mesh, its sharp edges (`creases`), the smooth edges that end charts
/// (`breaks`: a fillet's tangent lines), the fillets and the draw.
#[derive(Debug, Clone)]
pub struct RandomPart {
    pub mesh: Mesh,
    pub creases: HashSet<(u32, u32)>,
    pub breaks: HashSet<(u32, u32)>,
    pub fillets: Vec<FilletGeom>,
    pub draw: RandomDraw,
}

/// What a profile vertex is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Tag {
    Plain,
    /// The `k`-th of `m + 1` arc vertices of fillet `f`.
    Arc {
        f: usize,
        k: usize,
    },
}

fn sub2(a: P2, b: P2) -> P2 {
    [a[0] - b[0], a[1] - b[1]]
}
fn cross2(a: P2, b: P2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}
fn len2(a: P2) -> f64 {
    a[0].hypot(a[1])
}
fn unit2(a: P2) -> P2 {
    let l = len2(a);
    [a[0] / l, a[1] / l]
}

/// Distance from `p` to segment `a b`.
fn point_seg2(p: P2, a: P2, b: P2) -> f64 {
    let d = sub2(b, a);
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        ((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2
    } else {
        0.0
    }
    .clamp(0.0, 1.0);
    len2(sub2(p, [a[0] + t * d[0], a[1] + t * d[1]]))
}

/// Distance between segments `a b` and `c d` (0 when they cross).
fn seg_seg2(a: P2, b: P2, c: P2, d: P2) -> f64 {
    let o = |p: P2, q: P2, r: P2| cross2(sub2(q, p), sub2(r, p));
    let (d1, d2, d3, d4) = (o(a, b, c), o(a, b, d), o(c, d, a), o(c, d, b));
    if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
        return 0.0;
    }
    point_seg2(a, c, d)
        .min(point_seg2(b, c, d))
        .min(point_seg2(c, a, b))
        .min(point_seg2(d, a, b))
}

/// Smallest distance between two non-adjacent sides of a closed polygon.
fn self_clearance(poly: &[P2]) -> f64 {
    let n = poly.len();
    let mut best = f64::INFINITY;
    for i in 0..n {
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue; // adjacent through vertex 0
            }
            let d = seg_seg2(poly[i], poly[(i + 1) % n], poly[j], poly[(j + 1) % n]);
            best = best.min(d);
        }
    }
    best
}

/// Smallest distance between the sides of two closed polygons.
fn clearance(a: &[P2], b: &[P2]) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..a.len() {
        for j in 0..b.len() {
            let d = seg_seg2(a[i], a[(i + 1) % a.len()], b[j], b[(j + 1) % b.len()]);
            best = best.min(d);
        }
    }
    best
}

/// Point in polygon (crossing number).
fn inside(p: P2, poly: &[P2]) -> bool {
    let mut c = false;
    let n = poly.len();
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                c = !c;
            }
        }
    }
    c
}

/// Signed area (positive counter-clockwise).
fn area2(poly: &[P2]) -> f64 {
    let n = poly.len();
    0.5 * (0..n)
        .map(|i| cross2(poly[i], poly[(i + 1) % n]))
        .sum::<f64>()
}

fn extent(poly: &[P2]) -> (P2, P2) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in poly {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// Interior angle (radians) at each vertex of a counter-clockwise polygon, in (0, 2π).
fn interior_angles(poly: &[P2]) -> Vec<f64> {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let a = sub2(poly[(i + n - 1) % n], poly[i]);
            let b = sub2(poly[(i + 1) % n], poly[i]);
            // Angle from b (next side) counter-clockwise to a (previous side): the material.
            let t = cross2(b, a).atan2(b[0] * a[0] + b[1] * a[1]);
            if t < 0.0 { t + 2.0 * PI } else { t }
        })
        .collect()
}

/// A simple counter-clockwise polygon with `n` vertices, `concave` of them concave, drawn from
/// its turning angles (see the module comment), centred, largest extent 1. `None` when the
/// draw fails a condition.
fn draw_polygon(rng: &mut SmallRng, n: usize, concave: usize) -> Option<Vec<P2>> {
    let mut order: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        let j = rng.random_range(0..=i);
        order.swap(i, j);
    }
    let mut tau = vec![0.0f64; n];
    let mut sum_concave = 0.0;
    for &i in &order[..concave] {
        let t = rng.random_range(MIN_OPENING_DEG..MAX_OPENING_DEG);
        tau[i] = -t;
        sum_concave += t;
    }
    let weights: Vec<f64> = (concave..n).map(|_| rng.random_range(0.3..1.0)).collect();
    let total: f64 = weights.iter().sum();
    let s = 360.0 + sum_concave;
    for (w, &i) in weights.iter().zip(&order[concave..]) {
        let t = s * w / total;
        if !(MIN_OPENING_DEG..=MAX_OPENING_DEG).contains(&t) {
            return None;
        }
        tau[i] = t;
    }
    // Side i starts at vertex i; the turn at vertex i leads from side i − 1 to side i.
    let mut theta = rng.random_range(0.0..360.0f64);
    let mut dirs = Vec::with_capacity(n);
    for (i, t) in tau.iter().enumerate() {
        if i > 0 {
            theta += t;
        }
        let r = theta.to_radians();
        dirs.push([r.cos(), r.sin()]);
    }
    let mut lengths: Vec<f64> = (0..n - 2).map(|_| rng.random_range(0.4..1.0)).collect();
    let mut rest = [0.0, 0.0];
    for (l, d) in lengths.iter().zip(&dirs) {
        rest = [rest[0] - l * d[0], rest[1] - l * d[1]];
    }
    // a · d[n−2] + b · d[n−1] = rest.
    let (u, v) = (dirs[n - 2], dirs[n - 1]);
    let det = cross2(u, v);
    if det.abs() < 1e-9 {
        return None;
    }
    let a = cross2(rest, v) / det;
    let b = cross2(u, rest) / det;
    if a < 0.25 || b < 0.25 {
        return None;
    }
    lengths.push(a);
    lengths.push(b);
    let mut poly = Vec::with_capacity(n);
    let mut p = [0.0, 0.0];
    for (l, d) in lengths.iter().zip(&dirs) {
        poly.push(p);
        p = [p[0] + l * d[0], p[1] + l * d[1]];
    }
    let (lo, hi) = extent(&poly);
    let ext = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let c = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let poly: Vec<P2> = poly
        .iter()
        .map(|q| [(q[0] - c[0]) / ext, (q[1] - c[1]) / ext])
        .collect();
    (area2(&poly) > 0.0 && self_clearance(&poly) >= 0.08).then_some(poly)
}

/// A profile after chamfers and fillets: its vertices with tags, each fillet's radius and
/// interior angle (degrees), and the chamfer count.
struct Rounded {
    profile: Vec<(P2, Tag)>,
    fillets: Vec<(f64, f64)>,
    chamfers: usize,
}

/// Chamfers and fillets on the vertices of `poly` (see the module comment).
fn round_vertices(rng: &mut SmallRng, poly: &[P2]) -> Rounded {
    let n = poly.len();
    let angles = interior_angles(poly);
    let side = |i: usize| len2(sub2(poly[(i + 1) % n], poly[i]));
    let mut out = Vec::new();
    let mut fillets = Vec::new();
    let mut chamfers = 0;
    for i in 0..n {
        let v = poly[i];
        let alpha = angles[i];
        let deg = alpha.to_degrees();
        let room = 0.35 * side((i + n - 1) % n).min(side(i));
        let u1 = unit2(sub2(poly[(i + n - 1) % n], v));
        let u2 = unit2(sub2(poly[(i + 1) % n], v));
        let roll: f64 = rng.random();
        let cut: f64 = rng.random_range(0.05..0.09);
        let radius: f64 = rng.random_range(0.05..0.10);
        if roll < 0.15 && (60.0..=140.0).contains(&deg) && chamfers < 2 && cut <= room {
            chamfers += 1;
            out.push(([v[0] + cut * u1[0], v[1] + cut * u1[1]], Tag::Plain));
            out.push(([v[0] + cut * u2[0], v[1] + cut * u2[1]], Tag::Plain));
            continue;
        }
        let t = radius / (0.5 * alpha).tan();
        if (0.15..0.3).contains(&roll)
            && (70.0..=150.0).contains(&deg)
            && fillets.len() < 2
            && t <= room
        {
            let f = fillets.len();
            fillets.push((radius, deg));
            let bis = unit2([u1[0] + u2[0], u1[1] + u2[1]]);
            let cd = radius / (0.5 * alpha).sin();
            let c = [v[0] + cd * bis[0], v[1] + cd * bis[1]];
            let t1 = [v[0] + t * u1[0], v[1] + t * u1[1]];
            let t2 = [v[0] + t * u2[0], v[1] + t * u2[1]];
            let a1 = (t1[1] - c[1]).atan2(t1[0] - c[0]);
            let a2 = (t2[1] - c[1]).atan2(t2[0] - c[0]);
            let mut delta = a2 - a1;
            while delta > PI {
                delta -= 2.0 * PI;
            }
            while delta < -PI {
                delta += 2.0 * PI;
            }
            let m = ((PI - alpha).to_degrees() / 3.0).ceil().max(8.0) as usize;
            for k in 0..=m {
                let p = match k {
                    0 => t1,
                    _ if k == m => t2,
                    _ => {
                        let a = a1 + delta * k as f64 / m as f64;
                        [c[0] + radius * a.cos(), c[1] + radius * a.sin()]
                    }
                };
                out.push((p, Tag::Arc { f, k }));
            }
            continue;
        }
        out.push((v, Tag::Plain));
    }
    Rounded {
        profile: out,
        fillets,
        chamfers,
    }
}

/// The profile offset inwards by `d` (outwards for `d < 0`): every side moves along its
/// inward normal. `None` when a side would shrink below 0.3 of itself or turn over, or the
/// result is not simple.
fn offset(poly: &[P2], d: f64) -> Option<Vec<P2>> {
    let n = poly.len();
    let normal = |i: usize| {
        let e = unit2(sub2(poly[(i + 1) % n], poly[i]));
        [-e[1], e[0]] // left of a counter-clockwise side: inwards
    };
    let out: Vec<P2> = (0..n)
        .map(|i| {
            let (a, b) = (normal((i + n - 1) % n), normal(i));
            let s = d / (1.0 + a[0] * b[0] + a[1] * b[1]);
            [
                poly[i][0] + s * (a[0] + b[0]),
                poly[i][1] + s * (a[1] + b[1]),
            ]
        })
        .collect();
    for i in 0..n {
        let old = sub2(poly[(i + 1) % n], poly[i]);
        let new = sub2(out[(i + 1) % n], out[i]);
        if old[0] * new[0] + old[1] * new[1] < 0.3 * (old[0] * old[0] + old[1] * old[1]) {
            return None;
        }
    }
    (self_clearance(&out) >= 0.02).then_some(out)
}

/// A convex polygon of extent `size` placed at a random point inside `within` (every polygon
/// of it), at least `gap` from their borders and from every polygon of `avoid`.
fn place(
    rng: &mut SmallRng,
    sides: usize,
    size: f64,
    within: &[&[P2]],
    avoid: &[&[P2]],
    gap: f64,
) -> Option<Vec<P2>> {
    let shape = (0..20).find_map(|_| draw_polygon(rng, sides, 0))?;
    let (lo, hi) = extent(within[0]);
    for _ in 0..50 {
        let c = [
            rng.random_range(lo[0]..hi[0]),
            rng.random_range(lo[1]..hi[1]),
        ];
        let p: Vec<P2> = shape
            .iter()
            .map(|q| [c[0] + size * q[0], c[1] + size * q[1]])
            .collect();
        let ok = within
            .iter()
            .all(|w| inside(p[0], w) && clearance(&p, w) >= gap)
            && avoid
                .iter()
                .all(|a| !inside(p[0], a) && !inside(a[0], &p) && clearance(&p, a) >= gap);
        if ok {
            return Some(p);
        }
    }
    None
}

/// Triangulates a planar cap (outer ring and holes, as mesh vertex ids, at one height) and
/// appends its triangles facing +z (`up`) or −z.
fn cap(
    vertices: &[V3],
    outer: &[u32],
    holes: &[&[u32]],
    up: bool,
    tris: &mut Vec<[u32; 3]>,
) -> Option<()> {
    let mut data = Vec::new();
    let mut ids = Vec::new();
    let mut starts = Vec::new();
    for (r, ring) in std::iter::once(outer)
        .chain(holes.iter().copied())
        .enumerate()
    {
        if r > 0 {
            starts.push(ids.len());
        }
        for &v in ring {
            data.push(vertices[v as usize][0]);
            data.push(vertices[v as usize][1]);
            ids.push(v);
        }
    }
    let t = earcutr::earcut(&data, &starts, 2).ok()?;
    for c in t.chunks(3) {
        let [a, b, c] = [ids[c[0]], ids[c[1]], ids[c[2]]];
        let p = |v: u32| [vertices[v as usize][0], vertices[v as usize][1]];
        let s = cross2(sub2(p(b), p(a)), sub2(p(c), p(a)));
        if s.abs() < 1e-12 {
            return None; // a zero-area triangle would have no normal
        }
        tris.push(if (s > 0.0) == up {
            [a, b, c]
        } else {
            [a, c, b]
        });
    }
    Some(())
}

/// Checks that `mesh` is closed and consistently wound: every edge is used by exactly two
/// triangles, once in each direction, and the enclosed volume is positive.
pub fn check_closed(mesh: &Mesh) -> std::result::Result<f64, String> {
    let mut uses: HashMap<(u32, u32), i32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if a == b {
                return Err(format!("triangle {t:?} repeats a vertex"));
            }
            *uses.entry((a, b)).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &uses {
        let back = uses.get(&(b, a)).copied().unwrap_or(0);
        if n != 1 || back != 1 {
            return Err(format!(
                "edge {a}-{b} is used {n} times forwards, {back} backwards"
            ));
        }
    }
    let volume: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            dot(a, cross(b, c)) / 6.0
        })
        .sum();
    if volume > 0.0 {
        Ok(volume)
    } else {
        Err(format!("enclosed volume {volume} is not positive"))
    }
}

/// Opening angle (degrees) of every edge whose triangles' normals differ by more than the
/// sharp angle and that is not in `smooth`, keyed by (smaller, larger) vertex id.
pub fn sharp_openings(mesh: &Mesh, smooth: &HashSet<(u32, u32)>) -> HashMap<(u32, u32), f64> {
    let normals: Vec<Option<V3>> = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            triangle_normal(a, b, c)
        })
        .collect();
    let mut by_edge: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (i, t) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            by_edge.entry((a.min(b), a.max(b))).or_default().push(i);
        }
    }
    let mut out = HashMap::new();
    for (key, ts) in by_edge {
        if ts.len() != 2 || smooth.contains(&key) {
            continue;
        }
        let (Some(n0), Some(n1)) = (normals[ts[0]], normals[ts[1]]) else {
            continue;
        };
        let theta = crate::geometry::angle(n0, n1);
        if theta > SHARP_RAD {
            out.insert(key, 180.0 - theta.to_degrees());
        }
    }
    out
}

/// The random part of `seed` (see the module comment).
pub fn build(seed: u64) -> Result<RandomPart> {
    for attempt in 0..MAX_ATTEMPTS {
        let mut rng = SmallRng::seed_from_u64(derive(seed, &[TAG_RANDOM_PART, attempt]));
        if let Some(mut part) = attempt_part(&mut rng) {
            part.draw.attempt = attempt;
            return Ok(part);
        }
    }
    Err(Error::Degenerate {
        what: "random part",
        why: format!("no valid part in {MAX_ATTEMPTS} draws from seed {seed}"),
    })
}

fn attempt_part(rng: &mut SmallRng) -> Option<RandomPart> {
    let n = rng.random_range(4..=9usize);
    let concave = rng.random_range(0..=(n - 3).min(3));
    let base = draw_polygon(rng, n, concave)?;
    let Rounded {
        profile,
        fillets: fillet_params,
        chamfers,
    } = round_vertices(rng, &base);
    let height: f64 = rng.random_range(0.25..0.7);
    let bottom: Vec<P2> = profile.iter().map(|p| p.0).collect();
    let mut taper_deg = 0.0;
    let mut top = bottom.clone();
    if rng.random::<f64>() < 0.4 {
        let lean: f64 = rng.random_range(3.0..12.0);
        let signed = if rng.random::<f64>() < 0.7 {
            lean
        } else {
            -lean
        };
        // A profile that cannot take the lean (a fillet smaller than the offset) takes half.
        for lean in [signed, 0.5 * signed] {
            if let Some(t) = offset(&bottom, height * lean.to_radians().tan()) {
                top = t;
                taper_deg = lean;
                break;
            }
        }
    }
    let stack = if rng.random::<f64>() < 0.5 {
        let sides = rng.random_range(3..=6usize);
        let size = rng.random_range(0.2..0.4);
        let h2 = rng.random_range(0.1..0.3);
        place(rng, sides, size, &[&top], &[], 0.05).map(|p| (p, h2))
    } else {
        None
    };
    let mut holes: Vec<Vec<P2>> = Vec::new();
    if rng.random::<f64>() < 0.5 {
        let count = rng.random_range(1..=2usize);
        for _ in 0..count {
            let sides = rng.random_range(3..=6usize);
            let size = rng.random_range(0.08..0.18);
            let mut avoid: Vec<&[P2]> = holes.iter().map(Vec::as_slice).collect();
            if let Some((s, _)) = &stack {
                avoid.push(s);
            }
            if let Some(h) = place(rng, sides, size, &[&bottom, &top], &avoid, 0.04) {
                holes.push(h);
            }
        }
    }

    // Mesh: rings of vertices, walls, caps.
    let mut vertices: Vec<V3> = Vec::new();
    let mut ring = |poly: &[P2], z: f64| -> Vec<u32> {
        poly.iter()
            .map(|p| {
                vertices.push([p[0], p[1], z]);
                (vertices.len() - 1) as u32
            })
            .collect()
    };
    let ob = ring(&bottom, 0.0);
    let ot = ring(&top, height);
    let hb: Vec<Vec<u32>> = holes.iter().map(|h| ring(h, 0.0)).collect();
    let ht: Vec<Vec<u32>> = holes.iter().map(|h| ring(h, height)).collect();
    let st = stack
        .as_ref()
        .map(|(s, h2)| (ring(s, height), ring(s, height + h2)));
    let mut tris: Vec<[u32; 3]> = Vec::new();
    // Walls of a counter-clockwise ring pair face outwards; a hole's walls face into it.
    let wall = |lo: &[u32], hi: &[u32], outward: bool, tris: &mut Vec<[u32; 3]>| {
        let m = lo.len();
        for i in 0..m {
            let j = (i + 1) % m;
            if outward {
                tris.push([lo[i], lo[j], hi[j]]);
                tris.push([lo[i], hi[j], hi[i]]);
            } else {
                tris.push([lo[i], hi[j], lo[j]]);
                tris.push([lo[i], hi[i], hi[j]]);
            }
        }
    };
    wall(&ob, &ot, true, &mut tris);
    for (b, t) in hb.iter().zip(&ht) {
        wall(b, t, false, &mut tris);
    }
    let hole_refs_b: Vec<&[u32]> = hb.iter().map(Vec::as_slice).collect();
    cap(&vertices, &ob, &hole_refs_b, false, &mut tris)?;
    let mut top_holes: Vec<&[u32]> = ht.iter().map(Vec::as_slice).collect();
    if let Some((s0, s1)) = &st {
        wall(s0, s1, true, &mut tris);
        top_holes.push(s0);
        cap(&vertices, s1, &[], true, &mut tris)?;
    }
    cap(&vertices, &ot, &top_holes, true, &mut tris)?;
    let mesh = Mesh {
        vertices,
        triangles: tris,
    };
    check_closed(&mesh).ok()?;

    // Fillets: their facets' vertical edges are smooth; the tangent lines end charts.
    let mut fillets: Vec<FilletGeom> = fillet_params
        .iter()
        .map(|&(radius, angle_deg)| FilletGeom {
            radius,
            angle_deg,
            bottom: Vec::new(),
            top: Vec::new(),
        })
        .collect();
    for (i, (_, tag)) in profile.iter().enumerate() {
        if let Tag::Arc { f, k } = *tag {
            debug_assert_eq!(fillets[f].bottom.len(), k);
            fillets[f].bottom.push(ob[i]);
            fillets[f].top.push(ot[i]);
        }
    }
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut smooth = HashSet::new();
    let mut breaks = HashSet::new();
    for f in &fillets {
        let m = f.bottom.len();
        for k in 0..m {
            let e = key(f.bottom[k], f.top[k]);
            smooth.insert(e);
            if k == 0 || k + 1 == m {
                breaks.insert(e);
            }
        }
    }
    let openings = sharp_openings(&mesh, &smooth);
    if openings
        .values()
        .any(|o| !(MIN_OPENING_DEG..=MAX_OPENING_DEG).contains(o))
    {
        return None;
    }
    Some(RandomPart {
        creases: openings.keys().copied().collect(),
        breaks,
        draw: RandomDraw {
            attempt: 0,
            sides: n,
            concave,
            height,
            taper_deg,
            chamfers,
            fillets: fillets.iter().map(|f| f.radius).collect(),
            holes: holes.iter().map(Vec::len).collect(),
            stack: stack.as_ref().map(|s| s.0.len()),
        },
        fillets,
        mesh,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygons_from_turning_angles_close_and_keep_their_angles() {
        let mut rng = SmallRng::seed_from_u64(7);
        let mut made = 0;
        for _ in 0..500 {
            let Some(p) = draw_polygon(&mut rng, 7, 2) else {
                continue;
            };
            made += 1;
            let angles = interior_angles(&p);
            let reflex = angles.iter().filter(|a| **a > PI).count();
            assert_eq!(reflex, 2);
            for a in angles {
                let opening = if a > PI { 2.0 * PI - a } else { a }.to_degrees();
                assert!((19.999..=160.001).contains(&opening), "{opening}");
            }
            assert!(area2(&p) > 0.0);
        }
        assert!(made > 20, "{made}");
    }

    #[test]
    fn offset_square_by_a_tenth() {
        let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let o = offset(&sq, 0.1).unwrap();
        for (p, q) in o
            .iter()
            .zip([[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.1, 0.9]])
        {
            assert!(
                (p[0] - q[0]).abs() < 1e-12 && (p[1] - q[1]).abs() < 1e-12,
                "{p:?}"
            );
        }
        assert!(
            offset(&sq, 0.4).is_none(),
            "sides shrink to 0.2 of themselves"
        );
    }

    #[test]
    fn segment_distances() {
        assert_eq!(
            seg_seg2([0.0, 0.0], [1.0, 1.0], [0.0, 1.0], [1.0, 0.0]),
            0.0
        );
        assert!((seg_seg2([0.0, 0.0], [1.0, 0.0], [0.0, 0.5], [1.0, 0.5]) - 0.5).abs() < 1e-15);
    }
}
