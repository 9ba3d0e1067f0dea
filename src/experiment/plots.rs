//! The experiment's figures as SVG (plotters): convergence curves like the paper's Figures
//! 8–9, PSO against GA per trial like Figure 10, and one fit like Figure 6 (points, Scheme 1
//! lines and corner, PSO lines and corner, the true corner).
//!
//! Input: an [`ExperimentReport`] and a folder. Output: the paths of the files written
//! (`convergence_2d.svg`, `pso_vs_ga_2d.svg`, `fit_2d.svg`, or `_3d`).

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::ExperimentReport;
use crate::{Error, Result};

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

fn draw_err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::io(
        path,
        "cannot draw figure",
        std::io::Error::other(e.to_string()),
    )
}

/// Renders into a string with `draw`, then writes it to `dir/name`.
fn figure(
    dir: &Path,
    name: &str,
    size: (u32, u32),
    draw: impl FnOnce(&Area<'_>) -> std::result::Result<(), Box<dyn std::error::Error>>,
) -> Result<PathBuf> {
    let path = dir.join(name);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_err(&path, e))?;
        draw(&root).map_err(|e| draw_err(&path, e))?;
        root.present().map_err(|e| draw_err(&path, e))?;
    }
    std::fs::write(&path, svg).map_err(|e| Error::io(&path, "cannot write", e))?;
    Ok(path)
}

fn range(vals: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in vals.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.08).max(1e-9 * hi.abs().max(1.0));
    (lo - pad, hi + pad)
}

/// Writes the three figures for the report's dimension into `dir` (created if missing).
pub fn write_figures(report: &ExperimentReport, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, "cannot create folder", e))?;
    let d = report.dim;
    let ok: Vec<_> = report
        .records
        .iter()
        .filter(|r| r.failure.is_none())
        .collect();
    let mut written = Vec::new();

    // Figures 8–9: fitness per iteration of one trial, and the mean over all trials.
    let ex = report.example.clone().unwrap_or_default();
    let iters = ok.first().map_or(0, |r| r.pso_history.len());
    let mean_curve = |f: &dyn Fn(&super::TrialRecord) -> &Vec<f64>| -> Vec<f64> {
        (0..iters)
            .map(|k| {
                let v: Vec<f64> = ok.iter().filter_map(|r| f(r).get(k).copied()).collect();
                v.iter().sum::<f64>() / v.len().max(1) as f64
            })
            .collect()
    };
    let mean_pso = mean_curve(&|r| &r.pso_history);
    let mean_ga = mean_curve(&|r| &r.ga_history);
    written.push(figure(
        dir,
        &format!("convergence_{d}d.svg"),
        (1100, 450),
        |root| {
            let (left, right) = root.split_horizontally(550);
            let n = ex.pso_fitness.len().max(2) - 1;
            let (lo, hi) = range(ex.pso_fitness.iter().chain(&ex.ga_fitness).copied());
            let mut c = ChartBuilder::on(&left)
                .caption(
                    format!("{d}D, first trial: fitness 1/error per iteration"),
                    ("sans-serif", 17),
                )
                .margin(12)
                .x_label_area_size(35)
                .y_label_area_size(70)
                .build_cartesian_2d(0f64..n as f64, lo..hi)?;
            c.configure_mesh()
                .x_desc("iteration")
                .y_desc("fitness")
                .draw()?;
            c.draw_series(LineSeries::new(
                ex.pso_fitness
                    .iter()
                    .enumerate()
                    .map(|(k, f)| (k as f64, *f)),
                BLUE.stroke_width(2),
            ))?
            .label("PSO")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
            c.draw_series(LineSeries::new(
                ex.ga_fitness
                    .iter()
                    .enumerate()
                    .map(|(k, f)| (k as f64, *f)),
                RED.stroke_width(2),
            ))?
            .label("GA")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
            c.configure_series_labels()
                .border_style(BLACK)
                .background_style(WHITE)
                .draw()?;

            let (lo, hi) = range(mean_pso.iter().chain(&mean_ga).copied().chain([1.0]));
            let mut c = ChartBuilder::on(&right)
                .caption(
                    format!("{d}D, {} trials: mean best error / exact minimum", ok.len()),
                    ("sans-serif", 17),
                )
                .margin(12)
                .x_label_area_size(35)
                .y_label_area_size(70)
                .build_cartesian_2d(0f64..(iters.max(2) - 1) as f64, lo..hi)?;
            c.configure_mesh()
                .x_desc("iteration")
                .y_desc("error / exact")
                .draw()?;
            c.draw_series(LineSeries::new(
                mean_pso.iter().enumerate().map(|(k, f)| (k as f64, *f)),
                BLUE.stroke_width(2),
            ))?
            .label("PSO")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
            c.draw_series(LineSeries::new(
                mean_ga.iter().enumerate().map(|(k, f)| (k as f64, *f)),
                RED.stroke_width(2),
            ))?
            .label("GA")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
            c.draw_series(LineSeries::new(
                [(0.0, 1.0), ((iters.max(2) - 1) as f64, 1.0)],
                BLACK.mix(0.5),
            ))?
            .label("exact")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.5)));
            c.configure_series_labels()
                .border_style(BLACK)
                .background_style(WHITE)
                .draw()?;
            Ok(())
        },
    )?);

    // Figure 10: PSO and GA error per trial (the first 60 trials).
    let shown: Vec<_> = ok.iter().take(60).collect();
    written.push(figure(
        dir,
        &format!("pso_vs_ga_{d}d.svg"),
        (900, 450),
        |root| {
            let (lo, hi) = range(shown.iter().flat_map(|r| [r.error.pso, r.error.ga]));
            let s = &report.summary;
            let mut c = ChartBuilder::on(root)
                .caption(
                    format!(
                        "{d}D: fitting error per trial, mean PSO {:.2} vs GA {:.2} over {} trials",
                        s.mean_error.pso, s.mean_error.ga, s.ok
                    ),
                    ("sans-serif", 17),
                )
                .margin(12)
                .x_label_area_size(35)
                .y_label_area_size(60)
                .build_cartesian_2d(0f64..shown.len().max(2) as f64, lo..hi)?;
            c.configure_mesh()
                .x_desc("trial")
                .y_desc("error (sum of distances)")
                .draw()?;
            for (color, pick, name) in [
                (
                    BLUE,
                    (|r: &super::TrialRecord| r.error.pso) as fn(&super::TrialRecord) -> f64,
                    "PSO",
                ),
                (RED, |r: &super::TrialRecord| r.error.ga, "GA"),
            ] {
                let pts: Vec<(f64, f64)> = shown
                    .iter()
                    .enumerate()
                    .map(|(i, r)| (i as f64, pick(r)))
                    .collect();
                c.draw_series(LineSeries::new(pts.clone(), color))?
                    .label(name)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
                c.draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
            }
            c.configure_series_labels()
                .border_style(BLACK)
                .background_style(WHITE)
                .draw()?;
            Ok(())
        },
    )?);

    // Figure 6: one fit.
    written.push(if d == 2 {
        figure(dir, "fit_2d.svg", (1100, 520), |root| fit_2d(root, &ex))?
    } else {
        figure(dir, "fit_3d.svg", (1100, 520), |root| fit_3d(root, &ex))?
    });
    Ok(written)
}

const SIDE_COLORS: [RGBColor; 5] = [
    RGBColor(40, 110, 200),
    RGBColor(30, 150, 70),
    RGBColor(150, 90, 200),
    RGBColor(200, 130, 20),
    RGBColor(110, 110, 110),
];

fn fit_2d(
    root: &Area<'_>,
    ex: &super::Example,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let (l, r) = root.split_horizontally(550);
    let all = || ex.sides.iter().flatten();
    let (x0, x1) = range(all().map(|p| p[0]).chain([ex.truth[0]]));
    let (y0, y1) = range(all().map(|p| p[1]).chain([ex.truth[1]]));
    let reach = ((x1 - x0).powi(2) + (y1 - y0).powi(2)).sqrt();
    for (area, (name, (corner, dirs), err)) in [l, r].iter().zip([
        (
            "(a) Scheme 1: best data point",
            &ex.scheme1,
            ex.error_scheme1,
        ),
        ("(b) PSO", &ex.pso, ex.error_pso),
    ]) {
        let mut c = ChartBuilder::on(area)
            .caption(format!("{name}, error {err:.2}"), ("sans-serif", 17))
            .margin(12)
            .x_label_area_size(30)
            .y_label_area_size(45)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        c.configure_mesh().draw()?;
        for (k, side) in ex.sides.iter().enumerate() {
            let color = if k + 1 == ex.sides.len() {
                SIDE_COLORS[3]
            } else {
                SIDE_COLORS[k % 3]
            };
            c.draw_series(
                side.iter()
                    .map(|p| Circle::new((p[0], p[1]), 2, color.filled())),
            )?;
        }
        for d in dirs {
            c.draw_series(LineSeries::new(
                [
                    (corner[0], corner[1]),
                    (corner[0] + reach * d[0], corner[1] + reach * d[1]),
                ],
                BLACK.stroke_width(1),
            ))?;
        }
        c.draw_series([Circle::new((corner[0], corner[1]), 5, RED.filled())])?
            .label(format!("corner ({:.2}, {:.2})", corner[0], corner[1]))
            .legend(|(x, y)| Circle::new((x + 10, y), 4, RED.filled()));
        c.draw_series([Cross::new(
            (ex.truth[0], ex.truth[1]),
            6,
            BLACK.stroke_width(2),
        )])?
        .label("true corner")
        .legend(|(x, y)| Cross::new((x + 10, y), 5, BLACK));
        c.configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()?;
    }
    Ok(())
}

fn fit_3d(
    root: &Area<'_>,
    ex: &super::Example,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let (l, r) = root.split_horizontally(550);
    let all = || ex.sides.iter().flatten();
    let rng = |k: usize| range(all().map(move |p| p[k]).chain([ex.truth[k]]));
    let (x0, x1) = rng(0);
    let (y0, y1) = rng(1);
    let (z0, z1) = rng(2);
    let reach = 0.9
        * [(x1 - x0), (y1 - y0), (z1 - z0)]
            .iter()
            .fold(0.0f64, |a, b| a.max(*b));
    for (area, (name, (corner, dirs), err)) in [l, r].iter().zip([
        (
            "(a) Scheme 1: best data point",
            &ex.scheme1,
            ex.error_scheme1,
        ),
        ("(b) PSO", &ex.pso, ex.error_pso),
    ]) {
        let mut c = ChartBuilder::on(area)
            .caption(format!("{name}, error {err:.2}"), ("sans-serif", 17))
            .margin(12)
            .build_cartesian_3d(x0..x1, y0..y1, z0..z1)?;
        c.with_projection(|mut pb| {
            pb.yaw = 0.6;
            pb.pitch = 0.4;
            pb.scale = 0.85;
            pb.into_matrix()
        });
        c.configure_axes().max_light_lines(3).draw()?;
        for (k, side) in ex.sides.iter().enumerate() {
            let color = SIDE_COLORS[k % SIDE_COLORS.len()];
            c.draw_series(
                side.iter()
                    .map(|p| Circle::new((p[0], p[1], p[2]), 2, color.filled())),
            )?;
        }
        for d in dirs {
            c.draw_series(LineSeries::new(
                [
                    (corner[0], corner[1], corner[2]),
                    (
                        corner[0] + reach * d[0],
                        corner[1] + reach * d[1],
                        corner[2] + reach * d[2],
                    ),
                ],
                BLACK.stroke_width(1),
            ))?;
        }
        c.draw_series([Circle::new(
            (corner[0], corner[1], corner[2]),
            5,
            RED.filled(),
        )])?
        .label(format!(
            "corner ({:.2}, {:.2}, {:.2})",
            corner[0], corner[1], corner[2]
        ))
        .legend(|(x, y)| Circle::new((x + 10, y), 4, RED.filled()));
        c.draw_series([Cross::new(
            (ex.truth[0], ex.truth[1], ex.truth[2]),
            6,
            BLACK.stroke_width(2),
        )])?
        .label("true corner")
        .legend(|(x, y)| Cross::new((x + 10, y), 5, BLACK));
        c.configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()?;
    }
    Ok(())
}
