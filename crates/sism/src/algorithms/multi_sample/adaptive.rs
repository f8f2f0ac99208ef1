//! `rb-adaptive`: revectorization-based adaptive area-light sampling (Macedo et al.; what its
//! authors' code does, RBSM-VISIBILITY.md §6), on the light points of [`super`] (the 17 × 17 lattice
//! on the frame's light disk).
//!
//! A quadtree over the lattice: a node at level `ℓ` is a cell of side `16 / 2^ℓ` lattice steps and
//! its four samples are the cell's corners, so level `ℓ`'s samples are the `(2^ℓ + 1)²` lattice
//! points every `16 / 2^ℓ`-th step. `evaluate(node)`, depth first from the root (level 0), returns
//! at once at `max_level` (4: the paper's), else:
//!
//! 1. renders the node's samples not yet rendered (depth maps, the hard test and the screen-space
//!    discontinuity flag of the basic §1 rule, and the final per-sample test `V_i`) — each lattice
//!    point once;
//! 2. **reprojection**, per receiver: `SS` = the node's samples that light it; `SS = 5` ("soft
//!    discontinuity") where at least `D = 2` of them flag a discontinuity; the visibility map `VM`:
//!    at level 0, `SS / 4` for `SS ∈ {0, 4}`, else 0.5; deeper, 0.5 where `VM = 0` and `SS ≠ 0` or
//!    `VM = 1` and `SS ≠ 4` — the code's rule, which catches any change (broader than the paper's
//!    Eq. 6);
//! 3. **evaluation** on the reduced grid (every `div`-th pixel; `div` by level and mode, the code's
//!    table): a pixel survives when its `SS ∈ {1, 2, 3}` and its 8 neighbours `div` pixels away
//!    (inside the image) have the same `SS` — banding; if any survives, the node is subdivided and its
//!    four children evaluated.
//!
//! Then every leaf's corners take the leaf's level (the last leaf in depth-first order wins for shared
//! points) and leaves' corners not yet rendered (children of the deepest evaluated level) are
//! rendered. Final: `V = VM` where `VM ∈ {0, 1}`; in the penumbra (`VM = 0.5`)
//! `V = Σ wᵢ Vᵢ / Σ wᵢ` over every rendered sample, `wᵢ = 1 / (2^ℓᵢ + 1)²`. `Vᵢ` is `v_RSMSS`
//! (`visibility = rsmss`, the paper's), RPCF over `v_RSMSS` (`rpcf`, with RPCF's divisors) or the
//! hard test. The paper switches RSMSS→RPCF between frames (on at ≥ 81 samples, off at ≤ 9); a
//! single-frame render starts in RSMSS mode, so the switch is the `visibility` parameter here.
//! A point below a receiver's tangent plane neither lights nor flags it. All steps are kernels.

use rayon::prelude::*;
use sism_simd::{Kernel, ScalarClass, Simd};

use super::super::params::{ChoiceParam, IntParam};
use super::super::rbsm::visibility::{Function, Settings};
use super::super::shadow_map::depth_map::{self, MapStats};
use super::super::shadow_map::{self as sm, lookup::Method as MapMethod};
use super::super::{
    AlgorithmFrame, BenchPlan, Family, FrameInputs, ParamKind, ParamSpec, Params, ReceiverSource,
};
use super::{disk_normal, light_points, receiver_facing, LATTICE_SIDE};
use crate::algorithms::sism::grid::SampleIn;
use crate::algorithms::sism::light_samples::{self, LightSamples};
use crate::counted;
use crate::exec::{task_kind, FrameLog, Phase};
use crate::frame::Receiver;
use crate::stats::StatsReport;

/// Receivers per reprojection or final-pass task.
const CHUNK: usize = 4096;

/// `SS` of a pixel no receiver covers (the code's background 0.63).
const BACKGROUND: u8 = 255;

crate::declare_stats! {
    /// Counters of an adaptive frame.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct AdaptiveStats {
        /// Light samples rendered (at most (2^max_level + 1)²).
        pub samples_used: u64 => ("adaptive.samples_used", "samples", "light samples rendered (one set of depth maps each)"),
        /// Nodes evaluated at levels 0..=3.
        pub evaluated_0: u64 => ("adaptive.nodes_evaluated.l0", "nodes", "quadtree nodes evaluated at level 0"),
        /// Nodes evaluated at level 1.
        pub evaluated_1: u64 => ("adaptive.nodes_evaluated.l1", "nodes", "quadtree nodes evaluated at level 1"),
        /// Nodes evaluated at level 2.
        pub evaluated_2: u64 => ("adaptive.nodes_evaluated.l2", "nodes", "quadtree nodes evaluated at level 2"),
        /// Nodes evaluated at level 3.
        pub evaluated_3: u64 => ("adaptive.nodes_evaluated.l3", "nodes", "quadtree nodes evaluated at level 3"),
        /// Nodes refined (subdivided) at levels 0..=3.
        pub refined_0: u64 => ("adaptive.nodes_refined.l0", "nodes", "quadtree nodes refined at level 0"),
        /// Nodes refined at level 1.
        pub refined_1: u64 => ("adaptive.nodes_refined.l1", "nodes", "quadtree nodes refined at level 1"),
        /// Nodes refined at level 2.
        pub refined_2: u64 => ("adaptive.nodes_refined.l2", "nodes", "quadtree nodes refined at level 2"),
        /// Nodes refined at level 3.
        pub refined_3: u64 => ("adaptive.nodes_refined.l3", "nodes", "quadtree nodes refined at level 3"),
        /// Receivers in the penumbra (`VM = 0.5`): the weighted mean of the samples.
        pub penumbra: u64 => ("adaptive.penumbra_receivers", "receivers", "receivers in the visibility map's penumbra (VM = 0.5): the weighted mean of every sample"),
    }
}

const MAX_LEVEL: IntParam = IntParam::new(ParamSpec {
    key: "max_level",
    kind: ParamKind::Int { min: 0, max: 4 },
    default: "4",
    description: "deepest quadtree level: at most (2^max_level + 1)² light samples (4: the paper's 289)",
});

/// The per-sample test.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Visibility {
    Rsmss,
    Rpcf,
    Hard,
}
const VISIBILITY: ChoiceParam<Visibility> = ChoiceParam::new(
    ParamSpec {
        key: "visibility",
        kind: ParamKind::Choice(&["rsmss", "rpcf", "hard"]),
        default: "rsmss",
        description: "per-sample test V_i of the penumbra's weighted mean: v_RSMSS, RPCF over v_RSMSS \
(3×3, with RPCF's divisors), or the hard test",
    },
    &[Visibility::Rsmss, Visibility::Rpcf, Visibility::Hard],
);
const FORCE_REFINE: ChoiceParam<bool> = ChoiceParam::new(
    ParamSpec {
        key: "force_refine",
        kind: ParamKind::Choice(&["no", "yes"]),
        default: "no",
        description: "yes: refine every node and treat every receiver as penumbra (the uniform mean over \
the lattice, for tests)",
    },
    &[false, true],
);

/// `rb-adaptive`'s parameters.
const PARAMS: [ParamSpec; 8] = [
    sm::MAP_SIZE.with_default("1024").spec(),
    sm::MAP_PARAMS[1],
    sm::BIAS_SLOPE
        .with_default("4")
        .with_description(
            "slope-scaled depth bias: times the surface's largest depth change per texel (the \
revectorization papers' polygon offset factor 4)",
        )
        .spec(),
    MAX_LEVEL.spec(),
    VISIBILITY.spec(),
    FORCE_REFINE.spec(),
    super::super::rbsm::MAX_SEARCH.spec(),
    super::super::rbsm::EPSILON.spec(),
];

/// `rb-adaptive`: the adaptive method.
pub static RB_ADAPTIVE: super::super::Algorithm = super::super::Algorithm {
    name: "rb-adaptive",
    family: Family::ShadowMap,
    summary: "revectorization-based adaptive area-light sampling (Macedo et al.): a quadtree of light \
samples refined where the screen shows banding, the penumbra a weighted mean of v_RSMSS",
    params: &PARAMS,
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Sweep {
        key: "max_level",
        values: &["3", "4"],
    },
    run,
};

/// The reduced grid's divisor of `level` (the code's table; levels ≥ 4 are never evaluated).
fn divisor(rpcf: bool, level: u32) -> u32 {
    match (rpcf, level) {
        (_, 0 | 1) => 1,
        (false, 2 | 3) => 2,
        (true, 2 | 3) => 3,
        (false, _) => 4,
        (true, _) => 6,
    }
}

/// The weight of a sample of level `level`: `1 / (2^ℓ + 1)²`, `ℓ` clamped to 4.
pub fn sample_weight(level: u32) -> f32 {
    let side = (1u32 << level.min(4)) + 1;
    1.0 / (side * side) as f32
}

/// One rendered light sample: per receiver (sample order) bit 0 lit, bit 1 a discontinuity (both only
/// where the receiver faces the point), and `V_i`.
struct Rendered {
    code: Vec<u8>,
    v: Vec<f32>,
    level: u32,
}

/// What the traversal shares.
struct Frame<'a> {
    inputs: &'a FrameInputs<'a>,
    samples: &'a LightSamples,
    points: Vec<glam::Vec3>,
    map_params: depth_map::MapParams,
    test: Option<super::super::rbsm::Method>,
    settings: Settings,
    rpcf: bool,
    max_level: u32,
    force: bool,
    rendered: Vec<Option<Rendered>>,
    vm: Vec<f32>,
    ss: Vec<u8>,
    maps: MapStats,
    stats: AdaptiveStats,
    /// Leaves in depth-first order: lowest corner `(i, j)`, side in lattice steps, level.
    leaves: Vec<(u32, u32, u32, u32)>,
}

impl Frame<'_> {
    /// Renders lattice point `k` if it is not yet (maps, hard test and flag, `V_i`).
    fn render(&mut self, p: &mut Phase, k: usize) {
        if self.rendered[k].is_some() {
            return;
        }
        let scene = self.inputs.prepared.scene;
        let origin = self.points[k];
        let maps = depth_map::render_maps(p, scene, self.samples, origin, &self.map_params);
        self.maps.add_maps(&maps.stats(self.map_params.size));
        let shift = self.samples.light.center - origin;
        let smp = &self.samples.samples;
        let n = smp.len();
        let mut codes = vec![0f32; n];
        sm::lookups(
            p,
            &maps,
            smp,
            &self.inputs.receivers.pixels,
            shift,
            &MapMethod::HardAndDiscontinuity,
            &mut codes,
        );
        let mut v = Vec::new();
        if let Some(method) = self.test {
            v = vec![0f32; n];
            super::super::rbsm::lookups(p, &maps, smp, shift, method, &self.settings, &mut v);
        }
        let mut code = vec![0u8; n];
        let mut out_v = vec![0f32; n];
        let point = origin - self.samples.light.center;
        let receivers = &self.inputs.receivers.pixels;
        p.run_par(
            "sample_codes",
            smp.par_chunks(CHUNK)
                .zip(codes.par_chunks(CHUNK))
                .zip(code.par_chunks_mut(CHUNK))
                .zip(out_v.par_chunks_mut(CHUNK))
                .enumerate()
                .map(|(c, (((samples, codes), code), out_v))| SampleCodes {
                    samples,
                    receivers,
                    point,
                    codes,
                    v: if v.is_empty() {
                        None
                    } else {
                        Some(&v[c * CHUNK..c * CHUNK + samples.len()])
                    },
                    code,
                    out_v,
                }),
        );
        self.stats.samples_used += 1;
        self.rendered[k] = Some(Rendered {
            code,
            v: out_v,
            level: 0,
        });
    }

    /// `evaluate(node)`: the node with lowest corner `(i, j)`, side `size` lattice steps, at `level`.
    fn evaluate(&mut self, p: &mut Phase, (i, j, size, level): (u32, u32, u32, u32)) {
        if level >= self.max_level {
            self.leaves.push((i, j, size, level));
            return;
        }
        let corners = corners(i, j, size);
        for &k in &corners {
            self.render(p, k);
        }
        match level {
            0 => self.stats.evaluated_0 += 1,
            1 => self.stats.evaluated_1 += 1,
            2 => self.stats.evaluated_2 += 1,
            _ => self.stats.evaluated_3 += 1,
        }
        // Reprojection.
        let codes: [&[u8]; 4] = corners.map(|k| self.rendered[k].as_ref().expect("rendered").code.as_slice());
        let smp = &self.samples.samples;
        let ss_of: Vec<u8> = p
            .run_par(
                "reprojection",
                smp.par_chunks(CHUNK)
                    .zip(self.vm.par_chunks_mut(CHUNK))
                    .enumerate()
                    .map(|(c, (samples, vm))| Reprojection {
                        codes: codes.map(|code| &code[c * CHUNK..c * CHUNK + samples.len()]),
                        first_level: level == 0,
                        vm,
                    }),
            )
            .concat();
        for (s, &v) in smp.iter().zip(&ss_of) {
            self.ss[s.pixel as usize] = v;
        }
        // Evaluation on the reduced grid.
        let refine = self.force
            || p.run(
                "evaluation",
                Evaluation {
                    ss: &self.ss,
                    width: self.samples.image.width,
                    height: self.samples.image.height,
                    div: divisor(self.rpcf, level),
                },
            );
        if !refine {
            self.leaves.push((i, j, size, level));
            return;
        }
        match level {
            0 => self.stats.refined_0 += 1,
            1 => self.stats.refined_1 += 1,
            2 => self.stats.refined_2 += 1,
            _ => self.stats.refined_3 += 1,
        }
        let h = size / 2;
        for (di, dj) in [(0, 0), (h, 0), (0, h), (h, h)] {
            self.evaluate(p, (i + di, j + dj, h, level + 1));
        }
    }
}

/// Lattice indices of a node's four corners.
fn corners(i: u32, j: u32, size: u32) -> [usize; 4] {
    let side = LATTICE_SIDE;
    let at = |x: u32, y: u32| (y * side + x) as usize;
    [at(i, j), at(i + size, j), at(i, j + size), at(i + size, j + size)]
}

fn run(inputs: &FrameInputs<'_>, params: &Params, log: &mut FrameLog) -> AlgorithmFrame {
    let scene = inputs.prepared.scene;
    let samples = log.phase(
        "light_samples",
        "light view fitted to the receivers and their light-space samples",
        |p| light_samples::build(p, inputs.receivers, &scene.light),
    );
    let visibility = params.get(&VISIBILITY);
    let test = match visibility {
        Visibility::Rsmss => Some(super::super::rbsm::Method::Single(Function::Rsmss)),
        Visibility::Rpcf => Some(super::super::rbsm::Method::Rpcf {
            function: Function::Rsmss,
            k: 2,
            p: 1.0,
        }),
        Visibility::Hard => None,
    };
    let n = samples.samples.len();
    let (w, h) = (samples.image.width, samples.image.height);
    let normal = disk_normal(&samples.samples);
    let mut frame = Frame {
        inputs,
        samples: &samples,
        points: light_points(scene.light.center(), scene.light.radius, normal, LATTICE_SIDE),
        map_params: sm::map_params(params),
        test,
        settings: super::super::rbsm::settings(params),
        rpcf: visibility == Visibility::Rpcf,
        max_level: params.get(&MAX_LEVEL) as u32,
        force: params.get(&FORCE_REFINE),
        rendered: (0..LATTICE_SIDE * LATTICE_SIDE).map(|_| None).collect(),
        vm: vec![0.0; n],
        ss: vec![BACKGROUND; (w * h) as usize],
        maps: MapStats::default(),
        stats: AdaptiveStats::default(),
        leaves: Vec::new(),
    };
    let mut image = samples.image.clone();
    log.phase(
        "adaptive",
        "quadtree of light samples: maps, reprojection, evaluation, final weighted mean",
        |p| {
            // No receiver: no kernel runs; timed as zero, not as untimed host work.
            p.skip();
            frame.evaluate(p, (0, 0, LATTICE_SIDE - 1, 0));
            // Leaves' levels (the last leaf in depth-first order wins), then their unrendered corners.
            let leaves = std::mem::take(&mut frame.leaves);
            let mut level = vec![0u32; frame.rendered.len()];
            for &(i, j, size, l) in &leaves {
                for k in corners(i, j, size) {
                    level[k] = l;
                }
            }
            for &(i, j, size, _) in &leaves {
                for k in corners(i, j, size) {
                    frame.render(p, k);
                }
            }
            let mut used: Vec<(&[f32], f32)> = Vec::new();
            for (k, r) in frame.rendered.iter_mut().enumerate() {
                if let Some(r) = r {
                    r.level = level[k];
                }
            }
            for r in frame.rendered.iter().flatten() {
                used.push((&r.v, sample_weight(r.level)));
            }
            let total: f32 = used.iter().map(|&(_, w)| w).sum();
            let mut values = vec![0f32; n];
            let penumbra: u64 = p
                .run_par(
                    "final",
                    values
                        .par_chunks_mut(CHUNK)
                        .zip(frame.vm.par_chunks(CHUNK))
                        .enumerate()
                        .map(|(c, (out, vm))| Final {
                            first: c * CHUNK,
                            used: &used,
                            inv_total: 1.0 / total,
                            force: frame.force,
                            vm,
                            out,
                        }),
                )
                .iter()
                .sum();
            frame.stats.penumbra = penumbra;
            let pixels: Vec<u32> = samples.samples.iter().map(|s| s.pixel).collect();
            crate::algorithms::pixels::scatter_to_pixels(
                p,
                "scatter",
                task_kind::SHADOW_SCATTER,
                &pixels,
                &values,
                &mut image.values,
            );
        },
    );
    frame.maps.size = frame.map_params.size as u64;
    let mut out = StatsReport::default();
    out.rows(&frame.maps).rows(&frame.stats);
    AlgorithmFrame {
        visibility: image,
        stats: out,
    }
}

/// Step `sample_codes`: a rendered sample's per-receiver code and `V_i`, where the receiver faces
/// the light point (else 0: the point is below its tangent plane).
struct SampleCodes<'a> {
    samples: &'a [SampleIn],
    receivers: &'a [Option<Receiver>],
    point: glam::Vec3,
    /// Hard test + 2 × discontinuity.
    codes: &'a [f32],
    /// The final test's values (`None`: the hard test's).
    v: Option<&'a [f32]>,
    code: &'a mut [u8],
    out_v: &'a mut [f32],
}

impl Kernel for SampleCodes<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::ADAPTIVE_PASS);
        s.scalar_read(self.samples);
        s.scalar_read(self.codes);
        // Counted per sample: the loop's branch, its pixel and position (lines read above), the
        // receiver's tag (its line here), normal and facing test, the code's load, conversion and
        // store, and the value's choice, load or conversion, and store.
        for k in 0..self.samples.len() {
            let facing = receiver_facing(s, self.receivers, &self.samples[k], self.point)
                .is_some_and(|d| s.s_lt(0.0, d));
            let c = s.s_fn(ScalarClass::Alu, counted::streamed(s, self.codes, k), |c: f32| {
                c as u8
            });
            self.code[k] = if facing { c } else { 0 };
            s.scalar_op(ScalarClass::Store);
            s.scalar_op(ScalarClass::Branch);
            self.out_v[k] = match (facing, self.v) {
                (false, _) => 0.0,
                (true, Some(v)) => s.s_load(v, k),
                (true, None) => {
                    s.scalar_op(ScalarClass::Alu);
                    s.scalar_op(ScalarClass::Alu);
                    f32::from(c & 1)
                }
            };
            s.scalar_op(ScalarClass::Store);
        }
        s.scalar_write(self.code);
        s.scalar_write(self.out_v);
        s.end_task();
    }
}

/// Step `reprojection`: `SS` per receiver from a node's four samples, and the visibility map's update.
struct Reprojection<'a> {
    codes: [&'a [u8]; 4],
    first_level: bool,
    vm: &'a mut [f32],
}

impl Kernel for Reprojection<'_> {
    type Output = Vec<u8>;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> Vec<u8> {
        s.begin_task(task_kind::ADAPTIVE_PASS);
        let n = self.vm.len();
        for c in &self.codes {
            s.scalar_read(c);
        }
        // Counted per receiver: the loop's branch; per code its load and two bit tests with their
        // adds; the `SS` choice; the map's load, tests and store; `SS`'s store.
        let mut ss = vec![0u8; n];
        for (k, ss_k) in ss.iter_mut().enumerate() {
            s.scalar_op(ScalarClass::Branch);
            let (mut lit, mut flags) = (0u8, 0u8);
            for c in &self.codes {
                let ck = counted::streamed(s, c, k);
                for _ in 0..5 {
                    s.scalar_op(ScalarClass::Alu);
                }
                lit += ck & 1;
                flags += (ck >> 1) & 1;
            }
            let v = if s.s_branch(flags >= 2) { 5 } else { lit };
            let old = counted::streamed(s, self.vm, k);
            let vm = &mut self.vm[k];
            if self.first_level {
                s.scalar_op(ScalarClass::Branch);
                *vm = match v {
                    0 => 0.0,
                    4 => 1.0,
                    _ => 0.5,
                };
                s.scalar_op(ScalarClass::Store);
            } else if (s.s_branch(old == 0.0) && s.s_branch(v != 0))
                || (s.s_branch(old == 1.0) && s.s_branch(v != 4))
            {
                *vm = 0.5;
                s.scalar_op(ScalarClass::Store);
            }
            *ss_k = v;
            s.scalar_op(ScalarClass::Store);
        }
        s.scalar_write(self.vm);
        s.scalar_write(&ss);
        s.end_task();
        ss
    }
}

/// Step `evaluation`: does any pixel of the reduced grid show banding (`SS ∈ {1, 2, 3}` with all 8
/// neighbours `div` pixels away equal)?
struct Evaluation<'a> {
    ss: &'a [u8],
    width: u32,
    height: u32,
    div: u32,
}

impl Kernel for Evaluation<'_> {
    type Output = bool;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> bool {
        s.begin_task(task_kind::ADAPTIVE_PASS);
        let (w, h, d) = (self.width as i64, self.height as i64, self.div as i64);
        let mut found = false;
        // Counted per grid point: the loop's branch, its index, `SS`'s load and range test; per
        // neighbour its coordinates, the bounds tests, index, load and compare, up to the first
        // that differs.
        'grid: for y in (0..h).step_by(d as usize) {
            for x in (0..w).step_by(d as usize) {
                s.scalar_op(ScalarClass::Branch);
                let v = s.s_load(self.ss, s.s_add(s.s_mul(y, w), x) as usize);
                if !(s.s_le(1, v as u32) && s.s_le(v as u32, 3)) {
                    continue;
                }
                let mut same = true;
                for (dx, dy) in [
                    (-1, -1),
                    (0, -1),
                    (1, -1),
                    (-1, 0),
                    (1, 0),
                    (-1, 1),
                    (0, 1),
                    (1, 1),
                ] {
                    let (nx, ny) = (s.s_add(x, s.s_mul(dx, d)), s.s_add(y, s.s_mul(dy, d)));
                    if s.s_lt(nx, 0) || s.s_lt(ny, 0) || s.s_le(w, nx) || s.s_le(h, ny) {
                        continue;
                    }
                    if s.s_branch(s.s_load(self.ss, s.s_add(s.s_mul(ny, w), nx) as usize) != v) {
                        same = false;
                        break;
                    }
                }
                if same {
                    found = true;
                    break 'grid;
                }
            }
        }
        s.end_task();
        found
    }
}

/// Step `final`: `VM` outside the penumbra, the weighted mean of every sample's `V_i` inside it;
/// returns the penumbra receivers.
struct Final<'a> {
    first: usize,
    used: &'a [(&'a [f32], f32)],
    inv_total: f32,
    force: bool,
    vm: &'a [f32],
    out: &'a mut [f32],
}

impl Kernel for Final<'_> {
    type Output = u64;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> u64 {
        s.begin_task(task_kind::ADAPTIVE_PASS);
        let n = self.out.len();
        let mut penumbra = 0;
        let mut sums = vec![0f32; n];
        let zero = s.splat_f(0.0);
        for &(v, w) in self.used {
            let wv = s.splat_f(w);
            let mut i = 0;
            while s.s_lt(i, n) {
                let m = s.mask_first_n(n - i);
                let x = s.mask_load_f(zero, m, &v[self.first + i..]);
                let acc = s.mask_load_f(zero, m, &sums[i..]);
                s.mask_store_f(&mut sums[i..], m, s.fmadd(x, wv, acc));
                i = s.s_add(i, 16);
            }
        }
        // Counted per receiver: the loop's branch, the map's load and test, the sum's load and
        // scaling, the store.
        s.scalar_read(self.vm);
        for k in 0..n {
            s.scalar_op(ScalarClass::Branch);
            let vm = counted::streamed(s, self.vm, k);
            self.out[k] = if self.force || s.s_branch(vm == 0.5) {
                penumbra += 1;
                s.s_mul(counted::streamed(s, &sums, k), self.inv_total)
            } else {
                vm
            };
            s.scalar_op(ScalarClass::Store);
        }
        s.scalar_write(self.out);
        s.end_task();
        penumbra
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_tree_at_one_level_has_uniform_weights() {
        // Level ℓ has (2^ℓ + 1)² lattice points; all at one level weigh the same, so their weighted
        // mean is the uniform mean.
        for level in 0..=4u32 {
            let side = (1 << level) + 1;
            let w = sample_weight(level);
            let total = w * (side * side) as f32;
            assert!((total - 1.0).abs() < 1e-5, "{level}: {total}");
        }
        assert_eq!(sample_weight(7), sample_weight(4));
        assert_eq!(divisor(false, 3), 2);
        assert_eq!(divisor(true, 3), 3);
    }

    #[test]
    fn node_corners_lie_on_the_lattice_and_children_share_them() {
        let root = corners(0, 0, 16);
        assert_eq!(root, [0, 16, 16 * 17, 17 * 17 - 1]);
        // The four children of the root share its corners and its centre.
        let mut all: Vec<usize> = [(0, 0), (8, 0), (0, 8), (8, 8)]
            .iter()
            .flat_map(|&(i, j)| corners(i, j, 8))
            .collect();
        all.sort();
        all.dedup();
        assert_eq!(all.len(), 9);
        assert!(root.iter().all(|k| all.contains(k)));
        assert!(all.contains(&(8 * 17 + 8)));
    }
}
