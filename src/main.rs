//! The `sism` command line. Parsing lives here; the work lives in the library.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};

use sism::machine::MachineConfig;
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
        /// Time the SISM frame on a modelled many-core chip: a preset (larrabee-8/16/24/32/48/64) or a
        /// machine TOML file. Runs the kernels under the counting context and also writes machine.toml
        /// and records.bin (for `sism replay`); needs --algo sism, sism-independent or sism-sampled.
        #[arg(long)]
        machine: Option<String>,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Re-time saved task records (records.bin from `render --machine` or `study`) on another machine
    /// without re-running kernels; writes stats.txt, stats.json and machine.toml.
    Replay {
        /// Records file.
        records: PathBuf,
        /// A preset (larrabee-8/16/24/32/48/64) or a machine TOML file.
        #[arg(long, default_value = "larrabee-24")]
        machine: String,
        /// Output folder (created if missing).
        #[arg(long, default_value = "out/replay")]
        out: PathBuf,
        /// Print nothing.
        #[arg(long)]
        quiet: bool,
    },
    /// Simulate one SISM frame on many machines: cores (and optionally threads per core and L2 sizes)
    /// vary around a base machine; writes study.csv, speedup.png, phases.png, records.bin, machine.toml.
    Study {
        /// Scene file (TOML, see CONTRACTS.md and README).
        scene: PathBuf,
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
        /// Algorithm (sism, sism-independent or sism-sampled).
        #[arg(long, value_enum, default_value = "sism")]
        algo: Algorithm,
        /// Output folder (created if missing).
        #[arg(long, default_value = "out/study")]
        out: PathBuf,
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
/// be returned to the OS and page-faulted in again by the next phase. `LineAlloc` around it makes
/// counted frames repeatable (line-aligned blocks, no reuse within a counted frame).
#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<mimalloc::MiMalloc> = sism_simd::LineAlloc(mimalloc::MiMalloc);

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

/// Loads a scene and applies --width/--height.
fn load_scene(path: &std::path::Path, width: Option<u32>, height: Option<u32>) -> anyhow::Result<Scene> {
    let mut scene = Scene::load(path)?;
    if let Some(w) = width {
        scene.camera.width = w;
    }
    if let Some(h) = height {
        scene.camera.height = h;
    }
    if let Err((key, msg)) = scene.camera.validate() {
        anyhow::bail!("--width/--height: {} {msg}", key.replace("camera.", ""));
    }
    Ok(scene)
}

/// The SISM composition of `algo`; the machine model times SISM only.
fn composition_of(algo: Algorithm) -> anyhow::Result<sism::sism::Composition> {
    match algo.composition() {
        Some(c) => Ok(c),
        None => anyhow::bail!(
            "--machine times SISM's kernels: use --algo sism, sism-independent or sism-sampled, not {}",
            algo.name()
        ),
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
            machine,
            quiet,
        } => {
            let scene = load_scene(&scene, width, height)?;
            if let Some(machine) = machine {
                let config = MachineConfig::resolve(&machine).context("--machine")?;
                let composition = composition_of(algo)?;
                let r = sism::machine::run::render_on_machine(&scene, composition, &config);
                render::write_outputs(&out, &scene, &r.result)?;
                sism::machine::write_config(&out, &config)?;
                sism::machine::save_records(&out.join("records.bin"), &r.records)?;
                if !quiet {
                    eprint!("{}", r.result.stats.to_text());
                    eprint!("{}", r.report.to_table());
                    eprintln!("wrote {}", out.display());
                }
                return Ok(());
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
        Command::Replay {
            records,
            machine,
            out,
            quiet,
        } => {
            let config = MachineConfig::resolve(&machine).context("--machine")?;
            let report = sism::machine::run::replay(&records, &config, &out)?;
            if !quiet {
                print_stdout(report.to_table().trim_end())?;
                eprintln!("wrote {}", out.display());
            }
            Ok(())
        }
        Command::Study {
            scene,
            cores,
            threads,
            l2_kb,
            machine,
            algo,
            out,
            width,
            height,
            quiet,
        } => {
            use sism::machine::run::{parse_list, study, StudyOptions};
            let scene = load_scene(&scene, width, height)?;
            let options = StudyOptions {
                out,
                base: MachineConfig::resolve(&machine).context("--machine")?,
                cores: parse_list("--cores", &cores)?,
                threads: threads
                    .map(|s| parse_list("--threads", &s))
                    .transpose()?
                    .unwrap_or_default(),
                l2_kb: l2_kb
                    .map(|s| parse_list("--l2-kb", &s))
                    .transpose()?
                    .unwrap_or_default(),
                composition: composition_of(algo)?,
                progress: !quiet,
            };
            let points = study(&scene, &options)?;
            if !quiet {
                let mut s = String::from("cores threads l2_kb   frame_ms  speedup\n");
                for p in &points {
                    s += &format!(
                        "{:>5} {:>7} {:>5} {:>10.3} {:>8.2}\n",
                        p.cores,
                        p.threads,
                        p.l2_kb,
                        p.report.frame.ms,
                        sism::machine::run::speedup(&points, p)
                    );
                }
                print_stdout(s.trim_end())?;
                eprintln!("wrote {}", options.out.display());
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
