//! `sism bench`: run time against error for every registered algorithm; the table, `bench.csv`,
//! `bench.json`, `bench.png` and the truth's images.

use std::path::{Path, PathBuf};

use anyhow::{ensure, Context};

use sism::bench::{self, BenchReport, BenchRow, TruthInfo};
use sism::output::{pfm, pictures};

use super::{create_dir, plot, print_stdout, write_file, SceneArgs};

/// Largest spp accepted in the sweep (the reference's own bound).
const MAX_SPP: u32 = 65_536;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Output folder (created if missing).
    #[arg(long, default_value = "out/bench")]
    out: PathBuf,
    /// The reference's spp sweep, comma-separated, each 1..=65536.
    #[arg(long, default_value = "4,16,64,256")]
    spp_list: String,
    /// Only these algorithms, comma-separated (default: every one with a bench plan; `sism
    /// algorithms` lists them).
    #[arg(long)]
    algos: Option<String>,
    /// Light-disk samples per receiver of the truth render.
    #[arg(long, default_value_t = 1024)]
    truth_spp: u32,
    /// Score against this visibility PFM instead of rendering a truth.
    #[arg(long)]
    truth: Option<PathBuf>,
    /// Timed runs per configuration; the median is reported.
    #[arg(long, default_value_t = 3)]
    repeats: u32,
    /// Also time one counted frame of every candidate on the simd kernels on this modelled chip (a
    /// preset such as larrabee-24, or a machine TOML): the `sim_ms` column.
    #[arg(long)]
    machine: Option<String>,
    /// With --machine: skip the counted frame of candidates whose native median exceeds this, ms (a
    /// counted frame keeps every freed block; the largest many-map frames do not fit in memory).
    #[arg(long, default_value_t = 3000.0)]
    sim_budget_ms: f64,
    /// No progress bars.
    #[arg(long)]
    quiet: bool,
}

/// Parses a comma-separated spp list such as `4,16,64,256`; every entry must be in 1..=65536.
fn parse_spp_list(text: &str) -> anyhow::Result<Vec<String>> {
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
        list.push(spp.to_string());
    }
    Ok(list)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    ensure!(a.repeats >= 1, "--repeats must be at least 1");
    let spp_list = parse_spp_list(&a.spp_list)?;
    ensure!(
        a.truth.is_some() || (1..=MAX_SPP).contains(&a.truth_spp),
        "--truth-spp {} is out of range (1..={MAX_SPP})",
        a.truth_spp
    );
    let scene = a.scene.load()?;
    let only: Option<Vec<String>> = a.algos.as_ref().map(|s| {
        s.split(',')
            .map(|t| t.trim().to_string())
            .filter(|t| !t.is_empty())
            .collect()
    });
    let candidates = bench::candidates(&[("spp", spp_list)], only.as_deref())
        .map_err(|e| anyhow::anyhow!("--algos: {e}"))?;
    let out = create_dir(&a.out)?;
    let truth_dir = create_dir(&out.join("truth"))?;
    let (width, height) = (scene.camera.width, scene.camera.height);
    let progress = !a.quiet;
    let (truth, truth_info) = match &a.truth {
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
            if progress {
                eprintln!("truth: reference at {} spp, {width}x{height}", a.truth_spp);
            }
            let (result, info) = bench::render_truth(&scene, a.truth_spp, progress)?;
            sism::render::write_outputs(&truth_dir, &scene, &result)?;
            (result.visibility, info)
        }
    };
    let config = a
        .machine
        .as_deref()
        .map(sism::machine::MachineConfig::resolve)
        .transpose()
        .context("--machine")?;
    let mut report = bench::bench_scene(&scene, &candidates, &truth, truth_info, a.repeats, progress)?;
    if let Some(config) = &config {
        bench::simulate_rows(
            &scene,
            &candidates,
            &mut report.rows,
            config,
            a.sim_budget_ms,
            progress,
        );
    }
    write_file(&out.join("bench.csv"), &bench::to_csv(&report))?;
    write_file(&out.join("pareto.md"), &bench::pareto_markdown(&report))?;
    write_file(
        &out.join("bench.json"),
        &(serde_json::to_string_pretty(&report)? + "\n"),
    )?;
    write_plot(&out.join("bench.png"), &report)?;
    print_stdout(to_table(&report).trim_end())?;
    if progress {
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// The table printed on stdout.
fn to_table(report: &BenchReport) -> String {
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
        "{:<18} {:>7} {:>12} {:>10} {:>10} {:>10} {:>13} {:>14} {:>9}\n",
        "algorithm",
        "setting",
        "median ms",
        "MAE",
        "RMSE",
        "p99",
        "penumbra MAE",
        "ref ms at MAE",
        "ref ÷ it"
    );
    for r in &report.rows {
        let e = &r.error;
        let (at, ratio) = match r.reference_ms_at_mae {
            Some(t) => (format!("{t:.1}"), format!("{:.2}", t / r.median_ms)),
            None if r.algorithm == "reference" => (String::new(), String::new()),
            None => ("outside".into(), "-".into()),
        };
        s += &format!(
            "{:<18} {:>7} {:>12.2} {:>10.6} {:>10.6} {:>10.6} {:>13.6} {:>14} {:>9}\n",
            r.algorithm, r.setting, r.median_ms, e.mae, e.rmse, e.p99, e.penumbra_mae, at, ratio
        );
    }
    s += "ref ms at MAE: the reference's time at the row's MAE, log-log interpolated between the spp \
settings that bracket it (\"outside\": beyond the sweep; widen --spp-list)\n";
    s
}

/// `bench.png`: median time (ms, log) on x against MAE (log) on y; one series per algorithm, points
/// joined by a line when a series sweeps a setting, each point labelled with its setting.
fn write_plot(path: &Path, report: &BenchReport) -> anyhow::Result<()> {
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
        let root = BitMapBackend::with_buffer(&mut rgb, plot::PLOT_SIZE).into_drawing_area();
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
            // One marker shape per family.
            let family = rows.first().map_or("", |r| r.family.as_str());
            let shape = FAMILY_MARKERS.iter().position(|f| *f == family).unwrap_or(0);
            let label = format!("{name} ({family})");
            // The same series call per shape: plotters' markers are distinct types.
            macro_rules! markers {
                ($make:expr) => {
                    chart
                        .draw_series(points.iter().map(|&p| $make(p)))
                        .map_err(|e| err(&e))?
                        .label(label)
                        .legend(move |(x, y)| {
                            EmptyElement::at((x, y))
                                + PathElement::new(vec![(-10, 0), (10, 0)], colour.stroke_width(2))
                                + $make((0, 0))
                        })
                };
            }
            match shape {
                0 => markers!(|p| Circle::new(p, 6, colour.filled())),
                1 => markers!(|p| TriangleMarker::new(p, 8, colour.filled())),
                2 => markers!(|p| Circle::new(p, 6, colour.stroke_width(3))),
                _ => markers!(|p| Cross::new(p, 6, colour.stroke_width(3))),
            };
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
        // The time–error front: a staircase through its rows by rising time.
        let mut front: Vec<(f64, f64)> = report.rows.iter().filter(|r| r.pareto).map(at).collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut stairs = Vec::new();
        for (k, &p) in front.iter().enumerate() {
            if k > 0 {
                stairs.push((p.0, front[k - 1].1));
            }
            stairs.push(p);
        }
        if stairs.len() > 1 {
            chart
                .draw_series(DashedLineSeries::new(stairs, 8, 5, BLACK.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label("time-error front")
                .legend(|(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], BLACK.stroke_width(2)));
        }
        plot::legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    plot::save(path, rgb)
}

/// Families in marker order: filled circle, triangle, open circle, then a cross.
const FAMILY_MARKERS: [&str; 4] = ["ray-traced", "sism", "shadow-map", "test"];

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
        assert_eq!(parse_spp_list("4,16, 64").unwrap(), vec!["4", "16", "64"]);
        for bad in ["", "4,,16", "4,x", "0", "4,-1", "70000"] {
            let e = parse_spp_list(bad).unwrap_err().to_string();
            assert!(e.contains("--spp-list"), "{bad}: {e}");
        }
    }

    #[test]
    fn tick_labels() {
        assert_eq!(fmt_tick(200.0), "200");
        assert_eq!(fmt_tick(2.0 * 10f64.powi(-3)), "0.002");
        assert_eq!(fmt_tick(0.5), "0.5");
        assert_eq!(fmt_tick(5.0 * 10f64.powi(-4)), "0.0005");
    }
}
