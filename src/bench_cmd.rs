//! `sism bench`: run time against error.
//!
//! One high-spp reference render ("truth") is made once (or read from a PFM); then every
//! [`Candidate`] — the reference at each spp of a sweep, SISM, and every algorithm that joins later —
//! is rendered `repeats` times, timed, and scored against the truth with [`metrics::compare`]. The
//! results go out as a table on stdout, `bench.csv`, `bench.json` and a `bench.png` plot of
//! median time (log) against MAE (log).
//!
//! Time is the `time.total` counter of [`RenderResult::stats`]: host wall time of the whole
//! [`render::render`] call after the scene is loaded, so it includes the per-render BVH build of the
//! reference and the scene preparation of SISM. The median over the repeats is reported.
//!
//! Adding an algorithm to the comparison is one entry in [`candidates`].

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, ensure, Context};
use serde::Serialize;

use crate::frame::VisibilityImage;
use crate::metrics::{self, ErrorReport};
use crate::output::plot;
use crate::output::{pfm, pictures};
use crate::reference::ReferenceOptions;
use crate::render::{self, Algorithm, RenderResult};
use crate::scene::Scene;

/// Largest spp accepted anywhere in the bench (the same bound as `sism render --spp`).
pub const MAX_SPP: u32 = 65_536;
/// Seed of the reference renders being timed.
pub const SWEEP_SEED: u64 = 0;
/// Seed of the truth render, distinct from [`SWEEP_SEED`] so the truth's jitter is independent of
/// the jitter of the renders scored against it.
pub const TRUTH_SEED: u64 = 0x7472_7574_6800_0001;

/// Settings of one bench run.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Output folder (created if missing).
    pub out: PathBuf,
    /// The reference's spp sweep; sorted and de-duplicated before use.
    pub spp_list: Vec<u32>,
    /// Samples per receiver of the truth render (ignored when `truth` is given).
    pub truth_spp: u32,
    /// An existing truth visibility PFM to score against instead of rendering one.
    pub truth: Option<PathBuf>,
    /// Override the scene's image width, pixels.
    pub width: Option<u32>,
    /// Override the scene's image height, pixels.
    pub height: Option<u32>,
    /// Timed runs per candidate; the median is reported.
    pub repeats: u32,
    /// Draw progress bars on stderr (hidden anyway when stderr is not a terminal).
    pub progress: bool,
}

impl Default for BenchOptions {
    fn default() -> Self {
        Self {
            out: PathBuf::from("out/bench"),
            spp_list: vec![4, 16, 64, 256],
            truth_spp: 1024,
            truth: None,
            width: None,
            height: None,
            repeats: 3,
            progress: true,
        }
    }
}

/// One configuration in the time-vs-error comparison.
pub struct Candidate {
    /// Algorithm name; candidates sharing it form one series (one line) in the plot.
    pub algorithm: String,
    /// The swept setting, as printed in the table ("-" when there is none).
    pub setting: String,
    /// Label drawn beside the point in the plot (empty for none).
    pub label: String,
    /// Renders the scene.
    pub run: Box<dyn Fn(&Scene) -> RenderResult + Send + Sync>,
}

/// The candidates of the comparison: the reference at each spp of `spp_list` (in ascending order),
/// then SISM. A new algorithm joins with one more entry here.
pub fn candidates(spp_list: &[u32]) -> Vec<Candidate> {
    let mut spps = spp_list.to_vec();
    spps.sort_unstable();
    spps.dedup();
    let mut list: Vec<Candidate> = spps
        .into_iter()
        .map(|spp| Candidate {
            algorithm: Algorithm::Reference.name().into(),
            setting: spp.to_string(),
            label: format!("{spp} spp"),
            run: Box::new(move |scene: &Scene| {
                let options = ReferenceOptions {
                    spp,
                    seed: SWEEP_SEED,
                    progress: false,
                    ..Default::default()
                };
                render::render(scene, Algorithm::Reference, &options)
            }),
        })
        .collect();
    for algorithm in [
        Algorithm::Sism,
        Algorithm::SismIndependent,
        Algorithm::SismSampled,
    ] {
        list.push(Candidate {
            algorithm: algorithm.name().into(),
            setting: "-".into(),
            label: String::new(),
            run: Box::new(move |scene: &Scene| {
                render::render(scene, algorithm, &ReferenceOptions::default())
            }),
        });
    }
    list
}

/// Where the truth came from.
#[derive(Clone, Debug, Serialize)]
pub struct TruthInfo {
    /// Samples per receiver of the truth render (`None` when read from a file).
    pub spp: Option<u32>,
    /// Seed of the truth render (`None` when read from a file).
    pub seed: Option<u64>,
    /// The PFM given with `--truth`, if any.
    pub file: Option<PathBuf>,
    /// Host wall time of the truth render, ms (`None` when read from a file).
    pub time_ms: Option<f64>,
}

/// One candidate's measurements.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    pub algorithm: String,
    pub setting: String,
    pub label: String,
    /// `time.total` of each repeat, ms.
    pub times_ms: Vec<f64>,
    /// Median of `times_ms`.
    pub median_ms: f64,
    /// Error of the first repeat's image against the truth.
    pub error: ErrorReport,
}

/// Everything a bench run measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub scene: PathBuf,
    pub width: u32,
    pub height: u32,
    pub triangles: usize,
    pub repeats: u32,
    pub host_threads: usize,
    pub simd_backend: String,
    /// What the times measure.
    pub timing: String,
    pub truth: TruthInfo,
    pub rows: Vec<BenchRow>,
}

const TIMING: &str = "median over repeats of the render's time.total stat: host wall time of render() \
after scene load, including the reference's BVH build and SISM's scene preparation";

/// Parses a comma-separated spp list such as `4,16,64,256`; every entry must be in 1..=65536.
pub fn parse_spp_list(text: &str) -> anyhow::Result<Vec<u32>> {
    let mut list = Vec::new();
    for item in text.split(',') {
        let item = item.trim();
        ensure!(
            !item.is_empty(),
            "--spp-list '{text}': empty entry (expected numbers separated by commas, e.g. 4,16,64)"
        );
        let spp: u32 = item
            .parse()
            .map_err(|_| anyhow::anyhow!("--spp-list '{text}': '{item}' is not a whole number"))?;
        ensure!(
            (1..=MAX_SPP).contains(&spp),
            "--spp-list '{text}': {spp} spp is out of range (1..={MAX_SPP})"
        );
        list.push(spp);
    }
    Ok(list)
}

/// Loads the scene at `scene_path`, applies the size override and runs [`bench_scene`].
pub fn bench(scene_path: &Path, options: &BenchOptions) -> anyhow::Result<BenchReport> {
    let mut scene = Scene::load(scene_path)?;
    if let Some(w) = options.width {
        scene.camera.width = w;
    }
    if let Some(h) = options.height {
        scene.camera.height = h;
    }
    if let Err((key, msg)) = scene.camera.validate() {
        bail!("--width/--height: {} {msg}", key.replace("camera.", ""));
    }
    bench_scene(&scene, &candidates(&options.spp_list), options)
}

/// Runs `candidates` on `scene` against a truth, prints the table and writes `bench.csv`,
/// `bench.json`, `bench.png` and `truth/` into `options.out`.
pub fn bench_scene(
    scene: &Scene,
    candidates: &[Candidate],
    options: &BenchOptions,
) -> anyhow::Result<BenchReport> {
    ensure!(options.repeats >= 1, "--repeats must be at least 1");
    ensure!(
        options.truth.is_some() || (1..=MAX_SPP).contains(&options.truth_spp),
        "--truth-spp {} is out of range (1..={MAX_SPP})",
        options.truth_spp
    );
    ensure!(!candidates.is_empty(), "--spp-list: nothing to bench");
    let out = &options.out;
    let truth_dir = out.join("truth");
    std::fs::create_dir_all(&truth_dir)
        .with_context(|| format!("cannot create output folder {}", truth_dir.display()))?;
    let (width, height) = (scene.camera.width, scene.camera.height);

    // The truth, once.
    let (truth, truth_info) = match &options.truth {
        Some(path) => {
            let image = pfm::read_pfm(path).with_context(|| format!("--truth {}", path.display()))?;
            ensure!(
                (image.width, image.height) == (width, height),
                "--truth {}: image is {}x{}, the bench renders {width}x{height} (set --width/--height to match)",
                path.display(),
                image.width,
                image.height
            );
            pfm::write_pfm(&truth_dir.join("visibility.pfm"), &image)
                .with_context(|| format!("cannot write {}", truth_dir.join("visibility.pfm").display()))?;
            pictures::write_visibility_png(&truth_dir.join("visibility.png"), &image)?;
            let info = TruthInfo {
                spp: None,
                seed: None,
                file: Some(path.clone()),
                time_ms: None,
            };
            (image, info)
        }
        None => {
            let truth_options = ReferenceOptions {
                spp: options.truth_spp,
                seed: TRUTH_SEED,
                progress: options.progress,
                ..Default::default()
            };
            if options.progress {
                eprintln!("truth: reference at {} spp, {width}x{height}", options.truth_spp);
            }
            let t0 = Instant::now();
            let result = render::render(scene, Algorithm::Reference, &truth_options);
            let time_ms = total_ms(&result, t0);
            render::write_outputs(&truth_dir, scene, &result)?;
            let info = TruthInfo {
                spp: Some(options.truth_spp),
                seed: Some(TRUTH_SEED),
                file: None,
                time_ms: Some(time_ms),
            };
            (result.visibility, info)
        }
    };

    // Every candidate, `repeats` times.
    let bar = crate::progress::bar(
        (candidates.len() as u64) * options.repeats as u64,
        "bench",
        options.progress,
    );
    let mut rows = Vec::with_capacity(candidates.len());
    for c in candidates {
        bar.set_message(format!("{} {}", c.algorithm, c.setting));
        let mut times_ms = Vec::with_capacity(options.repeats as usize);
        let mut first: Option<VisibilityImage> = None;
        for _ in 0..options.repeats {
            let t0 = Instant::now();
            let result = (c.run)(scene);
            times_ms.push(total_ms(&result, t0));
            first.get_or_insert(result.visibility);
            bar.inc(1);
        }
        let image = first.expect("repeats >= 1");
        let error = metrics::compare(&truth, &image)
            .with_context(|| format!("scoring {} {} against the truth", c.algorithm, c.setting))?;
        rows.push(BenchRow {
            algorithm: c.algorithm.clone(),
            setting: c.setting.clone(),
            label: c.label.clone(),
            median_ms: median(&times_ms),
            times_ms,
            error,
        });
    }
    bar.finish_and_clear();

    let report = BenchReport {
        scene: scene.source.clone(),
        width,
        height,
        triangles: scene.triangle_count(),
        repeats: options.repeats,
        host_threads: rayon::current_num_threads(),
        simd_backend: format!("{:?}", sism_simd::selected_backend()),
        timing: TIMING.into(),
        truth: truth_info,
        rows,
    };
    std::fs::write(out.join("bench.csv"), to_csv(&report))
        .with_context(|| format!("cannot write {}", out.join("bench.csv").display()))?;
    std::fs::write(
        out.join("bench.json"),
        serde_json::to_string_pretty(&report)? + "\n",
    )
    .with_context(|| format!("cannot write {}", out.join("bench.json").display()))?;
    write_plot(&out.join("bench.png"), &report)?;
    Ok(report)
}

/// The render's `time.total` stat, or the wall time since `t0` if a render does not report it.
fn total_ms(result: &RenderResult, t0: Instant) -> f64 {
    result
        .stats
        .get("time.total")
        .unwrap_or_else(|| t0.elapsed().as_secs_f64() * 1e3)
}

fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The columns of the table and of `bench.csv`.
pub const CSV_HEADER: &str =
    "algorithm,setting,median_ms,mae,rmse,p99,penumbra_mae,max,share_over_0_1,compared,penumbra_pixels";

/// `bench.csv`: a header line, then one line per candidate.
pub fn to_csv(report: &BenchReport) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in &report.rows {
        let e = &r.error;
        s += &format!(
            "{},{},{:.3},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{},{}\n",
            r.algorithm,
            r.setting,
            r.median_ms,
            e.mae,
            e.rmse,
            e.p99,
            e.penumbra_mae,
            e.max,
            e.share_over_0_1,
            e.compared,
            e.penumbra_pixels
        );
    }
    s
}

/// The table printed on stdout.
pub fn to_table(report: &BenchReport) -> String {
    let truth = match (&report.truth.file, report.truth.spp) {
        (Some(f), _) => format!("truth {}", f.display()),
        (None, Some(spp)) => format!(
            "truth: reference {spp} spp ({:.0} ms)",
            report.truth.time_ms.unwrap_or(f64::NAN)
        ),
        _ => "truth".into(),
    };
    let mut s = format!(
        "{} {}x{}, {} triangles, {} threads, simd {}; {truth}\ntime: median of {} runs of time.total (host wall time of render() after scene load)\n",
        report.scene.display(),
        report.width,
        report.height,
        report.triangles,
        report.host_threads,
        report.simd_backend,
        report.repeats,
    );
    s += &format!(
        "{:<10} {:>7} {:>12} {:>10} {:>10} {:>10} {:>13}\n",
        "algorithm", "setting", "median ms", "MAE", "RMSE", "p99", "penumbra MAE"
    );
    for r in &report.rows {
        let e = &r.error;
        s += &format!(
            "{:<10} {:>7} {:>12.2} {:>10.6} {:>10.6} {:>10.6} {:>13.6}\n",
            r.algorithm, r.setting, r.median_ms, e.mae, e.rmse, e.p99, e.penumbra_mae
        );
    }
    s
}

/// Size of `bench.png`, pixels.
pub use crate::output::plot::PLOT_SIZE;

/// `bench.png`: median time (ms, log) on x against MAE (log) on y; one series per algorithm, points
/// joined by a line when a series sweeps a setting, each point labelled with its setting.
pub fn write_plot(path: &Path, report: &BenchReport) -> anyhow::Result<()> {
    use plotters::prelude::*;
    plot::register_fonts();
    let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("cannot draw {}: {e}", path.display());

    // Series in first-appearance order of the algorithm name.
    let mut series: Vec<(&str, Vec<&BenchRow>)> = Vec::new();
    for r in &report.rows {
        match series.iter_mut().find(|(name, _)| *name == r.algorithm) {
            Some((_, rows)) => rows.push(r),
            None => series.push((&r.algorithm, vec![r])),
        }
    }
    // Log axes need positive values: an exact result (MAE 0) sits on the floor of the axis.
    let positive = |v: f64| v.is_finite() && v > 0.0;
    let maes: Vec<f64> = report
        .rows
        .iter()
        .map(|r| r.error.mae)
        .filter(|&v| positive(v))
        .collect();
    let times: Vec<f64> = report
        .rows
        .iter()
        .map(|r| r.median_ms)
        .filter(|&v| positive(v))
        .collect();
    let span = |v: &[f64], fallback: (f64, f64)| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(0.0, f64::max);
        if lo.is_finite() && hi > 0.0 {
            (lo / 2.0, hi * 2.0)
        } else {
            fallback
        }
    };
    let (x0, x1) = span(&times, (0.1, 1000.0));
    let (y0, y1) = span(&maes, (1e-6, 1.0));
    let at = |r: &BenchRow| (r.median_ms.max(x0), r.error.mae.max(y0));

    let mut rgb = plot::canvas();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, PLOT_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let truth = match (&report.truth.file, report.truth.spp) {
            (Some(f), _) => format!("truth {}", f.display()),
            (None, Some(spp)) => format!("truth {spp} spp"),
            _ => "truth".into(),
        };
        let scene_name = report
            .scene
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let title = format!(
            "{scene_name} {}x{}: time vs error ({truth}, {} threads)",
            report.width, report.height, report.host_threads
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(20)
            .x_label_area_size(56)
            .y_label_area_size(80)
            .build_cartesian_2d(log_axis(x0, x1), log_axis(y0, y1))
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("median host wall time per frame, ms (log scale)")
            .y_desc("MAE of V against truth (log scale)")
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(200, 200, 200))
            .x_label_formatter(&|x| fmt_tick(*x))
            .y_label_formatter(&|y| fmt_tick(*y))
            .axis_desc_style(("sans-serif", 18))
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;

        for (i, (name, rows)) in series.iter().enumerate() {
            let (r, g, b) = plot::PALETTE[i % plot::PALETTE.len()];
            let colour = RGBColor(r, g, b);
            let points: Vec<(f64, f64)> = rows.iter().map(|r| at(r)).collect();
            if points.len() > 1 {
                chart
                    .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
                    .map_err(|e| err(&e))?;
            }
            chart
                .draw_series(points.iter().map(|&p| Circle::new(p, 6, colour.filled())))
                .map_err(|e| err(&e))?
                .label(name.to_string())
                .legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(-10, 0), (10, 0)], colour.stroke_width(2))
                        + Circle::new((0, 0), 5, colour.filled())
                });
            chart
                .draw_series(
                    rows.iter()
                        .zip(&points)
                        .filter(|(r, _)| !r.label.is_empty())
                        .map(|(r, &p)| {
                            EmptyElement::at(p)
                                + Text::new(r.label.clone(), (9, -20), ("sans-serif", 15).into_font())
                        }),
                )
                .map_err(|e| err(&e))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 16))
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    plot::save(path, rgb)
}

/// A log axis over `lo..hi` with labelled grid lines at 1, 2 and 5 times powers of ten (every
/// integer multiple when the range holds fewer than three of those) and light lines at the other
/// multiples. Plotters' own log-axis ticks skip decades.
fn log_axis(
    lo: f64,
    hi: f64,
) -> plotters::coord::combinators::WithKeyPoints<plotters::coord::combinators::LogCoord<f64>> {
    use plotters::coord::combinators::{BindKeyPoints, IntoLogRange};
    let mut all = Vec::new();
    for k in lo.log10().floor() as i32..=hi.log10().ceil() as i32 {
        for m in 1..=9 {
            let v = m as f64 * 10f64.powi(k);
            if v >= lo && v <= hi {
                all.push((m, v));
            }
        }
    }
    let mut bold: Vec<f64> = all
        .iter()
        .filter(|(m, _)| [1, 2, 5].contains(m))
        .map(|&(_, v)| v)
        .collect();
    if bold.len() < 3 {
        bold = all.iter().map(|&(_, v)| v).collect();
    }
    let light: Vec<f64> = all
        .iter()
        .map(|&(_, v)| v)
        .filter(|v| !bold.contains(v))
        .collect();
    (lo..hi)
        .log_scale()
        .with_key_points(bold)
        .with_light_points(light)
}

/// A tick label: a plain number with as many decimals as its first significant digit needs.
fn fmt_tick(x: f64) -> String {
    if x >= 1.0 {
        format!("{x:.0}")
    } else if x > 0.0 {
        let decimals = (-x.log10()).ceil().max(1.0) as usize;
        format!("{x:.decimals$}")
    } else {
        "0".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spp_list_parses_and_rejects() {
        assert_eq!(parse_spp_list("4,16, 64").unwrap(), vec![4, 16, 64]);
        for bad in ["", "4,,16", "4,x", "0", "4,-1", "70000"] {
            let e = parse_spp_list(bad).unwrap_err().to_string();
            assert!(e.contains("--spp-list"), "{bad}: {e}");
        }
    }

    #[test]
    fn median_of_odd_and_even() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
    }

    #[test]
    fn tick_labels() {
        assert_eq!(fmt_tick(200.0), "200");
        assert_eq!(fmt_tick(2.0 * 10f64.powi(-3)), "0.002");
        assert_eq!(fmt_tick(0.5), "0.5");
        assert_eq!(fmt_tick(5.0 * 10f64.powi(-4)), "0.0005");
    }

    #[test]
    fn candidates_sweep_sorted_then_sism() {
        let c = candidates(&[64, 4, 16, 4]);
        let names: Vec<_> = c
            .iter()
            .map(|c| (c.algorithm.as_str(), c.setting.as_str()))
            .collect();
        assert_eq!(
            names,
            [
                ("reference", "4"),
                ("reference", "16"),
                ("reference", "64"),
                ("sism", "-"),
                ("sism-independent", "-"),
                ("sism-sampled", "-"),
            ]
        );
    }
}
