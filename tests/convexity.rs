//! `convex` of the reported edges against the simulator's ground truth: on the L-block (its
//! inner edge concave, the others convex), on random parts (at least 95 % of the found edges
//! right), on a one-view scan (decided by the sensor when it is given, never wrong without
//! it), and on the real RGB-D frames (box edges convex, base edges concave; skipped with a
//! message when ../shared/data is absent).

use sharpedge::bench::frames;
use sharpedge::config::Settings;
use sharpedge::outcome::Outcome;
use sharpedge::pipeline::{NoClock, process};
use sharpedge::synth::scanner::{Pattern, ScanPattern};
use sharpedge::synth::{GroundTruth, Part, Sampling, SynthParams, generate};

fn scan(part: Part, pattern: Pattern, points: usize, seed: u64) -> (sharpedge::Cloud, GroundTruth) {
    let params = SynthParams {
        part,
        sampling: Sampling::Points(points),
        noise: 0.15,
        round: 1.5,
        rotate: true,
        seed,
        scan: ScanPattern {
            pattern,
            ..Default::default()
        },
        ..Default::default()
    };
    let s = generate(&params).unwrap();
    (s.cloud, s.ground_truth)
}

fn run(cloud: sharpedge::Cloud, sensors: Vec<[f64; 3]>) -> Outcome {
    let mut settings = Settings::default();
    settings.input.sensors = sensors;
    process(cloud, &settings, &mut NoClock).unwrap()
}

/// For every found edge whose middle lies within 3 spacings of a true edge: (its convex flag,
/// the true edge's).
fn flags(out: &Outcome, gt: &GroundTruth) -> Vec<(Option<bool>, bool)> {
    out.edges
        .iter()
        .filter_map(|e| {
            let pl = &e.polyline;
            let mid = if pl.len() > 2 {
                pl[pl.len() / 2]
            } else {
                [0, 1, 2].map(|k| 0.5 * (e.start[k] + e.end[k]))
            };
            let (d, k) = gt.distance_to_nearest_edge(mid)?;
            (d <= 3.0 * gt.spacing).then(|| (e.convex, gt.edges[k].convex))
        })
        .collect()
}

#[test]
fn lblock_inner_edge_is_concave_the_others_convex() {
    let (cloud, gt) = scan("lblock".parse().unwrap(), Pattern::Uniform, 100_000, 3);
    let out = run(cloud, vec![]);
    let f = flags(&out, &gt);
    assert!(f.len() >= 15, "{} edges matched", f.len());
    let concave = f.iter().filter(|(_, t)| !t).count();
    assert!(concave >= 1, "the inner edge was not found");
    for (found, truth) in &f {
        assert_eq!(*found, Some(*truth), "{f:?}");
    }
}

#[test]
fn random_parts_are_classified_right() {
    let mut right = 0;
    let mut all = 0;
    for seed in [1, 2, 3] {
        let (cloud, gt) = scan(Part::Random, Pattern::Uniform, 120_000, seed);
        let f = flags(&run(cloud, vec![]), &gt);
        assert!(
            f.iter().any(|(_, t)| !t),
            "seed {seed}: no concave edge found"
        );
        right += f.iter().filter(|(c, t)| *c == Some(*t)).count();
        all += f.len();
    }
    // Measured: 96 of 96 on these seeds (259 of 260 over seeds 1-10, one undecided).
    assert!(
        all >= 60 && right as f64 >= 0.95 * all as f64,
        "{right} of {all} right"
    );
}

#[test]
fn one_view_scans_are_decided_by_the_sensor_and_never_wrong_without() {
    let (cloud, gt) = scan("lblock".parse().unwrap(), Pattern::View, 120_000, 4);
    let sensors: Vec<[f64; 3]> = gt.sensors.iter().map(|s| s.position).collect();
    assert_eq!(sensors.len(), 1);
    let with = flags(&run(cloud.clone(), sensors), &gt);
    assert!(with.len() >= 2, "{with:?}");
    assert!(with.iter().all(|(c, t)| *c == Some(*t)), "{with:?}");
    // Without the sensor the back of the part is missing: rays through the scan cannot tell
    // (undecided), but they must not mislead.
    let without = flags(&run(cloud, vec![]), &gt);
    assert!(
        without.iter().all(|(c, t)| c.is_none() || *c == Some(*t)),
        "{without:?}"
    );
}

#[test]
fn rgbd_box_edges_are_convex_and_base_edges_concave() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/rgbd");
    let paths: Vec<_> = ["box.ply", "stacked_boxes.ply"]
        .iter()
        .map(|n| data.join(n))
        .collect();
    if !paths.iter().all(|p| p.is_file()) {
        eprintln!("skipped: {} is absent", data.display());
        return;
    }
    // bench --frames puts the sensor at the frames' camera origin.
    let results = frames::run_frames(
        &paths,
        &Settings::default(),
        frames::DEFAULT_TOLERANCE,
        None,
    )
    .unwrap();
    let mut decided = 0;
    for r in &results {
        let c = r.score.convex;
        assert_eq!(c.wrong, 0, "{}: {c:?}", r.path.display());
        assert_eq!(c.undecided, 0, "{}: {c:?}", r.path.display());
        decided += c.correct;
    }
    // Measured with the local scale: every found edge along a reference edge decided right,
    // 3 on box.ply and 2 on stacked_boxes.ply (with the cloud-wide scale 4 and 3 of other
    // edges).
    assert!(decided >= 5, "{results:#?}");
}
