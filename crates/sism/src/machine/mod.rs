//! The many-core machine model: replays the counting context's per-task records
//! ([`PhaseRecords`], one per barrier-separated step of a frame) on a configurable Larrabee-style
//! chip ([`MachineConfig`]) and reports simulated cycles, milliseconds, cycle stacks, lane utilisation
//! and cache behaviour per step, per phase (the steps' group, e.g. `grid` for `grid.classify`) and
//! per frame. See [`timing`] for the model's rules and [`cache`] for the caches.
//!
//! The model depends on the records and its configuration only, never on the renderer: records can
//! be saved to a file ([`save_records`]) and re-timed under another configuration without re-running
//! kernels ([`load_records`], `sism replay`), and a sweep ([`sweep`]) re-times one frame's records on
//! many machines.

pub mod cache;
pub mod config;
pub mod host;
pub mod params;
pub mod records;
pub mod roofline;
pub mod sweep;
pub mod timing;

use std::path::Path;

pub use config::MachineConfig;
pub use timing::{CycleStack, MemoryCounts, PhaseReport};

use crate::exec::{group_of, PhaseRecords};
use crate::stats::StatsReport;

/// A frame timed on a machine.
#[derive(Clone, Debug, PartialEq)]
pub struct MachineReport {
    /// The configuration used.
    pub config: MachineConfig,
    /// One report per step, in frame order (names `phase.step`, or `phase` for a one-step phase).
    pub phases: Vec<PhaseReport>,
    /// One report per phase: its steps summed (named by the phase), in frame order.
    pub groups: Vec<PhaseReport>,
    /// The frame's totals (sum of the steps).
    pub frame: PhaseReport,
}

/// Times the frame whose records are `records` on `config`. Deterministic: a function of the records
/// (line addresses enter only through their first-touch order) and the configuration.
pub fn simulate(records: &[PhaseRecords], config: &MachineConfig) -> MachineReport {
    let named = named(records);
    report(config, timing::simulate_frame(config, &named))
}

/// [`simulate`] and [`canonical`] of the same records in one pass: the replay's mapping stage gives
/// every line its first-touch id and stream state, which is what the records file holds, so the
/// records' first-touch form is encoded from the replay's own lines instead of mapping them all
/// again (`render --machine` on japanese-maple 800×600, Xeon VM: 4.3–4.7 s canonicalising beside a
/// 3.2–3.5 s replay). Both results equal the separate calls'.
pub fn simulate_canonical(
    records: &[PhaseRecords],
    config: &MachineConfig,
) -> (MachineReport, CanonicalRecords) {
    let named = named(records);
    let mut streams = Vec::with_capacity(records.iter().map(|p| p.tasks.len()).sum());
    let mut encoder = sism_simd::LineStreamEncoder::default();
    let phases = timing::simulate_frame_with(config, &named, |chunk, last| {
        for &x in chunk {
            // `id << 3 | stream << 1 | write` (`timing::LineMapper::map`).
            encoder.push(timing::canonical_line(x >> 3, (x >> 1) & 3), x & 1 == 1);
        }
        if last {
            streams.push(std::mem::take(&mut encoder).finish());
        }
    });
    let mut streams = streams.into_iter();
    let canonical =
        records::first_touch_form(records, |_, _| streams.next().expect("one line stream per task"));
    (report(config, phases), canonical)
}

/// [`simulate`] from the records' lines decoded once ([`decode`]): for re-timing one frame on many
/// machines (`study`), the same report without decoding the line streams for every machine.
pub fn simulate_decoded(
    records: &[PhaseRecords],
    lines: &timing::DecodedLines,
    config: &MachineConfig,
) -> MachineReport {
    let named = named(records);
    report(config, timing::simulate_decoded(config, &named, lines))
}

/// The records' line streams decoded into first-touch ids once (4 host bytes per line access).
pub fn decode(records: &[PhaseRecords]) -> timing::DecodedLines {
    timing::DecodedLines::decode(&named(records))
}

fn named(records: &[PhaseRecords]) -> Vec<timing::Step<'_>> {
    records
        .iter()
        .map(|p| timing::Step {
            name: p.phase.as_str(),
            tasks: &p.tasks[..],
            serial: p.serial,
            first_touch: p.first_touch,
        })
        .collect()
}

/// The frame's report from its steps' reports: steps grouped into phases, the frame's totals.
fn report(config: &MachineConfig, phases: Vec<PhaseReport>) -> MachineReport {
    let mut groups: Vec<PhaseReport> = Vec::new();
    for p in &phases {
        let g = group_of(&p.phase);
        match groups.last_mut() {
            Some(last) if last.phase == g => timing::add_phase(last, p),
            _ => {
                let mut first = timing::frame_total(std::slice::from_ref(p), config);
                first.phase = g.to_string();
                groups.push(first);
            }
        }
    }
    for g in &mut groups {
        g.ms = config.ms(g.cycles);
    }
    let frame = timing::frame_total(&phases, config);
    MachineReport {
        config: config.clone(),
        phases,
        groups,
        frame,
    }
}

impl MachineReport {
    /// The phase (a group of steps) or step named `name`.
    pub fn phase(&self, name: &str) -> Option<&PhaseReport> {
        self.groups.iter().chain(&self.phases).find(|p| p.phase == name)
    }

    /// Adds `machine.<phase>.*` (per phase: the group of its steps), `machine.<phase>.<step>.*` (per
    /// step of a phase of several) and `machine.frame.*` counters (cycles, ms, the cycle stack, lane
    /// utilisation, miss rates, bytes moved) and the machine's facts.
    pub fn add_to(&self, stats: &mut StatsReport) {
        let c = &self.config;
        stats
            .fact("machine", &c.name)
            .fact("machine.cores", c.cores)
            .fact("machine.clock_ghz", c.clock_ghz);
        let steps = self.phases.iter().filter(|p| p.phase.contains('.'));
        for p in self
            .groups
            .iter()
            .chain(steps)
            .chain(std::iter::once(&self.frame))
        {
            let name = &p.phase;
            let key = |k: &str| format!("machine.{name}.{k}");
            let what = if name == "frame" {
                "whole frame".to_string()
            } else if name.contains('.') {
                format!("step {name}")
            } else {
                format!("phase {name}")
            };
            stats
                .stat(
                    &key("cycles"),
                    p.cycles as f64,
                    "cycles",
                    &format!("{what}: simulated core cycles, including the barriers"),
                )
                .stat(
                    &key("ms"),
                    p.ms,
                    "ms",
                    &format!("{what}: simulated time at {} GHz on {}", c.clock_ghz, c.name),
                );
            for (part, v) in p.stack.parts() {
                let desc = match part {
                    "issue" => "issuing instructions (average core)",
                    "memory" => "memory stalls not hidden by other threads, DRAM bandwidth",
                    "atomics_sync" => "vector atomics, conflicts and the barrier",
                    _ => "idle: waiting for the busiest core (load imbalance) or no task",
                };
                stats.stat(
                    &key(&format!("stack.{part}")),
                    v as f64,
                    "cycles",
                    &format!("{what}: cycle stack, {desc}"),
                );
            }
            let line = c.line_bytes;
            stats
                .stat(
                    &key("tasks"),
                    p.tasks as f64,
                    "tasks",
                    &format!("{what}: tasks replayed"),
                )
                .stat(
                    &key("instructions"),
                    p.counters.instructions() as f64,
                    "instructions",
                    &format!("{what}: instructions of every class"),
                )
                .stat(
                    &key("lane_utilisation"),
                    p.lane_utilisation(),
                    "fraction",
                    &format!("{what}: active lanes per vector instruction / 16"),
                )
                .stat(
                    &key("branch_mispredicts"),
                    p.counters.branch_mispredicts as f64,
                    "branches",
                    &format!(
                        "{what}: counted branches the predictor model missed, {} cycles each",
                        c.mispredict_cycles
                    ),
                )
                .stat(
                    &key("line_accesses"),
                    p.memory.accesses as f64,
                    "accesses",
                    &format!("{what}: cache-line accesses replayed through L1"),
                )
                .stat(
                    &key("l1_miss_rate"),
                    p.memory.l1_miss_rate(),
                    "fraction",
                    &format!("{what}: L1 misses per line access"),
                )
                .stat(
                    &key("l2_miss_rate"),
                    p.memory.l2_miss_rate(),
                    "fraction",
                    &format!("{what}: L2 misses per L2 lookup"),
                )
                .stat(
                    &key("bytes_l2_to_l1"),
                    p.memory.l2_to_l1_bytes(line) as f64,
                    "bytes",
                    &format!("{what}: bytes filled into L1 from L2"),
                )
                .stat(
                    &key("bytes_dram"),
                    p.memory.dram_bytes(line) as f64,
                    "bytes",
                    &format!("{what}: bytes between DRAM and L2 (fills and write-backs)"),
                );
        }
    }

    /// A short human-readable table: per phase (and, indented, per step of a phase of several) ms,
    /// share of the frame, cycle stack and lane utilisation.
    pub fn to_table(&self) -> String {
        let mut s = format!(
            "{} ({} cores, {} threads/core, {} GHz)\n{:<24} {:>10} {:>7} {:>12} {:>12} {:>12} {:>12} {:>6}\n",
            self.config.name,
            self.config.cores,
            self.config.threads_per_core,
            self.config.clock_ghz,
            "phase",
            "ms",
            "share",
            "issue",
            "memory",
            "atom+sync",
            "imbal+idle",
            "lanes"
        );
        let row = |label: &str, p: &PhaseReport| {
            format!(
                "{:<24} {:>10.3} {:>6.1}% {:>12} {:>12} {:>12} {:>12} {:>5.0}%\n",
                label,
                p.ms,
                100.0 * p.cycles as f64 / self.frame.cycles.max(1) as f64,
                p.stack.issue,
                p.stack.memory,
                p.stack.atomics_sync,
                p.stack.imbalance_idle,
                100.0 * p.lane_utilisation()
            )
        };
        for g in &self.groups {
            s += &row(&g.phase, g);
            let steps: Vec<&PhaseReport> = self
                .phases
                .iter()
                .filter(|p| p.phase.contains('.') && group_of(&p.phase) == g.phase)
                .collect();
            if steps.len() > 1 {
                for p in steps {
                    s += &row(&format!("  {}", &p.phase[g.phase.len() + 1..]), p);
                }
            }
        }
        s += &row("frame", &self.frame);
        s
    }
}

/// Writes the resolved configuration as `machine.toml` into `dir`.
pub fn write_config(dir: &Path, config: &MachineConfig) -> crate::Result<()> {
    let path = dir.join("machine.toml");
    crate::output::write_atomic(&path, config.to_toml().as_bytes())
}

pub use records::{canonical, load_records, parse_records, save_records, CanonicalRecords};
