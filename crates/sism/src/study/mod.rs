//! Architecture studies: one frame counted once, re-timed on many machines (cores, threads per core,
//! L2 size around a base machine); the points, `study.csv` and the plots `speedup.png` and
//! `phases.png`.
//!
//! Two backends share everything but where the replays run: in this process ([`run_local`]), or as
//! a study directory replayed by a job array ([`slurm`]: manifest, records, one machine file per
//! point, a job script, the tasks' results, and `collect`'s merge, with the scheduler behind the
//! [`scheduler::Scheduler`] trait). Both end in [`write_outputs`], from [`Point`]s, so `study.csv`
//! is the same bytes either way.

mod report;
pub mod scheduler;
pub mod sensitivity;
pub mod slurm;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::machine::sweep::{self, SweepPoint};
use crate::machine::{CanonicalRecords, MachineConfig, PhaseReport};
use crate::output::plots::study as plots;

/// Replays `records` on every configuration in this process (`on_point` after each), as points in
/// sweep order.
pub fn run_local(
    records: &CanonicalRecords,
    configs: &[MachineConfig],
    set_keys: &[String],
    on_point: impl Fn() + Sync,
) -> Vec<Point> {
    sweep::run(records, configs, on_point)
        .iter()
        .enumerate()
        .map(|(i, p)| Point::new(i, p, set_keys))
        .collect()
}

/// One swept machine parameter's value at a point (`study --set`), as the machine file writes it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Setting {
    /// The machine-file key.
    pub key: String,
    /// Its value.
    pub value: String,
}

/// The values of `keys` in `m` (keys that are not parameters are skipped: callers pass checked keys).
pub fn settings(m: &MachineConfig, keys: &[String]) -> Vec<Setting> {
    keys.iter()
        .filter_map(|k| crate::machine::params::find(k).ok())
        .map(|p| Setting {
            key: p.name.to_string(),
            value: crate::machine::params::get(m, &p),
        })
        .collect()
}

/// What the plots' titles name: the scene (its file's stem) and the image size.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Label {
    /// The scene's name (its file's stem).
    pub name: String,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
}

/// One simulated configuration as the study's outputs need it: what `study.csv`, the plots and the
/// table read, and what a Slurm array task writes to its result file (floats round-trip exactly
/// through JSON, so a point read back writes the same bytes as the point computed).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Point {
    /// Position in the sweep (the manifest's point index).
    pub index: usize,
    /// The configuration's name (`<base>-c<cores>-t<threads>-l2<kb>`).
    pub name: String,
    /// Cores.
    pub cores: u32,
    /// Hardware threads per core.
    pub threads: u32,
    /// L2 subset size per core, KB.
    pub l2_kb: u32,
    /// The other swept parameters' values (`study --set`), in the order given.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub set: Vec<Setting>,
    /// Clock, GHz.
    pub clock_ghz: f64,
    /// One row per step, in frame order.
    pub steps: Vec<Row>,
    /// One row per phase (its steps' group), in frame order.
    pub groups: Vec<Row>,
    /// The frame's totals.
    pub frame: Row,
}

/// One step, phase or frame of a [`Point`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Row {
    /// `frame`, a phase (`grid`) or a step (`grid.classify`).
    pub phase: String,
    /// Tasks replayed.
    pub tasks: u64,
    /// Cycles from the start to the end of the barrier.
    pub cycles: u64,
    /// `cycles` at the clock, ms.
    pub ms: f64,
    /// Where the cycles went.
    pub stack: Stack,
    /// Average fraction of the vector lanes active per vector instruction, in [0, 1].
    pub lane_utilisation: f64,
    /// L1 misses per access (0 with no access).
    pub l1_miss_rate: f64,
    /// L2 misses per L2 lookup (0 with no lookup).
    pub l2_miss_rate: f64,
    /// Bytes moved between DRAM and L2 (fills and write-backs).
    pub bytes_dram: u64,
    /// Bytes filled into the L1s from the L2 subsets (L1 misses × line), for the roofline.
    pub bytes_l2: u64,
    /// Vector lane operations executed (arithmetic instructions × active lanes), for the roofline.
    pub lane_ops: f64,
}

/// A row's cycle stack (as [`crate::machine::CycleStack`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stack {
    /// Cycles issuing instructions.
    pub issue: u64,
    /// Cycles of memory stalls not hidden by other threads, and of DRAM bandwidth limits.
    pub memory: u64,
    /// Cycles of vector atomics (with conflicts) and the phase-end barrier.
    pub atomics_sync: u64,
    /// Cycles cores idle while the busiest core finishes (load imbalance), or with no work.
    pub imbalance_idle: u64,
}

impl Stack {
    /// Part names and values, in order.
    pub fn parts(&self) -> [(&'static str, u64); 4] {
        [
            ("issue", self.issue),
            ("memory", self.memory),
            ("atomics_sync", self.atomics_sync),
            ("imbalance_idle", self.imbalance_idle),
        ]
    }
}

impl Point {
    /// The point at `index` of a sweep whose other swept parameters are `set_keys`.
    pub fn new(index: usize, p: &SweepPoint, set_keys: &[String]) -> Point {
        let r = &p.report;
        let line = r.config.line_bytes;
        let row = |ph: &PhaseReport| Row {
            phase: ph.phase.clone(),
            tasks: ph.tasks,
            cycles: ph.cycles,
            ms: ph.ms,
            stack: Stack {
                issue: ph.stack.issue,
                memory: ph.stack.memory,
                atomics_sync: ph.stack.atomics_sync,
                imbalance_idle: ph.stack.imbalance_idle,
            },
            lane_utilisation: ph.lane_utilisation(),
            l1_miss_rate: ph.memory.l1_miss_rate(),
            l2_miss_rate: ph.memory.l2_miss_rate(),
            bytes_dram: ph.memory.dram_bytes(line),
            bytes_l2: ph.memory.l1_misses * line as u64,
            lane_ops: crate::machine::roofline::lane_ops(ph, &r.config),
        };
        Point {
            index,
            name: r.config.name.clone(),
            cores: p.cores,
            threads: p.threads,
            l2_kb: p.l2_kb,
            set: settings(&r.config, set_keys),
            clock_ghz: r.config.clock_ghz,
            steps: r.phases.iter().map(row).collect(),
            groups: r.groups.iter().map(row).collect(),
            frame: row(&r.frame),
        }
    }
}

/// Frame speedup of `p` over the smallest core count with the same threads, L2 size and other
/// swept values.
pub fn speedup(points: &[Point], p: &Point) -> f64 {
    let base = points
        .iter()
        .filter(|q| q.threads == p.threads && q.l2_kb == p.l2_kb && q.set == p.set)
        .min_by_key(|q| q.cores)
        .unwrap_or(p);
    base.frame.cycles as f64 / p.frame.cycles.max(1) as f64
}

/// The study's outputs in `out`, whichever backend computed `points` (in sweep order): `study.csv`,
/// `speedup.png`, `phases.png` and the roofline (`roofline.md`, `roofline.png`) of the base
/// machine's point, and `report.html` showing them. `machine_of` gives a point's machine (for the
/// roofline's ceilings).
pub fn write_outputs(
    out: &Path,
    label: &Label,
    base: &MachineConfig,
    points: &[Point],
    machine_of: &dyn Fn(&Point) -> crate::Result<MachineConfig>,
) -> crate::Result<()> {
    crate::output::write_atomic(&out.join("study.csv"), csv(points).as_bytes())?;
    plots::speedup(&out.join("speedup.png"), label, points)?;
    let table_point = points
        .iter()
        .find(|p| p.cores == base.cores && p.threads == base.threads_per_core && p.l2_kb == base.l2_kb)
        .or_else(|| points.iter().find(|p| p.cores == base.cores))
        .or(points.last())
        .ok_or_else(|| crate::Error::invalid("the sweep has no point"))?;
    plots::phases(&out.join("phases.png"), label, table_point)?;
    let machine = machine_of(table_point)?;
    let roof = crate::machine::roofline::points_of_study(table_point);
    let title = format!(
        "{} {}x{} on {}",
        label.name, label.width, label.height, machine.name
    );
    crate::machine::roofline::write_points(out, &title, &machine, &roof)?;
    report::write_study(out, label, base, points, table_point, &machine, &roof)
}

/// The study's table: frame time and speedup per point.
pub fn table(points: &[Point]) -> String {
    let keys: Vec<&str> = points
        .first()
        .map_or(Vec::new(), |p| p.set.iter().map(|s| s.key.as_str()).collect());
    let mut s = String::from("cores threads l2_kb");
    for k in &keys {
        s += &format!(" {k:>w$}", w = k.len().max(8));
    }
    s += "   frame_ms  speedup\n";
    for p in points {
        s += &format!("{:>5} {:>7} {:>5}", p.cores, p.threads, p.l2_kb);
        for (k, v) in keys.iter().zip(&p.set) {
            s += &format!(" {:>w$}", v.value, w = k.len().max(8));
        }
        s += &format!(" {:>10.3} {:>8.2}\n", p.frame.ms, speedup(points, p));
    }
    s.trim_end().to_string()
}

/// `study.csv`'s text: one row per configuration and step (plus `frame`).
/// The other swept parameters (`--set`) are columns after `l2_kb`, in the order given.
pub fn csv(points: &[Point]) -> String {
    let keys: String = points.first().map_or(String::new(), |p| {
        p.set.iter().map(|s| format!(",{}", s.key)).collect()
    });
    let mut s = format!(
        "cores,threads,l2_kb{keys},phase,tasks,cycles,ms,stack_issue,stack_memory,stack_atomics_sync,\
         stack_imbalance_idle,lane_utilisation,l1_miss_rate,l2_miss_rate,bytes_dram,frame_speedup\n",
    );
    for p in points {
        let sp = speedup(points, p);
        let values: String = p.set.iter().map(|s| format!(",{}", s.value)).collect();
        for ph in p.steps.iter().chain(std::iter::once(&p.frame)) {
            s += &format!(
                "{},{},{}{},{},{},{},{:.6},{},{},{},{},{:.6},{:.6},{:.6},{},{:.6}\n",
                p.cores,
                p.threads,
                p.l2_kb,
                values,
                ph.phase,
                ph.tasks,
                ph.cycles,
                ph.ms,
                ph.stack.issue,
                ph.stack.memory,
                ph.stack.atomics_sync,
                ph.stack.imbalance_idle,
                ph.lane_utilisation,
                ph.l1_miss_rate,
                ph.l2_miss_rate,
                ph.bytes_dram,
                sp
            );
        }
    }
    s
}

#[cfg(test)]
mod tests;
