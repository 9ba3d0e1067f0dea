//! Bad simulator parameters are errors that name the parameter and the allowed range.

use sharpedge::synth::{Part, Sampling, SynthParams, generate};

fn err(p: SynthParams) -> String {
    generate(&p).unwrap_err().to_string()
}

fn with(f: impl FnOnce(&mut SynthParams)) -> String {
    let mut p = SynthParams {
        sampling: Sampling::Points(1_000),
        ..Default::default()
    };
    f(&mut p);
    err(p)
}

#[test]
fn sampling_parameters() {
    assert_eq!(
        with(|p| p.sampling = Sampling::Spacing(0.0)),
        "synth parameter spacing = 0: must be a finite number > 0 (model units)"
    );
    assert_eq!(
        with(|p| p.sampling = Sampling::Spacing(-1.0)),
        "synth parameter spacing = -1: must be a finite number > 0 (model units)"
    );
    assert_eq!(
        with(|p| p.sampling = Sampling::Spacing(f64::NAN)),
        "synth parameter spacing = NaN: must be a finite number > 0 (model units)"
    );
    assert_eq!(
        with(|p| p.sampling = Sampling::Points(0)),
        "synth parameter points = 0: must be at least 1"
    );
    assert_eq!(
        with(|p| p.sampling = Sampling::Points(2_000_000_000)),
        "synth parameter points = 2000000000: must be at most 100000000"
    );
    assert_eq!(
        with(|p| p.sampling = Sampling::Spacing(1e-4)),
        "synth parameter spacing = 0.0001: would give about 3.760e12 points, more than 100000000; use a larger spacing"
    );
    assert_eq!(
        with(|p| p.size = Some(f64::INFINITY)),
        "synth parameter size = inf: must be a finite number > 0 (model units)"
    );
    assert_eq!(
        with(|p| p.jitter = 1.5),
        "synth parameter jitter = 1.5: must be in [0, 1] (in spacings)"
    );
}

#[test]
fn disturbance_parameters() {
    assert_eq!(
        with(|p| p.noise = -0.1),
        "synth parameter noise = -0.1: must be a finite number >= 0 (in spacings)"
    );
    assert_eq!(
        with(|p| p.noise = f64::NAN),
        "synth parameter noise = NaN: must be a finite number >= 0 (in spacings)"
    );
    assert_eq!(
        with(|p| p.round = -1.0),
        "synth parameter round = -1: must be a finite number >= 0 (in spacings)"
    );
    assert_eq!(
        with(|p| p.edge_noise = f64::INFINITY),
        "synth parameter edge_noise = inf: must be a finite number >= 0 (in spacings)"
    );
    assert_eq!(
        with(|p| p.edge_band = 0.0),
        "synth parameter edge_band = 0: must be a finite number > 0 (in spacings)"
    );
    for bad in [1.0, -0.01, f64::NAN] {
        assert_eq!(
            with(|p| p.outliers = bad),
            format!("synth parameter outliers = {bad}: must be a fraction in [0, 1)")
        );
    }
    assert_eq!(
        with(|p| p.translate = [0.0, f64::NAN, 1.0]),
        "synth parameter translate = [0.0, NaN, 1.0]: every component must be a finite number"
    );
}

#[test]
fn part_parameters() {
    assert_eq!(
        with(|p| {
            p.part = Part::Prism;
            p.sides = 2
        }),
        "synth parameter sides = 2: a prism needs 3 to 100000 sides"
    );
    for bad in [0.0, 180.0, -5.0, f64::NAN] {
        assert_eq!(
            with(|p| {
                p.part = Part::Wedge;
                p.angle = bad
            }),
            format!("synth parameter angle = {bad}: the wedge angle must be in (0, 180) degrees")
        );
    }
    assert_eq!(
        with(|p| {
            p.part = Part::Step;
            p.steps = 1
        }),
        "synth parameter steps = 1: a stepped block needs 2 to 1000 steps"
    );
    assert_eq!(
        with(|p| {
            p.part = Part::Mesh("x.off".into());
            p.sharp_angle = 0.0
        }),
        "synth parameter sharp_angle = 0: must be in (0, 180) degrees"
    );
    // A parameter that does not apply to the part is not checked.
    let ok = generate(&SynthParams {
        sides: 0,
        sampling: Sampling::Points(100),
        ..Default::default()
    });
    assert!(ok.is_ok());
}

/// A radius whose corner blends would overlap on the shortest edge is refused, with the limit.
#[test]
fn round_radius_too_large_for_the_part() {
    // Box 100 x 80 x 60 at spacing 1: the 60-long edges allow r <= 30.
    let e = with(|p| {
        p.sampling = Sampling::Spacing(1.0);
        p.round = 31.0
    });
    assert_eq!(
        e,
        "synth parameter round = 31: at most 30.0000 spacings for this part: a larger radius makes the corner blends of its shortest edge overlap"
    );
    assert!(
        generate(&SynthParams {
            sampling: Sampling::Spacing(1.0),
            round: 29.0,
            ..Default::default()
        })
        .is_ok()
    );
}

/// A mesh whose edges are all smooth is a valid part: no edges, no corners, no abnormal zone.
#[test]
fn mesh_without_sharp_edges_is_fine() {
    let p = SynthParams {
        part: Part::Prism,
        sides: 64, // 5.6° between neighbouring side faces, 90° at the caps
        sampling: Sampling::Points(2_000),
        round: 1.0,
        ..Default::default()
    };
    let mesh = sharpedge::synth::parts::polyhedron(&p.part, p.sides, p.angle, p.steps).unwrap();
    // As a "mesh file" with a 95° threshold even the caps are smooth.
    let scan = sharpedge::synth::generate_from_mesh(
        &SynthParams {
            sharp_angle: 95.0,
            ..p
        },
        mesh,
    )
    .unwrap();
    assert!(scan.ground_truth.edges.is_empty());
    assert!(scan.ground_truth.corners.is_empty());
    assert_eq!(scan.ground_truth.abnormal_points, 0);
    assert!(scan.truth.iter().all(|t| t.edge_distance.is_infinite()));
}
