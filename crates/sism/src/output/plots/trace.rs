//! `frames.png`: a trace run's host time and flicker per frame.

use std::path::Path;

use super::draw_error;

/// `frames.png`: host ms per frame and, on a second axis scale, the frame's mean flicker.
pub fn frames(path: &Path, trace: &Path, algo: &str, host: &[f64], flicker: &[f64]) -> crate::Result<()> {
    use plotters::prelude::*;
    super::register_fonts();
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let n = host.len().max(2) as f64;
    let tmax = host
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-3)
        * 1.15;
    let fmax = flicker
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-6)
        * 1.15;
    let mut rgb = super::canvas();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, super::PLOT_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let name = trace
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("{name}: {algo} per frame"), ("sans-serif", 24))
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .right_y_label_area_size(80)
            .build_cartesian_2d(0f64..n - 1.0, 0f64..tmax)
            .map_err(|e| err(&e))?
            .set_secondary_coord(0f64..n - 1.0, 0f64..fmax);
        chart
            .configure_mesh()
            .x_desc("frame")
            .y_desc("host ms")
            .axis_desc_style(("sans-serif", 18))
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;
        chart
            .configure_secondary_axes()
            .y_desc("mean flicker")
            .axis_desc_style(("sans-serif", 18))
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;
        let blue = RGBColor(31, 119, 180);
        let red = RGBColor(214, 39, 40);
        chart
            .draw_series(LineSeries::new(
                host.iter().enumerate().map(|(k, &v)| (k as f64, v)),
                blue.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label("host ms")
            .legend(move |(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], blue.stroke_width(2)));
        chart
            .draw_secondary_series(LineSeries::new(
                flicker
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| v.is_finite())
                    .map(|(k, &v)| (k as f64, v)),
                red.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label("mean flicker")
            .legend(move |(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], red.stroke_width(2)));
        super::legend(&mut chart, SeriesLabelPosition::UpperLeft).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    super::save(path, rgb)
}
