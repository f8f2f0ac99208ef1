//! `validate.png`: the machine model's predicted phase times against the host's measured ones.

use std::path::Path;

use super::draw_error;
use crate::host::validate::Row;

/// Predicted against measured ms, log–log, one point per major phase and frame, the ±tolerance band.
pub fn predicted_vs_measured(path: &Path, rows: &[Row], tolerance: f64) -> crate::Result<()> {
    use plotters::prelude::*;
    super::register_fonts();
    let points: Vec<(&Row, f64)> = rows
        .iter()
        .filter(|r| r.is_major() || r.phase == "frame")
        .filter_map(|r| r.predicted_ms.map(|p| (r, p)))
        .filter(|(r, p)| r.measured_ms > 0.0 && *p > 0.0)
        .collect();
    let lo = points
        .iter()
        .map(|(r, p)| r.measured_ms.min(*p))
        .fold(f64::INFINITY, f64::min)
        .max(1e-3)
        * 0.7;
    let hi = points
        .iter()
        .map(|(r, p)| r.measured_ms.max(*p))
        .fold(lo * 10.0, f64::max)
        * 1.4;
    let mut buf = super::canvas();
    {
        let root = BitMapBackend::with_buffer(&mut buf, super::PLOT_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_error(path, &e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "machine model against the host: predicted vs measured ms",
                ("sans-serif", 24),
            )
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d((lo..hi).log_scale(), (lo..hi).log_scale())
            .map_err(|e| draw_error(path, &e))?;
        chart
            .configure_mesh()
            .x_desc("measured host ms")
            .y_desc("model ms")
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(|e| draw_error(path, &e))?;
        let line = |k: f64| {
            (0..=50).map(move |i| {
                let x = lo * (hi / lo).powf(i as f64 / 50.0);
                (x, x * k)
            })
        };
        chart
            .draw_series(LineSeries::new(line(1.0), BLACK))
            .map_err(|e| draw_error(path, &e))?
            .label("model = host");
        for k in [1.0 + tolerance, 1.0 / (1.0 + tolerance)] {
            chart
                .draw_series(LineSeries::new(line(k), BLACK.mix(0.3)))
                .map_err(|e| draw_error(path, &e))?;
        }
        // One colour per major phase name, in first-seen order, and the frames last.
        let mut series: Vec<&str> = Vec::new();
        for (row, _) in &points {
            if row.phase != "frame" && !series.contains(&row.phase.as_str()) {
                series.push(&row.phase);
            }
        }
        series.push("frame");
        for (i, name) in series.iter().enumerate() {
            let (r, g, b) = super::PALETTE[i % super::PALETTE.len()];
            let colour = RGBColor(r, g, b);
            chart
                .draw_series(
                    points
                        .iter()
                        .filter(|(row, _)| row.phase == *name)
                        .map(|(row, p)| {
                            let style = if row.threads == 1 {
                                colour.filled()
                            } else {
                                colour.stroke_width(2)
                            };
                            Circle::new((row.measured_ms, *p), 6, style)
                        }),
                )
                .map_err(|e| draw_error(path, &e))?
                .label(format!("{name} (filled: 1 thread)"))
                .legend(move |(x, y)| Circle::new((x, y), 6, colour.filled()));
        }
        super::legend(&mut chart, SeriesLabelPosition::UpperLeft).map_err(|e| draw_error(path, &e))?;
        root.present().map_err(|e| draw_error(path, &e))?;
    }
    super::save(path, buf)
}
