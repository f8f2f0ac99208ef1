//! `bench.png`: time against error of every candidate of a bench run.

use std::path::Path;

use super::draw_error;
use crate::bench::{BenchReport, BenchRow};

/// `bench.png`: median time (ms, log) on x against MAE (log) on y; one series per algorithm, points
/// joined by a line when a series sweeps a setting, each point labelled with its setting.
pub fn bench(path: &Path, report: &BenchReport) -> crate::Result<()> {
    use plotters::prelude::*;
    super::register_fonts();
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);

    // Series in first-appearance order of the algorithm name.
    let mut series: Vec<(&str, Vec<&BenchRow>)> = Vec::new();
    for r in &report.rows {
        match series.iter_mut().find(|(name, _)| *name == r.algorithm) {
            Some((_, rows)) => rows.push(r),
            None => series.push((&r.algorithm, vec![r])),
        }
    }
    // Log axes need positive values: an exact result (MAE 0) sits on the floor of the axis.
    let positive = |v: f64| v.is_finite() && v > 0.0;
    let maes: Vec<f64> = report
        .rows
        .iter()
        .map(|r| r.error.mae)
        .filter(|&v| positive(v))
        .collect();
    let times: Vec<f64> = report
        .rows
        .iter()
        .map(|r| r.median_ms)
        .filter(|&v| positive(v))
        .collect();
    let span = |v: &[f64], fallback: (f64, f64)| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(0.0, f64::max);
        if lo.is_finite() && hi > 0.0 {
            (lo / 2.0, hi * 2.0)
        } else {
            fallback
        }
    };
    let (x0, x1) = span(&times, (0.1, 1000.0));
    let (y0, y1) = span(&maes, (1e-6, 1.0));
    let at = |r: &BenchRow| (r.median_ms.max(x0), r.error.mae.max(y0));

    let mut rgb = super::canvas();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, super::PLOT_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let truth = match (&report.truth.file, report.truth.spp) {
            (Some(f), _) => format!("truth {}", f.display()),
            (None, Some(spp)) => format!("truth {spp} spp"),
            _ => "truth".into(),
        };
        let scene_name = report
            .scene
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let title = format!(
            "{scene_name} {}x{}: time vs error ({truth}, {} threads)",
            report.width, report.height, report.host_threads
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(20)
            .x_label_area_size(56)
            .y_label_area_size(80)
            .build_cartesian_2d(log_axis(x0, x1), log_axis(y0, y1))
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("median host wall time per frame, ms (log scale)")
            .y_desc("MAE of V against truth (log scale)")
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(200, 200, 200))
            .x_label_formatter(&|x| fmt_tick(*x))
            .y_label_formatter(&|y| fmt_tick(*y))
            .axis_desc_style(("sans-serif", 18))
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;

        for (i, (name, rows)) in series.iter().enumerate() {
            let (r, g, b) = super::PALETTE[i % super::PALETTE.len()];
            let colour = RGBColor(r, g, b);
            let points: Vec<(f64, f64)> = rows.iter().map(|r| at(r)).collect();
            if points.len() > 1 {
                chart
                    .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
                    .map_err(|e| err(&e))?;
            }
            // One marker shape per family.
            let family = rows.first().map_or("", |r| r.family.as_str());
            let shape = FAMILY_MARKERS.iter().position(|f| *f == family).unwrap_or(0);
            let label = format!("{name} ({family})");
            // The same series call per shape: plotters' markers are distinct types.
            macro_rules! markers {
                ($make:expr) => {
                    chart
                        .draw_series(points.iter().map(|&p| $make(p)))
                        .map_err(|e| err(&e))?
                        .label(label)
                        .legend(move |(x, y)| {
                            EmptyElement::at((x, y))
                                + PathElement::new(vec![(-10, 0), (10, 0)], colour.stroke_width(2))
                                + $make((0, 0))
                        })
                };
            }
            match shape {
                0 => markers!(|p| Circle::new(p, 6, colour.filled())),
                1 => markers!(|p| TriangleMarker::new(p, 8, colour.filled())),
                2 => markers!(|p| Circle::new(p, 6, colour.stroke_width(3))),
                _ => markers!(|p| Cross::new(p, 6, colour.stroke_width(3))),
            };
            chart
                .draw_series(
                    rows.iter()
                        .zip(&points)
                        .filter(|(r, _)| !r.label.is_empty())
                        .map(|(r, &p)| {
                            EmptyElement::at(p)
                                + Text::new(r.label.clone(), (9, -20), ("sans-serif", 15).into_font())
                        }),
                )
                .map_err(|e| err(&e))?;
        }
        // The time–error front: a staircase through its rows by rising time.
        let mut front: Vec<(f64, f64)> = report.rows.iter().filter(|r| r.pareto).map(at).collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut stairs = Vec::new();
        for (k, &p) in front.iter().enumerate() {
            if k > 0 {
                stairs.push((p.0, front[k - 1].1));
            }
            stairs.push(p);
        }
        if stairs.len() > 1 {
            chart
                .draw_series(DashedLineSeries::new(stairs, 8, 5, BLACK.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label("time-error front")
                .legend(|(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], BLACK.stroke_width(2)));
        }
        super::legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    super::save(path, rgb)
}

/// Families in marker order: filled circle, triangle, open circle, then a cross.
const FAMILY_MARKERS: [&str; 4] = ["ray-traced", "sism", "shadow-map", "test"];

/// A log axis over `lo..hi` with labelled grid lines at 1, 2 and 5 times powers of ten (every
/// integer multiple when the range holds fewer than three of those) and light lines at the other
/// multiples. Plotters' own log-axis ticks skip decades.
fn log_axis(
    lo: f64,
    hi: f64,
) -> plotters::coord::combinators::WithKeyPoints<plotters::coord::combinators::LogCoord<f64>> {
    use plotters::coord::combinators::{BindKeyPoints, IntoLogRange};
    let mut all = Vec::new();
    for k in lo.log10().floor() as i32..=hi.log10().ceil() as i32 {
        for m in 1..=9 {
            let v = m as f64 * 10f64.powi(k);
            if v >= lo && v <= hi {
                all.push((m, v));
            }
        }
    }
    let mut bold: Vec<f64> = all
        .iter()
        .filter(|(m, _)| [1, 2, 5].contains(m))
        .map(|&(_, v)| v)
        .collect();
    if bold.len() < 3 {
        bold = all.iter().map(|&(_, v)| v).collect();
    }
    let light: Vec<f64> = all
        .iter()
        .map(|&(_, v)| v)
        .filter(|v| !bold.contains(v))
        .collect();
    (lo..hi)
        .log_scale()
        .with_key_points(bold)
        .with_light_points(light)
}

/// A tick label: a plain number with as many decimals as its first significant digit needs.
fn fmt_tick(x: f64) -> String {
    if x >= 1.0 {
        format!("{x:.0}")
    } else if x > 0.0 {
        let decimals = (-x.log10()).ceil().max(1.0) as usize;
        format!("{x:.decimals$}")
    } else {
        "0".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels() {
        assert_eq!(fmt_tick(200.0), "200");
        assert_eq!(fmt_tick(2.0 * 10f64.powi(-3)), "0.002");
        assert_eq!(fmt_tick(0.5), "0.5");
        assert_eq!(fmt_tick(5.0 * 10f64.powi(-4)), "0.0005");
    }
}
