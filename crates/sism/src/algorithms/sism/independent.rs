//! Independent-occluder composition: an alternative to Eq. 4's `C = 0` (paper Section 5.2).
//!
//! Eq. 4 adds the coverages of all occluders, so where partial occluders overlap in a receiver's view
//! of the light (foliage: many leaves each hiding part of the light) their sum exceeds the union and
//! penumbrae darken, often to black. Here each connected component of the mesh (a leaf, a branch, a
//! whole closed object) is one occluder: its coverage `f_k` is computed exactly as in Eq. 4 (depth
//! complexity from its triangles plus the signed terms of its silhouette edges, clamped to [0, 1]), and
//! the occluders are composed as if independent, `V = prod_k (1 - f_k)`: the expected visible fraction
//! when occluders are placed independently. For one occluder this equals Eq. 4; for a closed object it
//! is exact whatever its shape.
//!
//! Per bin (the task), the bin's triangles and penumbra quads are merged and ordered by component;
//! each component's coverage is accumulated at the samples it touches, then folded into the product.
//! This fuses the umbra and penumbra passes into one per bin.

use rayon::prelude::*;
use sism_simd::{Kernel, ScalarClass, Simd};

use super::penumbra::{add_edge_terms, BinPart, PenumbraStats, WedgeScan};
use super::umbra::{covered, triangle_in_bin, UmbraStats};
use super::{Occluders, StageInputs};
use crate::counted;
use crate::exec::{task_kind, Phase};

/// Visible fraction of every sample (sorted order) under independent composition, one task per bin
/// with triangles or quads (step `fused`).
pub fn visible_fraction(
    phase: &mut Phase,
    inputs: &StageInputs<'_>,
    occluders: &Occluders<'_>,
    umbra: &mut UmbraStats,
    penumbra: &mut PenumbraStats,
) -> Vec<f32> {
    let mut visible = vec![1f32; inputs.grid.samples.pixel.len()];
    let counters = phase.run_par(
        "fused",
        inputs
            .grid
            .split_by_bins(&mut visible)
            .into_par_iter()
            .enumerate()
            .filter(|(bin, _)| {
                !occluders.triangles.of(*bin).is_empty() || !occluders.quads.of(*bin).is_empty()
            })
            .map(|(bin, out)| OcclusionBin {
                inputs,
                occluders,
                bin,
                out,
            }),
    );
    for (c, _) in &counters {
        umbra.samples_tested += c[0];
        penumbra.add_bin([c[1], c[2], c[3], 0, 0, 0, 0]);
    }
    penumbra.set_quads_per_sample(counters.iter().map(|c| &c.1));
    penumbra.tasks += counters.len() as u64;
    visible
}

/// One bin of the fused pass.
pub struct OcclusionBin<'a> {
    /// What every occlusion stage reads.
    pub inputs: &'a StageInputs<'a>,
    /// The occluders binned into the grid.
    pub occluders: &'a Occluders<'a>,
    /// Index of the bin in the grid's bins.
    pub bin: usize,
    /// Visible fraction of the bin's samples (bin-local), starting at 1.
    pub out: &'a mut [f32],
}

impl Kernel for OcclusionBin<'_> {
    /// `[umbra samples tested, rows culled, samples culled, samples evaluated]` and the quads evaluated
    /// per bin-local sample.
    type Output = ([u64; 4], Vec<i32>);
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> ([u64; 4], Vec<i32>) {
        s.begin_task(task_kind::OCCLUSION_BIN);
        let inp = self.inputs;
        let occ = self.occluders;
        let grid = inp.grid;
        let bin = self.bin;
        let base = grid.bins[bin].samples.start as usize;
        let n_samples = self.out.len();
        // One task per whole bin: the fused pass orders the bin's triangles and quads by object.
        let part = BinPart::whole(grid, bin);
        let positions = part.positions(grid);

        // Items of the bin ordered by (component, kind, index): triangles (kind 0), then quads (1);
        // the last field is a quad's position in the bin's list (its prepared quad).
        // Counted: each item's index and object loads and its push, and every comparison of the
        // sort (a compare and a branch each).
        let (triangles, quads) = (occ.triangles.of(bin), occ.quads.of(bin));
        let mut items: Vec<(u32, u8, u32, u32)> = Vec::with_capacity(triangles.len() + quads.len());
        for k in 0..triangles.len() {
            let t = s.s_load(triangles, k);
            s.s_push(&mut items, (s.s_load(&inp.topo.object, t as usize), 0u8, t, 0));
        }
        for k in 0..quads.len() {
            let e = s.s_load(quads, k);
            s.s_push(
                &mut items,
                (s.s_load(&occ.silhouettes.objects, e as usize), 1u8, e, k as u32),
            );
        }
        items.sort_unstable_by(|a, b| {
            s.scalar_op(ScalarClass::Alu);
            s.scalar_op(ScalarClass::Branch);
            a.cmp(b)
        });

        // Coverage of the current component at the samples it touched; `touched` lists them once each
        // (stamp = index of the group that last listed the sample).
        let mut coverage = vec![0f32; n_samples];
        let mut stamp = vec![u32::MAX; n_samples];
        let mut touched: Vec<i32> = Vec::new();
        // Its `selected` also packs the samples behind each umbra triangle.
        let edges = &occ.silhouettes.edges;
        let mut wedge = WedgeScan::new(s, grid, &part, inp.light, edges, quads, 1, true);
        let mut tested = 0u64;
        let zero = s.splat_f(0.0);
        let one_f = s.splat_f(1.0);
        let lane = s.index_i();
        let mut group = 0u32;
        let mut at = 0;
        while at < items.len() {
            let component = items[at].0;
            let mut end = at;
            while end < items.len() && items[end].0 == component {
                end += 1;
            }
            for &(_, kind, index, k) in &items[at..end] {
                let n_hit = if kind == 0 {
                    // Umbra: +1 coverage where the sample lies behind the triangle.
                    let q = s
                        .s_read(&inp.topo.triangles[index as usize])
                        .map(|v| counted::sub(s, v, inp.light.center));
                    let Some(tri) = triangle_in_bin(s, grid, bin, &q) else {
                        continue;
                    };
                    let mut n = 0usize;
                    for row in tri.c0.y..tri.c1.y {
                        let (start, stop) = grid.row_span(s, bin, tri.c0, tri.c1, row, tri.first_slice);
                        let mut i = start;
                        while i < stop {
                            let m = s.mask_first_n(stop - i);
                            let local = i - base;
                            let x = s.mask_load_f(zero, m, &positions.0[local..]);
                            let y = s.mask_load_f(zero, m, &positions.1[local..]);
                            let z = s.mask_load_f(zero, m, &positions.2[local..]);
                            let hit = covered(s, &tri, m, x, y, z);
                            let cur = s.mask_load_f(zero, m, &coverage[local..]);
                            s.mask_store_f(&mut coverage[local..], hit, s.add_f(cur, one_f));
                            let idx = s.add_i(lane, s.splat_i(local as i32));
                            n += s.compress_store_i(&mut wedge.selected[n..], hit, idx);
                            tested += s.mask_popcnt(m) as u64;
                            i += 16;
                        }
                    }
                    n
                } else {
                    // Penumbra: the edge's signed term at the samples inside its wedge.
                    let edge = &edges[index as usize];
                    let Some(n) = wedge.select(s, k as usize) else {
                        continue;
                    };
                    add_edge_terms(
                        s,
                        &wedge.selected[..n],
                        positions,
                        edge,
                        inp.light.radius,
                        &mut coverage,
                    );
                    n
                };
                for j in 0..n_hit {
                    let i = s.s_load(&wedge.selected, j);
                    if s.s_branch(s.s_load(&stamp, i as usize) != group) {
                        s.s_store(&mut stamp, i as usize, group);
                        s.s_push(&mut touched, i);
                    }
                }
            }
            // Fold the component into the product: visible *= 1 - clamp01(coverage); reset coverage.
            let mut k = 0;
            while k < touched.len() {
                let m = s.mask_first_n(touched.len() - k);
                let idx = s.mask_load_i(s.splat_i(0), m, &touched[k..]);
                let f = s.clamp_f(s.mask_gather_f(zero, m, &coverage, idx), zero, one_f);
                let v = s.mask_gather_f(one_f, m, self.out, idx);
                s.mask_scatter_f(self.out, m, idx, s.mul_f(v, s.sub_f(one_f, f)));
                s.mask_scatter_f(&mut coverage, m, idx, zero);
                k += 16;
            }
            touched.clear();
            group += 1;
            at = end;
        }
        s.end_task();
        let ([culled_rows, culled_samples, evaluated, ..], reached) = wedge.output();
        ([tested, culled_rows, culled_samples, evaluated], reached)
    }
}
