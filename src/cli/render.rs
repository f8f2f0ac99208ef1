//! `sism render`: one frame of one algorithm, natively or timed on a modelled machine.

use std::path::PathBuf;

use anyhow::Context;

use sism::machine::{self, MachineConfig};
use sism::render::{self, RenderOptions};

use super::{algorithm, algorithm_values, ParamArgs, SceneArgs};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Algorithm (see `sism algorithms` for each one's parameters).
    #[arg(long, default_value = "reference", value_parser = algorithm_values(false))]
    algo: String,
    #[command(flatten)]
    params: ParamArgs,
    /// Output folder (created if missing).
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Time the frame on a modelled many-core chip: a preset (larrabee-8/16/24/32/48/64) or a
    /// machine TOML file. Runs the kernels under the counting context (same image, bit for bit) and
    /// also writes machine.toml and records.bin (for `sism replay`). Needs an algorithm that runs on
    /// the simd kernels (`sism algorithms` says which).
    #[arg(long)]
    machine: Option<String>,
    /// No progress bar and no summary.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let scene = a.scene.load()?;
    let algo = algorithm(&a.algo)?;
    let params = a.params.resolve(algo)?;
    if let Some(m) = a.machine {
        anyhow::ensure!(
            algo.kernels,
            "--machine times algorithms that run on the simd kernels ({}); {} is not one",
            sism::algorithms::REGISTRY
                .iter()
                .filter(|a| a.kernels && a.family != sism::algorithms::Family::Test)
                .map(|a| a.name)
                .collect::<Vec<_>>()
                .join(", "),
            algo.name
        );
        let config = MachineConfig::resolve(&m).context("--machine")?;
        let r = render::render_on_machine(&scene, algo, &params, &config, !a.quiet);
        render::write_outputs(&a.out, &scene, &r.result)?;
        machine::write_config(&a.out, &config)?;
        machine::save_records(&a.out.join("records.bin"), &r.records)?;
        if !a.quiet {
            eprint!("{}", r.result.stats.to_text());
            eprint!("{}", r.report.to_table());
            eprintln!("wrote {}", a.out.display());
        }
        return Ok(());
    }
    let options = RenderOptions {
        progress: !a.quiet,
        ..Default::default()
    };
    let result = render::render(&scene, algo, &params, &options);
    render::write_outputs(&a.out, &scene, &result)?;
    if result.receivers.pixels.iter().all(|p| p.is_none()) {
        eprintln!("warning: no pixel sees a surface: the image holds only misses (check the camera)");
    }
    if !a.quiet {
        eprint!("{}", result.stats.to_text());
        eprintln!("wrote {}", a.out.display());
    }
    Ok(())
}
