//! `sism trace`: make a frame trace (orbit, walk-through, light sweep) or render one, frame by frame,
//! natively or on the modelled chip, with per-frame times, counters, error and flicker.

use std::path::{Path, PathBuf};

use anyhow::Context;

use sism::scene::Scene;
use sism::trace::{self, run};

use super::{algorithm, algorithm_values, write_file, ParamArgs};

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand)]
enum Command {
    /// Write a trace over a scene: `orbit` (the camera turns about the look-at point), `walk` (the
    /// camera moves along its view direction) or `light-sweep` (the light turns about the look-at
    /// point).
    Make(MakeArgs),
    /// Render every frame of a trace: visibility PFMs (frame_NNNN.pfm), frames.csv (per frame: host
    /// ms, simulated ms with --machine, receivers, error and flicker with --reference), summary.txt
    /// and frames.png.
    Run(RunArgs),
}

#[derive(clap::Args)]
struct MakeArgs {
    #[arg(value_parser = ["orbit", "walk", "light-sweep"])]
    kind: String,
    /// Scene file the trace moves through.
    scene: PathBuf,
    /// Frames, 2..=10000.
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(2..=10000))]
    frames: u32,
    /// Orbit and light sweep: degrees turned over the trace. Walk: share of the eye's distance to the
    /// look-at point travelled.
    #[arg(long, default_value_t = 30.0)]
    amount: f32,
    /// The trace file to write.
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Args)]
struct RunArgs {
    /// The trace file.
    trace: PathBuf,
    /// Algorithm (see `sism algorithms`).
    #[arg(long, default_value = "sism", value_parser = algorithm_values(false))]
    algo: String,
    #[command(flatten)]
    params: ParamArgs,
    /// Override the image width, pixels.
    #[arg(long)]
    width: Option<u32>,
    /// Override the image height, pixels.
    #[arg(long)]
    height: Option<u32>,
    /// Also time every frame on this modelled chip (counted frames: slower).
    #[arg(long)]
    machine: Option<String>,
    /// A folder of an earlier `trace run` of the same trace (the reference, say): per-frame error
    /// against its frames and flicker against its frame-to-frame change.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Output folder.
    #[arg(long, default_value = "out/trace")]
    out: PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    match a.command {
        Command::Make(m) => make(m),
        Command::Run(r) => run_trace(r),
    }
}

fn make(a: MakeArgs) -> anyhow::Result<()> {
    anyhow::ensure!(a.amount.is_finite(), "--amount must be finite");
    let scene = Scene::load(&a.scene)?;
    // The trace names its scene relative to its own folder when it can.
    let dir = a
        .out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let scene_path = run::relative_to(&a.scene, dir);
    let n = a.frames as usize;
    let t = match a.kind.as_str() {
        "orbit" => trace::orbit(&scene_path, &scene, n, a.amount),
        "walk" => trace::walk(&scene_path, &scene, n, a.amount),
        _ => trace::light_sweep(&scene_path, &scene, n, a.amount),
    };
    // What is written must run: every frame renderable, and the text reading back as these frames.
    trace::check(&t, &scene).map_err(|e| {
        anyhow::anyhow!(
            "the {} trace cannot be written: {e} (--amount {} is too large for this scene?)",
            a.kind,
            a.amount
        )
    })?;
    let text = trace::write(&t).map_err(|e| anyhow::anyhow!("{} cannot be written: {e}", a.out.display()))?;
    let back = trace::parse_over(&text, &a.out, &scene)?;
    anyhow::ensure!(
        back == t,
        "{}: the trace does not read back as written (a bug: please report it)",
        a.out.display()
    );
    write_file(&a.out, &text)?;
    note!("wrote {} ({} frames)", a.out.display(), t.frames.len());
    Ok(())
}

fn run_trace(a: RunArgs) -> anyhow::Result<()> {
    let (t, base) = run::load(&a.trace, a.width, a.height)?;
    let algo = algorithm(&a.algo)?;
    let params = a.params.resolve(algo)?;
    let config = a
        .machine
        .as_deref()
        .map(super::resolve_machine)
        .transpose()
        .context("--machine")?;
    let result = run::run(
        &a.trace,
        &t,
        &base,
        &run::RunOptions {
            algorithm: algo,
            params: &params,
            machine: config.as_ref(),
            reference: a.reference.as_deref(),
            out: &a.out,
            progress: !a.quiet,
        },
    )?;
    if !a.quiet {
        note_inline!("{}", result.summary);
        note!("wrote {}", a.out.display());
    }
    Ok(())
}
