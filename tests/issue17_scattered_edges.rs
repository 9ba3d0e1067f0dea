//! Issue 17 (random parts): a run of edge candidates whose slabs fit unrelated faces (the
//! walls around a narrow through-hole's acute corner) was accepted as an edge although its
//! slab corners scattered by 23 spacings about their course: a 26-spacing "edge" 10–14
//! spacings from every true edge, counted against precision, its corrections moving face
//! points. The edge stage now leaves such runs out (`Reason::Scattered`).
//!
//! Checked on the random part that showed it (drawn by `sharpedge bench --random 100 --seed
//! 1` as r000): every reported sharp edge runs along a true edge (its polyline's points, at
//! every spacing, median distance to the nearest true edge within 2 spacings). Parts with
//! wide fillets are not checked here: an edge found along the middle of a 10-spacing fillet
//! at 134° is a known open problem of issue 17 (the zone measured at the band's limit).

mod synth_common;

use sharpedge::geometry::lines::point_segment;
use sharpedge::left_out::Reason;
use sharpedge::synth::Part;

/// Points along a polyline, about one per `step`.
fn along(polyline: &[[f64; 3]], step: f64) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for w in polyline.windows(2) {
        let d = [0, 1, 2].map(|k| w[1][k] - w[0][k]);
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let n = (len / step).ceil().max(1.0) as usize;
        out.extend((0..n).map(|i| {
            let t = i as f64 / n as f64;
            [0, 1, 2].map(|k| w[0][k] + t * d[k])
        }));
    }
    out.extend(polyline.last().copied());
    out
}

/// Runs the default pipeline on a random part and returns, per reported edge, the median
/// distance (in spacings) of its polyline to the nearest true edge, and how many runs were
/// left out as scattered.
fn edge_offsets(seed: u64, points: usize, noise: f64, round: f64) -> (Vec<f64>, usize) {
    let (out, gt) = synth_common::run_part(Part::Random, points, noise, round, seed);
    let h = gt.spacing;
    let offsets = out
        .edges
        .iter()
        .map(|e| {
            let mut d: Vec<f64> = along(&e.polyline, h)
                .into_iter()
                .map(|p| {
                    gt.edges
                        .iter()
                        .map(|t| point_segment(p, t.start, t.end).0)
                        .fold(f64::INFINITY, f64::min)
                        / h
                })
                .collect();
            d.sort_by(f64::total_cmp);
            d[d.len() / 2]
        })
        .collect();
    let scattered = out
        .left_out
        .iter()
        .filter(|l| l.reason == Reason::Scattered)
        .count();
    (offsets, scattered)
}

#[test]
fn issue17_edges_whose_slabs_scatter_are_left_out() {
    // r000 of `bench --random 100 --seed 1`: a tapered 4-sided block with a 4- and a 3-sided
    // through-hole, 477,035 points, noise 0.21 h, rounding 1.8 h.
    let (offsets, scattered) = edge_offsets(9_026_784_314_788_244_083, 477_035, 0.2056, 1.805);
    assert!(scattered >= 1, "no run left out as scattered");
    for (i, d) in offsets.iter().enumerate() {
        assert!(
            *d <= 2.0,
            "edge {i} runs {d:.1} spacings from every true edge"
        );
    }
}
