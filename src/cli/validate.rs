//! `sism validate`: the machine model's per-phase predictions against measured host times.

use std::path::PathBuf;

use anyhow::Context;

use sism::host::calibrate;
use sism::host::validate::{self, Row};
use sism::scene::Scene;

use super::{algorithm, create_dir, parse_list, print_stdout, write_file, ParamArgs};

#[derive(clap::Args)]
pub struct Args {
    /// Scene files (TOML), one or more.
    #[arg(required = true)]
    scenes: Vec<PathBuf>,
    /// Override every scene's image width, pixels.
    #[arg(long)]
    width: Option<u32>,
    /// Override every scene's image height, pixels.
    #[arg(long)]
    height: Option<u32>,
    /// The host's model: a machine file from `sism calibrate`, or the `host` preset (uncalibrated).
    #[arg(long, default_value = "host")]
    machine: String,
    /// Calibrate the host (as `sism calibrate`, about a minute) right before each scene and predict
    /// that scene with it, instead of one `--machine` for all: a shared host's speed moves with
    /// its other tenants over minutes, so the model and the frames are measured close together.
    /// Each fit is written to the output folder as `calibration-K-SCENE.toml`.
    #[arg(long, conflicts_with = "machine")]
    calibrate_per_scene: bool,
    /// With `--calibrate-per-scene`: passes over the benchmark list per calibration (1..=9; see
    /// `sism calibrate --rounds`).
    #[arg(long, default_value_t = calibrate::DEFAULT_ROUNDS, requires = "calibrate_per_scene")]
    calibration_rounds: usize,
    /// Algorithms, comma-separated (ones that run on the simd kernels).
    #[arg(long, default_value = "sism,sism-sampled")]
    algos: String,
    #[command(flatten)]
    params: ParamArgs,
    /// Host thread counts, comma-separated; `all` is every host thread.
    #[arg(long, default_value = "1,all")]
    threads: String,
    /// Native frames timed per configuration (the median is used), after one warm-up frame (1..=100).
    #[arg(long, default_value_t = 5)]
    frames: usize,
    /// Error counted as a hit in the summary (0.25 = ±25%).
    #[arg(long, default_value_t = 0.25)]
    tolerance: f64,
    /// Output folder: validate.csv, validate.md, validate.png.
    #[arg(long, default_value = "out/validate")]
    out: PathBuf,
    /// No progress and no table.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        (1..=100).contains(&a.frames),
        "--frames {}: must be 1..=100",
        a.frames
    );
    super::calibrate::check_rounds("--calibration-rounds", a.calibration_rounds)?;
    anyhow::ensure!(
        a.tolerance.is_finite() && a.tolerance > 0.0 && a.tolerance < 10.0,
        "--tolerance {}: must be in (0, 10)",
        a.tolerance
    );
    let model = super::resolve_machine(&a.machine).context("--machine")?;
    let all = std::thread::available_parallelism()
        .map(|n| n.get() as u32)
        .unwrap_or(1);
    let threads: Vec<u32> = a
        .threads
        .split(',')
        .map(|t| match t.trim() {
            "all" => Ok(vec![all]),
            t => parse_list("--threads", t),
        })
        .collect::<anyhow::Result<Vec<_>>>()?
        .into_iter()
        .flatten()
        .collect();
    for &t in &threads {
        anyhow::ensure!(t <= 4096, "--threads: {t} is more than 4096");
    }
    let mut algos = Vec::new();
    for name in a.algos.split(',').map(str::trim) {
        let algo = algorithm(name).with_context(|| format!("--algos {}", a.algos))?;
        anyhow::ensure!(
            algo.kernels,
            "--algos: {name} does not run on the simd kernels: the model has nothing to time"
        );
        algos.push((algo, a.params.resolve(algo)?));
    }
    let mut scenes = Vec::new();
    for path in &a.scenes {
        let mut scene = Scene::load(path)?;
        if let Some(w) = a.width {
            scene.camera.width = w;
        }
        if let Some(h) = a.height {
            scene.camera.height = h;
        }
        if let Err((key, msg)) = scene.camera.validate() {
            anyhow::bail!("--width/--height: {} {msg}", key.replace("camera.", ""));
        }
        scenes.push(scene);
    }
    let out = create_dir(&a.out)?;
    // The calibration's own measurements of the moment benchmarks, when the machine is a file
    // `sism calibrate` wrote (a preset has none).
    let mut evidence = std::path::Path::new(&a.machine)
        .is_file()
        .then(|| std::fs::read_to_string(&a.machine).ok())
        .flatten()
        .map(|t| calibrate::evidence_from_toml(&t))
        .unwrap_or_default();
    let per_scene = validate::progress_calls(algos.len(), threads.len(), a.frames);
    let calibrations = if a.calibrate_per_scene {
        scenes.len() as u64 * calibrate::calibrate_host_steps(a.calibration_rounds)
    } else {
        0
    };
    let bar = sism::progress::bar(
        scenes.len() as u64 * per_scene + 2 + calibrations,
        "validating",
        !a.quiet,
    );
    let mut model = model;
    let mut moment_start = None;
    let mut rows: Vec<Row> = Vec::new();
    for (k, scene) in scenes.iter().enumerate() {
        if a.calibrate_per_scene {
            let fitted = super::calibrate::calibrate_sound(a.calibration_rounds, &bar, "calibrating: ")
                .with_context(|| format!("calibrating before {}", scene.source.display()))?;
            let stem = scene
                .source
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "scene".into());
            let file = out.join(format!("calibration-{}-{stem}.toml", k + 1));
            let toml = super::calibrate::write_fit(&fitted, &file)?;
            if k == 0 {
                evidence = calibrate::evidence_from_toml(&toml);
            }
            // The model as the file reads back, so that `--machine FILE` predicts what this did.
            model = super::resolve_machine(&file.to_string_lossy())
                .with_context(|| format!("reading back {}", file.display()))?;
        }
        if moment_start.is_none() {
            bar.set_message("the host's moment (start)");
            moment_start = Some(calibrate::moment(&model));
            bar.inc(1);
        }
        rows.extend(validate::validate_scene(
            scene,
            &algos,
            &model,
            &threads,
            a.frames,
            &|what| {
                bar.set_message(what);
                bar.inc(1);
            },
        )?);
    }
    let moment_start = moment_start.unwrap_or_default();
    bar.set_message("the host's moment (end)");
    let moment_end = calibrate::moment(&model);
    bar.finish_and_clear();
    let md = format!(
        "Model `{}`{} against the host ({} GHz), {}×{} where given, backend {}; predicted / measured host ms \
         per major phase and per frame (a phase: its steps' work; the frame: the phases the model times); \
         a scene's algorithms' native frames timed interleaved, {} rounds after a warm-up.\n\n{}\n{}\n{}",
        model.name,
        if a.calibrate_per_scene {
            ", calibrated right before each scene (`calibration-K-SCENE.toml`)"
        } else {
            ""
        },
        model.clock_ghz,
        a.width.map(|w| w.to_string()).unwrap_or_else(|| "scene".into()),
        a.height.map(|h| h.to_string()).unwrap_or_else(|| "scene".into()),
        sism_simd::selected_backend().name(),
        a.frames,
        validate::moment_markdown(&evidence, &moment_start, &moment_end),
        validate::shared_work_markdown(&rows, a.tolerance),
        validate::markdown(&rows, a.tolerance)
    );
    write_file(&out.join("validate.csv"), &validate::csv(&rows))?;
    write_file(&out.join("validate.md"), &md)?;
    sism::output::plots::validate::predicted_vs_measured(&out.join("validate.png"), &rows, a.tolerance)?;
    if !a.quiet {
        print_stdout(md.trim_end())?;
        note!("wrote {}", out.display());
    }
    Ok(())
}
