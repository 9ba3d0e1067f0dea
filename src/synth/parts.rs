//! Parametric parts as closed, outward-wound triangle meshes, so the sampler has one code path.
//!
//! Every part is built in unit-ish proportions and then scaled so that its largest extent is
//! `size` and its bounding box is centred on the origin. Shapes (before scaling):
//! - `box`: 1.0 × 0.8 × 0.6 (not a cube, so the axes are distinguishable): 12 convex 90° edges.
//! - `lblock`: an L profile (1.0 × 0.7 with legs 0.35 and 0.4 thick) extruded by 0.5:
//!   one concave 270° edge along the extrusion, 17 convex 90° edges.
//! - `step`: a staircase of `steps` equal steps (profile `steps` × `steps`, extruded by
//!   0.6 `steps`): `steps − 1` concave edges along the extrusion, the rest convex.
//! - `wedge`: an isosceles triangle with apex angle `angle` extruded by 1.0 (legs 1.0): the
//!   apex edge has the dihedral angle `angle`, the two base edges (180° − angle) / 2.
//! - `prism`: a regular `sides`-gon of circumradius 0.5 extruded by 1.0: side edges have the
//!   dihedral angle (sides − 2)·180° / sides (120° for 6, 135° for 8), cap edges 90°.
//! - `pyramid`: a square base of side 1.0 and height 0.7: four edges meet at the apex.
//!
//! Caps of extruded profiles are triangulated by ear clipping (Meisters, "Polygons have ears",
//! 1975), which handles the non-convex L and staircase profiles.

use crate::geometry::V3;
use crate::io::mesh::Mesh;

/// The part to scan: a parametric shape or a triangle mesh file.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Part {
    Box,
    LBlock,
    Step,
    Wedge,
    Prism,
    Pyramid,
    Sphere,
    /// A part drawn from the seed (module [`super::random`]).
    Random,
    /// An OFF, PLY or OBJ triangle mesh.
    Mesh(std::path::PathBuf),
}

impl Part {
    /// The names [`Part::from_str`](std::str::FromStr) accepts.
    pub const NAMES: &'static str = "box, lblock, step, wedge, prism, pyramid, sphere, random";

    /// The part's name; for a mesh, the file name.
    pub fn name(&self) -> String {
        match self {
            Part::Box => "box".into(),
            Part::LBlock => "lblock".into(),
            Part::Step => "step".into(),
            Part::Wedge => "wedge".into(),
            Part::Prism => "prism".into(),
            Part::Pyramid => "pyramid".into(),
            Part::Sphere => "sphere".into(),
            Part::Random => "random".into(),
            Part::Mesh(p) => p
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_else(|| p.display().to_string()),
        }
    }
}

impl std::str::FromStr for Part {
    type Err = crate::Error;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "box" => Part::Box,
            "lblock" | "l-block" | "l" => Part::LBlock,
            "step" | "stepped" | "steps" => Part::Step,
            "wedge" => Part::Wedge,
            "prism" => Part::Prism,
            "pyramid" => Part::Pyramid,
            "sphere" => Part::Sphere,
            "random" => Part::Random,
            _ => {
                return Err(crate::Error::SynthParam {
                    name: "part",
                    value: format!("{s:?}"),
                    allowed: format!("one of {}", Part::NAMES),
                });
            }
        })
    }
}

/// The polyhedral mesh of `shape` (unscaled); `None` for the sphere, which is analytic, for
/// the random part (module `random`, drawn from the seed) and for a mesh file.
pub fn polyhedron(shape: &Part, sides: usize, angle_deg: f64, steps: usize) -> Option<Mesh> {
    Some(match shape {
        Part::Box => extrude(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.8], [0.0, 0.8]], 0.6),
        Part::LBlock => extrude(
            &[
                [0.0, 0.0],
                [1.0, 0.0],
                [1.0, 0.35],
                [0.4, 0.35],
                [0.4, 0.7],
                [0.0, 0.7],
            ],
            0.5,
        ),
        Part::Step => {
            let k = steps as f64;
            let mut p = vec![[0.0, 0.0], [k, 0.0]];
            for i in 0..steps {
                let x = k - i as f64;
                let y = i as f64 + 1.0;
                p.push([x, y]);
                p.push([x - 1.0, y]);
            }
            extrude(&p, 0.6 * k)
        }
        Part::Wedge => {
            let h = 0.5 * angle_deg.to_radians();
            extrude(&[[0.0, 0.0], [h.cos(), -h.sin()], [h.cos(), h.sin()]], 1.0)
        }
        Part::Prism => {
            let p: Vec<[f64; 2]> = (0..sides)
                .map(|i| {
                    let a = std::f64::consts::TAU * i as f64 / sides as f64;
                    [0.5 * a.cos(), 0.5 * a.sin()]
                })
                .collect();
            extrude(&p, 1.0)
        }
        Part::Pyramid => Mesh {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.5, 0.5, 0.7],
            ],
            triangles: vec![
                [0, 2, 1],
                [0, 3, 2],
                [0, 1, 4],
                [1, 2, 4],
                [2, 3, 4],
                [3, 0, 4],
            ],
        },
        Part::Sphere | Part::Random | Part::Mesh(_) => return None,
    })
}

/// Scales `mesh` so its largest extent is `size` and centres its bounding box on the origin.
/// Returns the centre (before scaling) and the scale factor.
pub fn normalise(mesh: &mut Mesh, size: Option<f64>) -> (V3, f64) {
    let Some((lo, hi)) = mesh.bbox() else {
        return ([0.0; 3], 1.0);
    };
    let c = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let ext = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let s = match size {
        Some(size) if ext > 0.0 => size / ext,
        _ => 1.0,
    };
    for v in &mut mesh.vertices {
        *v = [0, 1, 2].map(|k| (v[k] - c[k]) * s);
    }
    (c, s)
}

/// A prism over a counter-clockwise profile in the xy-plane, from z = 0 to z = `depth`.
fn extrude(profile: &[[f64; 2]], depth: f64) -> Mesh {
    let n = profile.len() as u32;
    let mut vertices: Vec<V3> = profile.iter().map(|p| [p[0], p[1], 0.0]).collect();
    vertices.extend(profile.iter().map(|p| [p[0], p[1], depth]));
    let mut triangles = Vec::new();
    for i in 0..n {
        let j = (i + 1) % n;
        // Outward normal of a counter-clockwise profile's edge is on its right.
        triangles.push([i, j, j + n]);
        triangles.push([i, j + n, i + n]);
    }
    for [a, b, c] in ear_clip(profile) {
        triangles.push([a, c, b]); // bottom cap faces -z
        triangles.push([a + n, b + n, c + n]); // top cap faces +z
    }
    Mesh {
        vertices,
        triangles,
    }
}

/// Triangulates a simple counter-clockwise polygon by ear clipping; O(n²), for small n.
fn ear_clip(poly: &[[f64; 2]]) -> Vec<[u32; 3]> {
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut idx: Vec<usize> = (0..poly.len()).collect();
    let mut out = Vec::new();
    let mut guard = 0;
    while idx.len() > 3 && guard < 10_000 {
        guard += 1;
        let m = idx.len();
        let mut clipped = false;
        for k in 0..m {
            let (ia, ib, ic) = (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
            let (a, b, c) = (poly[ia], poly[ib], poly[ic]);
            if cross(a, b, c) <= 0.0 {
                continue; // reflex or flat vertex: not an ear
            }
            let blocked = idx.iter().any(|&j| {
                j != ia
                    && j != ib
                    && j != ic
                    && cross(a, b, poly[j]) >= 0.0
                    && cross(b, c, poly[j]) >= 0.0
                    && cross(c, a, poly[j]) >= 0.0
            });
            if !blocked {
                out.push([ia as u32, ib as u32, ic as u32]);
                idx.remove(k);
                clipped = true;
                break;
            }
        }
        if !clipped {
            break; // not simple; the profiles here always are
        }
    }
    if idx.len() == 3 {
        out.push([idx[0] as u32, idx[1] as u32, idx[2] as u32]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{cross, dot};

    fn signed_volume(m: &Mesh) -> f64 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.vertices[i as usize]);
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn volumes_are_positive_and_exact() {
        let cases = [
            (Part::Box, 0.48),
            (Part::LBlock, (1.0 * 0.35 + 0.4 * 0.35) * 0.5),
            (Part::Step, (1.0 + 2.0 + 3.0) * 1.8),
            (Part::Pyramid, 0.7 / 3.0),
            (Part::Wedge, 0.5 * (15f64.to_radians() * 2.0).sin()),
        ];
        for (s, want) in cases {
            let m = polyhedron(&s, 6, 30.0, 3).unwrap();
            assert!((signed_volume(&m) - want).abs() < 1e-12, "{s:?}");
        }
        let hex = polyhedron(&Part::Prism, 6, 30.0, 3).unwrap();
        let area = 6.0 * 0.5 * 0.25 * 60f64.to_radians().sin();
        assert!((signed_volume(&hex) - area).abs() < 1e-12);
    }

    #[test]
    fn ear_clip_l_profile() {
        let l = [
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 0.35],
            [0.4, 0.35],
            [0.4, 0.7],
            [0.0, 0.7],
        ];
        let t = ear_clip(&l);
        assert_eq!(t.len(), 4);
        let area: f64 = t
            .iter()
            .map(|&[a, b, c]| {
                let (a, b, c) = (l[a as usize], l[b as usize], l[c as usize]);
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
            })
            .sum();
        assert!((area - 0.49).abs() < 1e-12);
    }

    #[test]
    fn normalise_sets_largest_extent() {
        let mut m = polyhedron(&Part::Box, 6, 30.0, 3).unwrap();
        let (c, s) = normalise(&mut m, Some(100.0));
        assert_eq!(c, [0.5, 0.4, 0.3]);
        assert_eq!(s, 100.0);
        assert_eq!(m.bbox(), Some(([-50.0, -40.0, -30.0], [50.0, 40.0, 30.0])));
    }

    #[test]
    fn unknown_part_name_lists_the_choices() {
        let e = "cube".parse::<Part>().unwrap_err().to_string();
        assert_eq!(
            e,
            "synth parameter part = \"cube\": one of box, lblock, step, wedge, prism, pyramid, sphere, random"
        );
    }
}
