//! Sort-middle binning: items (triangles, penumbra quads) sorted into per-bin lists, in a fixed order
//! whatever the host thread count. Two steps of the caller's phase: `bin` (one task per [`CHUNK`]
//! items, each emitting its (bin, item) pairs) and `lists` (one task per chunk scattering its pairs
//! into the lists, after a prefix sum of the counts).

use std::ops::AddAssign;

use rayon::prelude::*;
use sism_simd::{Kernel, Simd};

use crate::exec::{task_kind, Phase};

/// Items per binning task.
pub const CHUNK: usize = 4096;

/// Per-bin item lists in compressed form: bin `b`'s items are `items[offsets[b]..offsets[b + 1]]`,
/// in increasing item order.
#[derive(Clone, Debug, Default)]
pub struct BinLists {
    /// Start of each bin's items in `items`, then the end: bins + 1 entries.
    pub offsets: Vec<u32>,
    /// Item indices of every bin, bin after bin.
    pub items: Vec<u32>,
}

impl BinLists {
    /// `n_bins` empty lists.
    pub fn empty(n_bins: usize) -> BinLists {
        BinLists {
            offsets: vec![0; n_bins + 1],
            items: Vec::new(),
        }
    }

    /// Items of bin `b`.
    #[inline]
    pub fn of(&self, b: usize) -> &[u32] {
        &self.items[self.offsets[b] as usize..self.offsets[b + 1] as usize]
    }

    /// Total (bin, item) pairs.
    pub fn pairs(&self) -> usize {
        self.items.len()
    }
}

/// How one kind of item is binned: [`BinItems::emit`] pushes the (bin, item) pairs of one item and
/// reports its scalar work to `s` (it runs inside the `bin` step's kernels).
pub trait BinItems: Sync {
    /// Counters the binning keeps (items culled, pairs dropped), summed over the tasks.
    type Counts: Default + AddAssign + Send;
    /// Pushes the pairs of `item`, in increasing bin order or any fixed order.
    fn emit<S: Simd>(&self, s: S, item: u32, pairs: &mut Vec<(u32, u32)>, counts: &mut Self::Counts);
}

/// A `bin` task's output: its (bin, item) pairs and its counters.
type ChunkPairs<C> = (Vec<(u32, u32)>, C);

/// Bins items `0..n_items` into `n_bins` lists with `binner`, as the steps `bin` and `lists` of `phase`.
/// Returns the lists (each in increasing item order) and the binner's counters.
pub fn bin_items<B: BinItems>(
    phase: &mut Phase,
    binner: &B,
    n_bins: usize,
    n_items: usize,
) -> (BinLists, B::Counts) {
    let chunks: Vec<ChunkPairs<B::Counts>> = phase.run_par(
        "bin",
        (0..n_items.div_ceil(CHUNK)).into_par_iter().map(|c| BinChunk {
            binner,
            items: (c * CHUNK) as u32..((c + 1) * CHUNK).min(n_items) as u32,
        }),
    );
    let mut offsets = vec![0u32; n_bins + 1];
    phase.run(
        "lists",
        ListOffsets {
            chunks: &chunks,
            offsets: &mut offsets,
        },
    );
    let mut cursor = offsets.clone();
    let mut items = vec![0u32; offsets[n_bins] as usize];
    let mut counts = B::Counts::default();
    // The chunks share the cursors, so the host runs their scatters in chunk order (each bin's list
    // then comes out in item order).
    for (pairs, c) in chunks {
        counts += c;
        phase.run(
            "lists",
            ScatterPairs {
                pairs: &pairs,
                cursor: &mut cursor,
                items: &mut items,
            },
        );
    }
    (BinLists { offsets, items }, counts)
}

/// Step `bin`: a chunk of items.
struct BinChunk<'a, B> {
    binner: &'a B,
    items: std::ops::Range<u32>,
}

impl<B: BinItems> Kernel for BinChunk<'_, B> {
    type Output = (Vec<(u32, u32)>, B::Counts);
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> (Vec<(u32, u32)>, B::Counts) {
        s.begin_task(task_kind::BIN_ITEMS);
        let mut pairs = Vec::new();
        let mut counts = B::Counts::default();
        // The emitters push their pairs with `s_push`, which records the pairs' lines.
        for item in self.items {
            self.binner.emit(s, item, &mut pairs, &mut counts);
        }
        s.end_task();
        (pairs, counts)
    }
}

/// Step `lists`, first task: the lists' offsets, a histogram of every chunk's pairs by bin and its
/// prefix sum (`offsets[b]` = first position of bin `b`'s list, `offsets[n_bins]` = all pairs).
struct ListOffsets<'a, C> {
    chunks: &'a [ChunkPairs<C>],
    offsets: &'a mut [u32],
}

impl<C> Kernel for ListOffsets<'_, C> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::BIN_LISTS);
        // Counted per pair: its bin's load, the count's load, increment and store; per bin the
        // prefix sum's load, add and store.
        for (pairs, _) in self.chunks {
            s.scalar_read(pairs);
            for k in 0..pairs.len() {
                let (bin, _) = crate::counted::streamed(s, pairs, k);
                let at = bin as usize + 1;
                s.s_store(self.offsets, at, s.s_add(s.s_load(self.offsets, at), 1));
            }
        }
        for b in 0..self.offsets.len() - 1 {
            let sum = s.s_add(s.s_load(self.offsets, b + 1), s.s_load(self.offsets, b));
            s.s_store(self.offsets, b + 1, sum);
        }
        s.end_task();
    }
}

/// Step `lists`: one chunk's pairs scattered to the lists at the bins' cursors (the histogram before
/// it is counted here too: a chip's `bin` tasks would count their own).
struct ScatterPairs<'a> {
    pairs: &'a [(u32, u32)],
    cursor: &'a mut [u32],
    items: &'a mut [u32],
}

impl Kernel for ScatterPairs<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::BIN_LISTS);
        s.scalar_read(self.pairs);
        // Counted per pair: its load, the bin's cursor (load, increment, store) and the item's store.
        for k in 0..self.pairs.len() {
            let (bin, item) = crate::counted::streamed(s, self.pairs, k);
            let c = s.s_load(self.cursor, bin as usize);
            s.s_store(self.items, c as usize, item);
            s.s_store(self.cursor, bin as usize, s.s_add(c, 1));
        }
        s.end_task();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::{Exec, FrameLog};

    struct Modulo;
    impl BinItems for Modulo {
        type Counts = u64;
        fn emit<S: Simd>(&self, _: S, item: u32, out: &mut Vec<(u32, u32)>, counts: &mut u64) {
            out.push((item % 3, item));
            if item.is_multiple_of(5) {
                out.push(((item + 1) % 3, item));
                *counts += 1;
            }
        }
    }

    #[test]
    fn lists_are_sorted_and_complete() {
        for exec in [Exec::Native, Exec::Counting] {
            let mut log = FrameLog::new(exec);
            let (lists, extra) = log.phase("b", "binning", |p| bin_items(p, &Modulo, 3, 10_000));
            assert_eq!(lists.pairs(), 10_000 + 2_000);
            assert_eq!(extra, 2_000);
            for b in 0..3 {
                assert!(lists.of(b).windows(2).all(|w| w[0] < w[1]));
            }
        }
    }
}
