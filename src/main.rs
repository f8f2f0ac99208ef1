//! The `sism` command line. Parsing lives here; the work lives in the library.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};

use sism::metrics;
use sism::output::{pfm, pictures};
use sism::reference::ReferenceOptions;
use sism::render::{self, Algorithm};
use sism::scene::Scene;

#[derive(Parser)]
#[command(
    name = "sism",
    version,
    about = "Soft irregular shadow mapping on a modelled 16-wide SIMD many-core machine"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene's visibility and write visibility.pfm/png, shaded.png and stats.
    Render {
        /// Scene file (TOML, see CONTRACTS.md and README).
        scene: PathBuf,
        /// Algorithm.
        #[arg(long, value_enum, default_value = "reference")]
        algo: Algorithm,
        /// Output folder (created if missing).
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Light-disk samples per receiver for the reference, 1..=65536.
        #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=65536))]
        spp: u32,
        /// Seed of the reference's sample jitter.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Override the scene's image width, pixels.
        #[arg(long)]
        width: Option<u32>,
        /// Override the scene's image height, pixels.
        #[arg(long)]
        height: Option<u32>,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Compare a visibility image with a reference: MAE, RMSE, p99, share of |error| > 0.1, penumbra MAE.
    Compare {
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
    },
    /// Time against error: a high-spp truth, then the reference's spp sweep and SISM, each timed
    /// (median of --repeats) and scored against the truth; writes bench.csv, bench.json, bench.png.
    Bench {
        /// Scene file (TOML, see CONTRACTS.md and README).
        scene: PathBuf,
        /// Output folder (created if missing).
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
        /// The reference's spp sweep, comma-separated, each 1..=65536.
        #[arg(long, default_value = "4,16,64,256")]
        spp_list: String,
        /// Light-disk samples per receiver of the truth render.
        #[arg(long, default_value_t = 1024)]
        truth_spp: u32,
        /// Score against this visibility PFM instead of rendering a truth.
        #[arg(long)]
        truth: Option<PathBuf>,
        /// Override the scene's image width, pixels.
        #[arg(long)]
        width: Option<u32>,
        /// Override the scene's image height, pixels.
        #[arg(long)]
        height: Option<u32>,
        /// Timed runs per configuration; the median is reported.
        #[arg(long, default_value_t = 3)]
        repeats: u32,
        /// No progress bars.
        #[arg(long)]
        quiet: bool,
    },
}

/// mimalloc keeps freed pages for reuse: the frame's large buffers (tens of MB each) would otherwise
/// be returned to the OS and page-faulted in again by the next phase.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}

/// Prints `text` and a newline on stdout. A closed pipe (`sism compare ... | head`) is not an error:
/// the reader has what it wanted.
fn print_stdout(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    match writeln!(std::io::stdout().lock(), "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render {
            scene,
            algo,
            out,
            spp,
            seed,
            width,
            height,
            quiet,
        } => {
            let mut scene = Scene::load(&scene)?;
            if let Some(w) = width {
                scene.camera.width = w;
            }
            if let Some(h) = height {
                scene.camera.height = h;
            }
            if let Err((key, msg)) = scene.camera.validate() {
                anyhow::bail!("--width/--height: {} {msg}", key.replace("camera.", ""));
            }
            let options = ReferenceOptions {
                spp,
                seed,
                progress: !quiet,
                ..Default::default()
            };
            let result = render::render(&scene, algo, &options);
            render::write_outputs(&out, &scene, &result)?;
            if !quiet {
                eprint!("{}", result.stats.to_text());
                eprintln!("wrote {}", out.display());
            }
            Ok(())
        }
        Command::Compare {
            reference,
            test,
            heatmap,
            heatmap_scale,
            json,
        } => {
            let r = pfm::read_pfm(&reference)?;
            let t = pfm::read_pfm(&test)?;
            let report = metrics::compare(&r, &t)
                .with_context(|| format!("comparing {} with {}", test.display(), reference.display()))?;
            if json {
                print_stdout(&serde_json::to_string_pretty(&report)?)?;
            } else {
                print_stdout(&report.to_string())?;
            }
            if let Some(path) = heatmap {
                anyhow::ensure!(
                    heatmap_scale > 0.0 && heatmap_scale.is_finite(),
                    "--heatmap-scale must be > 0"
                );
                let errors = metrics::abs_error_map(&r, &t)?;
                pictures::write_error_heatmap(&path, r.width, r.height, &errors, heatmap_scale)?;
            }
            Ok(())
        }
        Command::Bench {
            scene,
            out,
            spp_list,
            truth_spp,
            truth,
            width,
            height,
            repeats,
            quiet,
        } => {
            let options = sism::bench_cmd::BenchOptions {
                out,
                spp_list: sism::bench_cmd::parse_spp_list(&spp_list)?,
                truth_spp,
                truth,
                width,
                height,
                repeats,
                progress: !quiet,
            };
            let report = sism::bench_cmd::bench(&scene, &options)?;
            print_stdout(sism::bench_cmd::to_table(&report).trim_end())?;
            if !quiet {
                eprintln!("wrote {}", options.out.display());
            }
            Ok(())
        }
    }
}
