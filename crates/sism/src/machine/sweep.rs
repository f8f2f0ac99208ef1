//! Sweeps: one frame's records re-timed on many machines that vary cores, hardware threads per core,
//! L2 subset sizes and any other machine parameter ([`super::params`]) around a base configuration (the work of `sism study`, without the rendering,
//! the files or the plots).

use rayon::prelude::*;

use super::params::{self, Param};
use super::{simulate, MachineConfig, MachineReport};
use crate::exec::PhaseRecords;

/// The axes of a sweep: every combination of the lists (empty lists: the base's value), or with
/// `one_at_a_time` the base and each value of each axis alone.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SweepAxes {
    /// Core counts.
    pub cores: Vec<u32>,
    /// Hardware threads per core.
    pub threads: Vec<u32>,
    /// L2 subset sizes per core, KB.
    pub l2_kb: Vec<u32>,
    /// Any other machine parameters and their values (`study --set KEY=V1,V2`), in order.
    pub set: Vec<(Param, Vec<serde_json::Value>)>,
    /// The base machine and each value of each axis varied alone, instead of the cross product.
    pub one_at_a_time: bool,
}

impl SweepAxes {
    /// The keys of `set`, in order (what each point reports beside cores, threads and L2).
    pub fn set_keys(&self) -> Vec<String> {
        self.set.iter().map(|(p, _)| p.name.to_string()).collect()
    }
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

/// The configurations of the sweep `axes` around `base`: the cross product (threads outermost,
/// then L2, then the `set` keys in order, cores innermost), or one axis at a time after the base
/// itself. Each is named `<base>-c<cores>-t<threads>-l2<kb>` followed by `-<key><value>` per `set`
/// key, and validated (the error names the point and the key).
pub fn configurations(base: &MachineConfig, axes: &SweepAxes) -> Result<Vec<MachineConfig>, String> {
    let or_base = |v: &[u32], b: u32| if v.is_empty() { vec![b] } else { v.to_vec() };
    let cores = or_base(&axes.cores, base.cores);
    let threads = or_base(&axes.threads, base.threads_per_core);
    let l2s = or_base(&axes.l2_kb, base.l2_kb);
    let lengths: Vec<usize> = [cores.len(), threads.len(), l2s.len()]
        .into_iter()
        .chain(axes.set.iter().map(|(_, v)| v.len()))
        .collect();
    // The count before anything is allocated: long lists multiply.
    let count =
        if axes.one_at_a_time {
            lengths.iter().try_fold(1usize, |a, &n| a.checked_add(n))
        } else {
            lengths.iter().try_fold(1usize, |a, &n| a.checked_mul(n))
        }
        .filter(|&n| n <= MAX_POINTS)
        .ok_or_else(|| {
            let what = lengths
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(" × ");
            format!(
            "the sweep has {what} points (cores × threads × L2 sizes{}); at most {MAX_POINTS} are accepted",
            axes.set.iter().map(|(p, _)| format!(" × {}", p.name)).collect::<String>()
        )
        })?;
    let name = |m: &MachineConfig| {
        let mut n = format!("{}-c{}-t{}-l2{}", base.name, m.cores, m.threads_per_core, m.l2_kb);
        for (p, _) in &axes.set {
            n += &format!("-{}{}", p.name, params::get(m, p));
        }
        n
    };
    let finish = |mut m: MachineConfig| -> Result<MachineConfig, String> {
        m.name = name(&m);
        m.validate()
            .map_err(|(k, msg)| format!("sweep point {}: `{k}` {msg}", m.name))?;
        Ok(m)
    };
    let mut out = Vec::with_capacity(count);
    if axes.one_at_a_time {
        out.push(finish(base.clone())?);
        let mut vary = |f: &dyn Fn(&mut MachineConfig)| -> Result<(), String> {
            let mut m = base.clone();
            f(&mut m);
            out.push(finish(m)?);
            Ok(())
        };
        for &c in &axes.cores {
            vary(&|m| m.cores = c)?;
        }
        for &t in &axes.threads {
            vary(&|m| m.threads_per_core = t)?;
        }
        for &l2 in &axes.l2_kb {
            vary(&|m| m.l2_kb = l2)?;
        }
        for (p, values) in &axes.set {
            for v in values {
                let m = params::with(base, p, v).map_err(|e| format!("sweep point: {e}"))?;
                out.push(finish(m)?);
            }
        }
        return Ok(out);
    }
    // The `set` keys' combinations, first key outermost.
    let mut set_points: Vec<MachineConfig> = vec![base.clone()];
    for (p, values) in &axes.set {
        let mut next = Vec::with_capacity(set_points.len() * values.len());
        for m in &set_points {
            for v in values {
                next.push(params::with(m, p, v).map_err(|e| format!("sweep point: {e}"))?);
            }
        }
        set_points = next;
    }
    for &t in &threads {
        for &l2 in &l2s {
            for s in &set_points {
                for &c in &cores {
                    let mut m = s.clone();
                    m.cores = c;
                    m.threads_per_core = t;
                    m.l2_kb = l2;
                    out.push(finish(m)?);
                }
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
