//! Occlusion boundaries: where the sensor's view of a surface ends. A run of edge candidates
//! there is a border of the scan, never a sharp edge of the part (issue 16, item 4; issue 17,
//! item 3).
//!
//! Two signs, each used where the input gives what it needs:
//! - **A depth jump on the scan's grid** (organised PCD frames, structured E57 scans): two
//!   neighbouring cells whose ranges differ by more than a surface seen at
//!   [`MAX_INCIDENCE_DEG`] could give. The silhouette of an object against what lies behind
//!   it, a table's far rim. Both cells, and the cells within [`JUMP_REACH`] of them, are
//!   marked ([`depth_jumps`]).
//! - **A face seen edge-on** from the sensor: a fitted edge whose face trace runs along the
//!   sensor's ray (within 90° − [`MAX_INCIDENCE_DEG`]) in most of its slabs. A depth camera
//!   leaves a veil of mixed pixels between a silhouette and the background, which the fit
//!   takes for a second face; no real face is sampled at such an angle. It needs the sensor
//!   position: the point's scan pose, or the one `input.sensors` entry.
//! - **One face only**, on any cloud: a fitted edge whose smaller side reaches less than
//!   [`BORDER_REACH`] spacings along its face and a small share of what the other side
//!   reaches, where both faces of an edge reach across the slab band: the scan of one face
//!   ends there (a one-view silhouette).
//!
//! Inputs: positions, the cloud's [`ScanStructure`] (optional), the sensors, the fitted edges
//! and their runs. Output: per point the jump marks, and per fitted edge whether it is an
//! occlusion boundary ([`is_border`]). Clouds without a grid or a sensor get no jump mark and
//! only the one-face test.

use crate::cloud::ScanStructure;
use crate::geometry::{add, cross, dot, norm, sub};
use crate::stages::edges::EdgeFit;
use crate::stages::faces::Plane;
use crate::stages::scale::quantile;

/// Beyond this angle between a surface's normal and the sensor's ray the surface counts as
/// seen edge-on (degrees). Structured light and time of flight sample a face at 80° with
/// neighbouring cells 5.8 times farther apart than face-on; PCL's organised edge detection
/// calls a relative depth step of 2 % per cell (86° at a Kinect's 1.7 mrad pitch) a jump.
pub const MAX_INCIDENCE_DEG: f64 = 80.0;

/// Grid cells within this many rows or columns of a depth jump are marked with it: the
/// candidates of an edge fit lie within a few spacings of the boundary.
pub const JUMP_REACH: u32 = 3;

/// Largest share of a run's or face's points from other scans than its main one for it to
/// be judged from that scan's sensor (see [`sensor_of`]).
pub const OTHER_SCANS: f64 = 0.2;

/// A scan's grid is walked for depth jumps when it has at most this many cells per point of
/// the scan (plus 65,536): an organised depth frame has 1–2 (its NaN slots), a terrestrial
/// scan's grid a little over one.
pub const MAX_CELLS_PER_POINT: usize = 4;

/// A fitted edge whose smaller side reaches less than this many spacings along its face (in
/// the median slab) ...
pub const BORDER_REACH: f64 = 2.0;

/// ... and less than this share of what its larger side reaches ([`is_border`]).
pub const BORDER_RATIO: f64 = 0.3;

/// Share of a run's points (or of an edge's slabs) on an occlusion boundary that makes the
/// whole edge one.
const BORDER_SHARE: f64 = 0.5;

/// Marks the points next to a depth jump of their scan's grid (see the module comment);
/// all false when the cloud has no grid. `positions` are in the cloud's order, as
/// `structure` is.
pub fn depth_jumps(positions: &[[f64; 3]], structure: Option<&ScanStructure>) -> Vec<bool> {
    let n = positions.len();
    let mut jump = vec![false; n];
    let Some(s) = structure.filter(|s| s.grid.len() == n && s.scan.len() == n) else {
        return jump;
    };
    let slope = MAX_INCIDENCE_DEG.to_radians().tan();
    // The points of each scan, in one pass (a file of many scans walks the cloud once).
    let mut points_of: Vec<Vec<u32>> = vec![Vec::new(); s.scans.len()];
    for (i, &k) in s.scan.iter().enumerate() {
        if let Some(v) = points_of.get_mut(k as usize) {
            v.push(i as u32);
        }
    }
    for (k, scan) in s.scans.iter().enumerate() {
        let Some([rows, cols]) = scan.grid_size else {
            continue;
        };
        let (rows, cols) = (rows as usize, cols as usize);
        // The grid's arrays cost a few bytes a cell: a grid far larger than its points (a
        // file's row or column index far beyond the others) is not walked.
        let bound = MAX_CELLS_PER_POINT * points_of[k].len() + 65_536;
        let Some(slots) = rows.checked_mul(cols).filter(|&c| c <= bound) else {
            tracing::debug!(
                "scan {k} ({}): a {rows} x {cols} grid for {} points; no depth jumps looked for",
                scan.name,
                points_of[k].len()
            );
            continue;
        };
        let origin = scan.pose.translation;
        // Point id in each cell of this scan's grid (u32::MAX: no point).
        let mut cell = vec![u32::MAX; slots];
        for &i in &points_of[k] {
            let [r, c] = s.grid[i as usize];
            if (r as usize) < rows && (c as usize) < cols {
                cell[r as usize * cols + c as usize] = i;
            }
        }
        let at = |r: usize, c: usize, dr: isize, dc: isize| -> Option<usize> {
            let (r2, c2) = (r as isize + dr, c as isize + dc);
            (r2 >= 0 && c2 >= 0 && (r2 as usize) < rows && (c2 as usize) < cols)
                .then(|| r2 as usize * cols + c2 as usize)
                .filter(|&k| cell[k] != u32::MAX)
        };
        let jumps = |a: usize, b: usize| {
            is_jump(
                positions[cell[a] as usize],
                positions[cell[b] as usize],
                origin,
                slope,
            )
        };
        // A cell that jumps against three or four of its four neighbours is a speckle (one
        // stray range), not the edge of a surface: its jumps mark nothing.
        let mut speckle = vec![false; slots];
        for r in 0..rows {
            for c in 0..cols {
                let k = r * cols + c;
                if cell[k] == u32::MAX {
                    continue;
                }
                let n = [(0, 1), (0, -1), (1, 0), (-1, 0)]
                    .iter()
                    .filter(|&&(dr, dc)| at(r, c, dr, dc).is_some_and(|j| jumps(k, j)))
                    .count();
                speckle[k] = n >= 3;
            }
        }
        let mut marked = vec![false; slots];
        for r in 0..rows {
            for c in 0..cols {
                let k = r * cols + c;
                if cell[k] == u32::MAX || speckle[k] {
                    continue;
                }
                // Right, down and the two down diagonals: every neighbouring pair once.
                for (dr, dc) in [(0isize, 1isize), (1, 0), (1, 1), (1, -1)] {
                    if let Some(j) = at(r, c, dr, dc).filter(|&j| !speckle[j] && jumps(k, j)) {
                        marked[k] = true;
                        marked[j] = true;
                    }
                }
            }
        }
        drop_short_contours(&mut marked, rows, cols);
        let reach = JUMP_REACH as usize;
        for r in 0..rows {
            for c in 0..cols {
                if !marked[r * cols + c] {
                    continue;
                }
                for r2 in r.saturating_sub(reach)..(r + reach + 1).min(rows) {
                    for c2 in c.saturating_sub(reach)..(c + reach + 1).min(cols) {
                        let j = cell[r2 * cols + c2];
                        if j != u32::MAX {
                            jump[j as usize] = true;
                        }
                    }
                }
            }
        }
    }
    jump
}

/// A depth jump marks cells along a contour at least this many cells long (8-connected): a
/// few jumping cells in the middle of a surface are range noise (a depth camera's quantised
/// ranges on a far, steep table), not where a surface ends.
pub const MIN_CONTOUR: usize = 12;

/// Unmarks the 8-connected groups of marked cells smaller than [`MIN_CONTOUR`].
fn drop_short_contours(marked: &mut [bool], rows: usize, cols: usize) {
    let mut seen = vec![false; marked.len()];
    let mut group = Vec::new();
    for start in 0..marked.len() {
        if !marked[start] || seen[start] {
            continue;
        }
        group.clear();
        group.push(start);
        seen[start] = true;
        let mut next = 0;
        while next < group.len() {
            let k = group[next];
            next += 1;
            let (r, c) = (k / cols, k % cols);
            for r2 in r.saturating_sub(1)..(r + 2).min(rows) {
                for c2 in c.saturating_sub(1)..(c + 2).min(cols) {
                    let j = r2 * cols + c2;
                    if marked[j] && !seen[j] {
                        seen[j] = true;
                        group.push(j);
                    }
                }
            }
        }
        if group.len() < MIN_CONTOUR {
            for &k in &group {
                marked[k] = false;
            }
        }
    }
}

/// True when the ranges of `p` and `q` from `origin` differ by more than `slope` times the
/// step between their rays: the surface between them would be seen beyond
/// [`MAX_INCIDENCE_DEG`]. Coincident rays (a sensor at one of the points) tell nothing.
pub fn is_jump(p: [f64; 3], q: [f64; 3], origin: [f64; 3], slope: f64) -> bool {
    let (a, b) = (sub(p, origin), sub(q, origin));
    let (ra, rb) = (norm(a), norm(b));
    if !(ra > 0.0 && rb > 0.0) {
        return false;
    }
    // The lateral step at the nearer range: |a × b| / max(|a|, |b|) = min range · sin(angle).
    let lateral = norm(cross(a, b)) / ra.max(rb);
    (ra - rb).abs() > slope * lateral
}

/// Where the sensor stood for a run's points: their scan's origin when the cloud records
/// scans and theirs is gridded, else the one configured sensor; `None` when neither tells (several sensors and no scan per
/// point), or when more than [`OTHER_SCANS`] of the points come from other scans than the
/// most common one: where scans overlap, what one scan could not see another did, and
/// nothing there is the border of a single view.
pub fn sensor_of(
    points: &[u32],
    structure: Option<&ScanStructure>,
    sensors: &[[f64; 3]],
) -> Option<[f64; 3]> {
    match structure {
        Some(s) if !s.scans.is_empty() && !s.scan.is_empty() => {
            let mut count = vec![0usize; s.scans.len()];
            for &p in points {
                if let Some(&k) = s.scan.get(p as usize) {
                    count[k as usize] += 1;
                }
            }
            let best = (0..count.len()).max_by_key(|&k| (count[k], std::cmp::Reverse(k)))?;
            let total: usize = count.iter().sum();
            let single = (total - count[best]) as f64 <= OTHER_SCANS * total as f64;
            // A gridded scan is in its sensor's frame; an unstructured scan's pose need not be
            // where a scanner stood: the configured sensor then, if one.
            match s.scans[best].grid_size {
                _ if count[best] == 0 || !single => None,
                Some(_) => Some(s.scans[best].pose.translation),
                None => (sensors.len() == 1).then(|| sensors[0]),
            }
        }
        _ => (sensors.len() == 1).then(|| sensors[0]),
    }
}

/// Why a fitted edge is an occlusion boundary, or `None` when it is not. Both signs need
/// the sensor and an edge that opens away from it (the bisector of its faces points away from
/// the sensor in most slabs: the foreground face and the veil or background behind it). A
/// concave edge opens towards the sensor that sees it: its faces meet without a gap, however
/// steep one of them is, and it stays an edge. Then: most of its run's points lie by a depth
/// jump (`jump`, from [`depth_jumps`]), or most of its slabs have a face that runs away from
/// the sensor along its ray.
pub fn is_border(
    fit: &EdgeFit,
    run_points: &[u32],
    jump: &[bool],
    sensor: Option<[f64; 3]>,
) -> Option<String> {
    if let Some(why) = one_sided(fit) {
        return Some(why);
    }
    let sensor = sensor?;
    let slabs = fit.slabs.len();
    if slabs == 0 {
        return None;
    }
    let rays = || {
        fit.slabs
            .iter()
            .map(move |s| (s, sub(s.corner, sensor)))
            .filter(|(_, ray)| norm(*ray) > 0.0)
    };
    let away = rays()
        .filter(|(s, ray)| dot(add(s.faces[0], s.faces[1]), *ray) > 0.0)
        .count();
    if away as f64 <= BORDER_SHARE * slabs as f64 {
        return None;
    }
    if let Some(on) = mostly_by_jumps(run_points, jump) {
        return Some(format!(
            "an occlusion boundary: {on} of its {} points lie by a depth jump of the scan's \
             grid (a silhouette against what lies behind it)",
            run_points.len()
        ));
    }
    let along = (90.0 - MAX_INCIDENCE_DEG).to_radians().cos();
    let edge_on = rays()
        .filter(|(s, ray)| s.faces.iter().any(|f| dot(*f, *ray) > along * norm(*ray)))
        .count();
    (edge_on as f64 > BORDER_SHARE * slabs as f64).then(|| {
        format!(
            "an occlusion boundary: in {edge_on} of its {slabs} slabs one face runs away from \
             the sensor along its ray (seen beyond {MAX_INCIDENCE_DEG}° incidence: the veil a \
             depth camera leaves between a silhouette and the background)"
        )
    })
}

/// Why a fitted edge is the border of a scan by its geometry alone (no sensor needed), or
/// `None`: in the median slab its smaller side reaches less than [`BORDER_REACH`] spacings
/// from the corner along its face, and less than [`BORDER_RATIO`] of what its larger side
/// reaches. Where the scan of a face ends (a one-view scan's silhouette) every point lies on
/// one side and the fit's second "face" is a few points of the same face by the corner:
/// 0.8–1.5 spacings against 10–17 for the other side (90th percentiles, medians over slabs,
/// the largest borders of `bench --random 100` seeds 1–3; a 586 h false edge of a noisy
/// one-view scan: 1.89 against 11.0), where both faces of most edges reach across the slab
/// band (6.6 spacings or more on the same scans). The limit is not clean: a true edge on scan
/// lines 6.2 spacings apart that barely cross one face reaches 1.85 against 10.8 and is lost
/// with it (at 1.65 it is kept and the false edge too). A true edge in a narrow part of a
/// noisy grid scan reaches 1.95 against 4.8: short on both sides, kept by the ratio. A
/// chamfer narrower than this is a rounding at this sampling.
fn one_sided(fit: &EdgeFit) -> Option<String> {
    let (mut short, mut long): (Vec<f64>, Vec<f64>) = fit
        .slabs
        .iter()
        .map(|s| (s.reach[0].min(s.reach[1]), s.reach[0].max(s.reach[1])))
        .unzip();
    if short.is_empty() || fit.scale.spacing.is_nan() || fit.scale.spacing <= 0.0 {
        return None;
    }
    let short = quantile(&mut short, 0.5) / fit.scale.spacing;
    let long = quantile(&mut long, 0.5) / fit.scale.spacing;
    tracing::trace!(
        "edge {}: its sides reach {short:.2} and {long:.2} spacings (medians of {} slabs)",
        fit.run,
        fit.slabs.len()
    );
    // A side at or behind the corner (reach ≤ 0) is a misfit whose corner lies off its
    // points (seen on scan lines as slab corners scattered by 6 spacings), no border: such
    // edges are left as they were.
    (short > 0.0 && short < BORDER_REACH && short < BORDER_RATIO * long).then(|| {
        format!(
            "a border of the scan: in its median slab one side's points reach {short:.1} \
             spacings from the corner along their face, the other side's {long:.1}: every \
             point lies on one face, which ends there"
        )
    })
}

/// How many of `points` lie by a depth jump, when more than [`BORDER_SHARE`] of them do.
fn mostly_by_jumps(points: &[u32], jump: &[bool]) -> Option<usize> {
    let on = points
        .iter()
        .filter(|&&p| jump.get(p as usize).copied().unwrap_or(false))
        .count();
    (!points.is_empty() && on as f64 > BORDER_SHARE * points.len() as f64).then_some(on)
}

/// Why a planar face is no face of the part, or `None`: seen edge-on from `sensor` (its
/// normal beyond [`MAX_INCIDENCE_DEG`] of the ray to its centroid: a veil between a
/// silhouette and the background is flat enough to grow as a face), or most of its points by
/// a depth jump.
pub fn is_border_face(
    plane: &Plane,
    points: &[u32],
    jump: &[bool],
    sensor: Option<[f64; 3]>,
) -> Option<String> {
    if let Some(on) = mostly_by_jumps(points, jump) {
        return Some(format!(
            "{on} of its {} points lie by a depth jump",
            points.len()
        ));
    }
    let ray = sub(plane.centroid, sensor?);
    let r = norm(ray);
    let cos = MAX_INCIDENCE_DEG.to_radians().cos();
    (r > 0.0 && dot(plane.normal, ray).abs() < cos * r).then(|| {
        format!(
            "seen edge-on from the sensor ({:.0}° incidence)",
            (dot(plane.normal, ray).abs() / r)
                .clamp(0.0, 1.0)
                .acos()
                .to_degrees()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloud::{Pose, Scan};

    /// A 20 x 20 organised frame from a sensor at the origin looking down +z: a plane at
    /// z = 1 whose right half (columns ≥ 10) is pushed back to z = 1.5.
    fn frame() -> (Vec<[f64; 3]>, ScanStructure) {
        let mut p = Vec::new();
        let mut grid = Vec::new();
        for r in 0..20u32 {
            for c in 0..20u32 {
                let z = if c >= 10 { 1.5 } else { 1.0 };
                let (u, v) = ((c as f64 - 10.0) * 0.002, (r as f64 - 10.0) * 0.002);
                p.push([u * z, v * z, z]);
                grid.push([r, c]);
            }
        }
        let s = ScanStructure {
            scans: vec![Scan {
                name: "frame".into(),
                pose: Pose::default(),
                grid_size: Some([20, 20]),
            }],
            scan: vec![0; p.len()],
            grid,
        };
        (p, s)
    }

    #[test]
    fn a_depth_step_marks_the_cells_beside_it_and_no_others() {
        let (p, s) = frame();
        let j = depth_jumps(&p, Some(&s));
        for (i, &m) in j.iter().enumerate() {
            let c = s.grid[i][1] as i64;
            // The jump is between columns 9 and 10; JUMP_REACH = 3 columns either side.
            let near = (6..=13).contains(&c);
            assert_eq!(m, near, "column {c}");
        }
        // The same plane without the step has no jump.
        let flat: Vec<[f64; 3]> = p
            .iter()
            .map(|q| {
                let z = q[2];
                [q[0] / z, q[1] / z, 1.0]
            })
            .collect();
        assert!(depth_jumps(&flat, Some(&s)).iter().all(|&m| !m));
        // No grid, no marks.
        assert!(depth_jumps(&p, None).iter().all(|&m| !m));
    }

    #[test]
    fn a_grid_far_larger_than_its_points_is_not_walked() {
        // A file's row index of a million for one of 400 points: 10^6 x 20 cells would be
        // 20 million cells for 400 points; a trillion-cell grid must not be allocated.
        let (p, mut s) = frame();
        s.scans[0].grid_size = Some([1 << 20, 1 << 20]);
        assert!(depth_jumps(&p, Some(&s)).iter().all(|&m| !m));
        s.scans[0].grid_size = Some([1_000_000, 20]);
        assert!(depth_jumps(&p, Some(&s)).iter().all(|&m| !m));
    }

    #[test]
    fn a_stray_range_is_a_speckle_and_marks_nothing() {
        let (p, s) = frame();
        // The flat frame (no step) with one cell pushed 20 cm back.
        let mut flat: Vec<[f64; 3]> = p.iter().map(|q| [q[0] / q[2], q[1] / q[2], 1.0]).collect();
        let k = 5 * 20 + 5;
        flat[k] = flat[k].map(|x| x * 1.2);
        assert!(depth_jumps(&flat, Some(&s)).iter().all(|&m| !m));
    }

    #[test]
    fn short_contours_are_dropped_long_ones_kept() {
        // A 5 x 6 grid: a 6-cell line (row 1) and a 2-cell blob (row 4).
        let mut m = vec![false; 30];
        for c in 0..6 {
            m[6 + c] = true;
        }
        m[4 * 6] = true;
        m[4 * 6 + 1] = true;
        let mut short = m.clone();
        drop_short_contours(&mut short, 5, 6);
        assert!(
            short.iter().all(|&x| !x),
            "both shorter than MIN_CONTOUR = {MIN_CONTOUR}"
        );
        // A 20-cell diagonal stays.
        let mut d = vec![false; 400];
        for i in 0..20 {
            d[i * 20 + i] = true;
        }
        let before = d.clone();
        drop_short_contours(&mut d, 20, 20);
        assert_eq!(d, before);
    }

    #[test]
    fn a_steep_real_face_is_no_jump_and_a_veil_is() {
        let slope = MAX_INCIDENCE_DEG.to_radians().tan();
        // Two rays 2 mrad apart at 1 m: the lateral step is 2 mm.
        let (p, q) = ([0.0, 0.0, 1.0], [0.002, 0.0, 1.0]);
        // A face at 70° incidence: the range changes by 2 mm · tan 70° = 5.5 mm.
        let q70 = [0.002 * 1.0055, 0.0, 1.0055];
        assert!(!is_jump(p, q70, [0.0; 3], slope));
        // Along the ray (89°): 11 cm.
        let q89 = [0.002 * 1.11, 0.0, 1.11];
        assert!(is_jump(p, q89, [0.0; 3], slope));
        assert!(!is_jump(p, q, [0.0; 3], slope));
        // A sensor at a point tells nothing.
        assert!(!is_jump(p, q, p, slope));
    }

    #[test]
    fn the_sensor_of_a_run_is_its_scan_or_the_one_configured() {
        let s = ScanStructure {
            scans: vec![
                Scan {
                    pose: Pose {
                        translation: [1.0, 0.0, 0.0],
                        ..Pose::default()
                    },
                    ..Scan::default()
                },
                Scan {
                    pose: Pose {
                        translation: [0.0, 2.0, 0.0],
                        ..Pose::default()
                    },
                    ..Scan::default()
                },
            ],
            scan: vec![0, 1, 1, 0],
            grid: Vec::new(),
        };
        // Unstructured scans: their poses need not be where a scanner stood.
        assert_eq!(sensor_of(&[1, 2], Some(&s), &[]), None);
        assert_eq!(sensor_of(&[1, 2], Some(&s), &[[5.0; 3]]), Some([5.0; 3]));
        let mut s = s;
        for sc in &mut s.scans {
            sc.grid_size = Some([2, 2]);
        }
        assert_eq!(sensor_of(&[1, 2], Some(&s), &[]), Some([0.0, 2.0, 0.0]));
        assert_eq!(sensor_of(&[0, 3], Some(&s), &[]), Some([1.0, 0.0, 0.0]));
        // Seen from both scans (a third from the other): no single view's border.
        assert_eq!(sensor_of(&[1, 2, 3], Some(&s), &[]), None);
        assert_eq!(sensor_of(&[0], None, &[[5.0; 3]]), Some([5.0; 3]));
        assert_eq!(sensor_of(&[0], None, &[[5.0; 3], [1.0; 3]]), None);
        assert_eq!(sensor_of(&[0], None, &[]), None);
    }
}
