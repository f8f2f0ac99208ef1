//! Sort-middle binning: items (triangles, penumbra quads) sorted into per-bin lists, in a fixed order
//! whatever the host thread count.

use rayon::prelude::*;

/// Per-bin item lists in compressed form: bin `b`'s items are `items[offsets[b]..offsets[b + 1]]`,
/// in increasing item order.
#[derive(Clone, Debug, Default)]
pub struct BinLists {
    pub offsets: Vec<u32>,
    pub items: Vec<u32>,
}

impl BinLists {
    /// Items of bin `b`.
    #[inline]
    pub fn of(&self, b: usize) -> &[u32] {
        &self.items[self.offsets[b] as usize..self.offsets[b + 1] as usize]
    }

    /// Total (bin, item) pairs.
    pub fn pairs(&self) -> usize {
        self.items.len()
    }

    /// Builds the lists from `(bin, item)` pairs produced per chunk of items; chunks must be in item
    /// order and each chunk's pairs in item order, so each bin's list comes out sorted by item.
    pub fn from_chunks(n_bins: usize, chunks: Vec<Vec<(u32, u32)>>) -> BinLists {
        let mut offsets = vec![0u32; n_bins + 1];
        for chunk in &chunks {
            for &(bin, _) in chunk {
                offsets[bin as usize + 1] += 1;
            }
        }
        for b in 0..n_bins {
            offsets[b + 1] += offsets[b];
        }
        let mut cursor = offsets.clone();
        let mut items = vec![0u32; offsets[n_bins] as usize];
        for chunk in &chunks {
            for &(bin, item) in chunk {
                let c = &mut cursor[bin as usize];
                items[*c as usize] = item;
                *c += 1;
            }
        }
        BinLists { offsets, items }
    }
}

/// Runs `emit(item, &mut pairs)` over `0..n_items` in parallel chunks and gathers the pairs into
/// [`BinLists`].
pub fn bin_items<F>(n_bins: usize, n_items: usize, emit: F) -> BinLists
where
    F: Fn(u32, &mut Vec<(u32, u32)>) + Sync,
{
    const CHUNK: usize = 4096;
    let chunks: Vec<Vec<(u32, u32)>> = (0..n_items.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut pairs = Vec::new();
            for item in c * CHUNK..((c + 1) * CHUNK).min(n_items) {
                emit(item as u32, &mut pairs);
            }
            pairs
        })
        .collect();
    BinLists::from_chunks(n_bins, chunks)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_are_sorted_and_complete() {
        let lists = bin_items(3, 10_000, |item, out| {
            out.push((item % 3, item));
            if item % 5 == 0 {
                out.push(((item + 1) % 3, item));
            }
        });
        assert_eq!(lists.pairs(), 10_000 + 2_000);
        for b in 0..3 {
            assert!(lists.of(b).windows(2).all(|w| w[0] < w[1]));
        }
    }
}
