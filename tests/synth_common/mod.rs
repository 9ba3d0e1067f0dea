//! Shared by the tests that run the library's pipeline on simulated parts: one call from
//! the simulator's settings to the run's outcome and the part's ground truth.

use sharpedge::config::Settings;
use sharpedge::outcome::Outcome;
use sharpedge::pipeline::{NoClock, process};
use sharpedge::synth::{GroundTruth, Part, Sampling, SynthParams, generate};

/// Simulates `part` (rotated, `points` points, noise and edge rounding in spacings, drawn
/// from `seed`) and runs the default pipeline on it.
pub fn run_part(
    part: Part,
    points: usize,
    noise: f64,
    round: f64,
    seed: u64,
) -> (Outcome, GroundTruth) {
    let params = SynthParams {
        part,
        sampling: Sampling::Points(points),
        noise,
        round,
        rotate: true,
        seed,
        ..Default::default()
    };
    let s = generate(&params).unwrap();
    let out = process(s.cloud, &Settings::default(), &mut NoClock).unwrap();
    (out, s.ground_truth)
}
