//! The branch predictor model of the counting context.
//!
//! Every counted conditional branch (`s_branch`, `s_lt`, `s_le`: the operations of
//! [`crate::ScalarClass::Branch`] that know their outcome) is predicted as it executes, and a wrong
//! prediction counts one [`crate::Counters::branch_mispredicts`]; the machine model charges each
//! one its `mispredict_cycles`. A branch is known by its call site (source file, line and column,
//! so the count is the same for every backend and build of the same source).
//!
//! The predictor is a two-level *local-history* predictor (Yeh and Patt's PAg, 1992), a textbook
//! stand-in for the much larger predictors of real cores: each site keeps its last
//! [`HISTORY_BITS`] outcomes; the pair (site, history) selects a 2-bit saturating counter. It
//! learns what real predictors learn easily (a biased branch, a loop of a fixed trip count of up to
//! [`HISTORY_BITS`], a repeating pattern) and misses what they miss (outcomes that depend on the
//! data: about half of them when the data is random). A counter never trained falls back to the
//! site's own 2-bit counter (bimodal), so a biased branch costs one or two mispredictions to learn,
//! not one per history.
//!
//! The state starts empty at every task (the counts do not depend on which host thread ran which
//! task before), so a task pays its branches' training; tasks run thousands of branches, so this is
//! small. Aliasing between sites in the tables is deterministic.

/// Outcomes a site remembers (its local history).
pub const HISTORY_BITS: u32 = 8;
/// Sites tracked (direct-mapped by a hash of the site).
const SITES: usize = 1024;
/// Pattern counters (direct-mapped by a hash of the site and its history).
const PATTERNS: usize = 16 * 1024;

/// A 2-bit counter: 0 = never trained, 1..=2 predict not taken, 3..=4 predict taken.
#[inline(always)]
fn train(c: u8, taken: bool) -> u8 {
    match (c, taken) {
        (0, true) => 3,
        (0, false) => 2,
        (c, true) => (c + 1).min(4),
        (c, false) => (c - 1).max(1),
    }
}

/// The predictor's tables (about 18 KB).
#[derive(Clone, Debug)]
pub struct BranchPredictor {
    history: Box<[u8; SITES]>,
    bimodal: Box<[u8; SITES]>,
    patterns: Box<[u8; PATTERNS]>,
    /// The tables hold outcomes of an earlier task: they are cleared at the current task's first
    /// branch (lazily, so tasks without a counted branch cost nothing).
    stale: bool,
    /// The tables hold outcomes (else they are all zero already).
    dirty: bool,
}

impl Default for BranchPredictor {
    fn default() -> Self {
        BranchPredictor {
            history: Box::new([0; SITES]),
            bimodal: Box::new([0; SITES]),
            patterns: Box::new([0; PATTERNS]),
            stale: false,
            dirty: false,
        }
    }
}

/// A site's key: its source location (file, line, column), independent of where the binary put
/// the `Location` itself.
#[inline(always)]
pub fn site_key(at: &core::panic::Location<'_>) -> u64 {
    let file = at.file().as_bytes();
    let mut tail = [0u8; 8];
    let n = file.len().min(8);
    tail[..n].copy_from_slice(&file[file.len() - n..]);
    (at.line() as u64) << 40 ^ (at.column() as u64) << 24 ^ (file.len() as u64) ^ u64::from_le_bytes(tail)
}

#[inline(always)]
fn slot(key: u64, bits: u32) -> usize {
    (key.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> (64 - bits)) as usize
}

impl BranchPredictor {
    /// Forgets everything (lazily: at the next [`BranchPredictor::observe`]).
    #[inline(always)]
    pub fn start_task(&mut self) {
        self.stale = self.dirty;
    }

    /// Predicts the branch at `site` ([`site_key`]), learns its outcome `taken`, and returns true
    /// when the prediction was wrong.
    #[inline]
    pub fn observe(&mut self, site: u64, taken: bool) -> bool {
        if self.stale {
            self.history.fill(0);
            self.bimodal.fill(0);
            self.patterns.fill(0);
            self.stale = false;
        }
        self.dirty = true;
        let s = slot(site, SITES.trailing_zeros());
        let h = self.history[s];
        let p = slot((s as u64) << HISTORY_BITS | h as u64, PATTERNS.trailing_zeros());
        let counter = match self.patterns[p] {
            0 => self.bimodal[s],
            c => c,
        };
        let predicted = counter >= 3;
        self.patterns[p] = train(self.patterns[p], taken);
        self.bimodal[s] = train(self.bimodal[s], taken);
        self.history[s] = h << 1 | taken as u8;
        predicted != taken
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(outcomes: impl Iterator<Item = bool>) -> u64 {
        let mut p = BranchPredictor::default();
        p.start_task();
        let site = site_key(core::panic::Location::caller());
        outcomes.map(|t| p.observe(site, t) as u64).sum()
    }

    #[test]
    fn learns_biased_branches_and_short_loops() {
        assert_eq!(run((0..1000).map(|_| false)), 0);
        assert!(run((0..1000).map(|_| true)) <= 1);
        // A loop of trip count 5: taken four times, then not.
        assert!(run((0..1000).map(|i| i % 5 != 4)) <= 10);
        // A repeating pattern of period 7.
        assert!(run((0..7000).map(|i| [true, false, false, true, true, false, true][i % 7])) <= 20);
    }

    #[test]
    fn misses_about_half_of_random_outcomes() {
        let mut x = 0x1234_5678u32;
        let m = run((0..20_000).map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x & 1 == 1
        }));
        assert!((8_000..12_000).contains(&m), "{m}");
    }

    #[test]
    fn a_new_task_starts_untrained() {
        let mut p = BranchPredictor::default();
        let site = 42;
        p.start_task();
        for _ in 0..10 {
            p.observe(site, true);
        }
        assert!(!p.observe(site, true));
        p.start_task();
        // Forgotten: the first taken outcome is mispredicted again.
        assert!(p.observe(site, true));
    }
}
