//! `sism table2`: the SISM paper's Table 2 from one command — per workload a `sism` frame counted and
//! timed on the modelled chip, its phases grouped as the paper groups them, beside the published rows.

use std::path::PathBuf;

use anyhow::Context;

use sism::render;
use sism::scene::Scene;
use sism::table2::{self, Row};

use super::{algorithm, algorithm_values, create_dir, print_stdout, write_file, ParamArgs};

/// The workloads in the paper's order (`scenes/table2/`).
const DEFAULT_WORKLOADS: [&str; 5] = [
    "scenes/table2/palm-hard.toml",
    "scenes/table2/palm.toml",
    "scenes/table2/fern.toml",
    "scenes/table2/street.toml",
    "scenes/table2/saloon.toml",
];

#[derive(clap::Args)]
pub struct Args {
    /// Workload scene files (default: the five of scenes/table2, run from the repository). A file's
    /// stem names its row; `palm-hard`, `fern`, `street` and `saloon` are printed beside the paper's.
    workloads: Vec<PathBuf>,
    /// The modelled chip: a preset (larrabee-8/16/24/32/48/64) or a machine TOML file.
    #[arg(long, default_value = "larrabee-24")]
    machine: String,
    /// Algorithm (one that runs on the simd kernels).
    #[arg(long, default_value = "sism", value_parser = algorithm_values(true))]
    algo: String,
    #[command(flatten)]
    params: ParamArgs,
    /// Output folder: table2.csv and table2.md.
    #[arg(long, default_value = "out/table2")]
    out: PathBuf,
    /// No progress lines.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let algo = algorithm(&a.algo)?;
    let params = a.params.resolve(algo)?;
    let config = super::resolve_machine(&a.machine).context("--machine")?;
    let workloads: Vec<PathBuf> = if a.workloads.is_empty() {
        DEFAULT_WORKLOADS.iter().map(PathBuf::from).collect()
    } else {
        a.workloads.clone()
    };
    let out = create_dir(&a.out)?;
    let mut rows = Vec::new();
    for (k, path) in workloads.iter().enumerate() {
        let scene = Scene::load(path)?;
        let name = path
            .file_stem()
            .map_or_else(|| format!("workload{k}"), |s| s.to_string_lossy().into_owned());
        if !a.quiet {
            note!(
                "[{}/{}] {name}: {}x{}, counting and timing on {}",
                k + 1,
                workloads.len(),
                scene.camera.width,
                scene.camera.height,
                a.machine
            );
        }
        let r = render::render_on_machine(&scene, algo, &params, &config, !a.quiet);
        rows.push(Row::new(
            &name,
            &r.report,
            &r.result.stats,
            scene.camera.width,
            scene.camera.height,
        ));
    }
    let md = table2::markdown(&rows);
    write_file(&out.join("table2.csv"), &table2::csv(&rows))?;
    write_file(&out.join("table2.md"), &md)?;
    print_stdout(&md)?;
    if !a.quiet {
        note!("wrote {}", out.display());
    }
    Ok(())
}
