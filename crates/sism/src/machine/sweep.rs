//! Sweeps: one frame's records re-timed on many machines that vary cores, hardware threads per core
//! and L2 subset sizes around a base configuration (the work of `sism study`, without the rendering,
//! the files or the plots).

use rayon::prelude::*;

use super::{simulate, MachineConfig, MachineReport};
use crate::exec::PhaseRecords;

/// The axes of a sweep: every combination of the three lists (empty lists: the base's value).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SweepAxes {
    /// Core counts.
    pub cores: Vec<u32>,
    /// Hardware threads per core.
    pub threads: Vec<u32>,
    /// L2 subset sizes per core, KB.
    pub l2_kb: Vec<u32>,
}

/// One simulated configuration of a sweep.
#[derive(Clone, Debug)]
pub struct SweepPoint {
    /// Cores.
    pub cores: u32,
    /// Hardware threads per core.
    pub threads: u32,
    /// L2 subset size per core, KB.
    pub l2_kb: u32,
    /// The frame's simulation on this configuration.
    pub report: MachineReport,
}

/// The configurations of the sweep `axes` around `base`, threads outermost, cores innermost; each
/// named `<base>-c<cores>-t<threads>-l2<kb>` and validated (the error names the point and the key).
pub fn configurations(base: &MachineConfig, axes: &SweepAxes) -> Result<Vec<MachineConfig>, String> {
    let or_base = |v: &[u32], b: u32| if v.is_empty() { vec![b] } else { v.to_vec() };
    let cores = or_base(&axes.cores, base.cores);
    let threads = or_base(&axes.threads, base.threads_per_core);
    let l2s = or_base(&axes.l2_kb, base.l2_kb);
    // The count before anything is allocated: three long lists multiply.
    let count = [cores.len(), threads.len(), l2s.len()]
        .iter()
        .try_fold(1usize, |a, &n| a.checked_mul(n))
        .filter(|&n| n <= MAX_POINTS)
        .ok_or_else(|| {
            format!(
                "the sweep has {} × {} × {} points (cores × threads × L2 sizes); at most {MAX_POINTS} are accepted",
                cores.len(),
                threads.len(),
                l2s.len()
            )
        })?;
    debug_assert!(count >= 1);
    let mut out = Vec::with_capacity(cores.len() * threads.len() * l2s.len());
    for &t in &threads {
        for &l2 in &l2s {
            for &c in &cores {
                let mut m = base.clone();
                m.cores = c;
                m.threads_per_core = t;
                m.l2_kb = l2;
                m.name = format!("{}-c{c}-t{t}-l2{l2}", base.name);
                m.validate()
                    .map_err(|(k, msg)| format!("sweep point {}: `{k}` {msg}", m.name))?;
                out.push(m);
            }
        }
    }
    Ok(out)
}

/// Most points a sweep may have (the product of its axes' lengths): each is a replay of the frame.
pub const MAX_POINTS: usize = 10_000;

/// Line accesses up to which [`run`] decodes the records once and shares the ids between the
/// configurations (4 bytes each: 2 GiB at this bound); past it every configuration decodes the
/// streams itself, as a single replay does.
pub const MAX_DECODED_LINES: u64 = 1 << 29;

/// Times `records` on every configuration (in parallel on the host; each replay is deterministic),
/// calling `done` after each. The line streams are decoded once for all configurations (up to
/// [`MAX_DECODED_LINES`]). Points come back in the configurations' order.
pub fn run(records: &[PhaseRecords], configs: &[MachineConfig], done: impl Fn() + Sync) -> Vec<SweepPoint> {
    let lines: u64 = records.iter().flat_map(|p| &p.tasks).map(|t| t.lines.len()).sum();
    let decoded = (configs.len() > 1 && lines <= MAX_DECODED_LINES).then(|| super::decode(records));
    configs
        .par_iter()
        .map(|m| {
            let report = match &decoded {
                Some(d) => super::simulate_decoded(records, d, m),
                None => simulate(records, m),
            };
            done();
            SweepPoint {
                cores: m.cores,
                threads: m.threads_per_core,
                l2_kb: m.l2_kb,
                report,
            }
        })
        .collect()
}
