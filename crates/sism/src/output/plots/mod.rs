//! sism's PNG plots (bench, study, trace, validation) and what they all share: the embedded font,
//! the canvas size, the series colours, and writing the drawn buffer.
//!
//! The plots live in the library, not the command line, because the library writes the outputs they
//! belong to (a study's `collect` on a cluster, a trace run, a caller from another language), and
//! every caller should get the same pictures.

pub mod bench;
pub mod roofline;
pub mod sensitivity;
pub mod study;
pub mod trace;
pub mod validate;

use std::path::Path;
use std::sync::Once;

/// Size of a plot, pixels.
pub const PLOT_SIZE: (u32, u32) = (1000, 700);

/// Series colours, in series order.
pub const PALETTE: [(u8, u8, u8); 6] = [
    (31, 119, 180),
    (214, 39, 40),
    (44, 160, 44),
    (255, 127, 14),
    (148, 103, 189),
    (140, 86, 75),
];

/// Registers the embedded DejaVu Sans as plotters' "sans-serif" (the ab_glyph backend has no system
/// fonts). Call before drawing text; later calls do nothing.
pub fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        use plotters::style::{register_font, FontStyle};
        for style in [FontStyle::Normal, FontStyle::Bold] {
            let bytes = match style {
                FontStyle::Bold => dejavu::sans::bold(),
                _ => dejavu::sans::regular(),
            };
            // DejaVu is a valid font: registration cannot fail.
            let _ = register_font("sans-serif", style, bytes);
        }
    });
}

/// A zeroed RGB buffer of [`PLOT_SIZE`], for plotters' `BitMapBackend::with_buffer`.
pub fn canvas() -> Vec<u8> {
    vec![0u8; PLOT_SIZE.0 as usize * PLOT_SIZE.1 as usize * 3]
}

/// Writes a drawn [`canvas`] to `path` as PNG (whole or not at all).
pub fn save(path: &Path, rgb: Vec<u8>) -> crate::Result<()> {
    let Some(image) = image::RgbImage::from_raw(PLOT_SIZE.0, PLOT_SIZE.1, rgb) else {
        crate::error::bail!(
            "cannot write {}: the canvas is not {}x{}",
            path.display(),
            PLOT_SIZE.0,
            PLOT_SIZE.1
        );
    };
    crate::output::save_png(path, &image)
}

/// The error of a failed drawing of the plot bound for `path`.
pub fn draw_error(path: &Path, e: &dyn std::fmt::Display) -> crate::Error {
    crate::Error::Io {
        what: "cannot draw",
        path: path.to_path_buf(),
        error: std::io::Error::other(e.to_string()),
    }
}

/// Draws the chart's legend (series labels) at `position`, in every plot's style.
pub fn legend<'a, DB, CT>(
    chart: &mut plotters::chart::ChartContext<'a, DB, CT>,
    position: plotters::chart::SeriesLabelPosition,
) -> Result<(), String>
where
    DB: plotters::prelude::DrawingBackend + 'a,
    CT: plotters::coord::CoordTranslate,
{
    use plotters::prelude::*;
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()
        .map_err(|e| e.to_string())
}
