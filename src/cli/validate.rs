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
    let evidence = std::path::Path::new(&a.machine)
        .is_file()
        .then(|| std::fs::read_to_string(&a.machine).ok())
        .flatten()
        .map(|t| calibrate::evidence_from_toml(&t))
        .unwrap_or_default();
    let runs = (scenes.len() * algos.len()) as u64;
    let bar = sism::progress::bar(runs * (1 + threads.len() as u64) + 2, "validating", !a.quiet);
    bar.set_message("the host's moment (start)");
    let moment_start = calibrate::moment(&model);
    bar.inc(1);
    let mut rows: Vec<Row> = Vec::new();
    for scene in &scenes {
        for (algo, params) in &algos {
            rows.extend(validate::validate(
                scene,
                algo,
                params,
                &model,
                &threads,
                a.frames,
                &|what| {
                    bar.set_message(what);
                    bar.inc(1);
                },
            )?);
        }
    }
    bar.set_message("the host's moment (end)");
    let moment_end = calibrate::moment(&model);
    bar.finish_and_clear();
    let md = format!(
        "Model `{}` against the host ({} GHz), {}×{} where given, backend {}; predicted / measured host ms \
         per major phase and per frame (a phase: its steps' work; the frame: the phases the model times).\n\n{}\n{}",
        model.name,
        model.clock_ghz,
        a.width.map(|w| w.to_string()).unwrap_or_else(|| "scene".into()),
        a.height.map(|h| h.to_string()).unwrap_or_else(|| "scene".into()),
        sism_simd::selected_backend().name(),
        validate::moment_markdown(&evidence, &moment_start, &moment_end),
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
