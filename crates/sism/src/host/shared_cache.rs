//! How much of the shared (last-level) cache this host's threads actually get, measured.
//!
//! `/sys` reports the shared cache the chip has (32 MiB on the project's Zen 4 VM), not what a
//! guest gets of it: other tenants' cores share it. A dependent walk over random lines of a buffer
//! (each load's address is the previous load's value, so nothing overlaps) costs the shared cache's
//! latency while the buffer fits and DRAM's once it does not. On the Zen 4 VM, with the same
//! binary, minutes apart: 2 MiB 14 ns a load, 4 MiB 16 ns, 8 MiB 113 ns, 16 MiB 140 ns, 128 MiB
//! 162 ns (transparent huge pages or not: not the TLB). The calibration's shared-cache benchmark had
//! run on half the `/sys` size (16 MiB), so it fitted the shared cache's latency at 138 cycles one
//! hour and 368 (DRAM's) the next, and the model kept 32 MiB of it. [`probe`] finds the
//! working set at which half the loads miss (rounded to a power of two); `sism calibrate` models that
//! capacity and sizes its shared-cache benchmarks by it.

use std::hint::black_box;
use std::time::Instant;

/// One point of the walk: working set and time per load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WalkPoint {
    /// Working set, KiB.
    pub kb: u32,
    /// Median time of a dependent load, ns.
    pub ns: f64,
}

/// What [`probe`] measured.
#[derive(Clone, Debug, PartialEq)]
pub struct SharedCacheProbe {
    /// The shared cache `/sys` reports, KiB.
    pub reported_kb: u32,
    /// The walk's points, smallest working set first; the last is the DRAM reference.
    pub points: Vec<WalkPoint>,
    /// The working set (a power of two, KiB, at most `reported_kb`) at which loads cost halfway
    /// from the smallest working set's to DRAM's ([`effective`]): the capacity the model gets.
    /// `None` when the walk makes no sense (DRAM as fast as the smallest working set or faster).
    pub effective_kb: Option<u32>,
}

impl SharedCacheProbe {
    /// One line for the machine file's header.
    pub fn describe(&self) -> String {
        let points: Vec<String> = self
            .points
            .iter()
            .map(|p| format!("{} KiB {:.0} ns", p.kb, p.ns))
            .collect();
        let effective = self
            .effective_kb
            .map_or("none".to_string(), |kb| format!("{kb} KiB"));
        format!(
            "shared cache: {} KiB reported, {effective} measured (dependent random loads: {})",
            self.reported_kb,
            points.join(", ")
        )
    }
}

/// Walks random lines of buffers from twice the private cache (`l2_kb`, KiB, rounded up to a power
/// of two) up to the reported shared cache (`l3_kb`, KiB) in powers of two, then one of
/// `max(4 × l3_kb, 64 MiB)` for DRAM; a few seconds in all. `None` without a shared cache.
pub fn probe(l2_kb: u32, l3_kb: u32) -> Option<SharedCacheProbe> {
    if l3_kb == 0 {
        return None;
    }
    let first = (2 * l2_kb.max(1)).next_power_of_two();
    let mut sizes: Vec<u32> = std::iter::successors(Some(first), |&k| k.checked_mul(2))
        .take_while(|&k| k <= l3_kb)
        .collect();
    if sizes.is_empty() {
        return None;
    }
    sizes.push(l3_kb.saturating_mul(4).max(64 << 10));
    let points: Vec<WalkPoint> = sizes
        .iter()
        .map(|&kb| WalkPoint {
            kb,
            ns: walk_ns(kb as usize * 1024),
        })
        .collect();
    let effective_kb = effective(&points);
    Some(SharedCacheProbe {
        reported_kb: l3_kb,
        points,
        effective_kb,
    })
}

/// The working set at which the walk's time crosses halfway from the first point's to the last's
/// (the DRAM reference): where about half the loads miss. Interpolated on a log scale between the
/// last point below and the first above, rounded to the nearest power of two, at most the largest
/// working set walked (the reference excluded).
pub fn effective(points: &[WalkPoint]) -> Option<u32> {
    let (near, far) = (points.first()?.ns, points.last()?.ns);
    if far <= near || points.len() < 2 {
        return None;
    }
    let limit = near + (far - near) / 2.0;
    let walked = &points[..points.len() - 1];
    let Some(above) = walked.iter().position(|p| p.ns > limit) else {
        return walked.last().map(|p| p.kb);
    };
    if above == 0 {
        return Some(walked[0].kb);
    }
    let (a, b) = (walked[above - 1], walked[above]);
    let share = (limit - a.ns) / (b.ns - a.ns);
    let log_kb = (a.kb as f64).log2() + share * ((b.kb as f64).log2() - (a.kb as f64).log2());
    Some(1u32 << (log_kb.round() as u32).min(31))
}

/// Median ns of a dependent load over one random cyclic order of the 64-byte lines of a `bytes`
/// buffer (three timed runs after a warm lap).
fn walk_ns(bytes: usize) -> f64 {
    const LINE_WORDS: usize = 8;
    let lines = (bytes / 64).max(2);
    // A random cycle through every line (Sattolo's shuffle), seeded: the same walk every run.
    let mut order: Vec<u32> = (0..lines as u32).collect();
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for i in (1..lines).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        order.swap(i, (state % i as u64) as usize);
    }
    let mut next = vec![0u64; lines * LINE_WORDS];
    for (k, &line) in order.iter().enumerate() {
        let to = order[(k + 1) % lines];
        next[line as usize * LINE_WORDS] = to as u64 * LINE_WORDS as u64;
    }
    drop(order);
    // A warm lap (pages, caches), then runs of at least 1M loads and ~30 ms.
    let mut p = 0u64;
    for _ in 0..lines {
        p = next[p as usize];
    }
    let loads = lines.clamp(1 << 20, 4 << 20);
    let mut times: Vec<f64> = (0..3)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..loads {
                p = next[p as usize];
            }
            t.elapsed().as_secs_f64() * 1e9 / loads as f64
        })
        .collect();
    black_box(p);
    times.sort_by(f64::total_cmp);
    times[1]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_capacity_is_the_last_point_below_halfway() {
        let p = |kb, ns| WalkPoint { kb, ns };
        // Two walks of the Zen 4 VM minutes apart. Halfway is 88 ns: crossed three quarters of
        // the way from 4 to 8 MiB (2^12.75 KiB, nearer 8 MiB).
        let points = [
            p(2048, 14.0),
            p(4096, 16.0),
            p(8192, 113.0),
            p(16384, 140.0),
            p(131072, 162.0),
        ];
        assert_eq!(effective(&points), Some(8192));
        // Halfway (95 ns) just below 4 MiB's 96 ns.
        let later = [p(2048, 15.0), p(4096, 96.0), p(8192, 155.0), p(131072, 175.0)];
        assert_eq!(effective(&later), Some(4096));
        // Everything fits: the largest size walked (the reference excluded).
        let fits = [p(2048, 14.0), p(4096, 15.0), p(8192, 16.0), p(131072, 160.0)];
        assert_eq!(effective(&fits), Some(8192));
        // A walk whose DRAM reference is no slower says nothing.
        assert_eq!(effective(&[p(2048, 100.0), p(65536, 100.0)]), None);
        assert_eq!(effective(&[]), None);
    }

    #[test]
    fn a_small_walk_runs_and_no_shared_cache_is_none() {
        assert!(walk_ns(64 << 10) > 0.0);
        assert_eq!(probe(256, 0), None);
    }
}
