//! The commands layer: parses the command line, maps names to the library's types, prints, writes
//! the commands' files and draws their plots. The work itself is the library's.
//!
//! Exit codes: 0 on success (and for `--help`, `--version`), 1 for any error — a malformed command
//! line as much as bad input — with one `error:` message on stderr naming what and where.

/// `eprintln!` that cannot panic: a closed or full stderr loses the note, never the run (exit codes
/// stay 0 or 1).
macro_rules! note {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

/// `eprint!` that cannot panic (see [`note!`]).
macro_rules! note_inline {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stderr(), $($t)*);
    }};
}

mod algorithms;
mod bench;
mod calibrate;
mod compare;
mod progress;
mod render;
mod replay;
mod sensitivity;
mod study;
mod table2;
mod trace;
mod validate;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::{Parser, Subcommand};

use sism::algorithms::{Algorithm, Params};
use sism::scene::Scene;

#[derive(Parser)]
#[command(
    name = "sism",
    version,
    about = "Soft irregular shadow mapping and other soft-shadow methods on a modelled 16-wide SIMD \
many-core machine, with a ray-traced reference"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// Parsed once per run: the size of its largest variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Command {
    /// Render a scene's visibility and write visibility.pfm/png, shaded.png and stats.
    Render(render::Args),
    /// Re-time saved task records (records.bin from `render --machine` or `study`) on another machine
    /// without re-running kernels; writes stats.txt, stats.json and machine.toml.
    Replay(replay::Args),
    /// Simulate one frame on many machines: cores (and optionally threads per core and L2 sizes)
    /// vary around a base machine; writes study.csv, speedup.png, phases.png, records.bin, machine.toml.
    /// `--backend slurm` writes the sweep to a study directory and submits it as a Slurm job array;
    /// `study run|collect|submit DIR` run a task, merge the results, (re)submit.
    Study(study::Args),
    /// Which machine parameter moves the frame: one counted frame replayed on the base machine and
    /// with each parameter that applies halved and doubled (`--factor`); ranks them for the frame and
    /// each phase and says what limits the frame; writes sensitivity.csv, sensitivity.md and a
    /// tornado chart, sensitivity.png.
    Sensitivity(sensitivity::Args),
    /// Compare a visibility image with a reference: MAE, RMSE, p99, share of |error| > 0.1, penumbra MAE.
    Compare(compare::Args),
    /// Time against error: a high-spp truth, then every registered algorithm (the reference's spp
    /// sweep included), each timed (median of --repeats) and scored against the truth; writes
    /// bench.csv, bench.json, bench.png (the time-error front drawn) and pareto.md; `--machine`
    /// adds one simulated frame per candidate. Also called `compare-all`.
    #[command(alias = "compare-all")]
    Bench(bench::Args),
    /// List the registered algorithms with their parameters (--markdown: the README's table).
    Algorithms(algorithms::Args),
    /// The SISM paper's Table 2: per workload (default scenes/table2) a frame timed on the modelled
    /// chip, phases grouped as the paper does (data structures, hard and soft shadow kernels), shares
    /// and frame rate beside the published numbers; writes table2.csv and table2.md.
    Table2(table2::Args),
    /// Frame traces: `trace make orbit|walk|light-sweep SCENE` writes one; `trace run TRACE` renders
    /// every frame (natively or with --machine), with per-frame CSV, error and flicker against a
    /// reference run, and a plot.
    Trace(trace::Args),
    /// Fit the `host` machine preset's per-class costs to microbenchmarks run on this CPU (arithmetic,
    /// gathers and scatters, atomics, streaming loads per cache level, task start and join); writes
    /// the fitted machine file (TOML) with the evidence as comments.
    Calibrate(calibrate::Args),
    /// The machine model against the host: each scene rendered natively (1 and all host threads) and
    /// counted, its records replayed on the host's model (`--machine`, e.g. from `sism calibrate`);
    /// predicted against measured ms per phase and frame; writes validate.csv, validate.md and
    /// validate.png.
    Validate(validate::Args),
}

/// Runs the command line; the process's exit code.
pub fn main() -> ExitCode {
    progress::install();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            let code = match e.kind() {
                ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => ExitCode::SUCCESS,
                _ => ExitCode::FAILURE,
            };
            // Clap's own rendering: usage, the offending argument, suggestions.
            let _ = e.print();
            return code;
        }
    };
    let result = match cli.command {
        Command::Render(a) => render::run(a),
        Command::Replay(a) => replay::run(a),
        Command::Study(a) => study::run(a),
        Command::Sensitivity(a) => sensitivity::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Algorithms(a) => algorithms::run(a),
        Command::Table2(a) => table2::run(a),
        Command::Trace(a) => trace::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Validate(a) => validate::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            note!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}

/// Prints `text` and a newline on stdout. A closed pipe (`sism compare ... | head`) is not an error:
/// the reader has what it wanted.
fn print_stdout(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|()| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(anyhow::anyhow!("cannot write to stdout: {e}")),
        Ok(()) => Ok(()),
    }
}

/// The scene a command renders, with the image-size overrides.
#[derive(clap::Args, Clone, Debug)]
struct SceneArgs {
    /// Scene file (TOML: see the README's "Scene files").
    scene: PathBuf,
    /// Override the scene's image width, pixels.
    #[arg(long)]
    width: Option<u32>,
    /// Override the scene's image height, pixels.
    #[arg(long)]
    height: Option<u32>,
}

impl SceneArgs {
    /// Loads the scene and applies `--width`/`--height`.
    fn load(&self) -> anyhow::Result<Scene> {
        let mut scene = Scene::load(&self.scene)?;
        if let Some(w) = self.width {
            scene.camera.width = w;
        }
        if let Some(h) = self.height {
            scene.camera.height = h;
        }
        if let Err((key, msg)) = scene.camera.validate() {
            anyhow::bail!("--width/--height: {} {msg}", key.replace("camera.", ""));
        }
        Ok(scene)
    }
}

/// `--algo`'s values: the registry's algorithms (only those on the simd kernels when `kernels_only`),
/// each with its one-line summary for `--help`.
fn algorithm_values(kernels_only: bool) -> PossibleValuesParser {
    PossibleValuesParser::new(
        sism::algorithms::REGISTRY
            .iter()
            .filter(|a| !kernels_only || a.kernels)
            .map(|a| PossibleValue::new(a.name).help(a.summary)),
    )
}

/// The registered algorithm `name` (already checked by [`algorithm_values`]).
fn algorithm(name: &str) -> anyhow::Result<&'static Algorithm> {
    sism::algorithms::find(name).ok_or_else(|| anyhow::anyhow!("--algo: unknown algorithm {name}"))
}

/// Options shared by the commands that render: the algorithm's parameters.
#[derive(clap::Args, Clone, Debug, Default)]
struct ParamArgs {
    /// An algorithm parameter, `key=value` (repeatable). `sism algorithms` lists every algorithm's
    /// parameters with their defaults and ranges.
    #[arg(long = "param", value_name = "KEY=VALUE")]
    params: Vec<String>,
    /// Shorthand for `--param spp=N` (light-disk samples per receiver of the ray-traced algorithms).
    #[arg(long)]
    spp: Option<String>,
    /// Shorthand for `--param seed=S` (seed of the ray-traced algorithms' jitter).
    #[arg(long)]
    seed: Option<String>,
}

impl ParamArgs {
    /// The parameters of `algo`: `--param` pairs, then the shorthands where `algo` declares them (a
    /// shorthand it does not declare is reported on stderr and ignored, so loops over algorithms can
    /// pass it to all).
    fn resolve(&self, algo: &Algorithm) -> anyhow::Result<Params> {
        let mut given = Vec::new();
        for p in &self.params {
            given.push(sism::algorithms::params::split_pair(p).map_err(|e| anyhow::anyhow!("--param {e}"))?);
        }
        for (key, value) in [("spp", &self.spp), ("seed", &self.seed)] {
            let Some(value) = value else { continue };
            if algo.param(key).is_some() {
                anyhow::ensure!(
                    !given.iter().any(|(k, _)| k == key),
                    "--{key} and --param {key}=... both given"
                );
                given.push((key.to_string(), value.clone()));
            } else {
                note!("note: --{key} does not apply to {}: ignored", algo.name);
            }
        }
        algo.params(&given).map_err(|e| anyhow::anyhow!("--param: {e}"))
    }
}

/// A comma-separated list of positive integers (`--cores 1,2,4`); empty entries are errors.
fn parse_list(flag: &str, s: &str) -> anyhow::Result<Vec<u32>> {
    s.split(',')
        .map(|t| {
            let t = t.trim();
            anyhow::ensure!(
                !t.is_empty(),
                "{flag} '{s}': empty entry (expected numbers separated by commas, e.g. 1,2,4)"
            );
            let v: u32 = t
                .parse()
                .map_err(|_| anyhow::anyhow!("{flag} '{s}': `{t}` is not a positive integer"))?;
            anyhow::ensure!(v > 0, "{flag} '{s}': values must be at least 1");
            Ok(v)
        })
        .collect()
}

/// `--machine`'s value: a preset (`host` probed once, here at the edge) or a machine file.
fn resolve_machine(name: &str) -> anyhow::Result<sism::machine::MachineConfig> {
    Ok(sism::host::resolve_machine(name)?)
}

/// Creates `dir` (and its parents), with an error naming it.
fn create_dir(dir: &Path) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow::anyhow!("cannot create output folder {}: {e}", dir.display()))?;
    Ok(dir.to_path_buf())
}

/// Writes `text` to `path`, with an error naming it.
fn write_file(path: &Path, text: &str) -> anyhow::Result<()> {
    Ok(sism::output::write_atomic(path, text.as_bytes())?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_parse_and_reject_empty_entries() {
        assert_eq!(parse_list("--cores", "1, 2,4").unwrap(), vec![1, 2, 4]);
        for bad in ["", "1,,2", "1,x", "0", "-1"] {
            assert!(
                parse_list("--cores", bad)
                    .unwrap_err()
                    .to_string()
                    .contains("--cores"),
                "{bad}"
            );
        }
    }
}
