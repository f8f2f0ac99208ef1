//! Revectorization-based shadow mapping (Macedo and Apolinário, GI 2016): `smsr`, `rsmss`,
//! `rpcf-smsr`, `rpcf-rsmss`, on the shadow-map family's depth maps ([`super::shadow_map`]), with the
//! visibility functions of [`visibility`] (which version of each: see there).
//!
//! The lookup kernel works 16 fragments a vector: their map positions (projected 16 at a time by
//! [`FaceMap::project_lanes`], bit-identical to the scalar functions, so both see the same
//! fragment), the centre and 4-neighbour tests as gathers, and the result of every lane without a
//! discontinuity (the plain test) in vector form; lanes with a discontinuity — a few percent — run
//! the scalar walks and cases, their work counted as scalar instructions (about 12 per walk or scan
//! step) and their texel reads as scalar reads (in the line stream the machine model replays).

pub mod visibility;

use crate::counted::{next_lane, LaneArray};
use rayon::prelude::*;
use sism_simd::{Kernel, Mask16, ScalarClass, Simd};

use super::params::{FloatParam, IntParam};
use super::shadow_map::depth_map::{FaceMap, LightMaps};
use super::shadow_map::{face_tasks, map_frame};
use super::{AlgorithmFrame, BenchPlan, Family, FrameInputs, ParamKind, ParamSpec, Params, ReceiverSource};
use crate::algorithms::sism::grid::SampleIn;
use crate::exec::{task_kind, FrameLog, Phase};
use crate::stats::{percentiles, Dist, StatsReport};
use visibility::{Function, Settings};

/// Which revectorization method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// One fragment's `v_SMSR` or `v_RSMSS`.
    Single(Function),
    /// RPCF over `(K + 1)²` taps of `function` (kernel order `k`, penumbra size `p` texels).
    Rpcf {
        /// The visibility function evaluated at each tap.
        function: Function,
        /// Kernel order `K`: `(K + 1)²` taps (1..=32).
        k: u32,
        /// Penumbra half-width `P`, texels: taps from `−P` to `P`.
        p: f32,
    },
}

crate::declare_stats! {
    /// Counters of a revectorization frame.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct RbsmStats {
        /// Receivers looked up.
        pub fragments: u64 => ("rbsm.fragments", "fragments", "receivers tested against the maps"),
        /// Taps per receiver (1, or RPCF's (K + 1)²).
        pub taps_per_fragment: u64 => ("rbsm.taps_per_fragment", "taps", "visibility evaluations per receiver"),
        /// Receivers with a discontinuity at some tap (the scalar walks ran).
        pub flagged: u64 => ("rbsm.flagged", "fragments", "receivers with a discontinuity (revectorized)"),
        /// Walk and scan steps per flagged receiver.
        pub steps: Dist => ("dist.rbsm_steps", "steps", "ONDS walk and case-scan steps per flagged receiver (distribution)"),
        /// Receivers whose result differs from the plain hard test's.
        pub differs_from_hard: u64 => ("rbsm.differs_from_hard", "fragments", "receivers whose result differs from the plain hard test"),
    }
}

/// The `max_search` parameter: steps of an ONDS walk, texels (1..=256).
pub const MAX_SEARCH: IntParam = IntParam::new(ParamSpec {
    key: "max_search",
    kind: ParamKind::Int { min: 1, max: 256 },
    default: "16",
    description: "steps of an ONDS walk (the paper's maximum edge length), texels",
});
/// The `epsilon` parameter: depth threshold of the sloped-surface rule, normalised depth
/// (`[0, 0.01]`).
pub const EPSILON: FloatParam = FloatParam::new(ParamSpec {
    key: "epsilon",
    kind: ParamKind::Float { min: 0.0, max: 0.01 },
    default: "2.5e-5",
    description: "depth threshold of the sloped-surface rule, normalised depth (the paper's 2.5e-5)",
});
const KERNEL_ORDER: IntParam = IntParam::new(ParamSpec {
    key: "kernel_order",
    kind: ParamKind::Int { min: 1, max: 32 },
    default: "2",
    description: "RPCF kernel order K: (K + 1)² taps (2: the paper's 3×3)",
});
const PENUMBRA_SIZE: FloatParam = FloatParam::new(ParamSpec {
    key: "penumbra_size",
    kind: ParamKind::Float { min: 0.1, max: 16.0 },
    default: "1",
    description: "RPCF half-width P: taps from −P to P texels",
});

const SINGLE_PARAMS: [ParamSpec; 5] = [
    depth_map_param(0),
    depth_map_param(1),
    depth_map_param(2),
    MAX_SEARCH.spec(),
    EPSILON.spec(),
];
const RPCF_PARAMS: [ParamSpec; 7] = [
    depth_map_param(0),
    depth_map_param(1),
    depth_map_param(2),
    MAX_SEARCH.spec(),
    EPSILON.spec(),
    KERNEL_ORDER.spec(),
    PENUMBRA_SIZE.spec(),
];

/// The shadow-map family's map parameters (`map_size`, `bias_constant`, `bias_slope`), with the slope
/// bias of the paper's maps: `glPolygonOffset(4, 20)`, 4 times the largest depth change per texel.
/// The visibility functions compare one depth with the 3×3 texels around the fragment's (and RPCF's
/// taps reach a texel further), so the bias must cover the receiver's own slope that far; the plain
/// family's 1.5 shadows tilted receivers at their neighbours' texels.
const fn depth_map_param(k: usize) -> ParamSpec {
    let spec = super::shadow_map::MAP_PARAMS[k];
    if k == 2 {
        ParamSpec {
            default: "4",
            description: "slope-scaled depth bias: times the surface's largest depth change per texel (the paper's polygon offset factor 4)",
            ..spec
        }
    } else {
        spec
    }
}

/// Registry entry of one revectorization method.
macro_rules! rbsm_algorithm {
    ($name:ident, $key:literal, $summary:literal, $params:expr, $plan:expr, $method:expr) => {
        #[doc = concat!("`", $key, "`: ", $summary)]
        pub static $name: super::Algorithm = super::Algorithm {
            name: $key,
            family: Family::ShadowMap,
            summary: $summary,
            params: $params,
            receivers: ReceiverSource::Raster,
            kernels: true,
            bench: $plan,
            run: |inputs, params, log| run(inputs, params, log, ($method)(params)),
        };
    };
}

fn rpcf(function: Function) -> impl Fn(&Params) -> Method {
    move |params| Method::Rpcf {
        function,
        k: params.get(&KERNEL_ORDER) as u32,
        p: params.get(&PENUMBRA_SIZE) as f32,
    }
}

rbsm_algorithm!(
    SMSR,
    "smsr",
    "single-pass shadow-map silhouette revectorization (paper-era v_SMSR): jagged hard-shadow edges straightened",
    &SINGLE_PARAMS,
    BenchPlan::Sweep { key: "map_size", values: &["512", "1024", "2048", "4096"] },
    |_: &Params| Method::Single(Function::Smsr)
);
rbsm_algorithm!(
    RSMSS,
    "rsmss",
    "revectorization-based silhouette smoothing (ReallyOptimized v_RSMSS): revectorized edges, filtered over one texel",
    &SINGLE_PARAMS,
    BenchPlan::Sweep { key: "map_size", values: &["512", "1024", "2048", "4096"] },
    |_: &Params| Method::Single(Function::Rsmss)
);
rbsm_algorithm!(
    RPCF_SMSR,
    "rpcf-smsr",
    "revectorization-based PCF over v_SMSR taps (2017 generalisation, (K+1)² taps)",
    &RPCF_PARAMS,
    BenchPlan::Defaults,
    |p: &Params| rpcf(Function::Smsr)(p)
);
rbsm_algorithm!(
    RPCF_RSMSS,
    "rpcf-rsmss",
    "revectorization-based PCF over v_RSMSS taps (2017 generalisation, (K+1)² taps)",
    &RPCF_PARAMS,
    BenchPlan::Sweep {
        key: "kernel_order",
        values: &["2", "4"]
    },
    |p: &Params| rpcf(Function::Rsmss)(p)
);

/// The settings of checked `params` (which declare [`MAX_SEARCH`] and [`EPSILON`]).
pub fn settings(params: &Params) -> Settings {
    Settings {
        max_search: params.get(&MAX_SEARCH) as i32,
        epsilon: params.get(&EPSILON) as f32,
    }
}

/// A revectorization frame: light samples, depth maps from the light centre, lookups.
fn run(inputs: &FrameInputs<'_>, params: &Params, log: &mut FrameLog, method: Method) -> AlgorithmFrame {
    let s = settings(params);
    let (visibility, map_stats, out) = map_frame(
        inputs,
        params,
        log,
        "revectorization lookups",
        |p, maps, samples, shift, values| lookups(p, maps, samples, shift, method, &s, values),
    );
    let stats = RbsmStats {
        fragments: out.fragments,
        taps_per_fragment: match method {
            Method::Single(_) => 1,
            Method::Rpcf { k, .. } => (k as u64 + 1).pow(2),
        },
        flagged: out.steps.len() as u64,
        steps: percentiles(out.steps.iter().map(|&s| s as u64)),
        differs_from_hard: out.differs_from_hard,
    };
    let mut rows = StatsReport::default();
    rows.rows(&map_stats).rows(&stats);
    AlgorithmFrame {
        visibility,
        stats: rows,
    }
}

/// What the lookup tasks report.
#[derive(Default)]
pub struct LookupOut {
    /// Receivers tested against the maps.
    pub fragments: u64,
    /// Receivers whose result differs from the plain hard test's.
    pub differs_from_hard: u64,
    /// Steps of every flagged fragment.
    pub steps: Vec<u32>,
}

/// Looks every sample (grouped by face) up in its face's map, as tasks of [`LOOKUP_CHUNK`] samples of
/// step `lookup`; visibilities into `values` (sample order).
pub fn lookups(
    phase: &mut Phase,
    maps: &LightMaps,
    samples: &[SampleIn],
    shift: glam::Vec3,
    method: Method,
    s: &Settings,
    values: &mut [f32],
) -> LookupOut {
    let tasks = face_tasks(samples, values);
    let outs = phase.run_par(
        "lookup",
        tasks.into_par_iter().map(|(face, range, out)| RbsmLookup {
            map: &maps.faces[face as usize],
            shift,
            samples: &samples[range],
            method,
            settings: *s,
            out,
        }),
    );
    let mut total = LookupOut::default();
    for o in outs {
        total.fragments += o.fragments;
        total.differs_from_hard += o.differs_from_hard;
        total.steps.extend(o.steps);
    }
    total
}

/// A face map whose texel reads the scalar walks make are reported to the SIMD context, so a counted
/// frame's line stream (and the machine model's caches) sees them; natively the report is a no-op.
struct CountedTexels<'a, S: Simd> {
    map: &'a FaceMap,
    s: S,
}

impl<S: Simd> visibility::DepthTexels for CountedTexels<'_, S> {
    #[inline(always)]
    fn depth(&self, x: i64, y: i64) -> f32 {
        let (s, n) = (self.s, self.map.size as i64);
        // Four compares joined into one branch.
        for _ in 0..3 {
            s.scalar_op(ScalarClass::Alu);
        }
        if s.s_branch(x < 0 || y < 0 || x >= n || y >= n) {
            return f32::NEG_INFINITY;
        }
        s.s_load(&self.map.depth, s.s_add(s.s_mul(y, n), x) as usize)
    }
    #[inline(always)]
    fn inside(&self, x: i64, y: i64) -> bool {
        for _ in 0..3 {
            self.s.scalar_op(ScalarClass::Alu);
        }
        self.s.s_branch(visibility::DepthTexels::inside(self.map, x, y))
    }
    #[inline(always)]
    fn op(&self, class: ScalarClass) {
        self.s.scalar_op(class);
    }
    #[inline(always)]
    #[track_caller]
    fn branch(&self, taken: bool) -> bool {
        self.s.s_branch(taken)
    }
}

/// One lookup task of a face.
struct RbsmLookup<'a> {
    map: &'a FaceMap,
    shift: glam::Vec3,
    samples: &'a [SampleIn],
    method: Method,
    settings: Settings,
    out: &'a mut [f32],
}

/// The test of texel `(ix + dx, iy + dy)` for 16 fragments at depths `z` (lanes `m`), by a gather;
/// outside the map is shadowed.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn lit_at<S: Simd>(
    s: S,
    map: &FaceMap,
    m: Mask16,
    ix: S::I32,
    iy: S::I32,
    dx: i32,
    dy: i32,
    z: S::F32,
) -> Mask16 {
    let (jx, jy) = (s.add_i(ix, s.splat_i(dx)), s.add_i(iy, s.splat_i(dy)));
    let n = s.splat_i(map.size as i32);
    let zero = s.splat_i(0);
    let inside = s.mask_and(
        m,
        s.mask_and(
            s.mask_and(s.cmp_ge_i(jx, zero), s.cmp_lt_i(jx, n)),
            s.mask_and(s.cmp_ge_i(jy, zero), s.cmp_lt_i(jy, n)),
        ),
    );
    let d = s.mask_gather_f(
        s.splat_f(f32::NEG_INFINITY),
        inside,
        &map.depth,
        s.add_i(s.mul_i(jy, n), jx),
    );
    s.mask_and(m, s.cmp_le_f(z, d))
}

/// The centre test and whether any 4-neighbour differs, for 16 fragments at map positions `(x, y)`
/// and depths `z` (lanes `m`).
#[inline(always)]
fn plain_and_flagged<S: Simd>(
    s: S,
    map: &FaceMap,
    m: Mask16,
    x: S::F32,
    y: S::F32,
    z: S::F32,
) -> (Mask16, Mask16) {
    let (ix, iy) = (s.floor_i(x), s.floor_i(y));
    let c = lit_at(s, map, m, ix, iy, 0, 0, z);
    let mut flagged = Mask16::NONE;
    for (dx, dy) in [(-1, 0), (1, 0), (0, 1), (0, -1)] {
        let n = lit_at(s, map, m, ix, iy, dx, dy, z);
        flagged = s.mask_or(flagged, s.mask_xor(n, c));
    }
    (c, s.mask_and(m, flagged))
}

impl Kernel for RbsmLookup<'_> {
    type Output = LookupOut;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> LookupOut {
        s.begin_task(task_kind::SHADOW_LOOKUP);
        let map = self.map;
        let mut out = LookupOut::default();
        let taps: Vec<(f32, f32)> = match self.method {
            Method::Single(_) => vec![(0.0, 0.0)],
            Method::Rpcf { k, p, .. } => {
                let step = 2.0 * p / k as f32;
                let mut offsets = Vec::new();
                let mut w = -p;
                while w <= p {
                    offsets.push(w);
                    w += step;
                }
                offsets
                    .iter()
                    .flat_map(|&h| offsets.iter().map(move |&w| (w, h)))
                    .collect()
            }
        };
        let function = match self.method {
            Method::Single(f) | Method::Rpcf { function: f, .. } => f,
        };
        let mut i = 0;
        while s.s_lt(i, self.samples.len()) {
            let chunk = &self.samples[i..(i + 16).min(self.samples.len())];
            let m = s.mask_first_n(chunk.len());
            // The positions into lanes (scalar work, counted per lane: the loop's branch, the
            // position's load, its line read with the chunk, and three stores), then projected 16 at
            // a time, each lane exactly as the scalar functions see it.
            s.scalar_read(chunk);
            let mut q = [[0f32; 16]; 3];
            for (lane, smp) in chunk.iter().enumerate() {
                s.scalar_op(ScalarClass::Branch);
                s.scalar_op(ScalarClass::Mem);
                (q[0][lane], q[1][lane], q[2][lane]) = (smp.q.x, smp.q.y, smp.q.z);
                for _ in 0..3 {
                    s.scalar_op(ScalarClass::Store);
                }
            }
            let q = [s.from_array_f(q[0]), s.from_array_f(q[1]), s.from_array_f(q[2])];
            let (valid, [x, y, z]) = map.project_lanes(s, m, q, self.shift);
            // Line-aligned lanes (counted loads and stores on the stack; see `LaneArray`).
            let (xs, ys, zs) = (
                LaneArray(s.to_array_f(x)),
                LaneArray(s.to_array_f(y)),
                LaneArray(s.to_array_f(z)),
            );
            let (hard, _) = plain_and_flagged(s, map, valid, x, y, z);
            // Taps: lanes without a discontinuity keep the plain test; the others run the functions.
            let mut sum = s.splat_f(0.0);
            let mut flagged_any = Mask16::NONE;
            let mut steps = LaneArray([0u32; 16]);
            for &(w, h) in &taps {
                let (tx, ty) = (s.add_f(x, s.splat_f(w)), s.add_f(y, s.splat_f(h)));
                let (c, flagged) = plain_and_flagged(s, map, valid, tx, ty, z);
                flagged_any = s.mask_or(flagged_any, flagged);
                // Without a discontinuity both functions give the plain test (v_SMSR: 1 lit, 0
                // shadowed; v_RSMSS: the test; RSMSS's speck filter only removes flags).
                let plain = s.select_f(c, s.splat_f(1.0), s.splat_f(0.0));
                let mut tap = LaneArray(s.to_array_f(plain));
                // The flagged lanes one by one. Counted: the loop's test with its outcome (how
                // many lanes are flagged varies chunk to chunk), the bit scan, the lane's position
                // and tap offset, and the results' stores.
                let mut rest = flagged.0;
                while let Some(lane) = next_lane(s, &mut rest) {
                    s.scalar_op(ScalarClass::Alu);
                    s.scalar_op(ScalarClass::Alu);
                    let (v, work) = visibility::visibility(
                        &CountedTexels { map, s },
                        s.s_add(s.s_load(&xs.0, lane), w),
                        s.s_add(s.s_load(&ys.0, lane), h),
                        s.s_load(&zs.0, lane),
                        function,
                        &self.settings,
                    );
                    s.s_store(&mut tap.0, lane, v);
                    let walked = s.s_add(s.s_load(&steps.0, lane), work.steps);
                    s.s_store(&mut steps.0, lane, walked);
                }
                sum = s.add_f(sum, s.from_array_f(tap.0));
            }
            let v = s.div_f(sum, s.splat_f(taps.len() as f32));
            let v = s.select_f(valid, v, s.splat_f(0.0));
            // Statistics (the walk steps of each flagged fragment), counted as the loop they are.
            let mut rest = flagged_any.0;
            while let Some(lane) = next_lane(s, &mut rest) {
                s.scalar_op(ScalarClass::Alu);
                s.s_push(&mut out.steps, s.s_load(&steps.0, lane));
            }
            let hard_f = s.select_f(hard, s.splat_f(1.0), s.splat_f(0.0));
            out.differs_from_hard += s.mask_popcnt(s.mask_and(m, s.cmp_ne_f(v, hard_f))) as u64;
            out.fragments += chunk.len() as u64;
            s.mask_store_f(&mut self.out[i..], m, v);
            i = s.s_add(i, 16);
        }
        s.end_task();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algorithms::sism::light_view::LightFace;
    use glam::{Vec2, Vec3};

    /// A 64² face map seen along +z from the origin: a sloped receiver plane under random occluding
    /// rectangles (depths normalised over `z` in [1, 3]).
    fn random_map(seed: u64) -> FaceMap {
        let mut state = seed;
        let mut rnd = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32
        };
        let size = 64usize;
        let (a, b, c) = (0.3 + 0.4 * rnd(), 0.004 * rnd(), 0.004 * rnd());
        let mut depth: Vec<f32> = (0..size * size)
            .map(|i| a + b * (i % size) as f32 + c * (i / size) as f32)
            .collect();
        for _ in 0..12 {
            let (x0, y0) = ((rnd() * 60.0) as usize, (rnd() * 60.0) as usize);
            let (w, h) = (1 + (rnd() * 20.0) as usize, 1 + (rnd() * 20.0) as usize);
            let d = 0.3 * rnd();
            for y in y0..(y0 + h).min(size) {
                for x in x0..(x0 + w).min(size) {
                    depth[y * size + x] = depth[y * size + x].min(d);
                }
            }
        }
        FaceMap {
            face: LightFace {
                axis: Vec3::Z,
                right: Vec3::X,
                up: Vec3::Y,
            },
            origin: Vec3::ZERO,
            extent: 1.0,
            size: size as u32,
            z0: 1.0,
            inv_range: 0.5,
            depth,
            z_min: 1.0,
        }
    }

    /// Fragments on the receiver plane (so the ε rule triggers), some beyond the map's edge.
    fn fragments(map: &FaceMap, n: usize) -> Vec<SampleIn> {
        let size = map.size as f32;
        (0..n)
            .map(|i| {
                let (x, y) = (
                    -2.0 + (size + 4.0) * ((i * 37 % 211) as f32 + 0.37) / 211.0,
                    -2.0 + (size + 4.0) * ((i * 53 % 197) as f32 + 0.61) / 197.0,
                );
                let (ix, iy) = (x.floor().clamp(0.0, size - 1.0), y.floor().clamp(0.0, size - 1.0));
                // The plane's own depth at the texel, nudged so some fragments sit just behind it.
                let d = map.depth[(iy as usize) * map.size as usize + ix as usize].max(0.3)
                    + 1e-5 * (i % 7) as f32;
                let z = map.z0 + d / map.inv_range;
                let u = (2.0 * x / size - 1.0) * map.extent;
                let v = (1.0 - 2.0 * y / size) * map.extent;
                SampleIn {
                    q: Vec3::new(u * z, v * z, z),
                    face: 0,
                    uv: Vec2::ZERO,
                    depth: z,
                    pixel: i as u32,
                    cos_theta: 1.0,
                }
            })
            .collect()
    }

    #[test]
    fn the_lookup_kernel_equals_the_scalar_functions_on_every_backend() {
        let settings = Settings {
            max_search: 16,
            epsilon: 2.5e-5,
        };
        let methods = [
            Method::Single(Function::Smsr),
            Method::Single(Function::Rsmss),
            Method::Rpcf {
                function: Function::Smsr,
                k: 2,
                p: 1.0,
            },
            Method::Rpcf {
                function: Function::Rsmss,
                k: 3,
                p: 1.5,
            },
        ];
        let mut flagged = 0;
        for seed in 1..=8u64 {
            let map = random_map(seed);
            let samples = fragments(&map, 2000);
            for method in methods {
                let scalar: Vec<f32> = samples
                    .iter()
                    .map(|smp| {
                        let (pos, z) = map.project_face(map.face.to_face(smp.q));
                        match method {
                            Method::Single(f) => {
                                visibility::visibility(&map, pos.x, pos.y, z, f, &settings).0
                            }
                            Method::Rpcf { function, k, p } => {
                                visibility::rpcf(&map, pos.x, pos.y, z, function, &settings, k, p).0
                            }
                        }
                    })
                    .collect();
                for backend in sism_simd::available_backends() {
                    let mut out = vec![f32::NAN; samples.len()];
                    let r = sism_simd::run_with(
                        backend,
                        RbsmLookup {
                            map: &map,
                            shift: Vec3::ZERO,
                            samples: &samples,
                            method,
                            settings,
                            out: &mut out,
                        },
                    );
                    flagged += r.steps.len();
                    for (i, (a, b)) in scalar.iter().zip(&out).enumerate() {
                        assert_eq!(
                            a.to_bits(),
                            b.to_bits(),
                            "seed {seed} {method:?} {} fragment {i}: scalar {a} kernel {b}",
                            backend.name()
                        );
                    }
                }
            }
        }
        // The comparison must reach the revectorized cases, not only the plain test.
        assert!(flagged > 5000, "{flagged} flagged fragments");
    }
}
