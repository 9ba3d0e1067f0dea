//! Two fixed checks of issue 17 as bench modes: the sampling-pattern check
//! (`sharpedge bench --patterns`) and the CAD check (`sharpedge bench --cad`).
//!
//! Input: the point count, the bench seed and, for the CAD check, the data folder. Output: the
//! [`Case`]s of each mode (scored by the bench's own runner: `run_case`) and [`grid`], the
//! part × pattern summary the patterns mode prints under the bench's tables.
//!
//! Patterns: each part of [`PARTS`] (box, L-block, octagonal prism) under each pattern of
//! [`PATTERNS`] (uniform; scan lines 3 and 10 along-line spacings apart; a structured-light
//! grid from one sensor; three overlapping views with densities 1x–2x and 0.2 h
//! misregistration; one view; uniform with the density falling 4x across the part), all at
//! the suite's noise 0.15 h and rounding 1.5 h, rotated. Every pattern of a part has the same
//! seed (derived from the bench seed and the part's name), so the part sits the same way in
//! space under every pattern and the sensors, cut planes and gradient come from that seed.
//! The check: the same edges and corners as the uniform scan, i.e. every row passes
//! the random parts' thresholds (corner recall ≥ 0.98, precision ≥ 0.99; edge recall ≥ 0.97,
//! precision ≥ 0.99), with the seen rule (module [`super::seen`]) deciding what a one-sided
//! scan requires, and no found edge on a scan border (module [`super::border`]).
//!
//! CAD: fandisk, anchor and joint from `cad/` of the data folder, each sampled with the faceted
//! patches as they are (`subdivide 0`) and smoothed by two levels of Loop subdivision
//! (`subdivide 2`); sharp = dihedral beyond 30°. Found edges along facet creases below that
//! are neither required nor counted against precision (their length is reported).

use std::path::Path;

use super::{Case, Kind, Skipped, name_hash};
use crate::synth::geom::derive;
use crate::synth::{Part, Pattern, Sampling, ScanPattern, SynthParams};

/// Points per case of the patterns mode unless `--points` says otherwise: its 21 cases at
/// 100,000 points took 8.7 s on two cores (the CAD mode keeps the suite's 500,000, at which
/// its 6 cases took 13.5 s, and fandisk and anchor are sampled as in the suite).
pub const DEFAULT_POINTS: usize = 100_000;
/// The suite's noise and rounding, in spacings.
const NOISE: f64 = 0.15;
const ROUND: f64 = 1.5;

/// The parts of the patterns check: name, description.
pub const PARTS: [(&str, &str); 3] = [
    ("box", "box"),
    ("lblock", "L-block"),
    ("prism8", "octagonal prism"),
];

/// The patterns: name, description.
pub const PATTERNS: [(&str, &str); 7] = [
    ("uniform", "uniform"),
    ("lines3", "scan lines, gap 3"),
    ("lines10", "scan lines, gap 10"),
    ("grid", "structured-light grid, one sensor"),
    ("views3", "3 overlapping views"),
    ("view", "one view"),
    ("density4", "uniform, density 4x across"),
];

/// The scan pattern of a [`PATTERNS`] name.
fn scan_pattern(name: &str) -> ScanPattern {
    let base = ScanPattern::default();
    match name {
        "lines3" => ScanPattern {
            pattern: Pattern::Lines,
            line_gap: 3.0,
            ..base
        },
        "lines10" => ScanPattern {
            pattern: Pattern::Lines,
            line_gap: 10.0,
            ..base
        },
        "grid" => ScanPattern {
            pattern: Pattern::Grid,
            ..base
        },
        "views3" => ScanPattern {
            pattern: Pattern::View,
            views: 3,
            ..base
        },
        "view" => ScanPattern {
            pattern: Pattern::View,
            ..base
        },
        "density4" => ScanPattern {
            density_ratio: 4.0,
            ..base
        },
        _ => base,
    }
}

/// The case name of a part under a pattern.
pub fn case_name(part: &str, pattern: &str) -> String {
    format!("{part}/{pattern}")
}

/// The 21 cases of the patterns check, parts outer, patterns inner.
pub fn cases(points: usize, seed: u64) -> Vec<Case> {
    let mut out = Vec::new();
    for (part, part_desc) in PARTS {
        let (shape, sides) = match part {
            "lblock" => (Part::LBlock, 6),
            "prism8" => (Part::Prism, 8),
            _ => (Part::Box, 6),
        };
        for (pattern, pattern_desc) in PATTERNS {
            out.push(Case {
                name: case_name(part, pattern),
                description: format!("{part_desc}, {pattern_desc}"),
                kind: Kind::Pattern,
                accuracy: false,
                params: SynthParams {
                    part: shape.clone(),
                    sides,
                    sampling: Sampling::Points(points),
                    noise: NOISE,
                    round: ROUND,
                    rotate: true,
                    seed: derive(seed, &[name_hash(part)]),
                    scan: scan_pattern(pattern),
                    ..SynthParams::default()
                },
            });
        }
    }
    out
}

/// The CAD meshes: case stem and file in `cad/`.
pub const CAD: [(&str, &str); 3] = [
    ("fandisk", "fandisk.off"),
    ("anchor", "anchor_dense.off"),
    ("joint", "joint.off"),
];
/// Loop subdivision levels the CAD check samples each mesh with.
pub const CAD_SUBDIVIDE: [u32; 2] = [0, 2];
/// Sharp = dihedral beyond this (degrees).
pub const CAD_SHARP_DEG: f64 = 30.0;

/// The CAD check's cases; a mesh whose file is missing (or no data folder) is skipped with
/// the reason.
pub fn cad_cases(points: usize, seed: u64, data: Option<&Path>) -> (Vec<Case>, Vec<Skipped>) {
    let mut cases = Vec::new();
    let mut skipped = Vec::new();
    for (stem, file) in CAD {
        for level in CAD_SUBDIVIDE {
            let name = format!("{stem}-s{level}");
            let Some(path) = data
                .map(|d| d.join("cad").join(file))
                .filter(|f| f.is_file())
            else {
                skipped.push(Skipped {
                    case: name,
                    reason: match data {
                        Some(d) => format!("{} not found", d.join("cad").join(file).display()),
                        None => "no data folder (../shared/data absent; pass --data DIR)".into(),
                    },
                });
                continue;
            };
            cases.push(Case {
                description: format!(
                    "{stem} mesh, {}",
                    if level == 0 {
                        "facets as they are".to_string()
                    } else {
                        format!("subdivided {level}x")
                    }
                ),
                name: name.clone(),
                kind: Kind::Cad,
                accuracy: false,
                params: SynthParams {
                    part: Part::Mesh(path),
                    sampling: Sampling::Points(points),
                    noise: NOISE,
                    round: ROUND,
                    rotate: true,
                    seed: derive(seed, &[name_hash(&name)]),
                    sharp_angle: CAD_SHARP_DEG,
                    subdivide: level,
                    ..SynthParams::default()
                },
            });
        }
    }
    (cases, skipped)
}

/// The part × pattern summary of a patterns run: per cell corner recall / edge recall and
/// the verdict (`ok` or the number of failed checks), `n/a` for a case that did not run.
pub fn grid(results: &[super::CaseResult]) -> String {
    use std::fmt::Write;
    let mut t = String::new();
    let _ = write!(t, "{:<8}", "part");
    for (p, _) in PATTERNS {
        let _ = write!(t, " {p:>16}");
    }
    let _ = writeln!(t);
    for (part, _) in PARTS {
        let _ = write!(t, "{part:<8}");
        for (pattern, _) in PATTERNS {
            let name = case_name(part, pattern);
            let cell = results
                .iter()
                .find(|r| r.name == name)
                .and_then(|r| Some((r, r.corners.as_ref()?, r.edges.as_ref()?)))
                .map(|(r, c, e)| {
                    let fmt = |v: Option<f64>| v.map_or("n/a".into(), |v| format!("{v:.2}"));
                    let verdict = if r.pass {
                        "ok".to_string()
                    } else {
                        format!("x{}", r.checks.iter().filter(|c| !c.pass).count())
                    };
                    format!("{}/{} {verdict}", fmt(c.recall), fmt(e.recall))
                })
                .unwrap_or_else(|| "n/a".into());
            let _ = write!(t, " {cell:>16}");
        }
        let _ = writeln!(t);
    }
    let _ = writeln!(
        t,
        "cells: corner recall / edge recall over what the scan saw; ok = every check passes, xN = N checks fail"
    );
    t
}
