//! `sism study`: the flags and what is printed; the study itself is [`sism::study`]'s (one frame
//! counted once, re-timed on many machines, in this process or as a Slurm job array).

mod slurm;

pub(super) use slurm::{prepare_and_submit, JobArgs};

use std::path::PathBuf;

use anyhow::Context;

use sism::machine;
use sism::machine::sweep::{self, SweepAxes};
use sism::render::{self, RenderOptions};
use sism::study::{self as studies, Label};

use super::{algorithm, algorithm_values, create_dir, parse_list, print_stdout, ParamArgs, SceneArgs};

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct Args {
    #[command(subcommand)]
    action: Option<Action>,
    #[command(flatten)]
    sweep: SweepArgs,
}

#[derive(clap::Subcommand)]
enum Action {
    /// Replay one array task's points of a study directory (what each Slurm array task runs; also
    /// to debug a task by hand); writes results/task-K.json.
    Run(slurm::RunArgs),
    /// Merge a study directory's results into study.csv, speedup.png and phases.png; report missing
    /// or failed points with their task's log; --watch waits for the array, --resubmit reruns the
    /// missing tasks.
    Collect(slurm::CollectArgs),
    /// Submit a study directory's job array with sbatch (--missing: only the tasks without results).
    Submit(slurm::SubmitArgs),
}

#[derive(clap::Args)]
struct SweepArgs {
    /// Scene file (TOML: see the README's "Scene files").
    scene: Option<PathBuf>,
    /// Override the scene's image width, pixels.
    #[arg(long)]
    width: Option<u32>,
    /// Override the scene's image height, pixels.
    #[arg(long)]
    height: Option<u32>,
    /// Core counts, comma-separated (default 1,2,4,8,16,24,32,48,64; with --one-at-a-time none).
    #[arg(long)]
    cores: Option<String>,
    /// Hardware threads per core, comma-separated (default: the base machine's).
    #[arg(long)]
    threads: Option<String>,
    /// L2 subset sizes per core in KB, comma-separated (default: the base machine's).
    #[arg(long)]
    l2_kb: Option<String>,
    /// Any other machine-file parameter and its values, `KEY=V1,V2,...` (repeatable): e.g.
    /// `--set dram_bandwidth_gbs=64,128,256 --set ring_bytes_per_clock=32,64`. Keys and ranges as in
    /// the machine file (a bad key is refused with the valid ones).
    #[arg(long = "set", value_name = "KEY=V1,V2")]
    set: Vec<String>,
    /// Vary one axis at a time around the base machine (the base, then each value of each axis
    /// alone) instead of every combination. `--cores` then defaults to none.
    #[arg(long)]
    one_at_a_time: bool,
    /// The base machine: a preset or a machine TOML file.
    #[arg(long, default_value = "larrabee-24")]
    machine: String,
    /// Algorithm (one that runs on the simd kernels).
    #[arg(long, default_value = "sism", value_parser = algorithm_values(true))]
    algo: String,
    #[command(flatten)]
    params: ParamArgs,
    /// Output folder (created if missing); with `--backend slurm`, the study directory.
    #[arg(long, default_value = "out/study")]
    out: PathBuf,
    /// Where the replays run: `local` (this process) or `slurm` (a job array; see `study collect`).
    #[arg(long, value_enum, default_value_t = Backend::Local)]
    backend: Backend,
    #[command(flatten)]
    slurm: slurm::JobArgs,
    /// No progress bar and no table.
    #[arg(long)]
    quiet: bool,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Backend {
    Local,
    Slurm,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    match (a.action, a.sweep) {
        (Some(Action::Run(r)), _) => slurm::run_task(r),
        (Some(Action::Collect(c)), _) => slurm::collect(c),
        (Some(Action::Submit(s)), _) => slurm::submit_cmd(s),
        (None, s) => sweep_cmd(s),
    }
}

/// The scene's frame counted once (its records, canonical) and the plots' label.
pub(super) fn counted_frame(
    scene: &sism::Scene,
    algo: &'static sism::Algorithm,
    params: &sism::Params,
    quiet: bool,
) -> (machine::CanonicalRecords, Label) {
    let frame = render::render(
        scene,
        algo,
        params,
        &RenderOptions {
            exec: sism::exec::Exec::Counting,
            progress: !quiet,
        },
    );
    let records = machine::canonical(&frame.records);
    drop(frame);
    let label = Label {
        name: scene
            .source
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        width: scene.camera.width,
        height: scene.camera.height,
    };
    (records, label)
}

fn sweep_cmd(a: SweepArgs) -> anyhow::Result<()> {
    if a.backend == Backend::Local {
        a.slurm.reject_for_local()?;
        sism::study::slurm::refuse_for_local(&a.out)?;
    }
    let Some(scene_path) = a.scene.clone() else {
        anyhow::bail!(
            "study: give a scene (`sism study SCENE ...`) or an action (`sism study run|collect|submit DIR`)"
        )
    };
    let scene_args = SceneArgs {
        scene: scene_path,
        width: a.width,
        height: a.height,
    };
    let scene = scene_args.load()?;
    let algo = algorithm(&a.algo)?;
    let params = a.params.resolve(algo)?;
    let base = super::resolve_machine(&a.machine).context("--machine")?;
    let default_cores = if a.one_at_a_time {
        ""
    } else {
        "1,2,4,8,16,24,32,48,64"
    };
    let set = a
        .set
        .iter()
        .map(|s| sism::machine::params::parse_set(s))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    if let Some(dup) = set
        .iter()
        .enumerate()
        .find(|(i, (p, _))| set[..*i].iter().any(|(q, _)| q.name == p.name))
    {
        anyhow::bail!("--set {}: given twice", dup.1 .0.name);
    }
    if let Some((p, _)) = set
        .iter()
        .find(|(p, _)| ["cores", "threads_per_core", "l2_kb"].contains(&p.name))
    {
        anyhow::bail!("--set {}: use --cores, --threads or --l2-kb for it", p.name);
    }
    let cores_text = a.cores.as_deref().unwrap_or(default_cores);
    let axes = SweepAxes {
        cores: if cores_text.is_empty() {
            Vec::new()
        } else {
            parse_list("--cores", cores_text)?
        },
        threads: a
            .threads
            .as_deref()
            .map(|s| parse_list("--threads", s))
            .transpose()?
            .unwrap_or_default(),
        l2_kb: a
            .l2_kb
            .as_deref()
            .map(|s| parse_list("--l2-kb", s))
            .transpose()?
            .unwrap_or_default(),
        set,
        one_at_a_time: a.one_at_a_time,
    };
    let set_keys = axes.set_keys();
    let configs = sweep::configurations(&base, &axes).map_err(|e| anyhow::anyhow!("{e}"))?;
    a.slurm.options().check()?;
    let out = create_dir(&a.out)?;
    let (records, label) = counted_frame(&scene, algo, &params, a.quiet);
    if a.backend == Backend::Slurm {
        let study = sism::study::slurm::Study {
            scene: &scene_args.scene,
            label: &label,
            algorithm: algo.name,
            params: &params.describe(),
            machine: &a.machine,
            base: &base,
            configs: &configs,
            set_keys: &set_keys,
            records: &records,
            sensitivity_factor: None,
        };
        return slurm::prepare_and_submit(&out, &study, &a.slurm, a.quiet);
    }
    machine::save_records(&out.join("records.bin"), &records)?;
    machine::write_config(&out, &base)?;
    let bar = sism::progress::bar(configs.len() as u64, "simulating", !a.quiet);
    let points = studies::run_local(&records, &configs, &set_keys, || bar.inc(1));
    bar.finish_and_clear();
    studies::write_outputs(&out, &label, &base, &points, &|p| Ok(configs[p.index].clone()))?;
    if !a.quiet {
        print_stdout(&studies::table(&points))?;
        note!("wrote {}", out.display());
    }
    Ok(())
}
