//! `light-samples`: soft shadows as the mean of hard shadows from many points of the light, the
//! uniform multi-sample baseline of the revectorization papers (Macedo et al., adaptive area-light
//! sampling: its 289-sample reference), on the shadow-map family's depth maps.
//!
//! # The light points
//!
//! sism's light is a sphere, seen from a receiver as a disk perpendicular to the line to it
//! (CONTRACTS.md). A shadow map needs fixed points, so they lie on **one** disk for the frame: radius
//! `r`, centred on the light, perpendicular to the direction from the light centre to the mean
//! position of the frame's receivers facing it. The paper's square light carries a square lattice of
//! samples, `k × k` (17 × 17 at its quadtree's level 4); here the lattice's vertices `(i, j) / (k − 1)`
//! of the unit square are mapped onto that disk by the Shirley–Chiu concentric map, which preserves
//! area and keeps lattice neighbours neighbours, so the adaptive method's quadtree carries over
//! unchanged. Like the paper's lattice, the vertex lattice puts points on the rim (corners and edges
//! of the square map onto the circle), each weighted equally in the mean.
//!
//! What the fixed disk costs: a receiver far off the mean direction sees the light's disk tilted,
//! not face-on; on the plate scene (where every receiver's disk is nearly the fixed one) the error
//! against the reference is that of the lattice and the maps alone — see the closing figures in
//! ARCHITECTURE.md.
//!
//! # A frame
//!
//! Phase `light_samples` (SISM's receivers facing the light centre and their light view), then phase
//! `light_points`: per light point, its depth maps (the binned rasterizer, from that point, with the
//! light centre's faces), the lookups of every receiver (the hard test, or `v_RSMSS` of the
//! revectorization papers per sample), and step `accumulate`, which adds the result where the
//! receiver faces the light point (a point below its tangent plane is hidden by the receiver's own
//! surface, as the reference sees it). Then the mean is scattered to pixels. All of it kernels:
//! `--machine` times every map.

pub mod adaptive;

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use sism_simd::{Kernel, ScalarClass, Simd};

use crate::algorithms::params::{ChoiceParam, IntParam};
use crate::algorithms::rbsm::visibility::{Function, Settings};
use crate::algorithms::shadow_map::depth_map::{self, MapStats};
use crate::algorithms::shadow_map::{self as sm, lookup::Method as HardMethod};
use crate::algorithms::sism::grid::SampleIn;
use crate::algorithms::sism::light_samples;
use crate::algorithms::{
    AlgorithmFrame, BenchPlan, Family, FrameInputs, ParamKind, ParamSpec, Params, ReceiverSource,
};
use crate::counted;
use crate::exec::{task_kind, FrameLog};
use crate::frame::Receiver;
use crate::sampling::concentric_disk;
use crate::stats::StatsReport;

/// Side of the adaptive method's lattice (level 4: 17 × 17 points).
pub const LATTICE_SIDE: u32 = 17;

/// Receivers per accumulate task.
const ACCUMULATE_CHUNK: usize = 4096;

crate::declare_stats! {
    /// Counters of a multi-sample frame.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct MultiSampleStats {
        /// Light points (one set of depth maps each).
        pub light_points: u64 => ("light_points.used", "points", "light points rendered (one set of depth maps each)"),
        /// Receivers looked up per light point.
        pub fragments: u64 => ("light_points.fragments", "fragments", "receivers tested against each light point's maps"),
        /// (receiver, light point) pairs where the point lies below the receiver's tangent plane.
        pub below_horizon: u64 => ("light_points.below_horizon", "pairs", "(receiver, light point) pairs with the point below the receiver's tangent plane (shadowed by the receiver itself)"),
    }
}

const SAMPLES_PER_SIDE: IntParam = IntParam::new(ParamSpec {
    key: "samples_per_side",
    kind: ParamKind::Int { min: 1, max: 65 },
    default: "17",
    description: "light points per side of the square lattice mapped onto the light disk: N = side² \
(17: the paper's 289)",
});
/// The test at each light point.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Visibility {
    Hard,
    Rsmss,
}
const VISIBILITY: ChoiceParam<Visibility> = ChoiceParam::new(
    ParamSpec {
        key: "visibility",
        kind: ParamKind::Choice(&["hard", "rsmss"]),
        default: "hard",
        description: "per light point: the hard test, or v_RSMSS (revectorized, filtered over one texel)",
    },
    &[Visibility::Hard, Visibility::Rsmss],
);

/// `light-samples`' parameters: the maps' (1024² by default, the soft-shadow paper's), the lattice and
/// the per-point test (with the revectorization settings for `rsmss`).
const PARAMS: [ParamSpec; 7] = [
    sm::MAP_SIZE.with_default("1024").spec(),
    sm::MAP_PARAMS[1],
    sm::MAP_PARAMS[2],
    SAMPLES_PER_SIDE.spec(),
    VISIBILITY.spec(),
    crate::algorithms::rbsm::MAX_SEARCH.spec(),
    crate::algorithms::rbsm::EPSILON.spec(),
];

/// `light-samples`: the mean of hard tests from `N` light points.
pub static LIGHT_SAMPLES: crate::algorithms::Algorithm = crate::algorithms::Algorithm {
    name: "light-samples",
    family: Family::ShadowMap,
    summary: "uniform multi-sample soft shadows: the mean of the hard tests (or v_RSMSS) of N = side² \
depth maps from a lattice of points on the light disk",
    params: &PARAMS,
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Sweep {
        key: "samples_per_side",
        values: &["4", "8", "17"],
    },
    run,
};

/// The unit-disk positions of a `side × side` vertex lattice of the unit square under the concentric
/// map, row by row (`side >= 1`; one point, the centre, for `side == 1`).
pub fn lattice_points(side: u32) -> Vec<Vec2> {
    assert!(side >= 1, "a lattice has at least one point");
    if side == 1 {
        return vec![Vec2::ZERO];
    }
    let step = 1.0 / (side - 1) as f32;
    (0..side)
        .flat_map(|j| (0..side).map(move |i| concentric_disk(Vec2::new(i as f32 * step, j as f32 * step))))
        .collect()
}

/// An orthonormal basis `(e1, e2)` of the plane perpendicular to unit `n` (Duff et al. 2017).
pub fn disk_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// The frame's fixed light disk: unit normal from the light centre towards the mean of the samples'
/// positions `q` (relative to the centre), or `+z` when they have none (or average to zero).
pub fn disk_normal(samples: &[SampleIn]) -> Vec3 {
    let sum = samples
        .iter()
        .fold(glam::DVec3::ZERO, |acc, s| acc + s.q.as_dvec3());
    sum.as_vec3().try_normalize().unwrap_or(Vec3::Z)
}

/// World positions of the light points: `centre + radius · (x e1 + y e2)` for each lattice point.
pub fn light_points(centre: Vec3, radius: f32, normal: Vec3, side: u32) -> Vec<Vec3> {
    let (e1, e2) = disk_basis(normal);
    lattice_points(side)
        .into_iter()
        .map(|p| centre + radius * (p.x * e1 + p.y * e2))
        .collect()
}

/// The per-point test.
enum PointTest {
    Hard(HardMethod),
    Rsmss(Settings),
}

fn run(inputs: &FrameInputs<'_>, params: &Params, log: &mut FrameLog) -> AlgorithmFrame {
    let scene = inputs.prepared.scene;
    let samples = log.phase(
        "light_samples",
        "light view fitted to the receivers and their light-space samples",
        |p| light_samples::build(p, inputs.receivers, &scene.light),
    );
    let map_params = sm::map_params(params);
    let side = params.get(&SAMPLES_PER_SIDE) as u32;
    let test = match params.get(&VISIBILITY) {
        Visibility::Rsmss => PointTest::Rsmss(crate::algorithms::rbsm::settings(params)),
        Visibility::Hard => PointTest::Hard(HardMethod::Hard),
    };
    let centre = scene.light.center();
    let points = light_points(centre, scene.light.radius, disk_normal(&samples.samples), side);
    let n = samples.samples.len();
    let mut stats = MultiSampleStats {
        light_points: points.len() as u64,
        ..Default::default()
    };
    let mut map_totals = MapStats::default();
    let mut visibility = samples.image.clone();
    log.phase(
        "light_points",
        "per light point: depth maps, lookups, accumulation",
        |p| {
            // No receiver: no kernel runs; timed as zero, not as untimed host work.
            p.skip();
            let mut sums = vec![0f32; n];
            let mut values = vec![0f32; n];
            for &origin in &points {
                let maps = depth_map::render_maps(p, scene, &samples, origin, &map_params);
                map_totals.add_maps(&maps.stats(map_params.size));
                let shift = samples.light.center - origin;
                match &test {
                    PointTest::Hard(method) => {
                        sm::lookups(
                            p,
                            &maps,
                            &samples.samples,
                            &inputs.receivers.pixels,
                            shift,
                            method,
                            &mut values,
                        );
                    }
                    PointTest::Rsmss(settings) => {
                        crate::algorithms::rbsm::lookups(
                            p,
                            &maps,
                            &samples.samples,
                            shift,
                            crate::algorithms::rbsm::Method::Single(Function::Rsmss),
                            settings,
                            &mut values,
                        );
                    }
                }
                let hidden = p.run_par(
                    "accumulate",
                    samples
                        .samples
                        .par_chunks(ACCUMULATE_CHUNK)
                        .zip(values.par_chunks(ACCUMULATE_CHUNK))
                        .zip(sums.par_chunks_mut(ACCUMULATE_CHUNK))
                        .map(|((samples, values), sums)| Accumulate {
                            samples,
                            receivers: &inputs.receivers.pixels,
                            point: origin - centre,
                            values,
                            sums,
                        }),
                );
                stats.below_horizon += hidden.iter().sum::<u64>();
                stats.fragments += n as u64;
            }
            let inv = 1.0 / points.len() as f32;
            sums.iter_mut().for_each(|v| *v *= inv);
            let pixels: Vec<u32> = samples.samples.iter().map(|s| s.pixel).collect();
            crate::algorithms::pixels::scatter_to_pixels(
                p,
                "scatter",
                task_kind::SHADOW_SCATTER,
                &pixels,
                &sums,
                &mut visibility.values,
            );
        },
    );
    map_totals.size = map_params.size as u64;
    let mut out = StatsReport::default();
    out.rows(&map_totals).rows(&stats);
    AlgorithmFrame {
        visibility,
        stats: out,
    }
}

/// Step `accumulate`: adds each receiver's result for one light point into its sum where the receiver
/// faces that point; returns how many did not.
struct Accumulate<'a> {
    samples: &'a [SampleIn],
    receivers: &'a [Option<Receiver>],
    /// The light point relative to the light centre (samples' `q` are relative to the centre).
    point: Vec3,
    values: &'a [f32],
    sums: &'a mut [f32],
}

impl Kernel for Accumulate<'_> {
    type Output = u64;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> u64 {
        s.begin_task(task_kind::MULTI_SAMPLE_ACCUMULATE);
        let zero = s.splat_f(0.0);
        let mut hidden = 0;
        let mut i = 0;
        while s.s_lt(i, self.samples.len()) {
            let m = s.mask_first_n(self.samples.len() - i);
            // n · (point − q) per lane: the receiver's normal against its line to the light point.
            // Counted per lane: the loop's branch, the sample's pixel and position (their lines read
            // with the samples), the receiver's tag (its line here), normal, difference and dot
            // product, and the lane's store.
            s.scalar_read(&self.samples[i..(i + 16).min(self.samples.len())]);
            let mut facing = [0f32; 16];
            for (lane, smp) in self.samples[i..].iter().enumerate().take(16) {
                facing[lane] = receiver_facing(s, self.receivers, smp, self.point).unwrap_or(0.0);
                s.scalar_op(ScalarClass::Store);
            }
            let up = s.mask_and(m, s.cmp_gt_f(s.from_array_f(facing), zero));
            hidden += (s.mask_popcnt(m) - s.mask_popcnt(up)) as u64;
            let v = s.mask_load_f(zero, up, &self.values[i..]);
            let acc = s.mask_load_f(zero, m, &self.sums[i..]);
            s.mask_store_f(&mut self.sums[i..], m, s.add_f(acc, v));
            i = s.s_add(i, 16);
        }
        s.end_task();
        hidden
    }
}

/// `n · (point − q)` of sample `smp`'s receiver (its normal against its line to the light point
/// `point`, relative to the light centre as `q` is); `None` without a receiver. Counted by `s`: the
/// loop's branch, the sample's pixel and position (their lines read by the caller with the samples),
/// the receiver's tag and its branch (its line here), the normal, the difference and dot product.
#[inline(always)]
fn receiver_facing<S: Simd>(
    s: S,
    receivers: &[Option<Receiver>],
    smp: &SampleIn,
    point: Vec3,
) -> Option<f32> {
    s.scalar_op(ScalarClass::Branch);
    s.scalar_op(ScalarClass::Mem);
    s.scalar_op(ScalarClass::Mem);
    let r = &receivers[smp.pixel as usize];
    s.scalar_read(std::slice::from_ref(r));
    s.scalar_op(ScalarClass::Mem);
    s.s_branch(r.is_some());
    r.map(|r| {
        s.scalar_op(ScalarClass::Mem);
        counted::dot(s, r.normal, counted::sub(s, point, smp.q))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_has_side_squared_points_in_the_disk_with_corners_on_the_rim() {
        for side in [1u32, 2, 4, 5, 17] {
            let p = lattice_points(side);
            assert_eq!(p.len(), (side * side) as usize);
            assert!(p.iter().all(|q| q.length() <= 1.0 + 1e-6));
        }
        let p = lattice_points(17);
        // The square's centre maps to the disk's centre, its corners onto the circle.
        assert!(p[8 * 17 + 8].length() < 1e-6);
        for k in [0usize, 16, 16 * 17, 17 * 17 - 1] {
            assert!((p[k].length() - 1.0).abs() < 1e-5, "{}", p[k].length());
        }
        // Level ℓ of the quadtree is every 2^(4-ℓ)-th lattice line: its points are points of level 4.
        let coarse = lattice_points(5);
        for (k, q) in coarse.iter().enumerate() {
            let (i, j) = (k % 5 * 4, k / 5 * 4);
            assert!((p[j * 17 + i] - *q).length() < 1e-6);
        }
    }

    #[test]
    fn light_points_lie_on_the_disk_perpendicular_to_the_normal() {
        let c = Vec3::new(1.0, 2.0, 3.0);
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        for q in light_points(c, 2.0, n, 9) {
            assert!((q - c).dot(n).abs() < 1e-5);
            assert!((q - c).length() <= 2.0 + 1e-5);
        }
    }
}
