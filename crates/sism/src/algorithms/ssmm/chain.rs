//! The shadow mip-map chain of one light face: level 0 holds, per texel of the light-centre depth
//! map, the inverse world distance `1 / d` of the surface its centre sees (`d` from the light's
//! centre, world units; 0 where it sees nothing); level `i + 1` holds per texel the largest of its
//! 2×2 children (the nearest surface: the thesis' MIN 2×2 chain, kept as inverse distances so the
//! kernels' Eq. 3.3 needs no division per texel). Texel `k` of level `i` covers base texels
//! `[k 2^i, (k + 1) 2^i)`; a level has `⌈size / 2^i⌉` texels a side (children beyond the base map
//! are absent, not zero-filled: they do not lower a maximum of non-negative values anyway).

use rayon::prelude::*;
use sism_simd::{Kernel, ScalarClass, Simd};

use crate::algorithms::shadow_map::depth_map::FaceMap;
use crate::exec::{task_kind, Phase};

/// Rows of a level per chain task.
const ROWS_PER_TASK: usize = 16;

/// One level: `side × side` inverse distances, row-major from the map's top row.
#[derive(Clone, Debug, Default)]
pub struct Level {
    /// Texels a side: `⌈size / 2^i⌉` for level `i` of a `size`-texel map.
    pub side: u32,
    /// Inverse distance `1 / d` per texel, 1/world units (0 where nothing is seen).
    pub inv: Vec<f32>,
}

/// A face's chain, finest level first; empty for a face without a map.
#[derive(Clone, Debug, Default)]
pub struct MipChain {
    /// The levels, finest (one per map texel) first.
    pub levels: Vec<Level>,
    /// The largest inverse distance of the map (its nearest surface), 1/world units; 0 when it sees
    /// nothing.
    pub inv_max: f32,
}

/// Builds the chain of `map` (rendered without bias) with `layers` levels, as steps `mip_base` and
/// `mip_levels` of `phase`.
pub fn build(phase: &mut Phase, map: &FaceMap, layers: usize) -> MipChain {
    if map.depth.is_empty() {
        return MipChain::default();
    }
    let side = map.size as usize;
    let mut base = vec![0f32; side * side];
    phase.run_par(
        "mip_base",
        base.par_chunks_mut(ROWS_PER_TASK * side)
            .enumerate()
            .map(|(t, out)| BaseTask {
                map,
                first_row: t * ROWS_PER_TASK,
                out,
            }),
    );
    let mut levels = vec![Level {
        side: map.size,
        inv: base,
    }];
    while levels.len() < layers {
        let fine = levels.last().expect("level 0 exists");
        let side = (fine.side as usize).div_ceil(2);
        let mut inv = vec![0f32; side * side];
        phase.run_par(
            "mip_levels",
            inv.par_chunks_mut(ROWS_PER_TASK * side)
                .enumerate()
                .map(|(t, out)| DownTask {
                    fine,
                    side,
                    first_row: t * ROWS_PER_TASK,
                    out,
                }),
        );
        levels.push(Level {
            side: side as u32,
            inv,
        });
    }
    let inv_max = levels
        .last()
        .map_or(0.0, |l| l.inv.iter().copied().fold(0.0, f32::max));
    MipChain { levels, inv_max }
}

/// Step `mip_base`: rows of level 0 from the depth map: view depth `z = z0 + d · range`, distance
/// `z · √(1 + u² + v²)` at the texel centre's image-plane position `(u, v)`.
struct BaseTask<'a> {
    map: &'a FaceMap,
    first_row: usize,
    out: &'a mut [f32],
}

impl Kernel for BaseTask<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::SSMM_CHAIN);
        let map = self.map;
        let side = map.size as usize;
        let scale = 2.0 * map.extent / map.size as f32;
        let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
        let (z0, range) = (s.splat_f(map.z0), s.splat_f(map.range()));
        let lane = s.cvt_i_f(s.index_i());
        // Counted scalar work: per row its index, its `v` and the row's offset; per vector the
        // loop's compare and increment and the column's centre.
        for (r, row) in self.out.chunks_mut(side).enumerate() {
            let y = s.s_add(self.first_row, r);
            let yf = s.s_fn(ScalarClass::Alu, y, |y: usize| y as f32);
            let v = s.s_sub(map.extent, s.s_mul(s.s_add(yf, 0.5), scale));
            let v2 = s.splat_f(s.s_add(1.0, s.s_mul(v, v)));
            let start = s.s_mul(y, side);
            let src = &map.depth[start..start + side];
            let mut x = 0;
            while s.s_lt(x, side) {
                let m = s.mask_first_n(side - x);
                let d = s.mask_load_f(s.splat_f(f32::INFINITY), m, &src[x..]);
                let xf = s.s_fn(ScalarClass::Alu, x, |x: usize| x as f32);
                let cx = s.add_f(lane, s.splat_f(s.s_add(xf, 0.5)));
                let u = s.fmsub(cx, s.splat_f(scale), s.splat_f(map.extent));
                let dist = s.mul_f(s.fmadd(d, range, z0), s.sqrt_f(s.fmadd(u, u, v2)));
                // Nothing seen (+∞), or a surface at or behind the light point: no blocker.
                let seen = s.mask_and(s.cmp_lt_f(d, s.splat_f(f32::INFINITY)), s.cmp_gt_f(dist, zero));
                let inv = s.div_f(one, s.select_f(seen, dist, one));
                s.mask_store_f(&mut row[x..], m, s.select_f(seen, inv, zero));
                x = s.s_add(x, 16);
            }
        }
        s.end_task();
    }
}

/// Step `mip_levels`: rows of level `i + 1`, each texel the largest of its 2×2 children in `fine`.
struct DownTask<'a> {
    fine: &'a Level,
    side: usize,
    first_row: usize,
    out: &'a mut [f32],
}

impl Kernel for DownTask<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::SSMM_CHAIN);
        let fine_side = self.fine.side as i32;
        let zero = s.splat_f(0.0);
        let lane = s.index_i();
        for (r, row) in self.out.chunks_mut(self.side).enumerate() {
            // Counted scalar work: the row's index; per vector the loop's compare and increment, and
            // per child row its index, test and offset.
            let y = s.s_add(self.first_row, r) as i32;
            let mut x = 0;
            while s.s_lt(x, self.side) {
                let m = s.mask_first_n(self.side - x);
                let cx = s.shl_i(s.add_i(lane, s.splat_i(x as i32)), 1);
                let mut best = zero;
                for dy in 0..2 {
                    let fy = s.s_add(s.s_mul(2, y), dy);
                    if s.s_le(fine_side, fy) {
                        continue;
                    }
                    let row_offset = s.s_mul(fy, fine_side);
                    for dx in 0..2 {
                        let fx = s.add_i(cx, s.splat_i(dx));
                        let inside = s.mask_and(m, s.cmp_lt_i(fx, s.splat_i(fine_side)));
                        let idx = s.add_i(fx, s.splat_i(row_offset));
                        best = s.max_f(best, s.mask_gather_f(zero, inside, &self.fine.inv, idx));
                    }
                }
                s.mask_store_f(&mut row[x..], m, best);
                x = s.s_add(x, 16);
            }
        }
        s.end_task();
    }
}
