//! `sism validate`: the machine model's per-phase predictions against measured host times.

use std::path::{Path, PathBuf};

use anyhow::Context;

use sism::machine::MachineConfig;
use sism::scene::Scene;
use sism::validate::{self, Row};

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
    #[arg(long, default_value_t = 3)]
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
    let model = MachineConfig::resolve(&a.machine).context("--machine")?;
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
    let runs = (scenes.len() * algos.len()) as u64;
    let bar = sism::progress::bar(runs * (1 + threads.len() as u64), "validating", !a.quiet);
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
                    bar.set_message(what.to_string());
                    bar.inc(1);
                },
            )?);
        }
    }
    bar.finish_and_clear();
    let md = format!(
        "Model `{}` against the host ({} GHz), {}×{} where given; predicted / measured host ms per major \
         phase and per frame (the frame: the phases the model times).\n\n{}",
        model.name,
        model.clock_ghz,
        a.width.map(|w| w.to_string()).unwrap_or_else(|| "scene".into()),
        a.height.map(|h| h.to_string()).unwrap_or_else(|| "scene".into()),
        validate::markdown(&rows, a.tolerance)
    );
    write_file(&out.join("validate.csv"), &validate::csv(&rows))?;
    write_file(&out.join("validate.md"), &md)?;
    plot(&out.join("validate.png"), &rows, a.tolerance)?;
    if !a.quiet {
        print_stdout(md.trim_end())?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// Predicted against measured ms, log–log, one point per major phase and frame, the ±tolerance band.
fn plot(path: &Path, rows: &[Row], tolerance: f64) -> anyhow::Result<()> {
    use plotters::prelude::*;
    super::plot::register_fonts();
    let points: Vec<(&Row, f64)> = rows
        .iter()
        .filter(|r| r.is_major() || r.phase == "frame")
        .filter_map(|r| r.predicted_ms.map(|p| (r, p)))
        .filter(|(r, p)| r.measured_ms > 0.0 && *p > 0.0)
        .collect();
    let lo = points
        .iter()
        .map(|(r, p)| r.measured_ms.min(*p))
        .fold(f64::INFINITY, f64::min)
        .max(1e-3)
        * 0.7;
    let hi = points
        .iter()
        .map(|(r, p)| r.measured_ms.max(*p))
        .fold(lo * 10.0, f64::max)
        * 1.4;
    let mut buf = super::plot::canvas();
    {
        let root = BitMapBackend::with_buffer(&mut buf, super::plot::PLOT_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e}"))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "machine model against the host: predicted vs measured ms",
                ("sans-serif", 24),
            )
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d((lo..hi).log_scale(), (lo..hi).log_scale())
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        chart
            .configure_mesh()
            .x_desc("measured host ms")
            .y_desc("model ms")
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let line = |k: f64| {
            (0..=50).map(move |i| {
                let x = lo * (hi / lo).powf(i as f64 / 50.0);
                (x, x * k)
            })
        };
        chart
            .draw_series(LineSeries::new(line(1.0), BLACK))
            .map_err(|e| anyhow::anyhow!("{e}"))?
            .label("model = host");
        for k in [1.0 + tolerance, 1.0 / (1.0 + tolerance)] {
            chart
                .draw_series(LineSeries::new(line(k), BLACK.mix(0.3)))
                .map_err(|e| anyhow::anyhow!("{e}"))?;
        }
        let series: Vec<&str> = validate::MAJOR_PHASES.iter().copied().chain(["frame"]).collect();
        for (i, name) in series.iter().enumerate() {
            let (r, g, b) = super::plot::PALETTE[i % super::plot::PALETTE.len()];
            let colour = RGBColor(r, g, b);
            chart
                .draw_series(
                    points
                        .iter()
                        .filter(|(row, _)| row.phase == *name)
                        .map(|(row, p)| {
                            let style = if row.threads == 1 {
                                colour.filled()
                            } else {
                                colour.stroke_width(2)
                            };
                            Circle::new((row.measured_ms, *p), 6, style)
                        }),
                )
                .map_err(|e| anyhow::anyhow!("{e}"))?
                .label(format!("{name} (filled: 1 thread)"))
                .legend(move |(x, y)| Circle::new((x, y), 6, colour.filled()));
        }
        super::plot::legend(&mut chart, SeriesLabelPosition::UpperLeft)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    super::plot::save(path, buf)
}
