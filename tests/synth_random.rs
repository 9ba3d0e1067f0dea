//! Random parts (`--part random`): over many seeds, every part is a closed, consistently
//! wound mesh whose sharp edges open within [20°, 160°] and cover that range; holes, stacked
//! blocks, tapers, chamfers and fillets all occur; the same seed gives the same bytes; and a
//! fillet is in the ground truth as a fillet, never as a sharp edge.

use std::collections::HashSet;

use sharpedge::synth::random::{self, MAX_OPENING_DEG, MIN_OPENING_DEG, check_closed};
use sharpedge::synth::{Part, Sampling, SynthParams, generate};

const SEEDS: u64 = 200;

#[test]
fn two_hundred_random_parts_are_closed_and_their_sharp_edges_open_20_to_160_degrees() {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut holes, mut stacks, mut tapers, mut chamfers, mut fillets, mut concave) =
        (0, 0, 0, 0, 0, 0);
    let mut openings_seen = [0usize; 7]; // 20° bins from 20° to 160°
    for seed in 0..SEEDS {
        let part = random::build(seed).unwrap();
        let volume = check_closed(&part.mesh).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        assert!(volume > 0.0);
        let smooth: HashSet<(u32, u32)> = part
            .fillets
            .iter()
            .flat_map(|f| {
                f.bottom
                    .iter()
                    .zip(&f.top)
                    .map(|(&a, &b)| (a.min(b), a.max(b)))
            })
            .collect();
        let openings = random::sharp_openings(&part.mesh, &smooth);
        assert_eq!(
            openings.keys().copied().collect::<HashSet<_>>(),
            part.creases,
            "seed {seed}: the creases are the sharp edges"
        );
        for &o in openings.values() {
            assert!(
                (MIN_OPENING_DEG..=MAX_OPENING_DEG).contains(&o),
                "seed {seed}: an edge opens {o}°"
            );
            lo = lo.min(o);
            hi = hi.max(o);
            openings_seen[(((o - 20.0) / 20.0) as usize).min(6)] += 1;
        }
        let d = &part.draw;
        holes += usize::from(!d.holes.is_empty());
        stacks += usize::from(d.stack.is_some());
        tapers += usize::from(d.taper_deg != 0.0);
        chamfers += usize::from(d.chamfers > 0);
        fillets += usize::from(!d.fillets.is_empty());
        concave += usize::from(d.concave > 0);
    }
    println!(
        "openings {lo:.1}°..{hi:.1}° bins {openings_seen:?}; parts with holes {holes}, stacks {stacks}, tapers {tapers}, chamfers {chamfers}, fillets {fillets}, concave vertices {concave}"
    );
    assert!(lo < 30.0 && hi > 150.0, "openings only {lo}..{hi}");
    assert!(openings_seen.iter().all(|&n| n > 0), "{openings_seen:?}");
    for (what, n) in [
        ("holes", holes),
        ("stacks", stacks),
        ("tapers", tapers),
        ("chamfers", chamfers),
        ("fillets", fillets),
        ("concave vertices", concave),
    ] {
        assert!(n >= 10, "only {n} of {SEEDS} parts with {what}");
    }
}

fn params(seed: u64) -> SynthParams {
    SynthParams {
        part: Part::Random,
        sampling: Sampling::Points(30_000),
        noise: 0.1,
        round: 1.0,
        rotate: true,
        seed,
        ..SynthParams::default()
    }
}

#[test]
fn the_same_seed_gives_the_same_scan_bytes_and_another_seed_another_part() {
    let a = generate(&params(11)).unwrap();
    let b = generate(&params(11)).unwrap();
    assert_eq!(
        a.ground_truth.to_json().unwrap(),
        b.ground_truth.to_json().unwrap()
    );
    let bits = |s: &sharpedge::synth::Scan| -> Vec<u64> {
        s.cloud
            .positions
            .iter()
            .flatten()
            .map(|c| c.to_bits())
            .collect()
    };
    assert_eq!(bits(&a), bits(&b));
    let c = generate(&params(12)).unwrap();
    assert_ne!(a.ground_truth.random, c.ground_truth.random);
}

/// A part with a fillet: no true sharp edge runs along it, its points lie on its charts, and
/// its faces are not those of any sharp edge's straight side.
#[test]
fn a_fillet_is_in_the_truth_as_a_fillet_not_as_a_sharp_edge() {
    let seed = (0..SEEDS)
        .find(|&s| !random::build(s).unwrap().fillets.is_empty())
        .unwrap();
    let scan = generate(&params(seed)).unwrap();
    let gt = &scan.ground_truth;
    assert!(!gt.fillets.is_empty());
    let h = gt.spacing;
    for f in &gt.fillets {
        assert!(f.radius_h > 4.0, "fillet of {} spacings", f.radius_h);
        // The middle of the fillet surface is far from every true sharp edge: the edge it
        // replaced is not in the truth.
        let on_fillet: Vec<_> = scan
            .truth
            .iter()
            .filter(|t| f.faces.contains(&(t.face as usize)))
            .collect();
        assert!(
            on_fillet.len() > 20,
            "{} points on fillet {}",
            on_fillet.len(),
            f.id
        );
        let far = on_fillet
            .iter()
            .filter(|t| t.edge_distance > 0.3 * f.radius)
            .count();
        assert!(far > on_fillet.len() / 2, "{far} of {}", on_fillet.len());
        // Its tangent lines are vertical segments of the part as tall as the true edges next
        // to them, not sharp edges.
        for [a, b] in f.tangent_lines {
            let mid = [0, 1, 2].map(|k| 0.5 * (a[k] + b[k]));
            let (d, _) = gt.distance_to_nearest_edge(mid).unwrap();
            assert!(
                d > 2.0 * h,
                "a sharp edge {:.2} h from a tangent line",
                d / h
            );
        }
        for e in &gt.edges {
            assert!(!(f.faces.contains(&e.faces[0]) && f.faces.contains(&e.faces[1])));
        }
    }
}
