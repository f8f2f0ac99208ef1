//! `roofline.png`: the frame's phases on the machine's roofline, log–log: vector lane operations per
//! cycle against operations per byte, each phase twice (per byte from DRAM, per byte from L2), under
//! the peak vector issue and the DRAM and L2 bandwidth roofs.

use std::path::Path;

use plotters::prelude::*;

use super::{canvas, draw_error, register_fonts, save, PALETTE, PLOT_SIZE as SIZE};
use crate::machine::roofline::{Ceilings, RooflinePoint};
use crate::machine::MachineConfig;

/// Draws the roofline of `points` (the frame first, then phases and steps: only the frame and the
/// phases are drawn) under `m`'s ceilings to `path`; `title` names the frame.
pub fn roofline(path: &Path, title: &str, m: &MachineConfig, points: &[RooflinePoint]) -> crate::Result<()> {
    register_fonts();
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let c = Ceilings::of(m);
    let frame_cycles = points.first().map_or(1, |p| p.cycles).max(1);
    let groups: Vec<&RooflinePoint> = points.iter().filter(|p| p.group).collect();
    // Intensities span the plot; a point without traffic sits at the right edge.
    let finite = |x: f64| x.is_finite() && x > 0.0;
    let xs: Vec<f64> = groups
        .iter()
        .flat_map(|p| [p.dram_intensity(), p.l2_intensity()])
        .filter(|&x| finite(x))
        .collect();
    let ridge_dram = c.lane_ops / c.dram_bytes;
    let ridge_l2 = c.lane_ops / c.l2_bytes;
    let x0 = xs.iter().copied().fold(ridge_l2.min(ridge_dram), f64::min) / 4.0;
    let x1 = xs.iter().copied().fold(ridge_l2.max(ridge_dram), f64::max) * 4.0;
    let ys: Vec<f64> = groups
        .iter()
        .map(|p| p.lane_ops_per_cycle())
        .filter(|&y| finite(y))
        .collect();
    let y0 = ys.iter().copied().fold(c.lane_ops, f64::min).max(1e-6) / 4.0;
    let y1 = c.lane_ops * 2.0;
    let mut rgb = canvas();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(20)
            .x_label_area_size(56)
            .y_label_area_size(80)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("vector lane operations per byte (from DRAM: ●, from L2: ▲)")
            .y_desc("vector lane operations per cycle (whole chip)")
            .bold_line_style(RGBColor(200, 200, 200))
            .light_line_style(RGBColor(238, 238, 238))
            .axis_desc_style(("sans-serif", 17))
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| err(&e))?;
        let roof = |bw: f64| -> Vec<(f64, f64)> {
            let ridge = c.lane_ops / bw;
            vec![(x0, x0 * bw), (ridge, c.lane_ops), (x1, c.lane_ops)]
        };
        for (k, (name, bw)) in [("DRAM", c.dram_bytes), ("L2", c.l2_bytes)]
            .into_iter()
            .enumerate()
        {
            let colour = if k == 0 { BLACK } else { RGBColor(120, 120, 120) };
            chart
                .draw_series(LineSeries::new(roof(bw), colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(format!(
                    "{name} roof: {bw:.1} B/cycle, peak {:.0} ops/cycle",
                    c.lane_ops
                ))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x - 10, y), (x + 10, y)], colour.stroke_width(2))
                });
        }
        for (i, p) in groups.iter().enumerate() {
            let (r_, g_, b_) = PALETTE[i % PALETTE.len()];
            let colour = RGBColor(r_, g_, b_);
            let y = p.lane_ops_per_cycle().max(y0);
            let at = |x: f64| if finite(x) { x.clamp(x0, x1) } else { x1 };
            let (xd, xl) = (at(p.dram_intensity()), at(p.l2_intensity()));
            chart
                .draw_series([Circle::new((xd, y), 6, colour.filled())])
                .map_err(|e| err(&e))?
                .label(format!(
                    "{} ({:.0}%)",
                    p.name,
                    100.0 * p.cycles as f64 / frame_cycles as f64
                ))
                .legend(move |(x, y)| Circle::new((x, y), 5, colour.filled()));
            chart
                .draw_series([TriangleMarker::new((xl, y), 7, colour.filled())])
                .map_err(|e| err(&e))?;
        }
        super::legend(&mut chart, SeriesLabelPosition::LowerRight).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    save(path, rgb)
}
