//! `sism sensitivity`: the flags and what is printed; the analysis is
//! [`sism::study::sensitivity`]'s.

use std::path::PathBuf;

use anyhow::Context;

use sism::study::sensitivity;

use super::{algorithm, algorithm_values, create_dir, print_stdout, ParamArgs, SceneArgs};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// The base machine: a preset or a machine TOML file.
    #[arg(long, default_value = "larrabee-24")]
    machine: String,
    /// Each parameter is divided and multiplied by this factor (in (1, 1000]; integers are rounded
    /// and move by at least one).
    #[arg(long, default_value_t = 2.0)]
    factor: f64,
    /// Algorithm (one that runs on the simd kernels).
    #[arg(long, default_value = "sism", value_parser = algorithm_values(true))]
    algo: String,
    #[command(flatten)]
    params: ParamArgs,
    /// Output folder (created if missing); with `--backend slurm`, the study directory.
    #[arg(long, default_value = "out/sensitivity")]
    out: PathBuf,
    /// Where the replays run: `local` (this process) or `slurm` (a job array: `sism study collect
    /// DIR` then writes the analysis, as here).
    #[arg(long, value_enum, default_value_t = super::study::Backend::Local)]
    backend: super::study::Backend,
    #[command(flatten)]
    slurm: super::study::JobArgs,
    /// No progress bar and no table.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let base = super::resolve_machine(&a.machine).context("--machine")?;
    let plan = sensitivity::plan(&base, a.factor)?;
    let scene = a.scene.load()?;
    let algo = algorithm(&a.algo)?;
    sism::algorithms::ensure_kernels(algo, "sensitivity")?;
    let params = a.params.resolve(algo)?;
    if a.backend == super::study::Backend::Local {
        a.slurm.reject_for_local()?;
        sism::study::slurm::refuse_for_local(&a.out)?;
    }
    a.slurm.options().check()?;
    let out = create_dir(&a.out)?;
    let (records, label) = super::study::counted_frame(&scene, algo, &params, a.quiet);
    if a.backend == super::study::Backend::Slurm {
        let study = sism::study::slurm::Study {
            scene: &a.scene.scene,
            label: &label,
            algorithm: algo.name,
            params: &params.describe(),
            machine: &a.machine,
            base: &base,
            configs: &plan.configs,
            set_keys: &[],
            records: &records,
            sensitivity_factor: Some(a.factor),
        };
        return super::study::prepare_and_submit(&out, &study, &a.slurm, a.quiet);
    }
    let bar = sism::progress::bar(plan.configs.len() as u64, "simulating", !a.quiet);
    let s = sensitivity::run_local(&records, &plan, || bar.inc(1))?;
    bar.finish_and_clear();
    sensitivity::write_outputs(&out, &label, &s)?;
    if !a.quiet {
        print_stdout(&sensitivity::table(&s))?;
        print_stdout(sensitivity::verdict(&s).trim_end())?;
        note!("wrote {}", out.display());
    }
    Ok(())
}
