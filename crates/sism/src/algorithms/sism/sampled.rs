//! Light-point composition: Eq. 3's regions counted at fixed points of the light disk, so that
//! overlapping occluders are composed exactly (the paper's `C = 0` removed).
//!
//! # Why
//!
//! Eq. 4 adds coverages: `V = 1 - clamp01(depth complexity + Σ edge terms)`. The sum is the *mean*
//! over the light disk of the number of counted triangles between the sample and each light point
//! (the depth complexity seen from that point). Where partial occluders overlap (foliage), that
//! mean exceeds the occluded fraction and penumbrae darken — on japanese-maple this is nearly all of
//! SISM's error. The occluded fraction is the share of light points whose count is *non-zero*, so
//! here each sample keeps the count at fixed points of its light disk ([`LightPoints`]: 128 by default) instead of
//! their mean.
//!
//! # How
//!
//! Eq. 3's term of one edge is the area of a region of the unit disk: inside the wedge from the
//! centre through the clipped projected edge, and beyond the edge's line (EQ3-NOTES.md). A light
//! point `P` lies in it when three linear functions are non-negative; in the line's frame (unit `ĝ`
//! along the line, unit `f̂` from the centre towards it, line at distance `d`, clipped endpoints at
//! `lo < hi` along `ĝ`):
//!
//! * `P·f̂ - d ≥ 0` (beyond the line),
//! * `d (P·ĝ) - lo (P·f̂) ≥ 0` and `hi (P·f̂) - d (P·ĝ) ≥ 0` (inside the wedge).
//!
//! The edge adds its integer weight (`Σ_k sign_k` of Eq. 3's sign rule, −2..2) to the counters of
//! the points inside; the umbra's depth complexity at the centre is every point's starting count.
//! By the same fan identity that makes Eq. 3 exact for one polygon, each point ends with the number
//! of counted triangles covering it, so `V = #{points with count 0} / #points` (then the horizon
//! term, as an independent occluder). The mean of the counts is exactly Eq. 4's sum in the limit of
//! many points; the light-centre silhouette approximation (single point of projection) remains.
//! Where every count is 0 or 1 nothing overlaps (as far as the points see) and Eq. 4's analytic
//! value, accumulated alongside, is used instead: exact there and free of point noise (see
//! [`LightPointEstimator`]).
//!
//! Section 5.2 of the paper names bitwise coverage masks (Schwarz and Stamminger 2007) as the way to
//! compute `C`, at the price of aliasing. Counts rather than bits let overlaps within one closed mesh
//! cancel as they should, the per-pixel rotation turns the aliasing into fine noise, and the analytic
//! fallback keeps single-occluder penumbrae smooth.
//!
//! The points are a Fibonacci (sunflower) spiral — evenly spread, no clumps — expressed in an
//! orthonormal basis of each sample's light disk, rotated per pixel by one of 256 angles chosen by
//! hashing the pixel index, so that the quantisation error of the points turns into fine noise
//! instead of contour bands. Counters are 32-bit lanes, one per point of each sample (512 bytes with
//! 128 points), in a buffer each host thread reuses across its bins. The points are stored in order
//! of angle, in groups of 16 each filling a sector of the disk (an eighth with 128 points); per
//! (sample, edge) a group is skipped when the cone of
//! the edge's region (from the centre through the clipped segment) misses the group's cone, or the
//! group lies nearer the centre than the edge's line (palm 1600×1200: −15% penumbra, images
//! unchanged).
//!
//! Cost: per (sample, edge) the vector part of Eq. 3 up to the clipped positions (shared with
//! [`edge_term`](super::occlusion::edge_term)), then per lane and group of 16 points the group
//! left (6 FMAs, 3 compares, a masked add). Measured with 64 points: 1.7–2× the additive penumbra
//! natively at 1600×1200, 2.6× on the modelled in-order chip (larrabee-24, japanese-maple 800×600).

use crate::counted::{next_lane, LaneArray};
use rayon::prelude::*;
use sism_simd::{Kernel, ScalarClass, Simd};

use super::grid::Grid;
use super::occlusion::{edge_frame, region_area, signed_sum, EdgeRecord};
use super::penumbra::{bin_parts, run_parts, BinCounts, BinPart, PenumbraStats, WedgeScan};
use super::{Occluders, SismLight, StageInputs};
use crate::algorithms::reference::DiskRays;
use crate::bvh::beam::{Beam, BEAM_RAYS};
use crate::bvh::SceneBvh;
use crate::counted;
use crate::exec::{task_kind, Phase};
use crate::frame::Receivers;
use crate::vmath::{cross3, dot3};

/// Most points of the light disk at which a sample counts occluders ([`LightPoints`]).
pub const MAX_LIGHT_POINTS: usize = 256;

/// Points of the light disk at which each sample counts occluders (parameter `light_points`: 64, 128
/// or 256; default 128). The points' quantisation is most of `sism-sampled`'s error in foliage
/// penumbrae (fine noise: the per-pixel rotation), so more points buy accuracy at a cost that grows
/// more slowly than their number (finer groups: an edge's region skips more of them). Measured at
/// 320×240 against a 1024-spp truth, reference and `sism-sampled` in one `sism bench` run per
/// scene (2-core AMD EPYC, AVX-512), 64 → 128 → 256 points: palm MAE 0.00426 → 0.00313 → 0.00245,
/// japanese-maple 0.0111 → 0.0088 → 0.0076, stanford-bunny 0.00143 → 0.00138 → 0.00133; the
/// reference's time at equal MAE ÷ `sism-sampled`'s 1.18 → 2.05 → 1.39 (palm), 1.17 → 1.45 →
/// 1.15 (maple), 1.85 → 2.33 → 2.05 (bunny): 128 is the default.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightPoints(usize);

impl LightPoints {
    /// 64 points.
    pub const P64: LightPoints = LightPoints(64);
    /// 128 points (the default).
    pub const P128: LightPoints = LightPoints(128);
    /// 256 points.
    pub const P256: LightPoints = LightPoints(256);
    /// The number of points (a multiple of 16, at most [`MAX_LIGHT_POINTS`]).
    pub fn get(self) -> usize {
        self.0
    }

    /// What one Eq. 3 evaluation of a sample costs with this many points, in eighths of a 64-point
    /// evaluation (the cost-aware penumbra's unit, in which [`QUAD_EVALUATIONS`],
    /// [`EVALUATIONS_PER_BEAM_OP`], [`BUILD_EVALUATIONS_PER_TRIANGLE`] and `ray_evaluations` are
    /// stated). Measured on the project's AVX-512 host (palm under a 1.5 m light at 320×240, rays
    /// off, 90.5M evaluations, the median of 5 frames): step `light_points` 887, 1138 and 1562 ms
    /// for 64, 128 and 256 points, i.e. +5.5 and +9.4 ns a thread-evaluation over the 64-point
    /// evaluation's 14.7 ns: 1, 1.37 and 2.0 times; more points cost less than their number
    /// because an edge skips the groups whose sector its region misses.
    pub fn evaluation_cost_eighths(self) -> u64 {
        match self.0 {
            0..=64 => EIGHTHS,
            65..=128 => 11,
            _ => 16,
        }
    }
}

/// Eighths in a 64-point evaluation: the cost-aware penumbra counts in eighths, so that its integer
/// estimates carry [`LightPoints::evaluation_cost_eighths`] exactly.
const EIGHTHS: u64 = 8;

impl Default for LightPoints {
    fn default() -> Self {
        LightPoints::P128
    }
}

/// How a sample's visibility is formed from its light-point counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightPointEstimator {
    /// Where every point's count is 0 or 1 (no two occluders overlap as far as the points see),
    /// Eq. 4's analytic coverage (depth complexity + Σ Eq. 3 terms), which is then exact and free of
    /// the points' quantisation noise; elsewhere the share of lit points. Against `Fraction` at
    /// 800×600: the same MAE on the foliage, slightly lower elsewhere (conference 0.0014 vs 0.0015),
    /// and single-occluder penumbrae as smooth as Eq. 4's (a light almost touching a box: MAE 0.0044
    /// vs 0.0101). A control variate `A + (z - m)` everywhere was tried and rejected: in deep foliage
    /// the mean count `m` over 64 points is far noisier than the lit share `z` (palm MAE 0.011).
    #[default]
    Hybrid,
    /// The plain share of lit points (for tests that ray-cast to the very same points).
    Fraction,
}

/// Vectors of 16 points, at most.
const MAX_GROUPS: usize = MAX_LIGHT_POINTS / 16;

/// Rotations of the point set; a pixel's is chosen by hashing its index.
const ROTATIONS: usize = 256;

/// The light points in the unit disk, as `groups` rows of 16 `x` and `y`, in order of angle: each
/// group fills a sector of the disk (a quarter with 64 points, a sixteenth with 256), so rays cast
/// to them in this order make compact vectors, and an edge whose region misses a group's sector
/// skips its 16 points.
///
/// Line-aligned, the point arrays first: the kernels load `x` and `y` with counted vector loads,
/// and the set lives on the host's stack, so their lines must not move with the stack's layout
/// (two counted runs of one frame write the same records).
#[repr(C, align(64))]
struct PointSet {
    x: [[f32; 16]; MAX_GROUPS],
    y: [[f32; 16]; MAX_GROUPS],
    /// Points ([`LightPoints`]).
    n: usize,
    /// Their groups of 16: `n / 16`.
    groups: usize,
    /// Per group, the cone (apex at the centre, less than half a turn) holding its points: unit
    /// boundary directions `b0`, then `b1` counterclockwise, `[b0x, b0y, b1x, b1y]`, opened by
    /// [`CONE_SLACK`] radians on each side so that no point lies within rounding of its boundary.
    cone: [[f32; 4]; MAX_GROUPS],
    /// Per group, the largest radius of its points (with a relative slack of 1e-6).
    radius: [f32; MAX_GROUPS],
}

/// Angle (radians) by which a group's cone is opened beyond its outermost points.
const CONE_SLACK: f64 = 1e-4;

/// `n` points of the unit disk on a Fibonacci spiral: point `k` at radius `√((k + ½) / n)` and angle
/// `phase + k · golden angle`, so each point stands for an equal share of the disk's area; then ordered by
/// angle (rays cast to them in this order make compact beams).
fn spiral(n: usize, phase: f64) -> Vec<(f32, f32)> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut points: Vec<(f64, f32, f32)> = (0..n)
        .map(|k| {
            let r = ((k as f64 + 0.5) / n as f64).sqrt();
            let a = k as f64 * golden + phase;
            let (x, y) = ((r * a.cos()) as f32, (r * a.sin()) as f32);
            (f64::from(y).atan2(f64::from(x)), x, y)
        })
        .collect();
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    points.into_iter().map(|(_, x, y)| (x, y)).collect()
}

/// The `n` points ([`spiral`]) in groups of 16, with each group's cone and radius.
fn point_set(n: LightPoints) -> PointSet {
    let n = n.get();
    let points = spiral(n, 0.0);
    let mut set = PointSet {
        n,
        groups: n / 16,
        x: [[0.0; 16]; MAX_GROUPS],
        y: [[0.0; 16]; MAX_GROUPS],
        cone: [[0.0; 4]; MAX_GROUPS],
        radius: [0.0; MAX_GROUPS],
    };
    for (k, &(x, y)) in points.iter().enumerate() {
        set.x[k / 16][k % 16] = x;
        set.y[k / 16][k % 16] = y;
        let r = &mut set.radius[k / 16];
        *r = r.max(x.hypot(y) * (1.0 + 1e-6));
    }
    for g in 0..set.groups {
        // Angles of the f32 points, so the cone holds the points the kernel tests.
        let angle = |l: usize| f64::from(set.y[g][l]).atan2(f64::from(set.x[g][l]));
        let (a0, a1) = (angle(0) - CONE_SLACK, angle(15) + CONE_SLACK);
        assert!(
            a1 - a0 < 0.9 * std::f64::consts::PI,
            "a group's cone spans under half a turn"
        );
        set.cone[g] = [a0.cos() as f32, a0.sin() as f32, a1.cos() as f32, a1.sin() as f32];
    }
    set
}

/// `(cos, sin)` of the [`ROTATIONS`] angles `2π j / ROTATIONS`.
fn rotation_table() -> (Vec<f32>, Vec<f32>) {
    (0..ROTATIONS)
        .map(|j| {
            let a = std::f64::consts::TAU * j as f64 / ROTATIONS as f64;
            (a.cos() as f32, a.sin() as f32)
        })
        .unzip()
}

/// The cost-aware penumbra: a bin part whose quads would cost more than casting its samples' rays
/// casts shadow rays to the same light points ([`LightPoints`]) instead (beams over the scene's BVH,
/// `bvh::beam`), so SISM is never the slow path. A bin knows its quad count before any Eq. 3 runs,
/// and per sample Eq. 3's light-point work grows with it; the rays' cost depends on the geometry
/// around the receiver (a foliage receiver's 64 rays walk 20× the nodes of an open one's), so it is
/// measured on a few samples of each candidate part rather than assumed.
#[derive(Clone, Copy)]
pub struct RayFallback<'a> {
    /// The scene's BVH, built (once per scene) only when some part casts rays.
    pub bvh: &'a (dyn Fn() -> &'a SceneBvh + Sync),
    /// Triangles of the BVH still to be built (0 when it exists): building it must pay for itself
    /// within the frame (see [`BUILD_EVALUATIONS_PER_TRIANGLE`]).
    pub unbuilt_triangles: usize,
    /// The frame's receivers (a sample's pixel indexes them).
    pub receivers: &'a Receivers,
    /// Estimated Eq. 3 evaluations per sample at or above which a bin part probes its rays' cost
    /// (>= 1); it casts them where they are cheaper than its Eq. 3 work.
    pub min_evaluations: u32,
    /// Rays a ray-cast sample adds (0..=[`MAX_REFINE_POINTS`]) when its first rays (one per light point)
    /// disagree (some hidden, some not): the penumbra's variance is there, so that is where more
    /// rays lower the error; a sample whose first rays all agree keeps their answer.
    pub refine_points: u32,
    /// Which probed parts cast rays.
    pub choice: RayChoice,
}

/// Which parts whose estimated Eq. 3 work reaches the threshold cast rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RayChoice {
    /// Those whose probed rays cost less than their estimated Eq. 3 work (and the BVH is built only
    /// when the work they could save pays for it).
    #[default]
    Cost,
    /// All of them (the rays alone: to test them, or to measure what they cost and give).
    All,
}

/// Angle (radians) by which the refinement's spiral is turned from the first points': half a golden
/// angle, the largest gap between consecutive spiral angles.
const REFINE_PHASE: f64 = std::f64::consts::PI * (3.0 - 2.236_067_977_499_79) / 2.0;

/// Most rays a partly lit ray-cast sample adds ([`RayFallback::refine_points`]): one beam.
pub const MAX_REFINE_POINTS: usize = BEAM_RAYS;

/// A part's Eq. 3 evaluations are estimated from every `ESTIMATE_STRIDE`-th quad's wedge selection
/// (the cheap half of the work); only parts whose quads could reach the threshold (at most one
/// evaluation per quad and sample, plus [`QUAD_EVALUATIONS`] per quad) run the estimate.
const ESTIMATE_STRIDE: usize = 16;

/// A bin part's cost per quad of its list, whatever its wedge selects (preparing the quad for the
/// part, its rows' entry depths and the wedge scan), in Eq. 3 evaluations. Measured on the project's
/// AVX-512 host (palm under a 3 m light, 320×240, every one of 788 parts evaluating Eq. 3; a fit of
/// part time against evaluations and quads): 14.7 ns an evaluation, 124 ns a quad; rounded down, so
/// that a close call keeps Eq. 3. In foliage under a large light a part's quads cost as much as its
/// evaluations (40% of the step).
const QUAD_EVALUATIONS: u64 = 8;

/// The BVH build's cost per triangle in Eq. 3 evaluations (0.87 µs a triangle on the palm against
/// 14.7 ns an evaluation on the project's AVX-512 host, rounded up): a frame builds it for its
/// ray-casting parts only when the evaluations they save beyond the threshold exceed this times the
/// triangles.
pub const BUILD_EVALUATIONS_PER_TRIANGLE: u64 = 64;

/// Visible fraction of every sample (sorted order) under light-point composition, one task per bin
/// part (step `light_points`). `depth` is the umbra's depth complexity per sample (sorted order).
/// With `rays`, parts whose estimated Eq. 3 work reaches `min_evaluations` per sample and exceeds
/// their probed rays' cost cast rays instead of evaluating Eq. 3.
#[allow(clippy::too_many_arguments)] // the stage's inputs, then the composition's own settings
pub fn visible_fraction(
    phase: &mut Phase,
    inputs: &StageInputs<'_>,
    occluders: &Occluders<'_>,
    depth: &[i32],
    estimator: LightPointEstimator,
    light_points: LightPoints,
    rays: Option<RayFallback<'_>>,
    stats: &mut PenumbraStats,
) -> Vec<f32> {
    let grid = inputs.grid;
    let lists = occluders.quads;
    // Samples no quad reaches are lit exactly when no triangle covers the light centre.
    let mut visible: Vec<f32> = depth.iter().map(|&d| if d == 0 { 1.0 } else { 0.0 }).collect();
    let points = point_set(light_points);
    let rotations = rotation_table();
    let parts = bin_parts(grid, lists);
    // The cost-aware penumbra: each part's Eq. 3 evaluations estimated from a sparse subset of its
    // quads' wedge selections (step `ray_estimate`); the parts at or above the threshold probe their
    // rays' cost (step `ray_probe`), and cast rays where that is lower. Parts with fewer quads than
    // the threshold cannot reach it (one evaluation per quad and sample at most).
    let mut cast = vec![false; parts.len()];
    let mut ray_tracer = None;
    // The refinement's points ([`spiral`]), as `x` and `y` rows.
    // Turned by half a golden angle from the first points, so that no refinement point repeats one
    // of them (with 64 refinement points the spirals would otherwise coincide).
    let refine: (Vec<f32>, Vec<f32>) = spiral(
        rays.map_or(0, |r| (r.refine_points as usize).min(MAX_REFINE_POINTS)),
        REFINE_PHASE,
    )
    .into_iter()
    .unzip();
    if let Some(r) = rays {
        // Costs in eighths of a 64-point evaluation (see `LightPoints::evaluation_cost_eighths`).
        let eval_cost = light_points.evaluation_cost_eighths();
        let threshold = EIGHTHS * r.min_evaluations.max(1) as u64;
        let candidates: Vec<usize> = (0..parts.len())
            .filter(|&k| {
                // At most one evaluation per quad and sample, plus each quad's own cost.
                let (quads, n) = (lists.of(parts[k].bin).len() as u64, parts[k].samples.len() as u64);
                quads * (n * eval_cost + EIGHTHS * QUAD_EVALUATIONS) >= threshold * n
            })
            .collect();
        let estimates = phase.run_par(
            "ray_estimate",
            candidates.par_iter().map(|&k| EvaluationEstimate {
                edges: &occluders.silhouettes.edges,
                light: inputs.light,
                grid,
                part: &parts[k],
                quads: lists.of(parts[k].bin),
                eval_cost,
            }),
        );
        let mut saved = 0u64;
        let mut probed: Vec<(usize, u64)> = Vec::new();
        for (&k, &estimate) in candidates.iter().zip(&estimates) {
            let at_threshold = threshold * parts[k].samples.len() as u64;
            if estimate >= at_threshold {
                probed.push((k, estimate));
                saved += estimate.saturating_sub(at_threshold);
            }
        }
        // The BVH is built only if the candidates' work beyond the threshold could pay for it.
        let pays = saved >= EIGHTHS * BUILD_EVALUATIONS_PER_TRIANGLE * r.unbuilt_triangles as u64;
        if !probed.is_empty() && (pays || r.choice == RayChoice::All) {
            let tracer = LightPointRays {
                bvh: (r.bvh)(),
                receivers: r.receivers,
                grid,
                light: inputs.light,
                points: &points,
                refine: (&refine.0, &refine.1),
                rotations: (&rotations.0, &rotations.1),
            };
            // Step `ray_probe`: what rays cost here (a foliage receiver's 64 rays can take 20× an
            // open one's), measured on a few of each candidate's samples; the part casts rays only
            // where that cost, scaled to all its samples, is below its estimated Eq. 3 work.
            let work = phase.run_par(
                "ray_probe",
                probed.par_iter().map(|&(k, _)| RayProbe {
                    tracer,
                    part: &parts[k],
                }),
            );
            stats.ray_parts_probed += probed.len() as u64;
            for (&(k, estimate), &(beam_work, n_probed)) in probed.iter().zip(&work) {
                stats.ray_probe_work += beam_work;
                let n = parts[k].samples.len() as f64;
                let ray_cost =
                    beam_work as f64 / n_probed.max(1) as f64 * n * EVALUATIONS_PER_BEAM_OP * EIGHTHS as f64;
                cast[k] = r.choice == RayChoice::All || ray_cost < estimate as f64;
            }
            ray_tracer = cast.contains(&true).then_some(tracer);
        }
    }
    // A part's index in `parts` (run_parts hands out references into it).
    let part_index = |part: &BinPart| {
        (part as *const BinPart as usize - parts.as_ptr() as usize) / std::mem::size_of::<BinPart>()
    };
    run_parts(phase, "light_points", &mut visible, &parts, stats, |part, out| {
        SampledBin {
            rays: ray_tracer.filter(|_| cast[part_index(part)]),
            edges: &occluders.silhouettes.edges,
            light: inputs.light,
            grid,
            part,
            quads: lists.of(part.bin),
            depth: &depth[part.samples.clone()],
            estimator,
            points: &points,
            rotations: (&rotations.0, &rotations.1),
            out,
        }
    });
    visible
}

/// The per-bin light-point penumbra task.
struct SampledBin<'a> {
    edges: &'a [EdgeRecord],
    light: &'a SismLight,
    grid: &'a Grid,
    part: &'a BinPart,
    quads: &'a [u32],
    /// Depth complexity at the light centre of the part's samples (part-local).
    depth: &'a [i32],
    estimator: LightPointEstimator,
    points: &'a PointSet,
    rotations: (&'a [f32], &'a [f32]),
    /// Visible fraction of the part's samples (part-local).
    out: &'a mut [f32],
    /// Set when this part casts rays instead (see [`RayFallback`]).
    rays: Option<LightPointRays<'a>>,
}

/// Shadow rays from samples to their light points (the parts that cast rays, and the probes).
#[derive(Clone, Copy)]
struct LightPointRays<'a> {
    bvh: &'a SceneBvh,
    receivers: &'a Receivers,
    grid: &'a Grid,
    light: &'a SismLight,
    points: &'a PointSet,
    /// The refinement's points (`x`, `y`; empty: no refinement).
    refine: (&'a [f32], &'a [f32]),
    rotations: (&'a [f32], &'a [f32]),
}

/// What one ray-cast sample found.
#[derive(Clone, Copy, Debug, Default)]
struct RaySample {
    /// Visible fraction (`None`: no receiver facing the light).
    visible: Option<f32>,
    /// The beam walks' work (node tests + triangle and box vectors).
    work: u64,
    /// Rays cast.
    rays: u64,
    /// Whether the first rays disagreed and the refinement's were cast.
    refined: bool,
    /// Whether the first rays all agreed (so a refinement, if enabled, was not needed).
    agreed: bool,
}

/// A sample's beam and the walk's scratch, reused across samples.
struct RayScratch {
    beam: Beam,
    stack: Vec<(u32, u16)>,
    hits: [sism_simd::Mask16; BEAM_RAYS / 16],
    /// Light-point offsets of the sample (the first points, then the refinement's).
    offsets: [glam::Vec3; OFFSETS],
}

/// Light-point offsets a [`RayScratch`] holds: the first points or the refinement's, whichever is more.
const OFFSETS: usize = if MAX_LIGHT_POINTS > MAX_REFINE_POINTS {
    MAX_LIGHT_POINTS
} else {
    MAX_REFINE_POINTS
};

impl RayScratch {
    fn new(light: &SismLight) -> RayScratch {
        RayScratch {
            beam: Beam::new(light.center),
            stack: Vec::new(),
            hits: [sism_simd::Mask16::NONE; BEAM_RAYS / 16],
            offsets: [glam::Vec3::ZERO; OFFSETS],
        }
    }
}

impl LightPointRays<'_> {
    /// Visible fraction of sample `sample` (sorted order) by shadow rays to its light points: a point
    /// is lit when no triangle crosses the segment to it. A point below the receiver's tangent plane
    /// casts no ray and counts lit here, because the resolve's horizon term accounts for it (as for
    /// Eq. 3's counts). First the light points; when their rays disagree (some hidden,
    /// some not) and a refinement is set, rays to its points too, and the fraction is over all of
    /// them (each set spreads its points evenly over the disk, one equal area each).
    #[inline(always)]
    fn visible<S: Simd>(&self, s: S, sample: usize, scratch: &mut RayScratch) -> RaySample {
        let c = self.light.center;
        // Counted: the sample's pixel and receiver, the disk's basis, the light points and each
        // point's ray into the beam.
        let pixel = s.s_load(&self.grid.samples.pixel, sample);
        let rcv = self.receivers.pixels.get(pixel as usize).copied().flatten();
        s.scalar_op(ScalarClass::Mem);
        let Some(rcv) = s.s_branch(rcv.is_some()).then(|| rcv.expect("tested")) else {
            return RaySample::default();
        };
        // (Samples are receivers facing the light centre, by the same test.)
        let Some(disk) = DiskRays::new_counted(s, self.bvh, c, self.light.radius, &rcv) else {
            return RaySample::default();
        };
        let q = counted::sub(s, rcv.position, c);
        let n = self.points.n;
        let first = self.cast(
            s,
            &disk,
            q,
            pixel,
            &self.points.x.as_flattened()[..n],
            &self.points.y.as_flattened()[..n],
            scratch,
        );
        let (mut lit, mut points) = (first.lit, n as u32);
        let mut out = RaySample {
            visible: None,
            work: first.work,
            rays: first.rays as u64,
            refined: false,
            agreed: true,
        };
        // The first rays disagree: some hit, some did not (points below the horizon cast none).
        let blocked = s.s_sub(n as u32, first.lit);
        if s.s_branch(blocked > 0 && blocked < first.rays) {
            out.agreed = false;
            if s.s_branch(!self.refine.0.is_empty()) {
                let more = self.cast(s, &disk, q, pixel, self.refine.0, self.refine.1, scratch);
                lit = s.s_add(lit, more.lit);
                points = s.s_add(points, self.refine.0.len() as u32);
                out.work += more.work;
                out.rays += more.rays as u64;
                out.refined = true;
            }
        }
        let fraction = s.s_fn(ScalarClass::Alu, lit, |l: u32| l as f32);
        out.visible = Some(s.s_div(fraction, s.s_fn(ScalarClass::Alu, points, |p: u32| p as f32)));
        out
    }

    /// Casts one beam from `disk`'s origin to the sample's points `(xs, ys)` (unit disk, at most
    /// [`BEAM_RAYS`]) rotated by the pixel's angle: how many are lit (no ray, or a ray that hit
    /// nothing), how many rays were cast, and the walk's work.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn cast<S: Simd>(
        &self,
        s: S,
        disk: &DiskRays,
        q: glam::Vec3,
        pixel: u32,
        xs: &[f32],
        ys: &[f32],
        scratch: &mut RayScratch,
    ) -> BeamCast {
        let c = self.light.center;
        let n = xs.len();
        light_points_into(s, q, pixel, xs, ys, self.rotations, &mut scratch.offsets[..n]);
        scratch.beam.reset(disk.origin);
        // In order of angle (compact vectors); the answer is a count, so the order changes nothing.
        for k in 0..n {
            let o = counted::streamed(s, &scratch.offsets, k);
            let target = counted::add(s, c, counted::scale(s, o, self.light.radius));
            if let Some((dir, len)) = disk.ray_counted(s, target) {
                scratch.beam.push_counted(s, dir, len);
            }
        }
        let rays = scratch.beam.len() as u32;
        let counts = self
            .bvh
            .beams()
            .occluded(s, &scratch.beam, &mut scratch.stack, &mut scratch.hits);
        let blocked: u32 = scratch.hits.iter().map(|m| m.count()).sum();
        BeamCast {
            lit: n as u32 - blocked,
            rays,
            work: counts.nodes + counts.triangle_vectors + counts.box_vectors,
        }
    }
}

/// One beam's answer ([`LightPointRays::cast`]).
struct BeamCast {
    lit: u32,
    rays: u32,
    work: u64,
}

/// Samples of a candidate part whose rays step `ray_probe` casts (evenly spread over the part).
const PROBE_SAMPLES: usize = 4;

/// Cost of one step of a beam walk (a node's cone test, a 16-ray triangle or box test) in Eq. 3
/// light-point evaluations, as measured on the project's AVX-512 host at 1600×1200 (palm: about
/// 10–11 ns a step against 13–15 ns an evaluation, per thread; rounded up, so that a close call
/// keeps Eq. 3).
const EVALUATIONS_PER_BEAM_OP: f64 = 0.8;

/// Step `ray_probe`: the beam work of [`PROBE_SAMPLES`] of a part's samples, and how many had rays.
struct RayProbe<'a> {
    tracer: LightPointRays<'a>,
    part: &'a BinPart,
}

impl Kernel for RayProbe<'_> {
    type Output = (u64, u64);
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> (u64, u64) {
        s.begin_task(task_kind::SAMPLED_BIN);
        let n = self.part.samples.len();
        let mut scratch = RayScratch::new(self.tracer.light);
        let (mut work, mut probed) = (0, 0);
        for j in 0..PROBE_SAMPLES.min(n) {
            let i = self.part.samples.start + (2 * j + 1) * n / (2 * PROBE_SAMPLES.min(n));
            let r = self.tracer.visible(s, i, &mut scratch);
            work += r.work;
            probed += r.visible.is_some() as u64;
        }
        s.end_task();
        (work, probed)
    }
}

/// Step `ray_estimate`: a part's Eq. 3 work in eighths of a 64-point evaluation: its evaluations
/// (samples inside each quad's wedge, summed, estimated from every `ESTIMATE_STRIDE`-th quad) at
/// `eval_cost` each plus [`QUAD_EVALUATIONS`] per quad.
struct EvaluationEstimate<'a> {
    edges: &'a [EdgeRecord],
    light: &'a SismLight,
    grid: &'a Grid,
    part: &'a BinPart,
    quads: &'a [u32],
    /// One evaluation's cost, eighths of a 64-point evaluation.
    eval_cost: u64,
}

impl Kernel for EvaluationEstimate<'_> {
    type Output = u64;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> u64 {
        s.begin_task(task_kind::SAMPLED_BIN);
        let mut wedge = WedgeScan::new(
            s,
            self.grid,
            self.part,
            self.light,
            self.edges,
            self.quads,
            ESTIMATE_STRIDE,
            false,
        );
        for k in 0..wedge.len() {
            wedge.quad(s, k);
        }
        s.end_task();
        wedge.evaluated * ESTIMATE_STRIDE as u64 * self.eval_cost
            + EIGHTHS * QUAD_EVALUATIONS * self.quads.len() as u64
    }
}

impl SampledBin<'_> {
    /// The part's visible fractions by shadow rays to each sample's light points (see
    /// [`LightPointRays::visible`]); `[samples refined, rays cast, samples whose first rays agreed]`.
    #[inline(always)]
    fn cast_rays<S: Simd>(&mut self, s: S, rays: LightPointRays<'_>) -> [u64; 3] {
        let base = self.part.samples.start;
        let mut scratch = RayScratch::new(self.light);
        let mut counts = [0u64; 3];
        for (i, out) in self.out.iter_mut().enumerate() {
            let r = rays.visible(s, base + i, &mut scratch);
            if let Some(visible) = r.visible {
                *out = visible;
                counts[0] += u64::from(r.refined);
                counts[1] += r.rays;
                counts[2] += u64::from(r.agreed);
            }
        }
        counts
    }
}

/// Each sample's light-disk basis `(e1, e2)` (world axes), bin-local, structure of arrays.
struct DiskBases {
    e1: [Vec<f32>; 3],
    e2: [Vec<f32>; 3],
}

/// An orthonormal basis of every sample's light disk (Duff et al. 2017, from `n̂ = (c - p) / |c - p|`),
/// rotated by the sample's pixel angle.
#[inline(always)]
fn disk_bases<S: Simd>(s: S, task: &SampledBin, positions: (&[f32], &[f32], &[f32])) -> DiskBases {
    let n = positions.0.len();
    let base = task.part.samples.start;
    // Pixel indices as i32 lanes (indices are < 2^31: images are at most 32768² pixels).
    let pixels: Vec<i32> = task.grid.samples.pixel[base..base + n]
        .iter()
        .map(|&p| p as i32)
        .collect();
    let mut out = DiskBases {
        e1: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        e2: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
    };
    let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
    let mut i = 0;
    while i < n {
        let m = s.mask_first_n(n - i);
        let x = s.mask_load_f(zero, m, &positions.0[i..]);
        let y = s.mask_load_f(zero, m, &positions.1[i..]);
        let z = s.mask_load_f(one, m, &positions.2[i..]);
        let minv = s.div_f(
            s.splat_f(-1.0),
            s.sqrt_f(s.fmadd(z, z, s.fmadd(y, y, s.mul_f(x, x)))),
        );
        let (nx, ny, nz) = (s.mul_f(x, minv), s.mul_f(y, minv), s.mul_f(z, minv));
        let sign = s.copysign_f(one, nz);
        let a = s.div_f(s.splat_f(-1.0), s.add_f(sign, nz));
        let b = s.mul_f(s.mul_f(nx, ny), a);
        let sa = s.mul_f(sign, a);
        let u = [
            s.fmadd(s.mul_f(sa, nx), nx, one),
            s.mul_f(sign, b),
            s.neg_f(s.mul_f(sign, nx)),
        ];
        let v = [b, s.fmadd(s.mul_f(ny, ny), a, sign), s.neg_f(ny)];
        // Rotation chosen by a multiplicative hash of the pixel index (top 8 bits).
        let pixel = s.mask_load_i(s.splat_i(0), m, &pixels[i..]);
        let j = s.shr_u(s.mul_i(pixel, s.splat_i(0x9E37_79B1u32 as i32)), 24);
        let cos = s.mask_gather_f(one, m, task.rotations.0, j);
        let sin = s.mask_gather_f(zero, m, task.rotations.1, j);
        for k in 0..3 {
            let e1 = s.fmadd(cos, u[k], s.mul_f(sin, v[k]));
            let e2 = s.fnmadd(sin, u[k], s.mul_f(cos, v[k]));
            s.mask_store_f(&mut out.e1[k][i..], m, e1);
            s.mask_store_f(&mut out.e2[k][i..], m, e2);
        }
        i += 16;
    }
    out
}

impl Kernel for SampledBin<'_> {
    /// `[rows culled, samples culled, samples evaluated]` and the quads evaluated per bin-local sample.
    type Output = (BinCounts, Vec<i32>);
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> (BinCounts, Vec<i32>) {
        s.begin_task(task_kind::SAMPLED_BIN);
        let positions = self.part.positions(self.grid);
        let n_samples = positions.0.len();
        if let Some(rays) = self.rays {
            let mut task = self;
            let [refined, cast, agreed] = task.cast_rays(s, rays);
            s.end_task();
            return (
                [0, 0, 0, n_samples as u64, refined, cast, agreed],
                vec![0; n_samples],
            );
        }
        let mut wedge = WedgeScan::new(
            s, self.grid, self.part, self.light, self.edges, self.quads, 1, true,
        );
        let bases = disk_bases(s, &self, positions);
        // Occluder counts minus the centre's depth complexity, one per light point of each sample.
        // A buffer reused across the bins a host thread runs: fresh allocations of this size would
        // cost a page fault per 4 KiB (more than the counting itself).
        // Not in a counted frame: there the buffer's address must not depend on which host thread
        // ran the bins before this one (records are the same in every run).
        let reuse = !sism_simd::HoldFrees::active();
        let mut counts = if reuse {
            COUNTS.with(|c| std::mem::take(&mut *c.borrow_mut()))
        } else {
            Vec::new()
        };
        counts.clear();
        let n_points = self.points.n;
        counts.resize(n_samples * n_points, 0);
        // Σ Eq. 3 terms per sample (Eq. 4's analytic coverage, less the depth complexity).
        let mut sums = match self.estimator {
            LightPointEstimator::Hybrid => vec![0f32; n_samples],
            LightPointEstimator::Fraction => Vec::new(),
        };
        for (k, &e) in self.quads.iter().enumerate() {
            let edge = &self.edges[e as usize];
            if let Some(selected) = wedge.quad(s, k) {
                add_edge_points(
                    s,
                    selected,
                    positions,
                    &bases,
                    self.points,
                    edge,
                    self.light.radius,
                    &mut counts,
                    &mut sums,
                );
            }
        }
        // Lit points: count (centre depth complexity + edge weights) exactly zero. A negative count (an
        // edge subtracted where the light-centre silhouette differs from the point's) counts as
        // occluded: measured closer to the reference on the shared scenes (stanford-bunny MAE 0.0015
        // against 0.0024 when counted lit).
        let inv_points = 1.0 / n_points as f32;
        for i in 0..n_samples {
            let depth = s.s_load(self.depth, i);
            let minus_depth = s.splat_i(-depth);
            let one_more = s.splat_i(s.s_sub(1, depth));
            let (mut lit, mut overlap) = (0, false);
            for g in 0..self.points.groups {
                let c = s.load_i(&counts[i * n_points + 16 * g..]);
                lit += s.mask_popcnt(s.cmp_eq_i(c, minus_depth));
                // Counts outside {0, 1}: overlapping occluders (or a negative count).
                overlap |= s.mask_any(s.mask_or(s.cmp_lt_i(c, minus_depth), s.cmp_gt_i(c, one_more)));
            }
            // Counted: the choice and its arithmetic, and the store.
            let v = if s.s_branch(sums.is_empty() || overlap) {
                s.s_mul(s.s_fn(ScalarClass::Alu, lit, |l: u32| l as f32), inv_points)
            } else {
                let d = s.s_fn(ScalarClass::Alu, depth, |d: i32| d as f32);
                let sum = s.s_add(d, s.s_load(&sums, i));
                // `clamp`: two operations (NaN passes through, unlike a max and a min).
                s.scalar_op(ScalarClass::Alu);
                s.s_sub(1.0, s.s_fn(ScalarClass::Alu, sum, |x: f32| x.clamp(0.0, 1.0)))
            };
            s.s_store(self.out, i, v);
        }
        if reuse {
            COUNTS.with(|c| *c.borrow_mut() = counts);
        }
        s.end_task();
        wedge.output()
    }
}

thread_local! {
    /// Per host thread: the light-point counters of the bin it runs.
    static COUNTS: std::cell::RefCell<Vec<i32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// For the packed samples `selected` (bin-local), adds edge `e`'s weight to the counters of the light
/// points inside its Eq. 3 region.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn add_edge_points<S: Simd>(
    s: S,
    selected: &[i32],
    (xs, ys, zs): (&[f32], &[f32], &[f32]),
    bases: &DiskBases,
    points: &PointSet,
    e: &EdgeRecord,
    light_radius: f32,
    counts: &mut [i32],
    sums: &mut [f32],
) {
    let zero = s.splat_f(0.0);
    let one = s.splat_f(1.0);
    let mut k = 0;
    // Counted loop test: the trip count changes from quad to quad (see add_edge_terms).
    while s.s_lt(k, selected.len()) {
        let m = s.mask_first_n(selected.len() - k);
        let idx = s.mask_load_i(s.splat_i(0), m, &selected[k..]);
        k += 16;
        let x = s.mask_gather_f(zero, m, xs, idx);
        let y = s.mask_gather_f(zero, m, ys, idx);
        let z = s.mask_gather_f(one, m, zs, idx);
        let Some(f) = edge_frame(s, m, x, y, z, e, light_radius) else {
            continue;
        };
        let weight = s.select_f(f.valid, signed_sum(s, &f, e, one), zero);
        let active = s.cmp_ne_f(weight, zero);
        if !s.s_branch(s.mask_any(active)) {
            continue;
        }
        if !sums.is_empty() {
            // The signed Eq. 3 term (weight · T: the same value `edge_term` gives).
            let term = s.mul_f(weight, region_area(s, &f));
            let acc = s.mask_gather_f(zero, active, sums, idx);
            s.mask_scatter_f(sums, active, idx, s.add_f(acc, term));
        }
        // Unit vectors of the line's frame (world axes): ĝ along the line, f̂ from the centre to it.
        // (No closures or `array::map` here: they would not inherit the kernel's target features.)
        let inv_gl = s.div_f(one, f.gl);
        let gh = [
            s.mul_f(f.g[0], inv_gl),
            s.mul_f(f.g[1], inv_gl),
            s.mul_f(f.g[2], inv_gl),
        ];
        let f_scale = s.select_f(s.cmp_ge_f(f.sc, zero), s.neg_f(inv_gl), inv_gl);
        let fc = cross3(s, f.g, f.nh);
        let fh = [
            s.mul_f(fc[0], f_scale),
            s.mul_f(fc[1], f_scale),
            s.mul_f(fc[2], f_scale),
        ];
        // ... in the sample's disk basis.
        let e1 = [
            s.mask_gather_f(zero, active, &bases.e1[0], idx),
            s.mask_gather_f(zero, active, &bases.e1[1], idx),
            s.mask_gather_f(zero, active, &bases.e1[2], idx),
        ];
        let e2 = [
            s.mask_gather_f(zero, active, &bases.e2[0], idx),
            s.mask_gather_f(zero, active, &bases.e2[1], idx),
            s.mask_gather_f(zero, active, &bases.e2[2], idx),
        ];
        let (gx, gy) = (dot3(s, gh, e1), dot3(s, gh, e2));
        let (fx, fy) = (dot3(s, fh, e1), dot3(s, fh, e2));
        let (d, lo, hi) = (f.dist, f.lo, f.hi);
        // Groups each lane's region can reach: its cone (from the centre through the clipped segment,
        // `after_lo` and `before_hi`) meets the group's cone, and its line is nearer the centre than
        // the group's farthest reach along the line's normal. Two cones under half a turn meet
        // unless one's boundary normal has both of the other's boundary rays on its outer side (by a
        // margin far above rounding, so only groups whose every point fails a test are skipped).
        let (nlo, nhi) = (
            [s.fnmadd(lo, fx, s.mul_f(d, gx)), s.fnmadd(lo, fy, s.mul_f(d, gy))],
            [s.fnmadd(d, gx, s.mul_f(hi, fx)), s.fnmadd(d, gy, s.mul_f(hi, fy))],
        );
        let (elo, ehi) = (
            [s.fmadd(lo, gx, s.mul_f(d, fx)), s.fmadd(lo, gy, s.mul_f(d, fy))],
            [s.fmadd(hi, gx, s.mul_f(d, fx)), s.fmadd(hi, gy, s.mul_f(d, fy))],
        );
        let (tlo, thi, telo, tehi) = (
            cone_margin(s, nlo),
            cone_margin(s, nhi),
            cone_margin(s, elo),
            cone_margin(s, ehi),
        );
        let mut reach = [0u16; MAX_GROUPS];
        for (g, reach) in reach.iter_mut().enumerate().take(points.groups) {
            let cone = &points.cone[g];
            let (b0, b1) = (
                [s.splat_f(cone[0]), s.splat_f(cone[1])],
                [s.splat_f(cone[2]), s.splat_f(cone[3])],
            );
            // Inward normals of the group's cone: m0 = (-b0y, b0x), m1 = (b1y, -b1x).
            let (m0, m1) = ([s.neg_f(b0[1]), b0[0]], [b1[1], s.neg_f(b1[0])]);
            let apart = s.mask_or(
                s.mask_or(
                    both_below(s, dot2(s, nlo, b0), dot2(s, nlo, b1), tlo, tlo),
                    both_below(s, dot2(s, nhi, b0), dot2(s, nhi, b1), thi, thi),
                ),
                s.mask_or(
                    both_below(s, dot2(s, elo, m0), dot2(s, ehi, m0), telo, tehi),
                    both_below(s, dot2(s, elo, m1), dot2(s, ehi, m1), telo, tehi),
                ),
            );
            // Farthest reach of the group along the line's normal f̂ = (fx, fy): its radius when f̂
            // is inside its cone, else the radius times the nearer boundary ray's cosine.
            let fv = [fx, fy];
            let f_inside = s.mask_and(
                s.cmp_ge_f(dot2(s, fv, m0), zero),
                s.cmp_ge_f(dot2(s, fv, m1), zero),
            );
            let along = s.max_f(s.max_f(dot2(s, fv, b0), dot2(s, fv, b1)), zero);
            let radius = s.splat_f(points.radius[g]);
            let far = s.select_f(f_inside, radius, s.mul_f(radius, along));
            let short = s.cmp_lt_f(s.mul_f(far, s.splat_f(1.0 + 1e-5)), d);
            *reach = s.mask_andn(s.mask_or(apart, short), active).bits();
        }
        // Line-aligned lanes (counted loads on the stack; see `LaneArray`).
        let coef: [LaneArray<f32>; 7] = [
            LaneArray(s.to_array_f(fx)),
            LaneArray(s.to_array_f(fy)),
            LaneArray(s.to_array_f(s.neg_f(d))),
            LaneArray(s.to_array_f(nlo[0])),
            LaneArray(s.to_array_f(nlo[1])),
            LaneArray(s.to_array_f(nhi[0])),
            LaneArray(s.to_array_f(nhi[1])),
        ];
        let w = LaneArray(s.to_array_i(s.cvtr_f_i(weight)));
        let at = s.to_array_i(idx);
        let mut lanes = active.bits();
        // The lane loop's test is a counted branch with its outcome (1 to 16 trips, data-dependent).
        while let Some(lane) = next_lane(s, &mut lanes) {
            // Broadcasts from the lane arrays: a load each (counted as the scalar loads they are).
            let c = [
                s.splat_f(s.s_load(&coef[0].0, lane)),
                s.splat_f(s.s_load(&coef[1].0, lane)),
                s.splat_f(s.s_load(&coef[2].0, lane)),
                s.splat_f(s.s_load(&coef[3].0, lane)),
                s.splat_f(s.s_load(&coef[4].0, lane)),
                s.splat_f(s.s_load(&coef[5].0, lane)),
                s.splat_f(s.s_load(&coef[6].0, lane)),
            ];
            let wv = s.splat_i(s.s_load(&w.0, lane));
            // Counted: the lane's extraction (count trailing zeros, clear the lowest bit) and the
            // row's offset.
            s.scalar_op(ScalarClass::Alu);
            s.scalar_op(ScalarClass::Alu);
            let row = s.s_mul(at[lane] as usize, points.n);
            for (g, reach) in reach.iter().enumerate().take(points.groups) {
                // Counted: the lane's bit test and its branch, predicted at this site (whether a
                // group is in reach varies lane by lane: the host mispredicts it, and those cycles
                // were outside the model while the branch was uncounted).
                s.scalar_op(ScalarClass::Alu);
                if !s.s_branch(reach & (1 << lane) != 0) {
                    continue;
                }
                let px = s.load_f(&points.x[g]);
                let py = s.load_f(&points.y[g]);
                let beyond = s.cmp_ge_f(s.fmadd(c[0], px, s.fmadd(c[1], py, c[2])), zero);
                let after_lo = s.cmp_ge_f(s.fmadd(c[3], px, s.mul_f(c[4], py)), zero);
                let before_hi = s.cmp_ge_f(s.fmadd(c[5], px, s.mul_f(c[6], py)), zero);
                let inside = s.mask_and(beyond, s.mask_and(after_lo, before_hi));
                let cnt = s.load_i(&counts[row + 16 * g..]);
                s.store_i(&mut counts[row + 16 * g..], s.mask_add_i(cnt, inside, cnt, wv));
            }
        }
    }
}

/// `a · b` of 2-vectors, lane-wise.
#[inline(always)]
fn dot2<S: Simd>(s: S, a: [S::F32; 2], b: [S::F32; 2]) -> S::F32 {
    s.fmadd(a[0], b[0], s.mul_f(a[1], b[1]))
}

/// `-1e-5 (|v.x| + |v.y|)`: how far below zero `v · b` (`b` a unit vector) must be to count as
/// outside, far beyond the rounding of either side's tests.
#[inline(always)]
fn cone_margin<S: Simd>(s: S, v: [S::F32; 2]) -> S::F32 {
    s.mul_f(s.splat_f(-1e-5), s.add_f(s.abs_f(v[0]), s.abs_f(v[1])))
}

/// Lanes where `a < ta` and `b < tb`.
#[inline(always)]
fn both_below<S: Simd>(s: S, a: S::F32, b: S::F32, ta: S::F32, tb: S::F32) -> sism_simd::Mask16 {
    s.mask_and(s.cmp_lt_f(a, ta), s.cmp_lt_f(b, tb))
}

/// The light points of the sample at `q` (relative to the light centre, world units) shading
/// `pixel`, as offsets from the light centre in light radii: light point `k` is at `c + r · out[k]`.
/// A scalar mirror of the kernel's basis (same formulas; may differ in the last bits), for tests
/// that ray-cast to the very points the kernel counts at (`n` of them).
pub fn light_point_offsets(q: glam::Vec3, pixel: u32, n: LightPoints) -> Vec<glam::Vec3> {
    let mut out = [glam::Vec3::ZERO; MAX_LIGHT_POINTS];
    let (cos, sin) = rotation_table();
    let p = point_set(n);
    light_points_into(
        sism_simd::Portable,
        q,
        pixel,
        &p.x.as_flattened()[..p.n],
        &p.y.as_flattened()[..p.n],
        (&cos, &sin),
        &mut out[..p.n],
    );
    out[..p.n].to_vec()
}

/// The `n` refinement points (`n` ≤ [`MAX_REFINE_POINTS`]) a ray-cast sample at `q` shading `pixel`
/// adds when its first rays disagree, as [`light_point_offsets`] gives the first ones (a scalar
/// mirror, for tests).
pub fn refine_point_offsets(q: glam::Vec3, pixel: u32, n: usize) -> Vec<glam::Vec3> {
    let (xs, ys): (Vec<f32>, Vec<f32>) = spiral(n.min(MAX_REFINE_POINTS), REFINE_PHASE).into_iter().unzip();
    let mut out = vec![glam::Vec3::ZERO; xs.len()];
    let (cos, sin) = rotation_table();
    light_points_into(sism_simd::Portable, q, pixel, &xs, &ys, (&cos, &sin), &mut out);
    out
}

/// [`light_point_offsets`] with the tables given and no allocation, for the points `(xs, ys)` of the
/// unit disk (one offset each into `out`, as long as `xs`).
fn light_points_into<S: Simd>(
    s: S,
    q: glam::Vec3,
    pixel: u32,
    xs: &[f32],
    ys: &[f32],
    (cos, sin): (&[f32], &[f32]),
    out: &mut [glam::Vec3],
) {
    use glam::Vec3;
    // Counted by `s` (the same bits as plain arithmetic): the basis, the pixel's rotation (a hash and
    // two table loads) and per point two loads, two scalings, an add and the store.
    let n = counted::scale(s, q, s.s_div(-1.0, counted::length(s, q)));
    let sign = s.s_fn(ScalarClass::Alu, n.z, |z| 1f32.copysign(z));
    let a = s.s_div(-1.0, s.s_add(sign, n.z));
    let b = s.s_mul(s.s_mul(n.x, n.y), a);
    let u = Vec3::new(
        s.s_add(1.0, s.s_mul(s.s_mul(s.s_mul(sign, a), n.x), n.x)),
        s.s_mul(sign, b),
        s.s_mul(-sign, n.x),
    );
    let v = Vec3::new(b, s.s_add(sign, s.s_mul(s.s_mul(n.y, n.y), a)), -n.y);
    s.scalar_op(ScalarClass::Alu);
    s.scalar_op(ScalarClass::Alu);
    let j = (pixel.wrapping_mul(0x9E37_79B1) >> 24) as usize;
    let (cj, sj) = (s.s_load(cos, j), s.s_load(sin, j));
    let e1 = counted::add(s, counted::scale(s, u, cj), counted::scale(s, v, sj));
    let e2 = counted::sub(s, counted::scale(s, v, cj), counted::scale(s, u, sj));
    for ((o, &px), &py) in out.iter_mut().zip(xs).zip(ys) {
        s.scalar_op(ScalarClass::Mem);
        s.scalar_op(ScalarClass::Mem);
        *o = counted::add(s, counted::scale(s, e1, px), counted::scale(s, e2, py));
        s.scalar_op(ScalarClass::Store);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_fill_the_unit_disk_evenly() {
        for count in [LightPoints::P64, LightPoints::P128, LightPoints::P256] {
            let p = point_set(count);
            assert_eq!((p.n, p.groups), (count.get(), count.get() / 16));
            let (mut cx, mut cy, mut r2) = (0.0f64, 0.0f64, 0.0f64);
            for g in 0..p.groups {
                for l in 0..16 {
                    let (x, y) = (p.x[g][l] as f64, p.y[g][l] as f64);
                    assert!(x * x + y * y < 1.0);
                    // Every point inside its group's cone and radius (the skip tests rely on it).
                    let [b0x, b0y, b1x, b1y] = p.cone[g].map(f64::from);
                    assert!(b0x * y - b0y * x >= 0.0 && b1x * y - b1y * x <= 0.0, "group {g}");
                    assert!((x * x + y * y).sqrt() <= f64::from(p.radius[g]));
                    cx += x;
                    cy += y;
                    r2 += x * x + y * y;
                }
            }
            let n = p.n as f64;
            // Centroid near the centre; mean squared radius of the uniform disk is 1/2.
            assert!(
                (cx / n).abs() < 0.02 && (cy / n).abs() < 0.02,
                "centroid {cx} {cy}"
            );
            assert!((r2 / n - 0.5).abs() < 0.01, "mean r² {}", r2 / n);
        }
    }
}
