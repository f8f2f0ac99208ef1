//! `sensitivity.png`: a tornado chart, one row per machine parameter (the most influential on top),
//! two bars per row: the frame's change with the parameter divided and multiplied by the factor.

use std::path::Path;

use plotters::prelude::*;

use super::{canvas, draw_error, register_fonts, save, PALETTE, PLOT_SIZE as SIZE};
use crate::study::sensitivity::Sensitivity;
use crate::study::Label;

/// Rows drawn (the rest are in the table).
pub const ROWS: usize = 16;

/// Draws the tornado chart of `s` to `path`.
pub fn tornado(path: &Path, scene: &Label, s: &Sensitivity) -> crate::Result<()> {
    register_fonts();
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let rows: Vec<_> = s.effects.iter().take(ROWS).collect();
    let n = rows.len().max(1);
    let change = |ms: f64| 100.0 * (ms / s.base_ms - 1.0);
    let reach = rows
        .iter()
        .flat_map(|e| [&e.low, &e.high])
        .flatten()
        .map(|x| change(x.frame_ms).abs())
        .fold(1.0, f64::max)
        * 1.15;
    let names: Vec<String> = rows
        .iter()
        .map(|e| format!("{} = {}", e.key, e.base_value))
        .collect();
    let mut rgb = canvas();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let title = format!(
            "{} {}x{} on {}: frame {:.2} ms, each parameter ÷{f} and ×{f}",
            scene.name,
            scene.width,
            scene.height,
            s.machine,
            s.base_ms,
            f = s.factor
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(20)
            .x_label_area_size(56)
            .y_label_area_size(250)
            .build_cartesian_2d(-reach..reach, -0.5..n as f64 - 0.5)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .y_labels(n + 1)
            .y_label_formatter(&|y| {
                // Row 0 (the most influential) at the top.
                let i = y.round();
                if (y - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < names.len() {
                    names[names.len() - 1 - i as usize].clone()
                } else {
                    String::new()
                }
            })
            .x_desc("change of the frame's simulated time, %")
            .bold_line_style(RGBColor(200, 200, 200))
            .light_line_style(RGBColor(238, 238, 238))
            .axis_desc_style(("sans-serif", 18))
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| err(&e))?;
        let row_y = |i: usize| (n - 1 - i) as f64;
        for (k, label) in [(0usize, format!("÷{}", s.factor)), (1, format!("×{}", s.factor))] {
            let (r, g, b) = PALETTE[k];
            let colour = RGBColor(r, g, b);
            let bars: Vec<Rectangle<(f64, f64)>> = rows
                .iter()
                .enumerate()
                .filter_map(|(i, e)| {
                    let side = if k == 0 { &e.low } else { &e.high };
                    side.as_ref().map(|x| {
                        // The divided bar in the row's upper half, the multiplied one in its lower.
                        let y = row_y(i);
                        let (y0, y1) = if k == 0 { (y, y + 0.38) } else { (y - 0.38, y) };
                        Rectangle::new([(0.0, y0), (change(x.frame_ms), y1)], colour.filled())
                    })
                })
                .collect();
            chart
                .draw_series(bars)
                .map_err(|e| err(&e))?
                .label(label)
                .legend(move |(x, y)| Rectangle::new([(x - 8, y - 6), (x + 8, y + 6)], colour.filled()));
        }
        chart
            .draw_series(LineSeries::new(
                vec![(0.0, -0.5), (0.0, n as f64 - 0.5)],
                BLACK.stroke_width(1),
            ))
            .map_err(|e| err(&e))?;
        super::legend(&mut chart, SeriesLabelPosition::LowerRight).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    save(path, rgb)
}
