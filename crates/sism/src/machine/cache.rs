//! A set-associative cache with true LRU replacement, write-allocate and write-back (dirty lines
//! are counted when evicted), and the remapping of recorded line addresses to compact ids.
//!
//! ## Why lines are remapped
//!
//! The counting context records real virtual line numbers of the host process (`address >> 6`).
//! They change from run to run (ASLR, the allocator's choices, thread timing in allocation), and the
//! set a line falls into depends on its low bits: timing raw addresses would make simulated cycles
//! differ between two identical renders. [`LineIds`] gives every distinct line a compact id in the
//! order it is first touched over the whole frame (phases in order, tasks in record order, accesses
//! in stream order). That order is a property of the records alone, so simulated figures are the
//! same for every run of the same render and every replay of the same file. A streaming pass over
//! an array touches new lines in order, so it still receives consecutive ids and fills consecutive
//! sets, as contiguous memory does; what is lost is only the relative placement of unrelated
//! arrays (which would conflict in a real cache by accident of addresses). That loss is real: the
//! grid's bin prefix once read 68–117 arrays at one offset in turn, lines of one L1 set on the host
//! (27 cycles a step there, about 1 here); a kernel that walks many arrays in lockstep is a kernel
//! to restructure, as that one was (`algorithms/sism/grid.rs`, `BinPrefix`).

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Multiply-shift hasher for `u64` keys (the std SipHash is several times slower here, and no key
/// comes from an adversary).
#[derive(Default, Clone, Copy)]
pub struct LineHasher(u64);

impl Hasher for LineHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    fn write_u64(&mut self, v: u64) {
        let x = (v ^ (v >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        self.0 = x ^ (x >> 32);
    }
}

/// Lines per page of the id table: 1024 lines, 64 KiB of host memory. Pages are large enough that
/// a task's few streams (a bin's x, y, z, out arrays) each stay within one or two pages.
const PAGE_LINES: u64 = 1024;
/// Entries of the direct-mapped memo of recently used pages (a task interleaves a handful of
/// streams; each usually keeps its own entry).
const MEMO: usize = 16;
const NO_ID: u32 = u32::MAX;
/// The host's base page size, bytes (the page faults and TLB reach of the model count these).
pub const PAGE_BYTES: u64 = 4096;

/// Compact line ids in first-touch order (see the module documentation).
///
/// A two-level table: a hash map from the page number (`line / PAGE_LINES`) to a dense block of
/// `PAGE_LINES` ids, with a small memo of recent pages in front of the map. Streams of nearby lines
/// (nearly every access) then cost an array lookup, not a hash probe; the ids are the same as a
/// plain map's.
#[derive(Clone)]
pub struct LineIds {
    pages: HashMap<u64, u32, BuildHasherDefault<LineHasher>>,
    /// `PAGE_LINES` ids per page, [`NO_ID`] for lines not touched yet.
    ids: Vec<u32>,
    /// `(page, offset of its block in ids)`; page `u64::MAX` is never a real page.
    memo: [(u64, u32); MEMO],
    next: u32,
}

impl Default for LineIds {
    fn default() -> Self {
        LineIds {
            pages: HashMap::default(),
            ids: Vec::new(),
            memo: [(u64::MAX, 0); MEMO],
            next: 0,
        }
    }
}

impl LineIds {
    /// An empty map.
    pub fn new() -> LineIds {
        LineIds::default()
    }
    /// The id of `line`, assigning the next free id on first touch.
    #[inline]
    pub fn id(&mut self, line: u64) -> u32 {
        let page = line / PAGE_LINES;
        let m = (page as usize) % MEMO;
        let block = if self.memo[m].0 == page {
            self.memo[m].1
        } else {
            let fresh = self.ids.len() as u32;
            let block = *self.pages.entry(page).or_insert(fresh);
            if block == fresh {
                self.ids.resize(self.ids.len() + PAGE_LINES as usize, NO_ID);
            }
            self.memo[m] = (page, block);
            block
        };
        let e = &mut self.ids[(block as u64 + line % PAGE_LINES) as usize];
        if *e == NO_ID {
            // Past 2^29 distinct lines (beyond any frame the records limits admit in practice) new
            // lines share the last id: the caches then see them as one line, never a panic.
            *e = self.next;
            if self.next < (NO_ID >> 3) - 1 {
                self.next += 1;
            }
        }
        *e
    }
    /// Distinct lines seen so far.
    pub fn len(&self) -> usize {
        self.next as usize
    }
    /// No line seen yet?
    pub fn is_empty(&self) -> bool {
        self.next == 0
    }
}

/// Result of one cache access.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Access {
    /// The line was present.
    pub hit: bool,
    /// A dirty line was evicted to make room (a write-back to the next level).
    pub writeback: bool,
}

const EMPTY: u32 = u32::MAX;

/// A set-associative LRU cache over compact line ids.
///
/// Each set keeps its ways in recency order, most recent first, free ways (`EMPTY`) at the end;
/// an entry is `id << 1 | dirty`. A hit moves the line to the front (usually it is already there,
/// or second); a miss shifts the set by one, dropping the last way (free, or the least recently
/// used line) and putting the new line in front. That is exactly true LRU with a free way used
/// first, without timestamps.
#[derive(Clone, Debug)]
pub struct Cache {
    set_mask: u32,
    ways: usize,
    /// `sets × ways` entries, each set in recency order.
    tags: Vec<u32>,
}

impl Cache {
    /// A cache of `bytes` capacity, `ways`-way set-associative, `line_bytes` lines. The number of
    /// sets must be a power of two (checked by `MachineConfig::validate`).
    pub fn new(bytes: u64, ways: u32, line_bytes: u32) -> Cache {
        let lines = (bytes / line_bytes as u64).max(1);
        let ways = (ways as u64).clamp(1, lines) as usize;
        let sets = (lines / ways as u64).max(1);
        assert!(
            sets.is_power_of_two(),
            "cache sets must be a power of two, got {sets}"
        );
        Cache {
            set_mask: sets as u32 - 1,
            ways,
            tags: vec![EMPTY; sets as usize * ways],
        }
    }

    /// Number of sets.
    pub fn sets(&self) -> usize {
        self.set_mask as usize + 1
    }

    /// Accesses `line` (a read, or a write when `write`): on a hit it becomes most recently used; on
    /// a miss it is allocated in its set over the least recently used way (a free way first).
    /// Line ids must be below 2^31 (one bit of each entry is the dirty flag).
    #[inline]
    pub fn access(&mut self, line: u32, write: bool) -> Access {
        debug_assert!(line < EMPTY >> 1);
        let base = (line & self.set_mask) as usize * self.ways;
        let set = &mut self.tags[base..base + self.ways];
        let key = line << 1;
        if set[0] | 1 == key | 1 {
            set[0] |= write as u32;
            return Access {
                hit: true,
                writeback: false,
            };
        }
        if let Some(w) = set.iter().position(|&t| t | 1 == key | 1) {
            let e = set[w] | write as u32;
            set.copy_within(0..w, 1);
            set[0] = e;
            return Access {
                hit: true,
                writeback: false,
            };
        }
        let victim = set[self.ways - 1];
        let writeback = victim != EMPTY && victim & 1 == 1;
        set.copy_within(0..self.ways - 1, 1);
        set[0] = key | write as u32;
        Access {
            hit: false,
            writeback,
        }
    }

    /// Is `line` resident (no state change)?
    pub fn contains(&self, line: u32) -> bool {
        let base = (line & self.set_mask) as usize * self.ways;
        self.tags[base..base + self.ways]
            .iter()
            .any(|&t| t != EMPTY && t >> 1 == line)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn direct_mapped_conflicts() {
        // 4 lines of 64 B, 1 way: 4 sets; lines 0 and 4 share set 0.
        let mut c = Cache::new(256, 1, 64);
        assert_eq!(c.sets(), 4);
        assert!(!c.access(0, false).hit);
        assert!(!c.access(4, false).hit);
        assert!(!c.access(0, false).hit);
        assert!(!c.access(1, false).hit);
        assert!(c.access(1, false).hit);
        assert!(c.access(0, false).hit);
    }

    #[test]
    fn two_way_lru() {
        // 4 lines, 2 ways: 2 sets. Even lines in set 0.
        let mut c = Cache::new(256, 2, 64);
        assert_eq!(c.sets(), 2);
        assert!(!c.access(0, false).hit); // set 0: [0]
        assert!(!c.access(2, false).hit); // [0, 2]
        assert!(c.access(0, false).hit); // 0 most recent
        assert!(!c.access(4, false).hit); // evicts 2 (LRU)
        assert!(c.contains(0) && c.contains(4) && !c.contains(2));
        assert!(!c.access(2, false).hit); // evicts 0
        assert!(!c.contains(0));
    }

    #[test]
    fn dirty_writeback() {
        let mut c = Cache::new(128, 1, 64); // 2 sets, direct mapped
        assert_eq!(
            c.access(0, true),
            Access {
                hit: false,
                writeback: false
            }
        );
        // Line 2 evicts dirty line 0.
        assert_eq!(
            c.access(2, false),
            Access {
                hit: false,
                writeback: true
            }
        );
        // Line 0 evicts clean line 2.
        assert!(!c.access(0, false).writeback);
    }

    #[test]
    fn ids_first_touch() {
        let mut ids = LineIds::new();
        assert_eq!(ids.id(0x7fff_1234), 0);
        assert_eq!(ids.id(0x10), 1);
        assert_eq!(ids.id(0x7fff_1234), 0);
        assert_eq!(ids.id(0x11), 2);
        assert_eq!(ids.len(), 3);
    }
}
