//! `sism compare`: error of a visibility image against a reference.

use std::path::PathBuf;

use anyhow::Context;

use sism::metrics;
use sism::output::{pfm, pictures};

use super::print_stdout;

#[derive(clap::Args)]
pub struct Args {
    /// Reference visibility (PFM).
    reference: PathBuf,
    /// Visibility to score (PFM).
    test: PathBuf,
    /// Write an |error| heat map PNG here (black 0, red, yellow at --heatmap-scale).
    #[arg(long)]
    heatmap: Option<PathBuf>,
    /// |error| shown as full yellow in the heat map.
    #[arg(long, default_value_t = 0.25)]
    heatmap_scale: f32,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let r = pfm::read_pfm(&a.reference)?;
    let t = pfm::read_pfm(&a.test)?;
    let report = metrics::compare(&r, &t)
        .with_context(|| format!("comparing {} with {}", a.test.display(), a.reference.display()))?;
    if a.json {
        print_stdout(&serde_json::to_string_pretty(&report)?)?;
    } else {
        print_stdout(&report.to_string())?;
    }
    if let Some(path) = a.heatmap {
        anyhow::ensure!(
            a.heatmap_scale > 0.0 && a.heatmap_scale.is_finite(),
            "--heatmap-scale must be > 0"
        );
        let errors = metrics::abs_error_map(&r, &t)?;
        pictures::write_error_heatmap(&path, r.width, r.height, &errors, a.heatmap_scale)?;
    }
    Ok(())
}
