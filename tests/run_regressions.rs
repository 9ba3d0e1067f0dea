//! Regression tests, one per bug found while testing `sharpedge run` end to end; each is named
//! after the bug and says in its comment what went wrong.

mod run_common;

use run_common::*;

/// Regression: errors of the scale and neighbour stages ("noise estimate: degenerate input:
/// ...") did not say which file they were about.
#[test]
fn stage_errors_name_the_input_file() {
    let c = Case::new();
    // Pairs of points 0.01 apart, the pairs 3 units apart along a helix: the mean spacing is
    // tiny, so no neighbourhood holds enough points to measure the noise.
    let mut text = String::new();
    for i in 0..500 {
        let t = i as f64 * 0.3;
        let (x, y, z) = (10.0 * t.cos(), 10.0 * t.sin(), 0.5 * t);
        text.push_str(&format!("{x} {y} {z}\n{} {y} {z}\n", x + 0.01));
    }
    c.write("pairs.xyz", &text);
    let r = c.run("pairs.xyz", &[]);
    assert_failed_cleanly(
        &r,
        &[
            "pairs.xyz: noise estimate: degenerate input: no point has 8 neighbours",
            "too sparse",
        ],
        &c.out(),
    );
}
