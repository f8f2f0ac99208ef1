//! Run time against error: a high-spp reference render ("truth") once, then every [`Candidate`] —
//! each registered algorithm at its defaults, or once per value of its swept parameter (the
//! reference's `spp`) — rendered `repeats` times, timed, and scored against the truth with
//! [`metrics::compare`].
//!
//! Time is the `time.total` counter of [`RenderResult::stats`]: host wall time of the whole
//! [`render::render`] call after the scene is loaded, so it includes the per-render BVH build of the
//! reference and the scene preparation of SISM. The median over the repeats is reported.
//!
//! The candidates come from the registry ([`Algorithm::bench`]): an algorithm joins the comparison
//! with its registry line.

use std::path::PathBuf;
use std::time::Instant;

use serde::Serialize;

use crate::algorithms::{self, Algorithm, BenchPlan, ParamError, Params};
use crate::frame::VisibilityImage;
use crate::metrics::{self, ErrorReport};
use crate::render::{self, RenderOptions, RenderResult};
use crate::scene::Scene;

/// Seed of the reference renders being timed.
pub const SWEEP_SEED: u64 = 0;
/// Seed of the truth render, distinct from [`SWEEP_SEED`] so the truth's jitter is independent of
/// the jitter of the renders scored against it.
pub const TRUTH_SEED: u64 = 0x7472_7574_6800_0001;

/// One configuration in the time-vs-error comparison.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// The algorithm run.
    pub algorithm: &'static Algorithm,
    /// Its resolved parameters.
    pub params: Params,
    /// The swept setting, as printed in the table ("-" when there is none).
    pub setting: String,
    /// Label drawn beside the point in the plot (empty for none).
    pub label: String,
}

/// The candidates of the comparison, in registry order: each algorithm's [`BenchPlan`], with the
/// values of a swept parameter replaced where `sweeps` names its key (`("spp", ["4", "16"])`; values
/// are sorted numerically when they are numbers, and de-duplicated).
/// With `only`, just the algorithms it names (in registry order; an unknown name is an error).
pub fn candidates(
    sweeps: &[(&str, Vec<String>)],
    only: Option<&[String]>,
) -> Result<Vec<Candidate>, ParamError> {
    if let Some(names) = only {
        if let Some(bad) = names.iter().find(|n| algorithms::find(n).is_none()) {
            return Err(ParamError {
                algorithm: bad.clone(),
                key: "name".into(),
                message: format!(
                    "is not a registered algorithm ({})",
                    algorithms::names().collect::<Vec<_>>().join(", ")
                ),
            });
        }
    }
    let mut list = Vec::new();
    for &a in algorithms::REGISTRY {
        if only.is_some_and(|names| !names.iter().any(|n| n == a.name)) {
            continue;
        }
        match a.bench {
            BenchPlan::Skip if only.is_none() => {}
            BenchPlan::Skip | BenchPlan::Defaults => list.push(Candidate {
                algorithm: a,
                params: a.params(&[])?,
                setting: "-".into(),
                label: String::new(),
            }),
            BenchPlan::Sweep { key, values } => {
                let mut values: Vec<String> = match sweeps.iter().find(|(k, _)| *k == key) {
                    Some((_, v)) => v.clone(),
                    None => values.iter().map(|v| v.to_string()).collect(),
                };
                values.sort_by(|x, y| match (x.parse::<f64>(), y.parse::<f64>()) {
                    (Ok(a), Ok(b)) => a.total_cmp(&b),
                    _ => x.cmp(y),
                });
                values.dedup();
                for v in values {
                    let mut given = vec![(key.to_string(), v.clone())];
                    if a.param("seed").is_some() {
                        given.push(("seed".into(), SWEEP_SEED.to_string()));
                    }
                    list.push(Candidate {
                        algorithm: a,
                        params: a.params(&given)?,
                        label: if key == "spp" {
                            format!("{v} spp")
                        } else {
                            format!("{key}={v}")
                        },
                        setting: v,
                    });
                }
            }
        }
    }
    Ok(list)
}

/// Where the truth came from.
#[derive(Clone, Debug, Serialize)]
pub struct TruthInfo {
    /// Samples per receiver of the truth render (`None` when read from a file).
    pub spp: Option<u32>,
    /// Seed of the truth render (`None` when read from a file).
    pub seed: Option<u64>,
    /// The PFM the truth was read from, if any.
    pub file: Option<PathBuf>,
    /// Host wall time of the truth render, ms (`None` when read from a file).
    pub time_ms: Option<f64>,
}

/// Renders the truth: the reference at `spp` with [`TRUTH_SEED`].
pub fn render_truth(
    scene: &Scene,
    spp: u32,
    progress: bool,
) -> Result<(RenderResult, TruthInfo), ParamError> {
    let reference = &algorithms::reference::REFERENCE;
    let params = reference.params(&[
        ("spp".into(), spp.to_string()),
        ("seed".into(), TRUTH_SEED.to_string()),
    ])?;
    let t0 = Instant::now();
    let result = render::render(
        scene,
        reference,
        &params,
        &RenderOptions {
            progress,
            ..Default::default()
        },
    );
    let time_ms = total_ms(&result, t0);
    let info = TruthInfo {
        spp: Some(spp),
        seed: Some(TRUTH_SEED),
        file: None,
        time_ms: Some(time_ms),
    };
    Ok((result, info))
}

/// One candidate's measurements.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    /// The algorithm's name.
    pub algorithm: String,
    /// Its family's name in tables.
    pub family: String,
    /// The swept setting, as printed in the table ("-" when there is none).
    pub setting: String,
    /// Label drawn beside the point in the plot (empty for none).
    pub label: String,
    /// Every parameter, `key=value`.
    pub params: String,
    /// `time.total` of each repeat, ms.
    pub times_ms: Vec<f64>,
    /// Median of `times_ms`.
    pub median_ms: f64,
    /// Error of the first repeat's image against the truth.
    pub error: ErrorReport,
    /// The reference's time at this row's MAE, ms: interpolated on the reference rows of the same
    /// run (log time against log MAE between the two spp settings that bracket it). `None` for the
    /// reference itself, or when the MAE lies outside the reference's range (no extrapolation).
    pub reference_ms_at_mae: Option<f64>,
    /// One counted frame timed on the modelled chip (`bench --machine`), ms; `None` when not asked,
    /// when the algorithm does not run on the simd kernels, or when its native frame exceeds the
    /// simulation budget (a counted frame holds every freed block, so the largest would not fit).
    pub sim_ms: Option<f64>,
    /// On the time–error Pareto front of the run: no other row is at most as slow and at most as
    /// wrong (median ms, MAE) and better in one.
    pub pareto: bool,
    /// The first repeat's visibility picture, relative to the bench's folder (`images/NN-….png`),
    /// when the bench wrote pictures.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub image: Option<String>,
    /// Its |error| heat map against the truth ([`HEATMAP_SCALE`] is full yellow), relative.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_image: Option<String>,
}

/// |error| drawn full yellow in the bench's error maps (as `compare --heatmap`'s default).
pub const HEATMAP_SCALE: f32 = 0.25;

/// The file stem of row `index`'s pictures: its number, algorithm and setting, in characters safe
/// in a file name and a link.
pub fn picture_stem(index: usize, algorithm: &str, setting: &str) -> String {
    let mut s = format!("{index:02}-{algorithm}");
    if setting != "-" && !setting.is_empty() {
        s.push('-');
        s.push_str(setting);
    }
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Marks the rows on the Pareto front of (median ms, MAE): a row is on it when no other row has
/// both a time and an MAE at most its own, one of them smaller. Rows with a non-finite time or
/// MAE are never on it.
pub fn mark_pareto(rows: &mut [BenchRow]) {
    let key: Vec<(f64, f64)> = rows.iter().map(|r| (r.median_ms, r.error.mae)).collect();
    for (i, r) in rows.iter_mut().enumerate() {
        let (t, e) = key[i];
        r.pareto = t.is_finite()
            && e.is_finite()
            && !key.iter().enumerate().any(|(j, &(tj, ej))| {
                j != i && tj.is_finite() && ej.is_finite() && tj <= t && ej <= e && (tj < t || ej < e)
            });
    }
}

/// Times one counted frame of each candidate that runs on the simd kernels on `config`, into the
/// rows' `sim_ms`, skipping candidates whose native median exceeds `budget_ms`.
pub fn simulate_rows(
    scene: &Scene,
    candidates: &[Candidate],
    rows: &mut [BenchRow],
    config: &crate::machine::MachineConfig,
    budget_ms: f64,
    progress: bool,
) -> Result<(), BenchError> {
    if !(budget_ms.is_finite() && budget_ms >= 0.0) {
        return Err(BenchError::Budget(budget_ms));
    }
    let bar = crate::progress::bar(candidates.len() as u64, "simulate", progress);
    for (c, r) in candidates.iter().zip(rows.iter_mut()) {
        bar.set_message(format!("{} {}", c.algorithm.name, c.setting));
        if c.algorithm.kernels && r.median_ms <= budget_ms {
            let m = render::render_on_machine(scene, c.algorithm, &c.params, config, false);
            r.sim_ms = Some(m.report.frame.ms);
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(())
}

/// The Pareto table (Markdown): every row by rising median time, the front marked.
pub fn pareto_markdown(report: &BenchReport) -> String {
    let mut rows: Vec<&BenchRow> = report.rows.iter().collect();
    rows.sort_by(|a, b| a.median_ms.total_cmp(&b.median_ms));
    let mut s = String::from(
        "| front | algorithm | setting | family | native ms | sim ms | MAE | p99 | penumbra MAE | share > 0.1 |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let e = &r.error;
        s += &format!(
            "| {} | `{}` | {} | {} | {:.1} | {} | {:.4} | {:.3} | {:.3} | {:.4} |\n",
            if r.pareto { "**yes**" } else { "" },
            r.algorithm,
            r.setting,
            r.family,
            r.median_ms,
            r.sim_ms.map_or("–".to_string(), |t| format!("{t:.1}")),
            e.mae,
            e.p99,
            e.penumbra_mae,
            e.share_over_0_1
        );
    }
    s
}

/// Everything a bench run measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// The scene file.
    pub scene: PathBuf,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Triangles in the scene.
    pub triangles: usize,
    /// Timed renders per candidate (at least 1).
    pub repeats: u32,
    /// Host worker threads (rayon's pool).
    pub host_threads: usize,
    /// Name of the simd crate's selected backend.
    pub simd_backend: String,
    /// What the times measure.
    pub timing: String,
    /// Where the truth came from.
    pub truth: TruthInfo,
    /// One row per candidate, in candidate order.
    pub rows: Vec<BenchRow>,
}

const TIMING: &str = "median over repeats of the render's time.total stat: host wall time of render() \
after scene load, including the reference's BVH build and SISM's scene preparation";

/// Most timed runs per configuration (their times are kept for the median).
pub const MAX_REPEATS: u32 = 1000;

/// A failure of the comparison.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// `repeats` is 0.
    #[error("repeats must be at least 1")]
    NoRepeats,
    /// `repeats` is above [`MAX_REPEATS`].
    #[error("repeats {0}: at most {MAX_REPEATS} timed runs per configuration")]
    TooManyRepeats(u32),
    /// The simulation budget is not a number of milliseconds.
    #[error("the simulation budget {0} ms must be a finite number of milliseconds, at least 0")]
    Budget(f64),
    /// No candidate to bench.
    #[error("nothing to bench")]
    NoCandidates,
    /// The truth's image size differs from the bench's.
    #[error("the truth is {truth_w}x{truth_h}, the bench renders {width}x{height}")]
    TruthSize {
        /// Truth image width, pixels.
        truth_w: u32,
        /// Truth image height, pixels.
        truth_h: u32,
        /// Bench image width, pixels.
        width: u32,
        /// Bench image height, pixels.
        height: u32,
    },
    /// A candidate's pictures could not be written.
    #[error("{0}")]
    Pictures(crate::Error),
    /// A candidate's image could not be scored against the truth.
    #[error("scoring {algorithm} {setting} against the truth: {source}")]
    Score {
        /// The candidate's algorithm.
        algorithm: String,
        /// The candidate's swept setting.
        setting: String,
        /// Why the comparison failed.
        #[source]
        source: crate::metrics::CompareError,
    },
}

/// Runs `candidates` on `scene` against `truth`, each `repeats` times, with a progress bar when
/// `progress` is set. With `pictures` (a folder, `images/` of the bench's output), each row's first
/// image and its error map are written there as PNGs, named in the row ([`BenchRow::image`]).
pub fn bench_scene(
    scene: &Scene,
    candidates: &[Candidate],
    truth: &VisibilityImage,
    truth_info: TruthInfo,
    repeats: u32,
    progress: bool,
    pictures: Option<&std::path::Path>,
) -> Result<BenchReport, BenchError> {
    if repeats == 0 {
        return Err(BenchError::NoRepeats);
    }
    if repeats > MAX_REPEATS {
        return Err(BenchError::TooManyRepeats(repeats));
    }
    if candidates.is_empty() {
        return Err(BenchError::NoCandidates);
    }
    let (width, height) = (scene.camera.width, scene.camera.height);
    if (truth.width, truth.height) != (width, height) {
        return Err(BenchError::TruthSize {
            truth_w: truth.width,
            truth_h: truth.height,
            width,
            height,
        });
    }
    let bar = crate::progress::bar((candidates.len() as u64) * repeats as u64, "bench", progress);
    let mut rows = Vec::with_capacity(candidates.len());
    for c in candidates {
        bar.set_message(format!("{} {}", c.algorithm.name, c.setting));
        let mut times_ms = Vec::with_capacity(repeats as usize);
        let mut first: Option<RenderResult> = None;
        for _ in 0..repeats {
            let t0 = Instant::now();
            let result = render::render(scene, c.algorithm, &c.params, &RenderOptions::default());
            times_ms.push(total_ms(&result, t0));
            first.get_or_insert(result);
            bar.inc(1);
        }
        let first = first.expect("repeats >= 1");
        // ꟻLIP shades both with this frame's receivers (the eye pass is the same for every
        // candidate and for the truth).
        let error =
            metrics::compare_frame(scene, &first.receivers, truth, &first.visibility).map_err(|e| {
                BenchError::Score {
                    algorithm: c.algorithm.name.into(),
                    setting: c.setting.clone(),
                    source: e,
                }
            })?;
        let (image, error_image) = match pictures {
            Some(dir) => {
                let stem = picture_stem(rows.len(), c.algorithm.name, &c.setting);
                let (image, error_image) = (format!("{stem}.png"), format!("{stem}-error.png"));
                crate::output::pictures::write_visibility_png(&dir.join(&image), &first.visibility)
                    .map_err(BenchError::Pictures)?;
                let errors =
                    metrics::abs_error_map(truth, &first.visibility).map_err(|e| BenchError::Score {
                        algorithm: c.algorithm.name.into(),
                        setting: c.setting.clone(),
                        source: e,
                    })?;
                crate::output::pictures::write_error_heatmap(
                    &dir.join(&error_image),
                    width,
                    height,
                    &errors,
                    HEATMAP_SCALE,
                )
                .map_err(BenchError::Pictures)?;
                let folder = dir
                    .file_name()
                    .map_or(String::new(), |n| format!("{}/", n.to_string_lossy()));
                (
                    Some(format!("{folder}{image}")),
                    Some(format!("{folder}{error_image}")),
                )
            }
            None => (None, None),
        };
        rows.push(BenchRow {
            image,
            error_image,
            algorithm: c.algorithm.name.into(),
            family: c.algorithm.family.name().into(),
            setting: c.setting.clone(),
            label: c.label.clone(),
            params: c.params.describe(),
            median_ms: crate::metrics::median(&times_ms),
            times_ms,
            error,
            reference_ms_at_mae: None,
            sim_ms: None,
            pareto: false,
        });
    }
    bar.finish_and_clear();
    let curve = reference_curve(&rows);
    for r in rows.iter_mut().filter(|r| r.algorithm != "reference") {
        r.reference_ms_at_mae = time_at_error(&curve, r.error.mae);
    }
    mark_pareto(&mut rows);
    Ok(BenchReport {
        scene: scene.source.clone(),
        width,
        height,
        triangles: scene.triangle_count(),
        repeats,
        host_threads: rayon::current_num_threads(),
        simd_backend: sism_simd::selected_backend().name().to_string(),
        timing: TIMING.into(),
        truth: truth_info,
        rows,
    })
}

/// The reference rows' `(MAE, median ms)`, by falling MAE.
fn reference_curve(rows: &[BenchRow]) -> Vec<(f64, f64)> {
    let mut curve: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.algorithm == "reference")
        .map(|r| (r.error.mae, r.median_ms))
        .filter(|&(mae, ms)| mae.is_finite() && mae > 0.0 && ms.is_finite() && ms > 0.0)
        .collect();
    curve.sort_by(|a, b| b.0.total_cmp(&a.0));
    curve
}

/// The time at which `curve` (`(MAE, ms)` by falling MAE) reaches `mae`: log-log interpolation
/// between the two points that bracket it; `None` outside the curve's range or for `mae <= 0`.
pub fn time_at_error(curve: &[(f64, f64)], mae: f64) -> Option<f64> {
    if !(mae.is_finite() && mae > 0.0) {
        return None;
    }
    curve.windows(2).find_map(|w| {
        let ((e0, t0), (e1, t1)) = (w[0], w[1]);
        if !(e1 <= mae && mae <= e0) {
            return None;
        }
        if mae == e0 || mae == e1 {
            return Some(if mae == e0 { t0 } else { t1 });
        }
        let f = (mae.ln() - e0.ln()) / (e1.ln() - e0.ln());
        Some((t0.ln() + f * (t1.ln() - t0.ln())).exp())
    })
}

/// The render's `time.total` stat, or the wall time since `t0` if a render does not report it.
fn total_ms(result: &RenderResult, t0: Instant) -> f64 {
    result
        .stats
        .get("time.total")
        .unwrap_or_else(|| t0.elapsed().as_secs_f64() * 1e3)
}

/// The columns of the table and of `bench.csv`.
pub const CSV_HEADER: &str = "algorithm,setting,median_ms,mae,rmse,p99,penumbra_mae,max,share_over_0_1,\
compared,penumbra_pixels,reference_ms_at_mae,reference_ratio,sim_ms,pareto,flip";

/// `bench.csv`: a header line, then one line per candidate.
pub fn to_csv(report: &BenchReport) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in &report.rows {
        let e = &r.error;
        let (at, ratio) = match r.reference_ms_at_mae {
            Some(t) => (format!("{t:.3}"), format!("{:.4}", t / r.median_ms)),
            None => (String::new(), String::new()),
        };
        s += &format!(
            "{},{},{:.3},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{},{},{at},{ratio},{},{},{}\n",
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
            e.penumbra_pixels,
            r.sim_ms.map_or(String::new(), |t| format!("{t:.3}")),
            r.pareto,
            e.flip.map_or(String::new(), |f| format!("{f:.6}")),
        );
    }
    s
}

/// `report.html` of a bench in `out`: the plot, every row (a sortable table), the Pareto front, the
/// truth's and every row's picture side by side with their error maps, and a flipper between any
/// two of them. `truth_picture` is the truth's visibility PNG, relative to `out`.
pub fn write_report(out: &std::path::Path, report: &BenchReport, truth_picture: &str) -> crate::Result<()> {
    use crate::output::report::{Picture, Report};
    let name = report
        .scene
        .file_stem()
        .map_or(String::new(), |s| s.to_string_lossy().into_owned());
    let mut r = Report::new(&format!(
        "Run time against error: {name} {}x{}",
        report.width, report.height
    ));
    let truth = match (&report.truth.file, report.truth.spp) {
        (Some(f), _) => format!("the image {}", f.display()),
        (None, Some(spp)) => format!("the reference at {spp} spp"),
        _ => "a given image".into(),
    };
    r.paragraph(&format!(
        "{} triangles; {} host threads, simd backend {}; truth: {truth}. Time: {} Error maps: \
         |visibility error| from black (0) through red to yellow ({HEATMAP_SCALE} and above), grey \
         where nothing is compared. Files beside this page: `bench.csv`, `bench.json`, `pareto.md`.",
        report.triangles, report.host_threads, report.simd_backend, report.timing
    ));
    r.figure("bench.png", "Median time against MAE, every row");
    let header: Vec<String> = [
        "algorithm",
        "setting",
        "median ms",
        "MAE",
        "RMSE",
        "p99",
        "penumbra MAE",
        "ꟻLIP",
        "ref ms at MAE",
        "ref ÷ it",
        "simulated ms",
        "Pareto",
    ]
    .map(String::from)
    .to_vec();
    let opt = |x: Option<f64>, digits: usize| x.map_or("–".to_string(), |v| format!("{v:.digits$}"));
    let rows: Vec<Vec<String>> = report
        .rows
        .iter()
        .map(|row| {
            let e = &row.error;
            vec![
                format!("`{}`", row.algorithm),
                row.setting.clone(),
                format!("{:.2}", row.median_ms),
                format!("{:.6}", e.mae),
                format!("{:.6}", e.rmse),
                format!("{:.6}", e.p99),
                format!("{:.6}", e.penumbra_mae),
                opt(e.flip, 5),
                opt(row.reference_ms_at_mae, 1),
                opt(row.reference_ms_at_mae.map(|t| t / row.median_ms), 2),
                opt(row.sim_ms, 2),
                if row.pareto { "yes".into() } else { String::new() },
            ]
        })
        .collect();
    r.heading(2, "Every row").table(&header, &rows);
    r.heading(2, "The Pareto front")
        .markdown(&pareto_markdown(report), 3);
    let mut pictures = vec![Picture {
        caption: format!("truth ({truth})"),
        src: truth_picture.to_string(),
        below: None,
    }];
    pictures.extend(report.rows.iter().filter_map(|row| {
        row.image.as_ref().map(|src| Picture {
            caption: format!(
                "{} {} — {:.2} ms, MAE {:.4}",
                row.algorithm, row.setting, row.median_ms, row.error.mae
            ),
            src: src.clone(),
            below: row.error_image.clone(),
        })
    }));
    if pictures.len() > 1 {
        r.heading(2, "Flip between two images")
            .paragraph("Choose A and B; click the image or press the space bar to swap them.");
        let flips: Vec<Picture> = pictures
            .iter()
            .map(|p| Picture {
                below: None,
                ..p.clone()
            })
            .collect();
        r.flipper(&flips);
        r.heading(2, "Every image beside the truth, with its error map")
            .gallery(&pictures);
    }
    r.write(&out.join("report.html"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_at_error_interpolates_log_log_inside_the_curve_only() {
        // MAE halves while time quadruples: MAE ∝ t^-1/2.
        let curve = [(0.04, 10.0), (0.02, 40.0), (0.01, 160.0)];
        let t = time_at_error(&curve, 0.02 / 2f64.sqrt()).unwrap();
        assert!((t - 80.0).abs() < 1e-9, "{t}");
        assert_eq!(time_at_error(&curve, 0.04), Some(10.0));
        assert_eq!(time_at_error(&curve, 0.01), Some(160.0));
        assert_eq!(time_at_error(&curve, 0.05), None);
        assert_eq!(time_at_error(&curve, 0.005), None);
        assert_eq!(time_at_error(&curve, 0.0), None);
        assert_eq!(time_at_error(&curve, f64::NAN), None);
    }

    #[test]
    fn pareto_front_keeps_rows_no_other_beats_on_both() {
        let row = |ms: f64, mae: f64| BenchRow {
            algorithm: "a".into(),
            family: "f".into(),
            setting: String::new(),
            label: String::new(),
            params: String::new(),
            times_ms: vec![ms],
            median_ms: ms,
            error: ErrorReport {
                mae,
                ..Default::default()
            },
            reference_ms_at_mae: None,
            sim_ms: None,
            pareto: false,
            image: None,
            error_image: None,
        };
        let mut rows = vec![
            row(10.0, 0.05),
            row(20.0, 0.01),
            row(20.0, 0.02), // slower than nothing faster, but (20, 0.01) beats it
            row(5.0, 0.1),
            row(30.0, 0.01), // (20, 0.01) is as good and faster
            row(f64::NAN, 0.0),
        ];
        mark_pareto(&mut rows);
        let front: Vec<bool> = rows.iter().map(|r| r.pareto).collect();
        assert_eq!(front, [true, true, false, true, false, false]);
    }

    #[test]
    fn median_of_odd_and_even() {
        assert_eq!(crate::metrics::median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(crate::metrics::median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
    }

    #[test]
    fn candidates_sweep_sorted_then_sism() {
        let c = candidates(
            &[("spp", vec!["64".into(), "4".into(), "16".into(), "4".into()])],
            None,
        )
        .unwrap();
        let names: Vec<_> = c.iter().map(|c| (c.algorithm.name, c.setting.as_str())).collect();
        assert_eq!(
            names,
            [
                ("reference", "4"),
                ("reference", "16"),
                ("reference", "64"),
                ("sism", "-"),
                ("sism-independent", "-"),
                ("sism-sampled", "-"),
                ("shadow-map", "512"),
                ("shadow-map", "1024"),
                ("shadow-map", "2048"),
                ("shadow-map", "4096"),
                ("pcf", "3"),
                ("pcf", "9"),
                ("pcf", "17"),
                ("pcss", "16"),
                ("pcss", "64"),
                ("smsr", "512"),
                ("smsr", "1024"),
                ("smsr", "2048"),
                ("smsr", "4096"),
                ("rsmss", "512"),
                ("rsmss", "1024"),
                ("rsmss", "2048"),
                ("rsmss", "4096"),
                ("rpcf-smsr", "-"),
                ("rpcf-rsmss", "2"),
                ("rpcf-rsmss", "4"),
                ("light-samples", "4"),
                ("light-samples", "8"),
                ("light-samples", "17"),
                ("rb-adaptive", "3"),
                ("rb-adaptive", "4"),
                ("gaussian-pcf", "-"),
                ("gaussian-single", "-"),
                ("gaussian-multi", "-"),
                ("ssmm-v2", "2"),
                ("ssmm-v2", "4"),
                ("ssmm-v2", "9"),
                ("ssmm", "2"),
                ("ssmm", "4"),
                ("ssmm", "9"),
            ]
        );
    }
}
