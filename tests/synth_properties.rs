//! Property tests of the simulator over random parts, seeds, radii and jitters: points not in
//! the abnormal zone are exact surface samples, abnormal points stay within the rounded band,
//! the count follows the request, and generation is repeatable.

use proptest::prelude::*;
use sharpedge::Error;
use sharpedge::geometry::dist;
use sharpedge::synth::{Part, Sampling, SynthParams, generate};

fn part_strategy() -> impl Strategy<Value = Part> {
    prop_oneof![
        Just(Part::Box),
        Just(Part::LBlock),
        Just(Part::Step),
        Just(Part::Wedge),
        Just(Part::Prism),
        Just(Part::Pyramid),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn samples_respect_their_truth(
        part in part_strategy(),
        seed in any::<u64>(),
        round in 0.0f64..3.0,
        jitter in 0.0f64..1.0,
        sides in 3usize..12,
        angle in 20.0f64..160.0,
        steps in 2usize..5,
        rotate in any::<bool>(),
    ) {
        let p = SynthParams {
            part,
            sampling: Sampling::Points(3_000),
            round,
            jitter,
            sides,
            angle,
            steps,
            rotate,
            seed,
            ..Default::default()
        };
        let scan = match generate(&p) {
            Ok(s) => s,
            // Thin wedges cannot take every radius; the refusal names the parameter.
            Err(Error::SynthParam { name: "round", .. }) => return Ok(()),
            Err(e) => return Err(TestCaseError::fail(e.to_string())),
        };
        let gt = &scan.ground_truth;
        let n = scan.cloud.len() as f64;
        prop_assert!((n / 3_000.0 - 1.0).abs() < 0.05, "{} points", n);
        let td_max = gt.edges.iter().map(|e| e.tangent_distance).fold(0.0, f64::max);
        for (q, t) in scan.cloud.positions.iter().zip(&scan.truth) {
            prop_assert!(gt.distance_to_surface(t.surface) < 1e-9 * 100.0);
            if t.abnormal {
                prop_assert!(t.edge_distance < td_max);
                prop_assert!(dist(*q, t.surface) < 2.0 * td_max);
            } else {
                prop_assert_eq!(*q, t.surface);
            }
        }
        let again = generate(&p).unwrap();
        prop_assert_eq!(&again.cloud.positions, &scan.cloud.positions);
    }
}
