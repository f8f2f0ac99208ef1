//! `sism bench`: run time against error for every registered algorithm; the table, `bench.csv`,
//! `bench.json`, `bench.png` and the truth's images.

use std::path::PathBuf;

use anyhow::{ensure, Context};

use sism::bench::{self, BenchReport, TruthInfo};
use sism::output::{pfm, pictures};

use super::{create_dir, print_stdout, write_file, SceneArgs};

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
    /// Score against this visibility image (PFM or OpenEXR) instead of rendering a truth.
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
    ensure!(
        (1..=bench::MAX_REPEATS).contains(&a.repeats),
        "--repeats {}: 1 to {}",
        a.repeats,
        bench::MAX_REPEATS
    );
    ensure!(
        a.sim_budget_ms.is_finite() && a.sim_budget_ms >= 0.0,
        "--sim-budget-ms {}: a finite number of milliseconds, at least 0",
        a.sim_budget_ms
    );
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
            let image =
                sism::output::read_visibility(path).with_context(|| format!("--truth {}", path.display()))?;
            ensure!(
                (image.width, image.height) == (width, height),
                "--truth {}: image is {}x{}, the bench renders {width}x{height} (set --width/--height to match)",
                path.display(),
                image.width,
                image.height
            );
            pfm::write_pfm(&truth_dir.join("visibility.pfm"), &image)?;
            sism::output::exr::write_visibility_exr(&truth_dir.join("visibility.exr"), &image)?;
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
                note!("truth: reference at {} spp, {width}x{height}", a.truth_spp);
            }
            let (result, info) = bench::render_truth(&scene, a.truth_spp, progress)?;
            sism::render::write_outputs(&truth_dir, &scene, &result)?;
            (result.visibility, info)
        }
    };
    let config = a
        .machine
        .as_deref()
        .map(super::resolve_machine)
        .transpose()
        .context("--machine")?;
    let images = create_dir(&out.join("images"))?;
    let mut report = bench::bench_scene(
        &scene,
        &candidates,
        &truth,
        truth_info,
        a.repeats,
        progress,
        Some(&images),
    )?;
    if let Some(config) = &config {
        bench::simulate_rows(
            &scene,
            &candidates,
            &mut report.rows,
            config,
            a.sim_budget_ms,
            progress,
        )
        .context("--sim-budget-ms")?;
    }
    write_file(&out.join("bench.csv"), &bench::to_csv(&report))?;
    write_file(&out.join("pareto.md"), &bench::pareto_markdown(&report))?;
    write_file(
        &out.join("bench.json"),
        &(serde_json::to_string_pretty(&report)? + "\n"),
    )?;
    sism::output::plots::bench::bench(&out.join("bench.png"), &report)?;
    bench::write_report(&out, &report, "truth/visibility.png")?;
    print_stdout(to_table(&report).trim_end())?;
    if progress {
        note!("wrote {}", out.display());
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
        "{:<18} {:>7} {:>12} {:>10} {:>10} {:>10} {:>13} {:>9} {:>14} {:>9}\n",
        "algorithm",
        "setting",
        "median ms",
        "MAE",
        "RMSE",
        "p99",
        "penumbra MAE",
        "ꟻLIP",
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
        let flip = e.flip.map_or("-".to_string(), |f| format!("{f:.5}"));
        s += &format!(
            "{:<18} {:>7} {:>12.2} {:>10.6} {:>10.6} {:>10.6} {:>13.6} {:>9} {:>14} {:>9}\n",
            r.algorithm, r.setting, r.median_ms, e.mae, e.rmse, e.p99, e.penumbra_mae, flip, at, ratio
        );
    }
    s += "ꟻLIP: mean LDR-ꟻLIP (NVIDIA's code, 67 ppd) between the truth's and the row's shaded views\n";
    s += "ref ms at MAE: the reference's time at the row's MAE, log-log interpolated between the spp \
settings that bracket it (\"outside\": beyond the sweep; widen --spp-list)\n";
    s
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
}
