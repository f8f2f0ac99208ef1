//! `sism validate`: the machine model checked against the one chip we can measure.
//!
//! A scene's algorithms are each rendered once under the counting context; the records are
//! replayed on the host's model (a fitted machine file from `sism calibrate`, or the `host` preset)
//! with `cores = t` for each host thread count `t`. Their native frames are then timed on a pool of
//! `t` host threads, interleaved (a warm-up round, then `frames` rounds of one frame of every
//! algorithm), and each phase's median wall time is set against the model's milliseconds. The
//! records do not depend on the host's thread count, so one counted frame serves every thread count.
//! Work the model predicts the same in several algorithms (the eye pass) shows how far the host's
//! own speed moved during the run ([`shared_work`]).

use rayon::ThreadPoolBuilder;

use crate::algorithms::{Algorithm, Params, PreparedScene};
use crate::exec::Exec;
use crate::machine::{self, MachineConfig, MachineReport};
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

/// One algorithm of a scene's validation: the algorithm and its resolved parameters.
pub type Subject<'a> = (&'a Algorithm, Params);

/// Validates one scene's algorithms: rows per algorithm (in `algorithms`' order), per thread count
/// in `threads` (each 1..=host threads allowed by rayon), phases in frame order, then their steps,
/// then `frame`.
///
/// Each algorithm's frame is counted once and replayed for every thread count. The native frames
/// are then timed **interleaved**: per thread count, one warm-up round, then `frames` ≥ 1 rounds
/// of one frame of every algorithm in turn (each round starting one algorithm further on), and
/// each figure is the median over the rounds. A shared host's speed moves with its other tenants
/// over seconds to minutes: timed one algorithm after the other, a slow minute sinks whichever
/// algorithm it fell on (the same eye pass was seen to spread by a third across one scene's
/// algorithms); interleaved, it falls on one round of every algorithm and the median drops it.
///
/// `progress(label)` is called before each counted frame and each round (warm-up included):
/// [`progress_calls`] times.
pub fn validate_scene(
    scene: &Scene,
    algorithms: &[Subject<'_>],
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
    let configs = threads
        .iter()
        .map(|&t| model_for_threads(model, t))
        .collect::<crate::Result<Vec<_>>>()?;
    let prepared = PreparedScene::new(scene);
    // Per algorithm, the model's report per thread count. Records are dropped once replayed (a
    // counted frame's are hundreds of MB at 1600×1200).
    let mut reports: Vec<Vec<MachineReport>> = Vec::with_capacity(algorithms.len());
    for (algorithm, params) in algorithms {
        progress(&format!("{name} {} counted", algorithm.name));
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
        // One replay per thread count, the records' lines decoded once for all of them.
        let points = machine::sweep::run(&records, &configs, || ());
        reports.push(points.into_iter().map(|p| p.report).collect());
    }
    // Per thread count, per algorithm, the timed native frames.
    let mut times: Vec<Vec<Vec<FrameTimes>>> = Vec::with_capacity(threads.len());
    for &t in threads {
        let pool = ThreadPoolBuilder::new()
            .num_threads(t as usize)
            .build()
            .map_err(|e| crate::Error::External(format!("cannot start {t} host threads: {e}")))?;
        let round_progress = |round: usize| {
            progress(&format!(
                "{name} native, {t} thread(s), {}",
                if round == 0 {
                    "warm-up".to_string()
                } else {
                    format!("round {round} of {frames}")
                }
            ))
        };
        times.push(native_times_interleaved(
            &pool,
            &prepared,
            algorithms,
            frames,
            &round_progress,
        ));
    }
    let mut rows = Vec::new();
    for (a, (algorithm, _)) in algorithms.iter().enumerate() {
        for (k, &t) in threads.iter().enumerate() {
            rows.extend(rows_of(&name, algorithm.name, t, &reports[a][k], &times[k][a]));
        }
    }
    Ok(rows)
}

/// How many times [`validate_scene`] calls its `progress` for `algorithms` algorithms, `threads`
/// thread counts and `frames` timed rounds: a counted frame per algorithm, a warm-up and the
/// rounds (at least one) per thread count.
pub fn progress_calls(algorithms: usize, threads: usize, frames: usize) -> u64 {
    algorithms as u64 + threads as u64 * (rounds(frames) as u64 + 1)
}

/// The timed rounds of `frames`: at least one.
fn rounds(frames: usize) -> usize {
    frames.max(1)
}

/// The rows of one algorithm on `t` threads: its model `report` against its native frames' `times`.
fn rows_of(scene: &str, algorithm: &str, t: u32, report: &MachineReport, times: &[FrameTimes]) -> Vec<Row> {
    let mut rows = Vec::new();
    let mut push = |phase: &str, measured: Option<f64>, predicted: Option<f64>| {
        if let Some(m) = measured {
            rows.push(Row {
                scene: scene.to_string(),
                algorithm: algorithm.to_string(),
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
    // The work the model times in a phase, per native frame: its steps' time when it has steps
    // (the rest, allocation and merging between them, is the phase's outside line), else the
    // phase's.
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
    // A step that runs more than once in a frame (a depth map per cube face or per light point)
    // is one host figure, the sum of its runs: the model's runs are summed likewise.
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
    // The frame: the work the model times, so an untimed phase is not a model error; the timed
    // phases' work outside their steps is the frame's outside line.
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
    for r in &mut rows {
        r.major = !r.phase.contains('.')
            && r.phase != "frame"
            && r.predicted_ms.is_some()
            && r.measured_ms >= MAJOR_SHARE * frame_ms;
    }
    rows
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

/// Per algorithm, `frames` native frames on `pool`, timed interleaved: one warm-up
/// round, then `frames` rounds of one frame of every algorithm, round `r` starting at algorithm
/// `r mod n` (so that no algorithm always follows the same one). `progress(round)` is called
/// before each round, 0 being the warm-up.
fn native_times_interleaved(
    pool: &rayon::ThreadPool,
    prepared: &PreparedScene<'_>,
    algorithms: &[Subject<'_>],
    frames: usize,
    progress: &dyn Fn(usize),
) -> Vec<Vec<FrameTimes>> {
    let opts = RenderOptions {
        exec: Exec::Native,
        progress: false,
    };
    let n = algorithms.len();
    let mut times: Vec<Vec<FrameTimes>> = (0..n).map(|_| Vec::with_capacity(frames)).collect();
    for round in 0..=rounds(frames) {
        progress(round);
        for k in 0..n {
            let a = (round + k) % n;
            let (algorithm, params) = &algorithms[a];
            let stats = pool.install(|| render::render_prepared(prepared, algorithm, params, &opts).stats);
            if round == 0 {
                continue;
            }
            let order = stats
                .stats
                .iter()
                .filter_map(|s| s.name.strip_prefix("time."))
                .filter(|k| !matches!(*k, "frame" | "total" | "prepare_scene" | "bvh_build"))
                .map(str::to_string)
                .collect();
            times[a].push(FrameTimes { stats, order });
        }
    }
    times
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

/// Work the model predicts the same in several algorithms of one scene (the same phase on the same
/// thread count, the same predicted ms): the same code on the same input, such as the eye
/// pass, timed in each algorithm's frames. Its measured spread is the host's, not the model's.
#[derive(Clone, Debug, PartialEq)]
pub struct SharedWork {
    /// Scene name.
    pub scene: String,
    /// Host threads.
    pub threads: u32,
    /// The phase.
    pub phase: String,
    /// The algorithms it was timed in (at least two).
    pub algorithms: Vec<String>,
    /// The model's time, ms (the same for all of them).
    pub predicted_ms: f64,
    /// The least and the most measured host time, ms.
    pub measured_ms: (f64, f64),
}

impl SharedWork {
    /// max / min − 1 of the measured times (0 when they agree).
    pub fn spread(&self) -> f64 {
        let (lo, hi) = self.measured_ms;
        if lo > 0.0 {
            hi / lo - 1.0
        } else {
            0.0
        }
    }
}

/// The [`SharedWork`] in `rows`, in the order first seen. Two predictions are the same when they
/// agree to 1e-9 relative (they come from the same records replayed on the same model).
pub fn shared_work(rows: &[Row]) -> Vec<SharedWork> {
    let mut groups: Vec<SharedWork> = Vec::new();
    for r in rows {
        let Some(p) = r.predicted_ms else { continue };
        // Phases only, as scored: a step is a share of its phase's time and noisier.
        if r.phase == "frame" || r.phase.contains('.') || p <= 0.0 {
            continue;
        }
        let same = |g: &SharedWork| {
            g.scene == r.scene
                && g.threads == r.threads
                && g.phase == r.phase
                && (g.predicted_ms - p).abs() <= 1e-9 * p
        };
        match groups.iter_mut().find(|g| same(g)) {
            Some(g) => {
                if !g.algorithms.contains(&r.algorithm) {
                    g.algorithms.push(r.algorithm.clone());
                }
                g.measured_ms.0 = g.measured_ms.0.min(r.measured_ms);
                g.measured_ms.1 = g.measured_ms.1.max(r.measured_ms);
            }
            None => groups.push(SharedWork {
                scene: r.scene.clone(),
                threads: r.threads,
                phase: r.phase.clone(),
                algorithms: vec![r.algorithm.clone()],
                predicted_ms: p,
                measured_ms: (r.measured_ms, r.measured_ms),
            }),
        }
    }
    groups.retain(|g| g.algorithms.len() >= 2);
    groups
}

/// The host's consistency as a table: per [`SharedWork`] its measured range across the algorithms
/// and the spread (✗ beyond `tolerance`), with the largest spread as the closing line. A spread
/// beyond the tolerance says the host's speed moved during the run by more than the model is
/// asked to be right by; the rows it touches are the host's moment as much as the model's error.
/// Empty when no work is shared (one algorithm per scene).
pub fn shared_work_markdown(rows: &[Row], tolerance: f64) -> String {
    let groups = shared_work(rows);
    if groups.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "The same work timed in several algorithms (same scene, threads and phase, the same model \
         time): its spread across them is the host's, not the model's.\n\n\
         | scene | threads | phase | algorithms | model ms | host ms, least – most | spread |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for g in &groups {
        s += &format!(
            "| {} | {} | {} | {} | {:.2} | {:.2} – {:.2} | {:.0}%{} |\n",
            g.scene,
            g.threads,
            g.phase,
            g.algorithms.len(),
            g.predicted_ms,
            g.measured_ms.0,
            g.measured_ms.1,
            100.0 * g.spread(),
            if g.spread() > tolerance { " ✗" } else { "" }
        );
    }
    let worst = groups.iter().map(SharedWork::spread).fold(0.0, f64::max);
    let beyond = groups.iter().filter(|g| g.spread() > tolerance).count();
    s += &format!(
        "\nlargest spread of the same work: {:.0}%; {beyond} of {} beyond ±{:.0}%\n",
        100.0 * worst,
        groups.len(),
        100.0 * tolerance
    );
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

    fn row(algorithm: &str, phase: &str, measured: f64, predicted: f64) -> Row {
        Row {
            scene: "s".into(),
            algorithm: algorithm.into(),
            threads: 1,
            phase: phase.into(),
            measured_ms: measured,
            predicted_ms: Some(predicted),
            major: false,
        }
    }

    /// Shared work is the same phase with the same prediction in two or more algorithms; the
    /// frame, a step, a different prediction and a phase of one algorithm are not.
    #[test]
    fn shared_work_groups_the_same_prediction_across_algorithms() {
        let rows = vec![
            row("a", "eye_pass", 10.0, 9.0),
            row("b", "eye_pass", 13.0, 9.0),
            row("c", "eye_pass", 11.0, 9.0),
            row("a", "depth_map", 5.0, 4.0),
            row("b", "depth_map", 8.0, 6.0),
            row("a", "frame", 20.0, 19.0),
            row("b", "frame", 20.0, 19.0),
            row("c", "lookup", 3.0, 3.0),
            row("a", "eye_pass.tiles", 3.0, 2.0),
            row("b", "eye_pass.tiles", 6.0, 2.0),
        ];
        let groups = shared_work(&rows);
        assert_eq!(groups.len(), 1, "{groups:?}");
        let g = &groups[0];
        assert_eq!((g.phase.as_str(), g.algorithms.len()), ("eye_pass", 3));
        assert_eq!(g.measured_ms, (10.0, 13.0));
        assert!((g.spread() - 0.3).abs() < 1e-12);
        let md = shared_work_markdown(&rows, 0.25);
        assert!(
            md.contains("| s | 1 | eye_pass | 3 | 9.00 | 10.00 – 13.00 | 30% ✗ |"),
            "{md}"
        );
        assert!(
            md.trim_end()
                .ends_with("largest spread of the same work: 30%; 1 of 1 beyond ±25%"),
            "{md}"
        );
        assert_eq!(shared_work_markdown(&rows[3..5], 0.25), "");
    }

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
