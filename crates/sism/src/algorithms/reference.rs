//! The ray-traced reference: `V(p)` by sampling the light disk with shadow rays.
//!
//! Primary visibility is ray casting through pixel centres (CONTRACTS.md camera). For each receiver
//! facing the light, the disk of radius `r` around the light centre, perpendicular to `c - p`, is
//! sampled with stratified, jittered samples (Shirley–Chiu concentric map, area-weighted strata so any
//! sample count is unbiased) and a shadow ray tests each with early-out BVH traversal. Randomness is
//! keyed by (seed, pixel), so the image is identical for any host thread count.

use std::time::{Duration, Instant};

use glam::Vec3;
use rayon::prelude::*;
use sism_simd::{Mask16, ScalarClass, Simd};

use super::params::{IntParam, U64Param};
use super::{AlgorithmFrame, BenchPlan, Family, FrameInputs, ParamKind, ParamSpec, Params, ReceiverSource};
use crate::bvh::beam::{Beam, BEAM_RAYS};
use crate::bvh::SceneBvh;
use crate::counted;
use crate::exec::FrameLog;
use crate::frame::{Receiver, Receivers, VisibilityImage, V_FACING_AWAY, V_MISS};
use crate::sampling::{concentric_disk, Rng, Strata};
use crate::scene::shapes::orthonormal_basis_counted;
use crate::scene::topology::SceneTopology;
use crate::scene::{Light, Scene};
use crate::stats::StatsReport;

const SPP: IntParam = IntParam::new(ParamSpec {
    key: "spp",
    kind: ParamKind::Int { min: 1, max: 65_536 },
    default: "256",
    description: "stratified light-disk samples per receiver, one shadow ray each",
});
const SEED: U64Param = U64Param::new(ParamSpec {
    key: "seed",
    kind: ParamKind::U64,
    default: "0",
    description: "seed of the sample jitter: the same seed gives the same image on any host",
});

/// The reference's parameters (both modes).
const PARAMS: &[ParamSpec] = &[SPP.spec(), SEED.spec()];

/// `reference`: the visibility of CONTRACTS.md, ray traced.
pub static REFERENCE: super::Algorithm = super::Algorithm {
    name: "reference",
    family: Family::RayTraced,
    summary: "ray-traced visibility: `spp` stratified light-disk samples per receiver, one shadow ray each",
    params: PARAMS,
    receivers: ReceiverSource::RayCast,
    kernels: false,
    bench: BenchPlan::Sweep {
        key: "spp",
        values: &["4", "16", "64", "256"],
    },
    run: |inputs, params, log| run(inputs, params, log, ReferenceMode::Exact),
};

/// `reference-additive`: SISM's model, ray traced (see [`ReferenceMode::AdditiveOverlap`]).
pub static REFERENCE_ADDITIVE: super::Algorithm = super::Algorithm {
    name: "reference-additive",
    family: Family::RayTraced,
    summary: "ray-traced SISM model without its projection approximation (counted occluder crossings \
averaged over the light disk): `compare` it with `reference` to measure the overlap (C = 0) error, \
with `sism` to measure the rest",
    params: PARAMS,
    receivers: ReceiverSource::RayCast,
    kernels: false,
    bench: BenchPlan::Skip,
    run: |inputs, params, log| run(inputs, params, log, ReferenceMode::AdditiveOverlap),
};

/// The registry's entry point: shadow rays for every receiver.
fn run(inputs: &FrameInputs<'_>, params: &Params, log: &mut FrameLog, mode: ReferenceMode) -> AlgorithmFrame {
    let options = ReferenceOptions {
        spp: params.get(&SPP) as u32,
        seed: params.get(&SEED),
        progress: inputs.progress,
        mode,
    };
    let prepared = inputs.prepared;
    let bvh = prepared.bvh();
    let topology = (mode == ReferenceMode::AdditiveOverlap).then(|| prepared.topology());
    let t = Instant::now();
    let (visibility, counts) = log.phase("shadow", "shadow rays", |_| {
        render_visibility(prepared.scene, bvh, topology, inputs.receivers, &options)
    });
    let shadow_s = t.elapsed().as_secs_f64();
    let mut stats = StatsReport::default();
    stats
        .stat(
            "reference.spp",
            options.spp as f64,
            "samples",
            "light-disk samples per receiver",
        )
        .rows(&counts)
        .stat(
            "rays.shadow_per_second",
            if shadow_s > 0.0 {
                counts.rays as f64 / shadow_s
            } else {
                0.0
            },
            "rays/s",
            "shadow-ray throughput on this host",
        );
    AlgorithmFrame { visibility, stats }
}

/// What the reference integrates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReferenceMode {
    /// The visibility of CONTRACTS.md: the fraction of light samples no triangle blocks.
    #[default]
    Exact,
    /// SISM's model without its single-point-of-projection approximation: `1 - clamp01(mean over
    /// light samples of the number of counted occluder triangles crossed)`, i.e. occluders' coverages
    /// added as if they never overlapped (the paper's C = 0). Comparing it with `Exact` measures the
    /// overlap error; comparing SISM with it measures the rest.
    AdditiveOverlap,
}

/// Settings of a reference render.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceOptions {
    /// Light-disk samples per receiver, >= 1 (ignored for a point light, which needs one ray).
    pub spp: u32,
    /// Seed of the jitter; the same seed gives the same image.
    pub seed: u64,
    /// Draw a progress bar on stderr (hidden when stderr is not a terminal).
    pub progress: bool,
    /// What to integrate.
    pub mode: ReferenceMode,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        Self {
            spp: 256,
            seed: 0,
            progress: false,
            mode: ReferenceMode::Exact,
        }
    }
}

/// Counts and times of a reference render.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReferenceStats {
    /// Primary rays cast: one per pixel.
    pub primary_rays: u64,
    /// Pixels whose primary ray hit a surface.
    pub receivers: u64,
    /// Receivers facing away from the light (visibility `-1`).
    pub receivers_facing_away: u64,
    /// Shadow rays cast.
    pub shadow_rays: u64,
    /// Host time of the primary rays.
    pub time_primary: Duration,
    /// Host time of the shadow rays.
    pub time_shadow: Duration,
}

/// Casts one primary ray per pixel and returns the receivers.
pub fn cast_primary_rays(scene: &Scene, bvh: &SceneBvh) -> Receivers {
    let frame = scene.camera.frame();
    let width = frame.width;
    let mut pixels = vec![None; width as usize * frame.height as usize];
    pixels
        .par_chunks_mut(width as usize)
        .enumerate()
        .for_each(|(j, row)| {
            for (i, px) in row.iter_mut().enumerate() {
                let dir = frame.ray_direction(i as u32, j as u32);
                *px = bvh.closest_hit(frame.eye, dir).map(|hit| Receiver {
                    position: frame.eye + dir * hit.t,
                    normal: if hit.normal.dot(dir) > 0.0 {
                        -hit.normal
                    } else {
                        hit.normal
                    },
                });
            }
        });
    Receivers {
        width,
        height: frame.height,
        pixels,
    }
}

/// Offset of shadow-ray origins along the receiver normal, world units: far enough to clear the
/// receiver's own triangle in f32, small against any feature of the scene.
#[inline]
pub fn ray_offset(bvh: &SceneBvh, p: Vec3) -> f32 {
    ray_offset_counted(sism_simd::Portable, bvh, p)
}

/// [`ray_offset`] counted by `s`: three absolute values, two maxima, an add and a multiply.
#[inline(always)]
fn ray_offset_counted<S: Simd>(s: S, bvh: &SceneBvh, p: Vec3) -> f32 {
    for _ in 0..3 {
        s.scalar_op(ScalarClass::Alu);
    }
    let a = p.abs();
    let largest = s.s_max(a.x, s.s_max(a.y, a.z));
    s.s_mul(2e-5, s.s_add(bvh.scene_diagonal, largest))
}

/// One receiver's shadow rays to a light disk: the offset origin, and the disk's basis
/// perpendicular to the direction to its centre. Every tracer of the reference (and of SISM's
/// light points) casts the same rays through it.
#[derive(Clone, Copy, Debug)]
pub struct DiskRays {
    /// Ray origin: the receiver, offset along its normal by [`ray_offset`].
    pub origin: Vec3,
    normal: Vec3,
    center: Vec3,
    radius: f32,
    /// Unit axes of the disk's plane.
    t: Vec3,
    b: Vec3,
}

impl DiskRays {
    /// The rays of receiver `r` to the disk of `radius` around `center` (world units); `None` when
    /// the receiver faces away from the centre.
    #[inline]
    pub fn new(bvh: &SceneBvh, center: Vec3, radius: f32, r: &Receiver) -> Option<DiskRays> {
        Self::new_counted(sism_simd::Portable, bvh, center, radius, r)
    }

    /// [`DiskRays::new`] with its operations counted by `s` (the same rays).
    #[inline(always)]
    pub fn new_counted<S: Simd>(
        s: S,
        bvh: &SceneBvh,
        center: Vec3,
        radius: f32,
        r: &Receiver,
    ) -> Option<DiskRays> {
        let to_light = counted::sub(s, center, r.position);
        if s.s_le(counted::dot(s, r.normal, to_light), 0.0) {
            return None;
        }
        // glam's `normalize`: times the reciprocal of the length.
        let unit = counted::scale(s, to_light, s.s_div(1.0, counted::length(s, to_light)));
        let (t, b) = orthonormal_basis_counted(s, unit);
        let offset = ray_offset_counted(s, bvh, r.position);
        Some(DiskRays {
            origin: counted::add(s, r.position, counted::scale(s, r.normal, offset)),
            normal: r.normal,
            center,
            radius,
            t,
            b,
        })
    }

    /// The point of the disk at offset `q` (in radii, in the disk's basis), world units.
    #[inline]
    pub fn point(&self, q: glam::Vec2) -> Vec3 {
        let q = q * self.radius;
        self.center + self.t * q.x + self.b * q.y
    }

    /// Stratified sample `k` of the disk and its weight.
    #[inline]
    pub fn sample(&self, k: u32, strata: &Strata, rng: &mut Rng) -> (Vec3, f32) {
        let (u, weight) = strata.sample(k, rng);
        (self.point(concentric_disk(u)), weight)
    }

    /// The ray to `target`: unit direction and segment length; `None` when the target is below the
    /// receiver's tangent plane (hidden by the receiver's own surface) or at the origin.
    #[inline]
    pub fn ray(&self, target: Vec3) -> Option<(Vec3, f32)> {
        self.ray_counted(sism_simd::Portable, target)
    }

    /// [`DiskRays::ray`] with its operations counted by `s` (the same ray).
    #[inline(always)]
    pub fn ray_counted<S: Simd>(&self, s: S, target: Vec3) -> Option<(Vec3, f32)> {
        let d = counted::sub(s, target, self.origin);
        let len = counted::length(s, d);
        (s.s_lt(0.0, len) && s.s_lt(0.0, counted::dot(s, d, self.normal))).then(|| {
            (
                Vec3::new(s.s_div(d.x, len), s.s_div(d.y, len), s.s_div(d.z, len)),
                len,
            )
        })
    }
}

/// Estimates `V` at receiver `r` with `strata.count()` disk samples drawn from `rng`, its shadow rays
/// traced as beams ([`crate::bvh::beam`]). Returns the estimate and the number of shadow rays cast. A
/// receiver facing away returns [`V_FACING_AWAY`]. The same value, bit for bit, as
/// [`receiver_visibility_rays`].
pub fn receiver_visibility(
    bvh: &SceneBvh,
    light: &Light,
    r: &Receiver,
    strata: &Strata,
    rng: &mut Rng,
) -> (f32, u32) {
    crate::exec::native(ReceiverBeams {
        bvh,
        light,
        receiver: r,
        strata,
        rng,
    })
}

/// [`receiver_visibility`] with one ray at a time through the CWBVH (the general tracer): the
/// yardstick the beams are checked and benchmarked against.
pub fn receiver_visibility_rays(
    bvh: &SceneBvh,
    light: &Light,
    r: &Receiver,
    strata: &Strata,
    rng: &mut Rng,
) -> (f32, u32) {
    disk_visibility(bvh, light, r, strata, rng, |origin, dir, len| {
        bvh.occluded(origin, dir, len) as u32
    })
}

/// One receiver's shadow rays as beams (a kernel so the lanes run on the host's best backend).
struct ReceiverBeams<'a> {
    bvh: &'a SceneBvh,
    light: &'a Light,
    receiver: &'a Receiver,
    strata: &'a Strata,
    rng: &'a mut Rng,
}

impl sism_simd::Kernel for ReceiverBeams<'_> {
    type Output = (f32, u32);
    #[inline(always)]
    fn run<S: sism_simd::Simd>(self, s: S) -> (f32, u32) {
        let mut scratch = BeamScratch::new();
        beam_visibility(
            s,
            self.bvh,
            self.light,
            self.receiver,
            self.strata,
            self.rng,
            &mut scratch,
        )
    }
}

/// One image row's receivers, their shadow rays as beams (the exact mode's render loop): one kernel
/// dispatch and one set of buffers a row.
struct RowBeams<'a> {
    bvh: &'a SceneBvh,
    light: &'a Light,
    row: &'a [Option<Receiver>],
    out: &'a mut [f32],
    strata: &'a Strata,
    seed: u64,
    /// Pixel index of the row's first pixel (keys each pixel's random stream).
    first_pixel: usize,
}

impl sism_simd::Kernel for RowBeams<'_> {
    type Output = ShadowRayCounts;
    #[inline(always)]
    fn run<S: sism_simd::Simd>(self, s: S) -> ShadowRayCounts {
        let mut scratch = BeamScratch::new();
        let mut rays = 0u64;
        for (i, (v, r)) in self.out.iter_mut().zip(self.row).enumerate() {
            if let Some(r) = r {
                let mut rng = Rng::new(self.seed, (self.first_pixel + i) as u64);
                let (value, n) =
                    beam_visibility(s, self.bvh, self.light, r, self.strata, &mut rng, &mut scratch);
                *v = value;
                rays += n as u64;
            }
        }
        ShadowRayCounts {
            rays,
            ..scratch.counts
        }
    }
}

crate::declare_stats! {
    /// What a frame's shadow rays did.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct ShadowRayCounts {
        /// Shadow rays cast.
        pub rays: u64 => ("rays.shadow", "rays", "shadow rays cast"),
        /// Beams traced (exact mode: up to 256 rays of one receiver each).
        pub beams: u64 => ("rays.beams", "beams", "beams of one receiver's shadow rays traced together"),
        /// BVH nodes a beam's cone was tested against, summed over beams.
        pub beam_nodes: u64 => ("rays.beam_nodes", "nodes", "BVH nodes tested against a beam's cone"),
        /// Triangle tests, in 16-lane vectors.
        pub triangle_vectors: u64 => ("rays.triangle_vectors", "vectors", "triangle tests of 16 rays each"),
        /// Box tests of wide beams, in 16-lane vectors.
        pub box_vectors: u64 => ("rays.box_vectors", "vectors", "box tests of 16 rays each (wide beams: a large or near light)"),
    }
}

impl ShadowRayCounts {
    fn add(mut self, o: ShadowRayCounts) -> ShadowRayCounts {
        self.rays += o.rays;
        self.beams += o.beams;
        self.beam_nodes += o.beam_nodes;
        self.triangle_vectors += o.triangle_vectors;
        self.box_vectors += o.box_vectors;
        self
    }
}

/// Reused buffers of [`beam_visibility`].
struct BeamScratch {
    beam: Beam,
    stack: Vec<(u32, u16)>,
    /// Per sample of the current beam: its weight and its ray's index in the beam (`u16::MAX`: no
    /// ray, the sample is below the receiver's tangent plane and counts as occluded).
    samples: Vec<(f32, u16)>,
    /// Beam walk counters, summed.
    counts: ShadowRayCounts,
}

impl BeamScratch {
    fn new() -> BeamScratch {
        BeamScratch {
            beam: Beam::new(Vec3::ZERO),
            stack: Vec::new(),
            samples: Vec::with_capacity(BEAM_RAYS),
            counts: ShadowRayCounts::default(),
        }
    }
}

/// [`disk_visibility`] of the exact mode with the rays traced [`BEAM_RAYS`] at a time: the samples are
/// drawn, and their weights summed, in the same order, so the result is the same bit for bit.
#[inline(always)]
fn beam_visibility<S: sism_simd::Simd>(
    s: S,
    bvh: &SceneBvh,
    light: &Light,
    r: &Receiver,
    strata: &Strata,
    rng: &mut Rng,
    scratch: &mut BeamScratch,
) -> (f32, u32) {
    let c = light.center();
    let Some(rays) = DiskRays::new(bvh, c, light.radius, r) else {
        return (V_FACING_AWAY, 0);
    };
    let point_light = light.radius == 0.0;
    let count = if point_light { 1 } else { strata.count() };
    let mut occluded = 0.0f32;
    let mut hits = [Mask16::NONE; BEAM_RAYS / 16];
    let mut k = 0;
    while k < count {
        let end = (k + BEAM_RAYS as u32).min(count);
        scratch.beam.reset(rays.origin);
        scratch.samples.clear();
        for i in k..end {
            let (target, weight) = if point_light {
                (c, 1.0)
            } else {
                rays.sample(i, strata, rng)
            };
            let ray = match rays.ray(target) {
                Some((dir, len)) => {
                    scratch.beam.push(dir, len);
                    (scratch.beam.len() - 1) as u16
                }
                None => u16::MAX,
            };
            scratch.samples.push((weight, ray));
        }
        let walk = bvh
            .beams()
            .occluded(s, &scratch.beam, &mut scratch.stack, &mut hits);
        scratch.counts.beams += 1;
        scratch.counts.beam_nodes += walk.nodes;
        scratch.counts.triangle_vectors += walk.triangle_vectors;
        scratch.counts.box_vectors += walk.box_vectors;
        for &(weight, ray) in &scratch.samples {
            let occ = ray == u16::MAX || hits[ray as usize / 16].test(ray as usize % 16);
            if point_light {
                return (1.0 - occ as u32 as f32, 1);
            }
            occluded += weight * occ as u32 as f32;
        }
        k = end;
    }
    (1.0 - occluded.clamp(0.0, 1.0), strata.count())
}

/// [`ReferenceMode::AdditiveOverlap`] at receiver `r`: occluder crossings of the triangles that SISM
/// counts (see `sism::silhouettes`), averaged over the disk samples and clamped.
pub fn receiver_visibility_additive(
    bvh: &SceneBvh,
    topology: &SceneTopology,
    light: &Light,
    r: &Receiver,
    strata: &Strata,
    rng: &mut Rng,
) -> (f32, u32) {
    let c = light.center();
    disk_visibility(bvh, light, r, strata, rng, |origin, dir, len| {
        bvh.count_crossings(origin, dir, len, |t| topology.counts(t as usize, c))
    })
}

/// `1 - clamp01(sum of weight * occlusion(sample))` over the light-disk samples; a sample below the
/// receiver's tangent plane is hidden by the receiver's own surface and counts as one occluder.
fn disk_visibility(
    bvh: &SceneBvh,
    light: &Light,
    r: &Receiver,
    strata: &Strata,
    rng: &mut Rng,
    occlusion: impl Fn(Vec3, Vec3, f32) -> u32,
) -> (f32, u32) {
    let c = light.center();
    let Some(rays) = DiskRays::new(bvh, c, light.radius, r) else {
        return (V_FACING_AWAY, 0);
    };
    let occluders = |target: Vec3| match rays.ray(target) {
        Some((dir, len)) => occlusion(rays.origin, dir, len),
        None => 1,
    };
    if light.radius == 0.0 {
        return ((1.0 - occluders(c).min(1) as f32), 1);
    }
    let mut occluded = 0.0f32;
    for k in 0..strata.count() {
        let (target, weight) = rays.sample(k, strata, rng);
        occluded += weight * occluders(target) as f32;
    }
    (1.0 - occluded.clamp(0.0, 1.0), strata.count())
}

/// Renders reference visibility for every pixel of `receivers`; `topology` is needed (and used) by
/// [`ReferenceMode::AdditiveOverlap`] only. Returns the image and what its shadow rays did.
pub fn render_visibility(
    scene: &Scene,
    bvh: &SceneBvh,
    topology: Option<&SceneTopology>,
    receivers: &Receivers,
    options: &ReferenceOptions,
) -> (VisibilityImage, ShadowRayCounts) {
    let strata = Strata::new(options.spp);
    let width = receivers.width as usize;
    let mut image = VisibilityImage::filled(receivers.width, receivers.height, V_MISS);
    let bar = crate::progress::bar(receivers.height as u64, "reference shadow rays", options.progress);
    let built;
    let topology = match (options.mode, topology) {
        (ReferenceMode::Exact, _) => None,
        (ReferenceMode::AdditiveOverlap, Some(t)) => Some(t),
        (ReferenceMode::AdditiveOverlap, None) => {
            built = SceneTopology::build(scene);
            Some(&built)
        }
    };
    let counts = image
        .values
        .par_chunks_mut(width)
        .zip(receivers.pixels.par_chunks(width))
        .enumerate()
        .map(|(j, (out, row))| {
            let rays = match topology {
                None => crate::exec::native(RowBeams {
                    bvh,
                    light: &scene.light,
                    row,
                    out,
                    strata: &strata,
                    seed: options.seed,
                    first_pixel: j * width,
                }),
                Some(topo) => {
                    let mut rays = 0u64;
                    for (i, (v, r)) in out.iter_mut().zip(row).enumerate() {
                        if let Some(r) = r {
                            let mut rng = Rng::new(options.seed, (j * width + i) as u64);
                            let (value, n) =
                                receiver_visibility_additive(bvh, topo, &scene.light, r, &strata, &mut rng);
                            *v = value;
                            rays += n as u64;
                        }
                    }
                    ShadowRayCounts {
                        rays,
                        ..Default::default()
                    }
                }
            };
            bar.inc(1);
            rays
        })
        .reduce(ShadowRayCounts::default, ShadowRayCounts::add);
    bar.finish_and_clear();
    (image, counts)
}

/// The whole reference render outside the registry (for tests and tools): primary rays, then shadow
/// rays. The BVH is built by the caller so it can be timed apart and reused.
pub fn render(
    scene: &Scene,
    bvh: &SceneBvh,
    options: &ReferenceOptions,
) -> (Receivers, VisibilityImage, ReferenceStats) {
    let t0 = Instant::now();
    let receivers = cast_primary_rays(scene, bvh);
    let time_primary = t0.elapsed();
    let t1 = Instant::now();
    let (image, counts) = render_visibility(scene, bvh, None, &receivers, options);
    let shadow_rays = counts.rays;
    let time_shadow = t1.elapsed();
    let stats = ReferenceStats {
        primary_rays: receivers.pixels.len() as u64,
        receivers: receivers.pixels.iter().filter(|r| r.is_some()).count() as u64,
        receivers_facing_away: image.values.iter().filter(|&&v| v == V_FACING_AWAY).count() as u64,
        shadow_rays,
        time_primary,
        time_shadow,
    };
    (receivers, image, stats)
}
