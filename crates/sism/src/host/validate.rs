//! `sism validate`: the machine model checked against the one chip we can measure.
//!
//! A frame is rendered natively on the host (a warm-up frame, then the median of `frames` frames'
//! per-phase wall times, on a pool of `t` host threads) and once under the counting context; its
//! records are replayed on the host's model (a fitted machine file from `sism calibrate`, or the
//! `host` preset) with `cores = t`, and the model's per-phase milliseconds are set against the
//! measured ones. The records do not depend on the host's thread count, so one counted frame serves
//! every thread count.

use rayon::ThreadPoolBuilder;

use crate::algorithms::{Algorithm, Params, PreparedScene};
use crate::exec::Exec;
use crate::machine::{self, MachineConfig};
use crate::render::{self, RenderOptions};
use crate::scene::Scene;
use crate::stats::StatsReport;

/// The major phases validation scores (eye pass, grid, umbra, penumbra), where a frame has them.
pub const MAJOR_PHASES: &[&str] = &["eye_pass", "grid", "umbra", "penumbra"];

/// One phase (or step, or the frame) predicted against measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Scene name (file stem).
    pub scene: String,
    /// The algorithm's name.
    pub algorithm: String,
    /// Host threads of the native run = cores of the model.
    pub threads: u32,
    /// `frame`, a phase (`grid`) or a step (`grid.classify`).
    pub phase: String,
    /// Median native host time, ms.
    pub measured_ms: f64,
    /// The model's time, ms (`None`: the phase ran no kernel, the model does not time it).
    pub predicted_ms: Option<f64>,
}

impl Row {
    /// (predicted − measured) / measured, or `None` when either is missing or measured is 0.
    pub fn error(&self) -> Option<f64> {
        let p = self.predicted_ms?;
        (self.measured_ms > 0.0).then(|| (p - self.measured_ms) / self.measured_ms)
    }
    /// A phase (not a step, not the frame) of [`MAJOR_PHASES`]?
    pub fn is_major(&self) -> bool {
        MAJOR_PHASES.contains(&self.phase.as_str())
    }
}

/// Validates one scene and algorithm: rows per thread count in `threads` (each 1..=host threads
/// allowed by rayon), phases in frame order, then their steps, then `frame`. `frames` ≥ 1 native
/// frames are timed after one warm-up frame. `progress(label)` is called before each native run.
pub fn validate(
    scene: &Scene,
    algorithm: &Algorithm,
    params: &Params,
    model: &MachineConfig,
    threads: &[u32],
    frames: usize,
    progress: &dyn Fn(&str),
) -> crate::Result<Vec<Row>> {
    let name = scene
        .source
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    progress(&format!("{name} {} counted", algorithm.name));
    let prepared = PreparedScene::new(scene);
    let mut counted = render::render_prepared(
        &prepared,
        algorithm,
        params,
        &RenderOptions {
            exec: Exec::Counting,
            progress: false,
        },
    );
    let records = std::mem::take(&mut counted.records);
    drop(counted);
    let mut configs = Vec::with_capacity(threads.len());
    for &t in threads {
        let mut config = model.clone();
        config.cores = t;
        config
            .validate()
            .map_err(|(k, e)| crate::Error::invalid(format!("the model with {t} cores: `{k}` {e}")))?;
        configs.push(config);
    }
    // One replay per thread count, the records' lines decoded once for all of them.
    let reports = machine::sweep::run(&records, &configs, || ());
    let mut rows = Vec::new();
    for (&t, point) in threads.iter().zip(&reports) {
        let report = &point.report;
        progress(&format!("{name} {} native, {t} thread(s)", algorithm.name));
        let pool = ThreadPoolBuilder::new()
            .num_threads(t as usize)
            .build()
            .map_err(|e| crate::Error::External(format!("cannot start {t} host threads: {e}")))?;
        let times = pool.install(|| native_times(&prepared, algorithm, params, frames));
        let mut push = |phase: &str, measured: Option<f64>, predicted: Option<f64>| {
            if let Some(m) = measured {
                rows.push(Row {
                    scene: name.clone(),
                    algorithm: algorithm.name.to_string(),
                    threads: t,
                    phase: phase.to_string(),
                    measured_ms: m,
                    predicted_ms: predicted,
                });
            }
        };
        let measured = |phase: &str| {
            let key = format!("time.{phase}");
            median(times.iter().filter_map(|f| f.stats.get(&key)))
        };
        // Phases in the native frame's order; the model's group when it has one.
        let order = times.first().map(|f| f.order.clone()).unwrap_or_default();
        for phase in order.iter().filter(|p| !p.contains('.')) {
            push(
                phase,
                measured(phase),
                report.groups.iter().find(|g| g.phase == *phase).map(|g| g.ms),
            );
        }
        for step in report.phases.iter().filter(|p| p.phase.contains('.')) {
            push(&step.phase, measured(&step.phase), Some(step.ms));
        }
        // The frame: only the phases the model times, so an untimed phase is not a model error.
        let timed: Vec<&String> = order
            .iter()
            .filter(|p| !p.contains('.') && report.groups.iter().any(|g| g.phase == **p))
            .collect();
        let frame_measured = median(times.iter().map(|f| {
            timed
                .iter()
                .filter_map(|p| f.stats.get(&format!("time.{p}")))
                .sum::<f64>()
        }));
        push("frame", frame_measured, Some(report.frame.ms));
    }
    Ok(rows)
}

/// One native frame's stats (its `time.*` rows, ms) and the order of its phases and steps.
struct FrameTimes {
    stats: StatsReport,
    /// Phase and step names in the order the frame reported them.
    order: Vec<String>,
}

/// `frames` native frames after one warm-up, on the current rayon pool.
fn native_times(
    prepared: &PreparedScene<'_>,
    algorithm: &Algorithm,
    params: &Params,
    frames: usize,
) -> Vec<FrameTimes> {
    let opts = RenderOptions {
        exec: Exec::Native,
        progress: false,
    };
    let _ = render::render_prepared(prepared, algorithm, params, &opts);
    (0..frames.max(1))
        .map(|_| {
            let stats = render::render_prepared(prepared, algorithm, params, &opts).stats;
            let order = stats
                .stats
                .iter()
                .filter_map(|s| s.name.strip_prefix("time."))
                .filter(|k| !matches!(*k, "frame" | "total" | "prepare_scene" | "bvh_build"))
                .map(str::to_string)
                .collect();
            FrameTimes { stats, order }
        })
        .collect()
}

/// The median of `values` ([`crate::metrics::median`]), `None` when there are none.
fn median(values: impl Iterator<Item = f64>) -> Option<f64> {
    let v: Vec<f64> = values.collect();
    (!v.is_empty()).then(|| crate::metrics::median(&v))
}

/// `validate.csv`: one row per scene, algorithm, thread count and phase.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from("scene,algorithm,threads,phase,measured_ms,predicted_ms,error\n");
    for r in rows {
        s += &format!(
            "{},{},{},{},{:.4},{},{}\n",
            r.scene,
            r.algorithm,
            r.threads,
            r.phase,
            r.measured_ms,
            r.predicted_ms.map(|p| format!("{p:.4}")).unwrap_or_default(),
            r.error().map(|e| format!("{e:.4}")).unwrap_or_default()
        );
    }
    s
}

/// The validation table in Markdown: per scene, algorithm and thread count one line with the major
/// phases and the frame (predicted / measured ms and the error), and a summary of how many are within
/// `tolerance` (0.25 = ±25%).
pub fn markdown(rows: &[Row], tolerance: f64) -> String {
    let mut keys: Vec<(String, String, u32)> = Vec::new();
    for r in rows {
        let k = (r.scene.clone(), r.algorithm.clone(), r.threads);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let cols: Vec<&str> = MAJOR_PHASES.iter().copied().chain(["frame"]).collect();
    let mut s = String::from("| scene | algorithm | threads |");
    for c in &cols {
        s += &format!(" {c} model / host ms (error) |");
    }
    s += "\n|---|---|---|";
    for _ in &cols {
        s += "---|";
    }
    s += "\n";
    let (mut within, mut total) = (0, 0);
    for (scene, algo, t) in &keys {
        s += &format!("| {scene} | `{algo}` | {t} |");
        for c in &cols {
            let cell = rows
                .iter()
                .find(|r| &r.scene == scene && &r.algorithm == algo && r.threads == *t && r.phase == *c);
            match cell.and_then(|r| Some((r, r.predicted_ms?, r.error()?))) {
                Some((r, p, e)) => {
                    total += 1;
                    let ok = e.abs() <= tolerance;
                    within += ok as usize;
                    s += &format!(
                        " {p:.1} / {:.1} ({:+.0}%){} |",
                        r.measured_ms,
                        100.0 * e,
                        if ok { "" } else { " ✗" }
                    );
                }
                None => s += " – |",
            }
        }
        s += "\n";
    }
    s += &format!(
        "\n{within} of {total} figures (major phases and frames) within ±{:.0}%; ✗ marks the others.\n",
        100.0 * tolerance
    );
    s
}
