//! Candidates left out by reason, through the real binary: a box whose edges are fillets far
//! wider than `edges.max_rounding` has them counted as fillets or curved surfaces, not as
//! failed fits, in report.json's `left_out` section and in the summary line; on the aerial
//! lidar file autzen (../shared/data/lidar, skipped with a message when absent) the failed
//! fits are far fewer than the candidates left out as no sharp edge.

mod run_common;

use std::path::Path;

use run_common::*;

/// The summary line `E edges, C corners; left out N candidates (...), F fits failed` agrees
/// with report.json, whose `left_out.by_reason` counts add up to its candidate list.
fn check_summary_and_report(stderr: &str, rep: &serde_json::Value) {
    let c = &rep["counts"];
    let lo = &rep["left_out"];
    let by_reason = lo["by_reason"].as_object().unwrap();
    let listed = lo["candidates"].as_array().unwrap();
    let total: u64 = by_reason.values().map(|n| n.as_u64().unwrap()).sum();
    assert_eq!(total as usize, listed.len(), "{by_reason:?}");
    let failed = by_reason.get("failed").map_or(0, |n| n.as_u64().unwrap());
    assert_eq!(c["failed_fits"].as_u64(), Some(failed));
    assert_eq!(c["left_out"].as_u64(), Some(total - failed));
    for l in listed {
        assert!(by_reason.contains_key(l["reason"].as_str().unwrap()), "{l}");
        assert!(
            ["run", "vertex"].contains(&l["kind"].as_str().unwrap()),
            "{l}"
        );
        assert!(!l["message"].as_str().unwrap().is_empty(), "{l}");
    }
    let line = format!(
        "{} edges, {} corners; left out {} candidates",
        c["edges"],
        c["corners"],
        total - failed
    );
    assert!(stderr.contains(&line), "summary lacks `{line}`:\n{stderr}");
    let tail = format!(
        ", {failed} fit{} failed\n",
        if failed == 1 { "" } else { "s" }
    );
    assert!(stderr.contains(&tail), "summary lacks `{tail}`:\n{stderr}");
}

#[test]
fn fillets_are_counted_under_their_reason_not_as_failed_fits() {
    let c = Case::new();
    // Every edge of the box rounded with a radius of 10 spacings: more than
    // edges.max_rounding = 6, so none is a sharp edge the scan rounded.
    synth(
        c.path(),
        "scan.ply",
        &[
            "--part", "box", "--points", "60000", "--noise", "0.1", "--round", "10", "--seed", "3",
        ],
    );
    let r = c.run("scan.ply", &[]);
    r.assert_ok();
    let rep = report(&c.out());
    check_summary_and_report(&r.stderr, &rep);
    let lo = &rep["left_out"];
    let count = |reason: &str| lo["by_reason"][reason].as_u64().unwrap_or(0);
    // The box's 12 rounded edges come as runs judged fillets or curved surfaces (a run may
    // break in two at a rounded corner).
    let rounded = count("fillet") + count("curved");
    assert!(rounded >= 12, "{}", lo["by_reason"]);
    // Every message that speaks of a rounding or of arcs has its reason, none is "failed".
    for l in lo["candidates"].as_array().unwrap() {
        let m = l["message"].as_str().unwrap();
        if m.contains("rounding of radius") || m.contains("arcs wider than") {
            let reason = l["reason"].as_str().unwrap();
            assert!(reason == "fillet" || reason == "curved", "{l}");
        }
    }
    assert!(
        count("failed") <= 1 && count("failed") * 10 < rounded,
        "{}",
        lo["by_reason"]
    );
}

#[test]
fn autzen_fails_fewer_fits_than_it_leaves_out() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/lidar");
    let input = data.join("autzen_trim.las");
    if !input.is_file() {
        eprintln!(
            "skipped: {} is absent (the shared data folder is not mounted)",
            input.display()
        );
        return;
    }
    let c = Case::new();
    let r = c.run(input.to_str().unwrap(), &[]);
    r.assert_ok();
    let rep = report(&c.out());
    check_summary_and_report(&r.stderr, &rep);
    let counts = &rep["counts"];
    let failed = counts["failed_fits"].as_u64().unwrap();
    let left_out = counts["left_out"].as_u64().unwrap();
    // Measured: 168 left out (fillet 15, curved 24, bending 48, too few slabs 42, too short
    // 26, edges left out 13), 3 fits failed; before the reasons, all 171 read "failed". With
    // the local scale (issue 17) far fewer candidates reach the fits: 35 left out (bending
    // 17, too few slabs 7, curved 6, fillet 3, edges left out 2), 0 failed.
    assert!(
        left_out >= 20 && failed * 10 < left_out,
        "{failed} failed, {left_out} left out: {}",
        rep["left_out"]["by_reason"]
    );
}
