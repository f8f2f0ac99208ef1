//! The study's plots, `speedup.png` and `phases.png`, drawn from the points alone (both backends).

use std::path::Path;

use plotters::prelude::*;

use super::{canvas, draw_error, register_fonts, save, PALETTE, PLOT_SIZE as SIZE};
use crate::study::{speedup as point_speedup, Label, Point as StudyPoint};

/// `speedup.png`: frame speedup against cores (over the smallest core count), one series per
/// (threads, L2) pair, and the linear speedup.
pub fn speedup(path: &Path, scene: &Label, points: &[StudyPoint]) -> crate::Result<()> {
    register_fonts();
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let c0 = points.iter().map(|p| p.cores).min().unwrap_or(1) as f64;
    let c1 = points.iter().map(|p| p.cores).max().unwrap_or(1) as f64;
    let ymax = points
        .iter()
        .map(|p| point_speedup(points, p))
        .fold(c1 / c0, f64::max)
        * 1.05;
    type Series = ((u32, u32), Vec<(f64, f64)>);
    let mut series: Vec<Series> = Vec::new();
    for p in points {
        let key = (p.threads, p.l2_kb);
        let pt = (p.cores as f64, point_speedup(points, p));
        match series.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(pt),
            None => series.push((key, vec![pt])),
        }
    }
    let mut rgb = canvas();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let title = format!(
            "{} {}x{}: simulated speedup vs cores",
            scene.name, scene.width, scene.height
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(20)
            .x_label_area_size(56)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..c1 * 1.05, 0.0..ymax)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("cores")
            .y_desc(format!("frame speedup over {} core(s)", c0))
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(200, 200, 200))
            .axis_desc_style(("sans-serif", 18))
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;
        chart
            .draw_series(LineSeries::new(
                vec![(c0, 1.0), (c1, c1 / c0)],
                BLACK.mix(0.5).stroke_width(1),
            ))
            .map_err(|e| err(&e))?
            .label("linear")
            .legend(|(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], BLACK.mix(0.5)));
        for (i, ((t, l2), pts)) in series.iter().enumerate() {
            let (r, g, b) = PALETTE[i % PALETTE.len()];
            let colour = RGBColor(r, g, b);
            chart
                .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                .map_err(|e| err(&e))?;
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 5, colour.filled())))
                .map_err(|e| err(&e))?
                .label(format!("{t} threads/core, L2 {l2} KB"))
                .legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(-10, 0), (10, 0)], colour.stroke_width(2))
                        + Circle::new((0, 0), 4, colour.filled())
                });
        }
        super::legend(&mut chart, SeriesLabelPosition::UpperLeft).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    save(path, rgb)
}

/// `phases.png`: per-phase simulated ms and share of the frame, one bar per phase, in the style
/// of the paper's Table 2.
pub fn phases(path: &Path, scene: &Label, point: &StudyPoint) -> crate::Result<()> {
    register_fonts();
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let r = point;
    let n = r.groups.len().max(1);
    let ymax = r.groups.iter().map(|p| p.ms).fold(0.0, f64::max).max(1e-6) * 1.2;
    let mut rgb = canvas();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let title = format!(
            "{} {}x{} on {} cores, {} threads/core, {} GHz: {:.2} ms/frame",
            scene.name,
            scene.width,
            scene.height,
            point.cores,
            point.threads,
            point.clock_ghz,
            point.frame.ms
        );
        let names: Vec<String> = r.groups.iter().map(|p| p.phase.clone()).collect();
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(20)
            .x_label_area_size(56)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.5..n as f64 - 0.5, 0.0..ymax)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n)
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < names.len() {
                    names[i as usize].clone()
                } else {
                    String::new()
                }
            })
            .x_desc("phase")
            .y_desc("simulated time, ms")
            .bold_line_style(RGBColor(200, 200, 200))
            .light_line_style(RGBColor(238, 238, 238))
            .axis_desc_style(("sans-serif", 18))
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;
        // Each bar stacked by its cycle stack, scaled to ms.
        let parts = ["issue", "memory", "atomics + sync", "imbalance + idle"];
        for (k, part) in parts.iter().enumerate() {
            let (cr, cg, cb) = PALETTE[k];
            let colour = RGBColor(cr, cg, cb);
            let bars: Vec<Rectangle<(f64, f64)>> = r
                .groups
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let s = p.stack.parts();
                    let below: u64 = s[..k].iter().map(|x| x.1).sum();
                    let ms = |c: u64| c as f64 / (r.clock_ghz * 1e6);
                    Rectangle::new(
                        [
                            (i as f64 - 0.35, ms(below)),
                            (i as f64 + 0.35, ms(below + s[k].1)),
                        ],
                        colour.filled(),
                    )
                })
                .collect();
            chart
                .draw_series(bars)
                .map_err(|e| err(&e))?
                .label(*part)
                .legend(move |(x, y)| Rectangle::new([(x - 8, y - 6), (x + 8, y + 6)], colour.filled()));
        }
        chart
            .draw_series(r.groups.iter().enumerate().map(|(i, p)| {
                Text::new(
                    format!(
                        "{:.2} ms ({:.0}%)",
                        p.ms,
                        100.0 * p.cycles as f64 / r.frame.cycles.max(1) as f64
                    ),
                    (i as f64 - 0.3, p.ms + ymax * 0.04),
                    ("sans-serif", 15).into_font(),
                )
            }))
            .map_err(|e| err(&e))?;
        super::legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    save(path, rgb)
}
