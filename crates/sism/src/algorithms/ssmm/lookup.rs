//! The per-receiver soft shadow mip-map filter, 16 receivers a vector, one kernel for both methods:
//!
//! * **`ssmm`** (§3.3): on each layer the `n × n` texel region around the receiver's position; every
//!   texel nearer than the receiver (after the layer's bias) is a blocker with its own filter size
//!   `r_j` (Eq. 3.3 of its own distance) and adds `f_j · w_i(r_j)` to the blocked light (Eqs. 3.14,
//!   3.17; `f_j` the kernel's volume over the texel, `w_i` the layer's hat of [`filter_size`]);
//!   `V = 1 − min(1, Σ)`.
//! * **`ssmm-v2`** (§3.2): PCSS's blocker search gives one mean blocker distance and so one `r`; the
//!   binary tests of the layers around it are box-filtered and blended by the same hats
//!   (Eqs. 3.8–3.10 are the hats at that `r`).
//!
//! **Bias** (§3.5). The receiver's distance is lowered by a constant share of it and, per layer, by a
//! slope term: `bias_slope · tan θ · t_i · (n/2 + 1)` with `θ` the angle between the receiver's normal
//! and its line to the light and `t_i` the layer's texel width at the receiver (world units). The
//! receiver's own plane rises by `tan θ` per unit across the region, whose farthest texel reaches
//! `n/2 + 1/2` texels out, and a MIN texel holds its footprint's nearest point another half texel
//! nearer: so `bias_slope = 1` just clears a planar receiver on every layer.
//!
//! **Work skipped, counted.** Layers run coarse to fine. A layer's region contains every finer
//! layer's, and a parent texel is the nearest of its children, so the nearest surface a visited
//! region holds bounds every finer layer: a lane whose bound is not nearer than its receiver (after
//! the finest, smallest bias) is finished, and a layer where the bound puts every blocker below half
//! the layer's filter size (hat weight 0) is skipped. The first bound is the map's nearest surface.
//!
//! Reads outside a level are no blocker: coarse layers' regions reach past the map's padding, and a
//! black border there would darken every receiver near the map's rim through the last layer.

use glam::{Vec2, Vec3};
use sism_simd::{Kernel, Mask16, ScalarClass, Simd};

use super::chain::MipChain;
use super::filter_size::{self, layer_weight_simd};
use crate::algorithms::shadow_map::depth_map::FaceMap;
use crate::algorithms::shadow_map::lookup::project;
use crate::algorithms::sism::grid::SampleIn;
use crate::exec::task_kind;
use crate::frame::Receiver;

/// Largest kernel side, texels (the thesis' range 2–9).
pub const MAX_N: u32 = 9;

/// Steepest slope the bias follows: `tan θ` is capped here (86°), so grazing receivers keep a finite
/// bias.
const MAX_TAN: f32 = 16.0;

/// The filter kernel over a layer's `n × n` region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterKernel {
    /// Constant over the region; each texel weighs the area of it inside the region (§3.4).
    Box,
    /// A separable tent (a product of 1D tents) over the region, each texel weighing the volume over
    /// it.
    Pyramid,
}

/// Which method.
#[derive(Clone, Debug, PartialEq)]
pub enum Variant {
    /// Every texel a blocker with its own filter size.
    Full,
    /// PCSS's blocker search (taps in the unit disk), one filter size per receiver.
    V2 {
        /// Blocker-search taps, in the unit disk.
        blocker: Vec<Vec2>,
    },
}

/// A frame's method and parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    /// Kernel side, texels of each layer, `2..=MAX_N`.
    pub n: u32,
    /// Layers of the chain, `≥ 1`.
    pub layers: usize,
    /// Light radius, world units.
    pub light_radius: f32,
    /// Constant bias, a share of the receiver's distance (`≥ 0`).
    pub bias_constant: f32,
    /// Slope-scaled bias, see the module docs (`≥ 0`).
    pub bias_slope: f32,
    /// The filter kernel over a layer's `n × n` region.
    pub kernel: FilterKernel,
    /// Which method, with its blocker-search taps for `V2`.
    pub variant: Variant,
}

/// Counters of one task.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SsmmCounts {
    /// Receivers looked up.
    pub fragments: u64,
    /// Texel reads of the layers' regions (and of the blocker search).
    pub texels: u64,
    /// Layers visited, summed over receivers.
    pub layers_visited: u64,
    /// Layers a receiver did not visit because its bound said they add nothing.
    pub layers_skipped: u64,
    /// `ssmm-v2`: receivers whose blocker search found nothing (lit, no filter).
    pub no_blocker: u64,
    /// Receivers with some light blocked (`V < 1`).
    pub blocked: u64,
}

impl std::ops::AddAssign for SsmmCounts {
    fn add_assign(&mut self, o: Self) {
        self.fragments += o.fragments;
        self.texels += o.texels;
        self.layers_visited += o.layers_visited;
        self.layers_skipped += o.layers_skipped;
        self.no_blocker += o.no_blocker;
        self.blocked += o.blocked;
    }
}

/// One task: `samples` of one face (relative to the light centre, plus `shift` to the map's light
/// point, which is the centre here), their visibility written to `out`.
pub struct SsmmTask<'a> {
    /// The face's depth map.
    pub map: &'a FaceMap,
    /// The face's shadow mip-map chain.
    pub chain: &'a MipChain,
    /// The frame's receivers (a sample's normal is its pixel's).
    pub receivers: &'a [Option<Receiver>],
    /// `light centre − map origin`, world units: added to a sample's `q` for its position relative
    /// to the map's light point (zero here).
    pub shift: Vec3,
    /// The samples to look up, all of this face.
    pub samples: &'a [SampleIn],
    /// The frame's method and parameters.
    pub setup: &'a Setup,
    /// Visibility per sample of `samples`.
    pub out: &'a mut [f32],
}

/// The kernel's weights along one axis: texels `x0 .. x0 + n` (`n + 1` of them) against the region
/// `[c − n/2, c + n/2]` (continuous texel coordinates of the layer), the kernel's volume over each.
#[inline(always)]
fn axis_weights<S: Simd>(
    s: S,
    c: S::F32,
    x0: S::F32,
    n: u32,
    kernel: FilterKernel,
) -> [S::F32; MAX_N as usize + 1] {
    let zero = s.splat_f(0.0);
    let inv_half_n = s.splat_f(2.0 / n as f32);
    let mut w = [zero; MAX_N as usize + 1];
    let mut prev = kernel_cdf(s, x0, c, inv_half_n, kernel);
    for (k, wk) in w.iter_mut().enumerate().take(n as usize + 1) {
        let next = kernel_cdf(s, s.add_f(x0, s.splat_f(k as f32 + 1.0)), c, inv_half_n, kernel);
        *wk = s.sub_f(next, prev);
        prev = next;
    }
    w
}

/// The kernel's cumulative share of the region up to boundary `b`: `t = (b − c) / (n/2)` clamped to
/// `[−1, 1]`; the box's `(t + 1) / 2`, the tent's `(1 + t)² / 2` below 0 and `1 − (1 − t)² / 2` above.
#[inline(always)]
fn kernel_cdf<S: Simd>(s: S, b: S::F32, c: S::F32, inv_half_n: S::F32, kernel: FilterKernel) -> S::F32 {
    let (zero, one, half) = (s.splat_f(0.0), s.splat_f(1.0), s.splat_f(0.5));
    let t = s.clamp_f(s.mul_f(s.sub_f(b, c), inv_half_n), s.splat_f(-1.0), one);
    match kernel {
        FilterKernel::Box => s.mul_f(s.add_f(t, one), half),
        FilterKernel::Pyramid => {
            let lo = s.add_f(one, t);
            let hi = s.sub_f(one, t);
            s.select_f(
                s.cmp_lt_f(t, zero),
                s.mul_f(s.mul_f(lo, lo), half),
                s.fnmadd(s.mul_f(hi, hi), half, one),
            )
        }
    }
}

/// The receiver's inverse distance after layer `level`'s bias: `biased` (its distance less the
/// constant bias) less `slope · 2^level`; `+∞` where nothing is left (nothing counts as nearer).
#[inline(always)]
fn inv_receiver<S: Simd>(s: S, biased: S::F32, slope: S::F32, level: usize) -> S::F32 {
    let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
    let d = s.fnmadd(slope, s.splat_f((1u64 << level) as f32), biased);
    let pos = s.cmp_gt_f(d, zero);
    s.select_f(
        pos,
        s.div_f(one, s.select_f(pos, d, one)),
        s.splat_f(f32::INFINITY),
    )
}

/// The inverse distance at texel `(ix, iy)` of `level` for lanes `m` (0 outside the level).
#[inline(always)]
fn fetch<S: Simd>(s: S, chain: &MipChain, level: usize, m: Mask16, ix: S::I32, iy: S::I32) -> S::F32 {
    let l = &chain.levels[level];
    let n = s.splat_i(l.side as i32);
    let zero = s.splat_i(0);
    let inside = s.mask_and(
        m,
        s.mask_and(
            s.mask_and(s.cmp_ge_i(ix, zero), s.cmp_lt_i(ix, n)),
            s.mask_and(s.cmp_ge_i(iy, zero), s.cmp_lt_i(iy, n)),
        ),
    );
    s.mask_gather_f(s.splat_f(0.0), inside, &l.inv, s.add_i(s.mul_i(iy, n), ix))
}

impl Kernel for SsmmTask<'_> {
    type Output = SsmmCounts;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> SsmmCounts {
        s.begin_task(task_kind::SSMM_LOOKUP);
        let (map, chain, setup) = (self.map, self.chain, self.setup);
        let n = setup.n;
        let layers = setup.layers.min(chain.levels.len());
        let taps_per_layer = (n as u64 + 1) * (n as u64 + 1);
        let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
        // World width of a base texel per unit of view depth.
        let texel_per_z = 2.0 * map.extent / map.size as f32;
        // a_i = r_L / (2 tan ρ_i), the Eq. 3.3 ratio's scale per layer.
        // Counted, as every scalar operation below: the loop's compare and increment per vector, the
        // layer loop's tests, the taps' loop branches.
        let mut scale: Vec<f32> = Vec::with_capacity(layers);
        for i in 0..layers {
            let rho = filter_size::layer_filter_size_counted(s, n, i, map.size);
            s.s_push(
                &mut scale,
                filter_size::filter_scale_counted(s, setup.light_radius, map.extent, rho),
            );
        }
        let mut c = SsmmCounts::default();
        let mut i = 0;
        while s.s_lt(i, self.samples.len()) {
            let m = s.mask_first_n(self.samples.len() - i);
            let p = project::<S>(s, map, self.shift, &self.samples[i..], self.receivers, m);
            c.fragments += s.mask_popcnt(m) as u64;
            let valid = p.valid;
            let dist = s.sqrt_f(s.fmadd(p.x, p.x, s.fmadd(p.y, p.y, s.mul_f(p.z, p.z))));
            let dist = s.select_f(valid, dist, one);
            // tan θ of the receiver's normal against its line to the light, capped.
            let cos = s.max_f(
                s.div_f(s.abs_f(p.np), dist),
                s.splat_f(1.0 / (1.0 + MAX_TAN * MAX_TAN).sqrt()),
            );
            let cos = s.min_f(cos, one);
            let tan = s.div_f(s.sqrt_f(s.fnmadd(cos, cos, one)), cos);
            let slope = s.mul_f(
                s.mul_f(
                    s.splat_f(setup.bias_slope * (0.5 * n as f32 + 1.0) * texel_per_z),
                    tan,
                ),
                p.z,
            );
            let biased = s.fnmadd(s.splat_f(setup.bias_constant), dist, dist);
            let inv_r0 = inv_receiver(s, biased, slope, 0);
            // Eq. 3.3 takes the receiver's own distance: the biases shift only the depth tests, so
            // every layer sees the same filter size and the hats keep their partition of unity.
            let inv_dist = s.div_f(one, dist);
            // The nearest surface any finer region can hold (inverse distance).
            let mut bound = s.splat_f(chain.inv_max);
            let mut done = s.mask_not(valid);
            // ssmm-v2: the mean blocker's filter size over layer 0's (x_0); lanes with no blocker lit.
            let mut v2_ratio = zero;
            if let Variant::V2 { blocker } = &setup.variant {
                // The search radius: the nearest surface's filter size, base texels.
                let rs = s.mul_f(
                    s.splat_f(map.size as f32 * setup.light_radius / (2.0 * map.extent)),
                    s.max_f(s.sub_f(bound, inv_dist), zero),
                );
                let rs = s.min_f(rs, s.splat_f(map.size as f32));
                let (mut sum_d, mut count) = (zero, zero);
                for t in blocker {
                    let x = s.fmadd(rs, s.splat_f(t.x), p.tx);
                    let y = s.fmadd(rs, s.splat_f(t.y), p.ty);
                    let inv = fetch(s, chain, 0, valid, s.floor_i(x), s.floor_i(y));
                    let is = s.mask_and(valid, s.cmp_gt_f(inv, inv_r0));
                    sum_d = s.mask_add_f(sum_d, is, sum_d, s.div_f(one, s.select_f(is, inv, one)));
                    count = s.mask_add_f(count, is, count, one);
                }
                c.texels += s.mask_popcnt(valid) as u64 * blocker.len() as u64;
                let found = s.mask_and(valid, s.cmp_gt_f(count, zero));
                c.no_blocker += (s.mask_popcnt(valid) - s.mask_popcnt(found)) as u64;
                done = s.mask_not(found);
                let mean_d = s.div_f(sum_d, s.select_f(found, count, one));
                let inv_mean = s.div_f(one, s.select_f(found, mean_d, one));
                v2_ratio = s.max_f(
                    filter_size_ratio(s, scale.first().copied().unwrap_or(0.0), inv_mean, inv_dist),
                    zero,
                );
            }
            let mut blocked = zero;
            let mut visited = 0u64;
            for level in (0..layers).rev() {
                let active = s.mask_andn(done, m);
                if !s.s_branch(s.mask_any(active)) {
                    break;
                }
                let inv_r = inv_receiver(s, biased, slope, level);
                let a = s.splat_f(s.s_load(&scale, level));
                let (lanes, lane_weight) = match setup.variant {
                    Variant::Full => {
                        // Finer layers see no nearer surface than `bound`: hat weight 0 below x = 1/2
                        // (layer 0 keeps every blocker, Eq. 3.12).
                        let reach = if level == 0 {
                            s.cmp_gt_f(bound, inv_r)
                        } else {
                            s.cmp_gt_f(
                                filter_size_ratio(s, scale[level], bound, inv_dist),
                                s.splat_f(0.5),
                            )
                        };
                        (s.mask_and(active, reach), one)
                    }
                    Variant::V2 { .. } => {
                        let x = s.mul_f(v2_ratio, s.splat_f(1.0 / (1u64 << level) as f32));
                        let w = layer_weight_simd(s, x, level, layers);
                        (s.mask_and(active, s.cmp_gt_f(w, zero)), w)
                    }
                };
                let visiting = s.mask_popcnt(lanes) as u64;
                if !s.s_branch(visiting != 0) {
                    continue;
                }
                visited += visiting;
                c.texels += visiting * taps_per_layer;
                let shrink = s.splat_f(1.0 / (1u64 << level) as f32);
                let (cx, cy) = (s.mul_f(p.tx, shrink), s.mul_f(p.ty, shrink));
                let half_n = s.splat_f(0.5 * n as f32);
                let (x0, y0) = (s.floor_f(s.sub_f(cx, half_n)), s.floor_f(s.sub_f(cy, half_n)));
                let wx = axis_weights(s, cx, x0, n, setup.kernel);
                let wy = axis_weights(s, cy, y0, n, setup.kernel);
                let (ix0, iy0) = (s.cvtt_f_i(x0), s.cvtt_f_i(y0));
                let mut region_max = zero;
                let mut layer_sum = zero;
                for (ky, &fy) in wy.iter().enumerate().take(n as usize + 1) {
                    let iy = s.add_i(iy0, s.splat_i(ky as i32));
                    for (kx, &fx) in wx.iter().enumerate().take(n as usize + 1) {
                        s.scalar_op(ScalarClass::Branch);
                        let ix = s.add_i(ix0, s.splat_i(kx as i32));
                        let inv = fetch(s, chain, level, lanes, ix, iy);
                        region_max = s.max_f(region_max, inv);
                        let occ = s.cmp_gt_f(inv, inv_r);
                        let f = s.mul_f(fx, fy);
                        let w = match setup.variant {
                            Variant::Full => {
                                layer_weight_simd(s, filter_size_ratio_v(s, a, inv, inv_dist), level, layers)
                            }
                            Variant::V2 { .. } => one,
                        };
                        layer_sum = s.mask_fmadd(layer_sum, occ, f, w, layer_sum);
                    }
                }
                blocked = s.mask_fmadd(blocked, lanes, layer_sum, lane_weight, blocked);
                if let Variant::Full = setup.variant {
                    bound = s.select_f(lanes, s.min_f(bound, region_max), bound);
                    done = s.mask_or(done, s.mask_and(lanes, s.cmp_le_f(bound, inv_r0)));
                }
            }
            c.layers_visited += visited;
            c.layers_skipped += s.mask_popcnt(valid) as u64 * layers as u64 - visited;
            let v = s.sub_f(one, s.clamp_f(blocked, zero, one));
            let v = s.select_f(valid, v, zero);
            c.blocked += s.mask_popcnt(s.mask_and(valid, s.cmp_lt_f(v, one))) as u64;
            s.mask_store_f(&mut self.out[i..], m, v);
            i = s.s_add(i, 16);
        }
        s.end_task();
        c
    }
}

/// [`filter_size::filter_ratio`] for 16 lanes with a scalar scale.
#[inline(always)]
fn filter_size_ratio<S: Simd>(s: S, scale: f32, inv_blocker: S::F32, inv_receiver: S::F32) -> S::F32 {
    filter_size_ratio_v(s, s.splat_f(scale), inv_blocker, inv_receiver)
}

/// [`filter_size::filter_ratio`] for 16 lanes.
#[inline(always)]
fn filter_size_ratio_v<S: Simd>(s: S, scale: S::F32, inv_blocker: S::F32, inv_receiver: S::F32) -> S::F32 {
    s.mul_f(scale, s.sub_f(inv_blocker, inv_receiver))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algorithms::sism::light_view::LightFace;
    use crate::exec::{Exec, FrameLog};

    /// Uniform numbers in [0, 1) from a 64-bit LCG seeded with `seed`.
    fn uniform(mut state: u64) -> impl FnMut() -> f32 {
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// A face looking down −y from the origin, 64 texels a side over `[−1, 1]²`, depths 1–5 world
    /// units: rectangles of random depths (the nearest wins) over nothing.
    fn synthetic_map(seed: u64) -> FaceMap {
        let mut next = uniform(seed);
        let size = 64usize;
        let mut depth = vec![f32::INFINITY; size * size];
        for _ in 0..12 {
            let (x0, y0) = ((next() * 56.0) as usize, (next() * 56.0) as usize);
            let (w, h) = (1 + (next() * 20.0) as usize, 1 + (next() * 20.0) as usize);
            let d = 0.05 + 0.5 * next();
            for y in y0..(y0 + h).min(size) {
                for x in x0..(x0 + w).min(size) {
                    depth[y * size + x] = depth[y * size + x].min(d);
                }
            }
        }
        FaceMap {
            face: LightFace {
                axis: Vec3::NEG_Y,
                right: Vec3::X,
                up: Vec3::Z,
            },
            origin: Vec3::ZERO,
            extent: 1.0,
            size: size as u32,
            z0: 1.0,
            inv_range: 0.25,
            depth,
            z_min: 1.0,
        }
    }

    /// The method by its equations, one receiver at a time, every layer and texel read.
    fn oracle(map: &FaceMap, chain: &MipChain, setup: &Setup, q: Vec3, normal: Vec3) -> f32 {
        let f = map.face.to_face(q);
        let (pos, _) = map.project_face(f);
        let n = setup.n;
        let dist = f.length();
        let cos = (normal.dot(q).abs() / dist).clamp(1.0 / (1.0 + MAX_TAN * MAX_TAN).sqrt(), 1.0);
        let tan = (1.0 - cos * cos).sqrt() / cos;
        let texel = 2.0 * map.extent / map.size as f32 * f.z;
        let slope = setup.bias_slope * (0.5 * n as f32 + 1.0) * texel * tan;
        let biased = dist - setup.bias_constant * dist;
        let layers = setup.layers;
        let cdf = |b: f32, c: f32| {
            let t = ((b - c) / (0.5 * n as f32)).clamp(-1.0, 1.0);
            match setup.kernel {
                FilterKernel::Box => (t + 1.0) / 2.0,
                FilterKernel::Pyramid if t < 0.0 => (1.0 + t) * (1.0 + t) / 2.0,
                FilterKernel::Pyramid => 1.0 - (1.0 - t) * (1.0 - t) / 2.0,
            }
        };
        let scale = |level: usize| {
            let rho = filter_size::layer_filter_size(n, level, map.size);
            filter_size::filter_scale(setup.light_radius, map.extent, rho)
        };
        let read = |level: usize, x: i64, y: i64| {
            let l = &chain.levels[level];
            if x < 0 || y < 0 || x >= l.side as i64 || y >= l.side as i64 {
                0.0
            } else {
                l.inv[(y * l.side as i64 + x) as usize]
            }
        };
        let inv_receiver = |level: usize| {
            let d = biased - slope * (1u64 << level) as f32;
            if d > 0.0 {
                1.0 / d
            } else {
                f32::INFINITY
            }
        };
        // ssmm-v2: the mean blocker distance's filter size, else every texel's own.
        let mean_ratio = match &setup.variant {
            Variant::Full => None,
            Variant::V2 { blocker } => {
                let rs = (map.size as f32 * setup.light_radius / (2.0 * map.extent)
                    * (chain.inv_max - 1.0 / dist))
                    .max(0.0)
                    .min(map.size as f32);
                let (mut sum, mut count) = (0.0, 0.0);
                for t in blocker {
                    let inv = read(
                        0,
                        (pos.x + rs * t.x).floor() as i64,
                        (pos.y + rs * t.y).floor() as i64,
                    );
                    if inv > inv_receiver(0) {
                        sum += 1.0 / inv;
                        count += 1.0;
                    }
                }
                if count == 0.0 {
                    return 1.0;
                }
                Some((scale(0) * (count / sum - 1.0 / dist)).max(0.0))
            }
        };
        let mut blocked = 0.0;
        for level in 0..layers {
            let shrink = 1.0 / (1u64 << level) as f32;
            let (cx, cy) = (pos.x * shrink, pos.y * shrink);
            let (x0, y0) = ((cx - 0.5 * n as f32).floor(), (cy - 0.5 * n as f32).floor());
            let mut sum = 0.0;
            for ky in 0..=n {
                let fy = cdf(y0 + ky as f32 + 1.0, cy) - cdf(y0 + ky as f32, cy);
                for kx in 0..=n {
                    let fx = cdf(x0 + kx as f32 + 1.0, cx) - cdf(x0 + kx as f32, cx);
                    let inv = read(level, x0 as i64 + kx as i64, y0 as i64 + ky as i64);
                    if inv > inv_receiver(level) {
                        let w = match mean_ratio {
                            None => {
                                filter_size::layer_weight(scale(level) * (inv - 1.0 / dist), level, layers)
                            }
                            Some(x0) => filter_size::layer_weight(x0 * shrink, level, layers),
                        };
                        sum += fx * fy * w;
                    }
                }
            }
            blocked += sum;
        }
        1.0 - blocked.clamp(0.0, 1.0)
    }

    /// The kernel, with its bounds and skips, gives the equations' value for every receiver, for
    /// both methods, both kernels and every n, on random blockers.
    #[test]
    fn kernel_matches_the_equations_read_directly() {
        for seed in 1..4u64 {
            let map = synthetic_map(seed);
            let mut log = FrameLog::new(Exec::Native);
            let mut next = uniform(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15));
            // Receivers 3.5–5 below the light, within the map, normals tilted up to ~60°.
            let mut receivers = Vec::new();
            let mut samples = Vec::new();
            for k in 0..200u32 {
                let z = 3.5 + 1.5 * next();
                let q = Vec3::new((next() * 1.6 - 0.8) * z, -z, (next() * 1.6 - 0.8) * z);
                let normal = Vec3::new(next() - 0.5, 1.0, next() - 0.5).normalize();
                receivers.push(Some(Receiver { position: q, normal }));
                samples.push(SampleIn {
                    q,
                    face: 0,
                    uv: glam::Vec2::ZERO,
                    depth: z,
                    pixel: k,
                    cos_theta: 1.0,
                });
            }
            for n in [2, 4, 5, 9] {
                for kernel in [FilterKernel::Box, FilterKernel::Pyramid] {
                    for variant in [
                        Variant::Full,
                        Variant::V2 {
                            blocker: crate::algorithms::shadow_map::lookup::poisson_disk(16),
                        },
                    ] {
                        let setup = Setup {
                            n,
                            layers: filter_size::layer_count(map.size, n),
                            light_radius: 0.4,
                            bias_constant: 1e-3,
                            bias_slope: 1.0,
                            kernel,
                            variant,
                        };
                        let chain = log.phase("chain", "test", |p| {
                            super::super::chain::build(p, &map, setup.layers)
                        });
                        let mut out = vec![0f32; samples.len()];
                        let counts = crate::exec::native(SsmmTask {
                            map: &map,
                            chain: &chain,
                            receivers: &receivers,
                            shift: Vec3::ZERO,
                            samples: &samples,
                            setup: &setup,
                            out: &mut out,
                        });
                        assert!(counts.blocked > 20 && counts.blocked < 190, "{counts:?}");
                        for (k, s) in samples.iter().enumerate() {
                            let want = oracle(&map, &chain, &setup, s.q, receivers[k].unwrap().normal);
                            assert!(
                                (out[k] - want).abs() <= 2e-4,
                                "seed {seed} n {n} {kernel:?} {:?} receiver {k}: kernel {} equations {want}",
                                setup.variant,
                                out[k]
                            );
                        }
                    }
                }
            }
        }
    }
}
