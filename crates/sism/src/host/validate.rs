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

/// A phase the model times is *major* (scored beside the frame) when its measured time is at
/// least this share of the measured frame.
pub const MAJOR_SHARE: f64 = 0.10;

/// Suffix of the line that shows a phase's host work outside its steps (`grid.outside`).
pub const OUTSIDE: &str = "outside";

/// One phase (or step, or the frame) predicted against measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Scene name (file stem).
    pub scene: String,
    /// The algorithm's name.
    pub algorithm: String,
    /// Host threads of the native run = cores of the model.
    pub threads: u32,
    /// `frame`, a phase (`grid`), a step (`grid.classify`), or a phase's host work outside its
    /// steps (`grid.outside`, and `frame.outside` for the frame's).
    pub phase: String,
    /// Median native host time, ms.
    pub measured_ms: f64,
    /// The model's time, ms (`None`: the phase ran no kernel, or the line is host work outside
    /// the steps, which the model does not time).
    pub predicted_ms: Option<f64>,
    /// A major phase ([`MAJOR_SHARE`]); false for steps, frames and the outside lines.
    pub major: bool,
}

impl Row {
    /// (predicted − measured) / measured, or `None` when either is missing or measured is 0.
    pub fn error(&self) -> Option<f64> {
        let p = self.predicted_ms?;
        (self.measured_ms > 0.0).then(|| (p - self.measured_ms) / self.measured_ms)
    }
    /// A major phase ([`MAJOR_SHARE`]; not a step, not the frame)?
    pub fn is_major(&self) -> bool {
        self.major
    }
    /// Scored in the summary: a major phase or a frame, with a prediction.
    pub fn is_scored(&self) -> bool {
        (self.major || self.phase == "frame") && self.error().is_some()
    }
}

/// The summary of the scored rows ([`Row::is_scored`]): how many, how many within `tolerance`,
/// and the mean |error|.
pub fn summary(rows: &[Row], tolerance: f64) -> (usize, usize, f64) {
    let errors: Vec<f64> = rows
        .iter()
        .filter(|r| r.is_scored())
        .filter_map(Row::error)
        .collect();
    let within = errors.iter().filter(|e| e.abs() <= tolerance).count();
    let mean = if errors.is_empty() {
        0.0
    } else {
        errors.iter().map(|e| e.abs()).sum::<f64>() / errors.len() as f64
    };
    (errors.len(), within, mean)
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
    let configs = threads
        .iter()
        .map(|&t| model_for_threads(model, t))
        .collect::<crate::Result<Vec<_>>>()?;
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
        let first = rows.len();
        let mut push = |phase: &str, measured: Option<f64>, predicted: Option<f64>| {
            if let Some(m) = measured {
                rows.push(Row {
                    scene: name.clone(),
                    algorithm: algorithm.name.to_string(),
                    threads: t,
                    phase: phase.to_string(),
                    measured_ms: m,
                    predicted_ms: predicted,
                    major: false,
                });
            }
        };
        let measured = |phase: &str| {
            let key = format!("time.{phase}");
            median(times.iter().filter_map(|f| f.stats.get(&key)))
        };
        // The work the model times in a phase, per native frame: its steps' time when it has
        // steps (the rest, allocation and merging between them, is the phase's outside line),
        // else the phase's.
        let order = times.first().map(|f| f.order.clone()).unwrap_or_default();
        let steps_of = |phase: &str| -> Vec<String> {
            order
                .iter()
                .filter(|s| s.strip_prefix(phase).is_some_and(|rest| rest.starts_with('.')))
                .cloned()
                .collect()
        };
        let same_work = |f: &FrameTimes, phase: &str| -> Option<f64> {
            let steps = steps_of(phase);
            if steps.is_empty() {
                f.stats.get(&format!("time.{phase}"))
            } else {
                Some(
                    steps
                        .iter()
                        .filter_map(|s| f.stats.get(&format!("time.{s}")))
                        .sum(),
                )
            }
        };
        let phases: Vec<&String> = order.iter().filter(|p| !p.contains('.')).collect();
        let model_of = |phase: &str| report.groups.iter().find(|g| g.phase == phase).map(|g| g.ms);
        for phase in &phases {
            push(
                phase,
                median(times.iter().filter_map(|f| same_work(f, phase))),
                model_of(phase),
            );
            if !steps_of(phase).is_empty() {
                let outside = median(times.iter().filter_map(|f| {
                    Some((f.stats.get(&format!("time.{phase}"))? - same_work(f, phase)?).max(0.0))
                }));
                push(&format!("{phase}.{OUTSIDE}"), outside, None);
            }
        }
        // A step that runs more than once in a frame (a depth map per cube face or per light
        // point) is one host figure, the sum of its runs: the model's runs are summed likewise.
        let mut steps: Vec<(&str, f64)> = Vec::new();
        for step in report.phases.iter().filter(|p| p.phase.contains('.')) {
            match steps.iter_mut().find(|s| s.0 == step.phase) {
                Some(s) => s.1 += step.ms,
                None => steps.push((&step.phase, step.ms)),
            }
        }
        for (step, ms) in steps {
            push(step, measured(step), Some(ms));
        }
        // The frame: the work the model times, so an untimed phase is not a model error; the
        // timed phases' work outside their steps is the frame's outside line.
        let timed: Vec<&&String> = phases.iter().filter(|p| model_of(p).is_some()).collect();
        let frame_measured = median(
            times
                .iter()
                .map(|f| timed.iter().filter_map(|p| same_work(f, p)).sum::<f64>()),
        );
        let frame_outside = median(times.iter().map(|f| {
            timed
                .iter()
                .filter_map(|p| Some((f.stats.get(&format!("time.{p}"))? - same_work(f, p)?).max(0.0)))
                .sum::<f64>()
        }));
        push("frame", frame_measured, Some(report.frame.ms));
        push(&format!("frame.{OUTSIDE}"), frame_outside, None);
        // Major phases: timed, and at least MAJOR_SHARE of the frame.
        let frame_ms = frame_measured.unwrap_or(0.0);
        for r in &mut rows[first..] {
            r.major = !r.phase.contains('.')
                && r.phase != "frame"
                && r.predicted_ms.is_some()
                && r.measured_ms >= MAJOR_SHARE * frame_ms;
        }
    }
    Ok(rows)
}

/// `model` as the host run on `t` threads: `t` threads on cores of the model's `threads_per_core`
/// SMT threads (what [`validate`] predicts each thread count with).
pub fn model_for_threads(model: &MachineConfig, t: u32) -> crate::Result<MachineConfig> {
    let mut config = model.clone();
    let smt = model.threads_per_core.max(1);
    config.cores = t.div_ceil(smt);
    config.threads_per_core = smt.min(t);
    config
        .validate()
        .map_err(|(k, e)| crate::Error::invalid(format!("the model with {t} cores: `{k}` {e}")))?;
    Ok(config)
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

/// The host's moment as a table: per moment benchmark ([`super::calibrate::MOMENT_BENCHES`]) its
/// time in the machine file's calibration (`evidence`, when the file states it), at the start and
/// at the end of this run, ms, with the change against the calibration (else against the start).
/// A shared host's speed moves with its other tenants: an error the moment explains is not the
/// model's.
pub fn moment_markdown(evidence: &[(String, f64)], start: &[(&str, f64)], end: &[(&str, f64)]) -> String {
    let change = |now: f64, base: Option<f64>| match base {
        Some(b) if b > 0.0 => format!("{:.2} ({:+.0}%)", now / 1e6, 100.0 * (now / b - 1.0)),
        _ => format!("{:.2}", now / 1e6),
    };
    let mut s = String::from(
        "The host's moment: microbenchmarks of the calibration re-run at the start and the end of this \
         run, ms (change against the calibration where the machine file states it). A shared host's \
         speed moves with its other tenants; an error the moment explains is not the model's.\n\n\
         | benchmark | calibration | start | end |\n|---|---|---|---|\n",
    );
    for (name, t0) in start {
        let cal = evidence.iter().find(|(n, _)| n == name).map(|(_, ns)| *ns);
        let t1 = end.iter().find(|(n, _)| n == name).map(|(_, ns)| *ns);
        s += &format!(
            "| {name} | {} | {} | {} |\n",
            cal.map_or("–".to_string(), |c| format!("{:.2}", c / 1e6)),
            change(*t0, cal),
            t1.map_or("–".to_string(), |t| change(t, cal.or(Some(*t0)))),
        );
    }
    s
}

/// `validate.csv`: one row per scene, algorithm, thread count and phase.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from("scene,algorithm,threads,phase,major,measured_ms,predicted_ms,error\n");
    for r in rows {
        s += &format!(
            "{},{},{},{},{},{:.4},{},{}\n",
            r.scene,
            r.algorithm,
            r.threads,
            r.phase,
            r.major,
            r.measured_ms,
            r.predicted_ms.map(|p| format!("{p:.4}")).unwrap_or_default(),
            r.error().map(|e| format!("{e:.4}")).unwrap_or_default()
        );
    }
    s
}

/// The validation table in Markdown: per scene, algorithm and thread count one line with the major
/// phases (predicted / measured ms and the error), the frame, and the host's work outside the
/// steps (ms and share of the frame's); then the summary: how many of the scored figures are within
/// `tolerance` (0.25 = ±25%) and their mean |error|, as the last lines.
pub fn markdown(rows: &[Row], tolerance: f64) -> String {
    let mut keys: Vec<(String, String, u32)> = Vec::new();
    for r in rows {
        let k = (r.scene.clone(), r.algorithm.clone(), r.threads);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let mut s = String::from(
        "| scene | algorithm | threads | major phases: model / host ms (error) | frame: model / host ms (error) | outside the steps: host ms (share) |\n|---|---|---|---|---|---|\n",
    );
    let cell = |r: &Row| match (r.predicted_ms, r.error()) {
        (Some(p), Some(e)) => format!(
            "{p:.1} / {:.1} ({:+.0}%){}",
            r.measured_ms,
            100.0 * e,
            if e.abs() <= tolerance { "" } else { " ✗" }
        ),
        _ => "–".into(),
    };
    for (scene, algo, t) in &keys {
        let mine: Vec<&Row> = rows
            .iter()
            .filter(|r| &r.scene == scene && &r.algorithm == algo && r.threads == *t)
            .collect();
        let majors: Vec<String> = mine
            .iter()
            .filter(|r| r.major)
            .map(|r| format!("{} {}", r.phase, cell(r)))
            .collect();
        let frame = mine.iter().find(|r| r.phase == "frame");
        let outside = mine.iter().find(|r| r.phase == format!("frame.{OUTSIDE}"));
        let outside = match (outside, frame) {
            (Some(o), Some(f)) if f.measured_ms + o.measured_ms > 0.0 => format!(
                "{:.1} ({:.0}%)",
                o.measured_ms,
                100.0 * o.measured_ms / (f.measured_ms + o.measured_ms)
            ),
            _ => "–".into(),
        };
        s += &format!(
            "| {scene} | `{algo}` | {t} | {} | {} | {outside} |\n",
            if majors.is_empty() {
                "–".into()
            } else {
                majors.join("; ")
            },
            frame.map(|r| cell(r)).unwrap_or_else(|| "–".into()),
        );
    }
    let (total, within, mean) = summary(rows, tolerance);
    s += &format!(
        "\nScored: major phases (≥ {:.0}% of the frame) and frames; ✗ marks those outside ±{:.0}%.\n\
         mean |error|: {:.1}% over {total} figures\n\
         within ±{:.0}%: {within} of {total} ({:.0}%)\n",
        100.0 * MAJOR_SHARE,
        100.0 * tolerance,
        100.0 * mean,
        100.0 * tolerance,
        if total == 0 {
            0.0
        } else {
            100.0 * within as f64 / total as f64
        },
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The moment's changes are against the calibration where the file states it, else the start.
    #[test]
    fn moment_changes_against_the_calibration_or_the_start() {
        let start = [("alu", 1.5e6), ("scalar-mix", 3.0e6)];
        let end = [("alu", 2.0e6), ("scalar-mix", 1.5e6)];
        let evidence = vec![("alu".to_string(), 1.0e6)];
        let md = moment_markdown(&evidence, &start, &end);
        assert!(md.contains("| alu | 1.00 | 1.50 (+50%) | 2.00 (+100%) |"), "{md}");
        assert!(md.contains("| scalar-mix | – | 3.00 | 1.50 (-50%) |"), "{md}");
    }
}
