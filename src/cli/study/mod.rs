//! `sism study`: one frame counted once, re-timed on many machines; the table, `study.csv` and the
//! plots `speedup.png` and `phases.png`.
//!
//! Two backends share everything but where the replays run: `local` (the default) replays every
//! point in this process; `slurm` writes the sweep to a study directory (manifest, records, one
//! machine file per point, a job-array script; see [`slurm`]) and submits it with `sbatch`. Each array
//! task (`sism study run DIR --task K`) replays its points with the same code and writes its results;
//! `sism study collect DIR` merges them. Both backends end in [`write_outputs`], from [`Point`]s.

mod plots;
mod slurm;

use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::{Deserialize, Serialize};

use sism::machine::sweep::{self, SweepAxes, SweepPoint};
use sism::machine::PhaseReport;
use sism::machine::{self, MachineConfig};
use sism::render::{self, RenderOptions};

use super::{
    algorithm, algorithm_values, create_dir, parse_list, print_stdout, write_file, ParamArgs, SceneArgs,
};

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
    /// Core counts, comma-separated.
    #[arg(long, default_value = "1,2,4,8,16,24,32,48,64")]
    cores: String,
    /// Hardware threads per core, comma-separated (default: the base machine's).
    #[arg(long)]
    threads: Option<String>,
    /// L2 subset sizes per core in KB, comma-separated (default: the base machine's).
    #[arg(long)]
    l2_kb: Option<String>,
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
enum Backend {
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

fn sweep_cmd(a: SweepArgs) -> anyhow::Result<()> {
    if a.backend == Backend::Local {
        a.slurm.reject_for_local()?;
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
    let base = MachineConfig::resolve(&a.machine).context("--machine")?;
    let axes = SweepAxes {
        cores: parse_list("--cores", &a.cores)?,
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
    };
    let configs = sweep::configurations(&base, &axes).map_err(|e| anyhow::anyhow!("{e}"))?;
    a.slurm.check(configs.len())?;
    let out = create_dir(&a.out)?;
    let frame = render::render(
        &scene,
        algo,
        &params,
        &RenderOptions {
            exec: sism::exec::Exec::Counting,
            progress: !a.quiet,
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
    if a.backend == Backend::Slurm {
        let study = slurm::Study {
            scene: &scene_args.scene,
            label: &label,
            algorithm: algo.name,
            params: &params.describe(),
            machine: &a.machine,
            base: &base,
            configs: &configs,
            records: &records,
        };
        return slurm::prepare_and_submit(&out, &study, &a.slurm, a.quiet);
    }
    machine::save_records(&out.join("records.bin"), &records)?;
    machine::write_config(&out, &base)?;
    let bar = sism::progress::bar(configs.len() as u64, "simulating", !a.quiet);
    let points = sweep::run(&records, &configs, || bar.inc(1));
    bar.finish_and_clear();
    let points: Vec<Point> = points.iter().enumerate().map(|(i, p)| Point::new(i, p)).collect();
    write_outputs(&out, &label, &base, &points, a.quiet)
}

/// What the plots' titles name: the scene (its file's stem) and the image size.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Label {
    pub name: String,
    pub width: u32,
    pub height: u32,
}

/// One simulated configuration as the study's outputs need it: what `study.csv`, the plots and the
/// table read, and what a Slurm array task writes to its result file (floats round-trip exactly
/// through JSON, so a point read back writes the same bytes as the point computed).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Point {
    /// Position in the sweep (the manifest's point index).
    pub index: usize,
    /// The configuration's name (`<base>-c<cores>-t<threads>-l2<kb>`).
    pub name: String,
    pub cores: u32,
    pub threads: u32,
    pub l2_kb: u32,
    pub clock_ghz: f64,
    /// One row per step, in frame order.
    pub steps: Vec<Row>,
    /// One row per phase (its steps' group), in frame order.
    pub groups: Vec<Row>,
    /// The frame's totals.
    pub frame: Row,
}

/// One step, phase or frame of a [`Point`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Row {
    pub phase: String,
    pub tasks: u64,
    pub cycles: u64,
    pub ms: f64,
    pub stack: Stack,
    pub lane_utilisation: f64,
    pub l1_miss_rate: f64,
    pub l2_miss_rate: f64,
    pub bytes_dram: u64,
}

/// A row's cycle stack (as [`sism::machine::CycleStack`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stack {
    pub issue: u64,
    pub memory: u64,
    pub atomics_sync: u64,
    pub imbalance_idle: u64,
}

impl Stack {
    /// Part names and values, in order.
    pub fn parts(&self) -> [(&'static str, u64); 4] {
        [
            ("issue", self.issue),
            ("memory", self.memory),
            ("atomics_sync", self.atomics_sync),
            ("imbalance_idle", self.imbalance_idle),
        ]
    }
}

impl Point {
    /// The point at `index` of a sweep.
    pub fn new(index: usize, p: &SweepPoint) -> Point {
        let r = &p.report;
        let line = r.config.line_bytes;
        let row = |ph: &PhaseReport| Row {
            phase: ph.phase.clone(),
            tasks: ph.tasks,
            cycles: ph.cycles,
            ms: ph.ms,
            stack: Stack {
                issue: ph.stack.issue,
                memory: ph.stack.memory,
                atomics_sync: ph.stack.atomics_sync,
                imbalance_idle: ph.stack.imbalance_idle,
            },
            lane_utilisation: ph.lane_utilisation(),
            l1_miss_rate: ph.memory.l1_miss_rate(),
            l2_miss_rate: ph.memory.l2_miss_rate(),
            bytes_dram: ph.memory.dram_bytes(line),
        };
        Point {
            index,
            name: r.config.name.clone(),
            cores: p.cores,
            threads: p.threads,
            l2_kb: p.l2_kb,
            clock_ghz: r.config.clock_ghz,
            steps: r.phases.iter().map(row).collect(),
            groups: r.groups.iter().map(row).collect(),
            frame: row(&r.frame),
        }
    }
}

/// Frame speedup of `p` over the smallest core count with the same threads and L2 size.
pub fn speedup(points: &[Point], p: &Point) -> f64 {
    let base = points
        .iter()
        .filter(|q| q.threads == p.threads && q.l2_kb == p.l2_kb)
        .min_by_key(|q| q.cores)
        .unwrap_or(p);
    base.frame.cycles as f64 / p.frame.cycles.max(1) as f64
}

/// The study's outputs in `out`, whichever backend computed `points` (in sweep order): `study.csv`,
/// `speedup.png`, `phases.png` (of the base machine's point) and, unless `quiet`, the table.
pub fn write_outputs(
    out: &Path,
    label: &Label,
    base: &MachineConfig,
    points: &[Point],
    quiet: bool,
) -> anyhow::Result<()> {
    write_csv(&out.join("study.csv"), points)?;
    plots::speedup(&out.join("speedup.png"), label, points)?;
    let table_point = points
        .iter()
        .find(|p| p.cores == base.cores && p.threads == base.threads_per_core && p.l2_kb == base.l2_kb)
        .or_else(|| points.iter().find(|p| p.cores == base.cores))
        .or(points.last())
        .context("the sweep has no point")?;
    plots::phases(&out.join("phases.png"), label, table_point)?;
    if !quiet {
        let mut s = String::from("cores threads l2_kb   frame_ms  speedup\n");
        for p in points {
            s += &format!(
                "{:>5} {:>7} {:>5} {:>10.3} {:>8.2}\n",
                p.cores,
                p.threads,
                p.l2_kb,
                p.frame.ms,
                speedup(points, p)
            );
        }
        print_stdout(s.trim_end())?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// `study.csv`: one row per configuration and step (plus `frame`).
fn write_csv(path: &Path, points: &[Point]) -> anyhow::Result<()> {
    let mut s = String::from(
        "cores,threads,l2_kb,phase,tasks,cycles,ms,stack_issue,stack_memory,stack_atomics_sync,\
         stack_imbalance_idle,lane_utilisation,l1_miss_rate,l2_miss_rate,bytes_dram,frame_speedup\n",
    );
    for p in points {
        let sp = speedup(points, p);
        for ph in p.steps.iter().chain(std::iter::once(&p.frame)) {
            s += &format!(
                "{},{},{},{},{},{},{:.6},{},{},{},{},{:.6},{:.6},{:.6},{},{:.6}\n",
                p.cores,
                p.threads,
                p.l2_kb,
                ph.phase,
                ph.tasks,
                ph.cycles,
                ph.ms,
                ph.stack.issue,
                ph.stack.memory,
                ph.stack.atomics_sync,
                ph.stack.imbalance_idle,
                ph.lane_utilisation,
                ph.l1_miss_rate,
                ph.l2_miss_rate,
                ph.bytes_dram,
                sp
            );
        }
    }
    write_file(path, &s)
}
