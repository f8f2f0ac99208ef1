//! The shadow-map family on sism's machinery: light-view depth maps by the binned rasterizer
//! ([`depth_map`]), then per receiver a lookup kernel ([`lookup`]):
//!
//! * `shadow-map`: the hard test at the receiver's texel (nearest texel): lit when its normalised
//!   depth is at most the map's (which carries the bias).
//! * `pcf`: the mean of the hard tests over an N×N box of texels around it (Reeves et al. 1987).
//! * `pcss` (Fernando 2005): a blocker search over the image-plane region where a blocker at the
//!   nearest depth the map holds, `z_min`, could hide part of the receiver's light disk — radius
//!   `r (1/z_min − 1/z_r)` — the blockers' mean depth `z_b`, the penumbra width
//!   `w = r (z_r − z_b) / z_b` at the receiver (Fernando's `w_light (d_r − d_b)/d_b` with `w_light` the
//!   light's radius), and PCF over the image-plane radius `w / z_r = r (1/z_b − 1/z_r)`. Tap patterns
//!   are a Poisson disk (best-candidate) or a regular grid; radii are capped at
//!   [`lookup::MAX_PCSS_RADIUS`] texels.
//!
//! The maps look from the light's centre. `V` is the lit fraction of taps (no horizon term: a shadow
//! map knows nothing of the receiver's own tangent plane). Phases: `light_samples` (SISM's: receivers
//! facing the light, the light view), `depth_map` (the rasterizer's steps per face, then
//! `depth_min`), `lookup` (steps `lookup` and `scatter`). All of them kernels: `--machine` times them.

pub mod depth_map;
pub mod lookup;

use rayon::prelude::*;

use super::params::{ChoiceParam, FloatParam, IntParam};
use super::{AlgorithmFrame, BenchPlan, Family, FrameInputs, ParamKind, ParamSpec, Params, ReceiverSource};
use std::ops::Range;

use crate::algorithms::sism::grid::SampleIn;
use crate::algorithms::sism::light_samples;
use crate::exec::{task_kind, FrameLog, Phase};
use crate::frame::VisibilityImage;
use crate::stats::StatsReport;
use depth_map::{LightMaps, MapParams, MapStats};
use lookup::{LookupCounts, LookupTask, Method};

/// Receivers per lookup task.
pub const LOOKUP_CHUNK: usize = 4096;

crate::declare_stats! {
    /// Counters of a shadow-map frame.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct ShadowMapStats {
        /// Receivers looked up (facing the light).
        pub fragments: u64 => ("shadow_map.fragments", "fragments", "receivers tested against the maps"),
        /// Map reads.
        pub taps: u64 => ("shadow_map.taps", "taps", "map reads (gather lanes) over all receivers"),
        /// Taps per receiver, mean.
        pub taps_per_fragment: f64 => ("shadow_map.taps_per_fragment", "taps", "map reads per receiver (mean)"),
        /// Receivers whose visibility differs from the plain hard test's.
        pub differs_from_hard: u64 => ("shadow_map.differs_from_hard", "fragments", "receivers whose result differs from the plain hard test"),
        /// PCSS: receivers without blockers.
        pub no_blocker: u64 => ("shadow_map.no_blocker", "fragments", "PCSS receivers whose blocker search found nothing (no filter)"),
    }
}

/// The family's map parameters.
pub const MAP_SIZE: IntParam = IntParam::new(ParamSpec {
    key: "map_size",
    kind: ParamKind::Int { min: 256, max: 8192 },
    default: "2048",
    description: "side of each light-view depth map, texels",
});
/// The `bias_constant` parameter: constant depth bias, normalised depth (`[0, 0.1]`).
pub const BIAS_CONSTANT: FloatParam = FloatParam::new(ParamSpec {
    key: "bias_constant",
    kind: ParamKind::Float { min: 0.0, max: 0.1 },
    default: "1e-5",
    description: "constant depth bias, normalised depth (a face's receivers span [0, 1])",
});
/// The `bias_slope` parameter: slope-scaled depth bias, times the surface's largest depth
/// change per texel (`[0, 16]`).
pub const BIAS_SLOPE: FloatParam = FloatParam::new(ParamSpec {
    key: "bias_slope",
    kind: ParamKind::Float { min: 0.0, max: 16.0 },
    default: "1.5",
    description: "slope-scaled depth bias: times the surface's largest depth change per texel",
});
const PCF_N: IntParam = IntParam::new(ParamSpec {
    key: "n",
    kind: ParamKind::OddInt { min: 1, max: 33 },
    default: "3",
    description: "PCF box side, texels",
});

const BLOCKER_SAMPLES: IntParam = IntParam::new(ParamSpec {
    key: "blocker_samples",
    kind: ParamKind::Int { min: 1, max: 64 },
    default: "16",
    description: "taps of the blocker search",
});
const FILTER_SAMPLES: IntParam = IntParam::new(ParamSpec {
    key: "filter_samples",
    kind: ParamKind::Int { min: 1, max: 256 },
    default: "16",
    description: "taps of the PCF filter",
});

/// PCSS's tap pattern.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Pattern {
    Poisson,
    Grid,
}
const PATTERN: ChoiceParam<Pattern> = ChoiceParam::new(
    ParamSpec {
        key: "pattern",
        kind: ParamKind::Choice(&["poisson", "grid"]),
        default: "poisson",
        description: "tap pattern: a Poisson disk or a regular grid over the square",
    },
    &[Pattern::Poisson, Pattern::Grid],
);

/// The depth-map parameters every method of the family takes.
pub const MAP_PARAMS: [ParamSpec; 3] = [MAP_SIZE.spec(), BIAS_CONSTANT.spec(), BIAS_SLOPE.spec()];
const HARD_PARAMS: [ParamSpec; 3] = MAP_PARAMS;
const PCF_PARAMS: [ParamSpec; 4] = [
    MAP_SIZE.spec(),
    BIAS_CONSTANT.spec(),
    BIAS_SLOPE.spec(),
    PCF_N.spec(),
];
const PCSS_PARAMS: [ParamSpec; 6] = [
    MAP_SIZE.spec(),
    BIAS_CONSTANT.spec(),
    BIAS_SLOPE.spec(),
    BLOCKER_SAMPLES.spec(),
    FILTER_SAMPLES.spec(),
    PATTERN.spec(),
];

/// `shadow-map`: the hard test.
pub static SHADOW_MAP: super::Algorithm = super::Algorithm {
    name: "shadow-map",
    family: Family::ShadowMap,
    summary: "hard shadows: a light-centre depth map by the binned rasterizer, the nearest texel's test",
    params: &HARD_PARAMS,
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Sweep {
        key: "map_size",
        values: &["512", "1024", "2048", "4096"],
    },
    run: |inputs, params, log| run(inputs, params, log, Method::Hard),
};

/// `pcf`: percentage-closer filtering.
pub static PCF: super::Algorithm = super::Algorithm {
    name: "pcf",
    family: Family::ShadowMap,
    summary: "percentage-closer filtering: the mean hard test over an N×N texel box",
    params: &PCF_PARAMS,
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Sweep {
        key: "n",
        values: &["3", "9", "17"],
    },
    run: |inputs, params, log| {
        let n = params.get(&PCF_N) as u32;
        run(inputs, params, log, Method::Pcf { n })
    },
};

/// `pcss`: percentage-closer soft shadows.
pub static PCSS: super::Algorithm = super::Algorithm {
    name: "pcss",
    family: Family::ShadowMap,
    summary:
        "percentage-closer soft shadows (Fernando 2005): blocker search, mean blocker depth, PCF of the \
penumbra width",
    params: &PCSS_PARAMS,
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Sweep {
        key: "filter_samples",
        values: &["16", "64"],
    },
    run: |inputs, params, log| {
        let pattern = |n: i64| {
            let n = n as usize;
            match params.get(&PATTERN) {
                Pattern::Grid => lookup::regular_grid(n),
                Pattern::Poisson => lookup::poisson_disk(n),
            }
        };
        let method = Method::Pcss {
            radius: inputs.prepared.scene.light.radius,
            blocker: pattern(params.get(&BLOCKER_SAMPLES)),
            filter: pattern(params.get(&FILTER_SAMPLES)),
        };
        run(inputs, params, log, method)
    },
};

/// The map parameters of checked `params`.
pub fn map_params(params: &Params) -> MapParams {
    MapParams {
        size: params.get(&MAP_SIZE) as u32,
        bias_constant: params.get(&BIAS_CONSTANT) as f32,
        bias_slope: params.get(&BIAS_SLOPE) as f32,
    }
}

/// A frame of the family: light samples (phase `light_samples`), depth maps from the light centre
/// (`depth_map`), then phase `lookup`: `lookup` writes one visibility per sample (sample order) and
/// its counters come back, then step `scatter` puts the values into the image. `what` describes the
/// lookup phase.
pub fn map_frame<T>(
    inputs: &FrameInputs<'_>,
    params: &Params,
    log: &mut FrameLog,
    what: &'static str,
    lookup: impl FnOnce(&mut Phase, &LightMaps, &[SampleIn], glam::Vec3, &mut [f32]) -> T,
) -> (VisibilityImage, MapStats, T) {
    map_frame_with(inputs, &map_params(params), log, what, lookup)
}

/// [`map_frame`] with the maps made as `map_params` says (for methods whose bias is their own).
pub fn map_frame_with<T>(
    inputs: &FrameInputs<'_>,
    map_params: &MapParams,
    log: &mut FrameLog,
    what: &'static str,
    lookup: impl FnOnce(&mut Phase, &LightMaps, &[SampleIn], glam::Vec3, &mut [f32]) -> T,
) -> (VisibilityImage, MapStats, T) {
    let scene = inputs.prepared.scene;
    let samples = log.phase(
        "light_samples",
        "light view fitted to the receivers and their light-space samples",
        |p| light_samples::build(p, inputs.receivers, &scene.light),
    );
    let centre = scene.light.center();
    let maps = log.phase("depth_map", "light-view depth maps (binned rasterizer)", |p| {
        depth_map::render_maps(p, scene, &samples, centre, map_params)
    });
    let mut visibility = samples.image;
    let counts = log.phase("lookup", what, |p| {
        let mut values = vec![0f32; samples.samples.len()];
        let counts = lookup(
            p,
            &maps,
            &samples.samples,
            samples.light.center - centre,
            &mut values,
        );
        let pixels: Vec<u32> = samples.samples.iter().map(|s| s.pixel).collect();
        crate::algorithms::pixels::scatter_to_pixels(
            p,
            "scatter",
            task_kind::SHADOW_SCATTER,
            &pixels,
            &values,
            &mut visibility.values,
        );
        counts
    });
    (visibility, maps.stats(map_params.size), counts)
}

/// `samples` (grouped by face) cut into runs of one face of at most `chunk` samples each: per run
/// its face and its range of samples, in sample order.
pub fn face_chunks(samples: &[SampleIn], chunk: usize) -> Vec<(u32, Range<usize>)> {
    let mut chunks = Vec::new();
    let mut start = 0;
    while start < samples.len() {
        let face = samples[start].face;
        let end = start + samples[start..].partition_point(|s| s.face == face);
        let mut k = start;
        while k < end {
            let stop = (k + chunk).min(end);
            chunks.push((face, k..stop));
            k = stop;
        }
        start = end;
    }
    chunks
}

/// The lookup tasks of `samples` (grouped by face): per task its face, its range of samples and its
/// part of `values`, at most [`LOOKUP_CHUNK`] samples each and never straddling a face.
pub fn face_tasks<'v>(
    samples: &[SampleIn],
    values: &'v mut [f32],
) -> Vec<(u32, Range<usize>, &'v mut [f32])> {
    let mut rest: &mut [f32] = values;
    face_chunks(samples, LOOKUP_CHUNK)
        .into_iter()
        .map(|(face, range)| {
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(range.len());
            rest = tail;
            (face, range, head)
        })
        .collect()
}

/// A shadow-map frame: light samples, depth maps from the light centre, lookups.
fn run(inputs: &FrameInputs<'_>, params: &Params, log: &mut FrameLog, method: Method) -> AlgorithmFrame {
    let (visibility, map_stats, counts) = map_frame(
        inputs,
        params,
        log,
        "per-receiver map lookups",
        |p, maps, samples, shift, values| {
            lookups(p, maps, samples, &inputs.receivers.pixels, shift, &method, values)
        },
    );
    let stats = ShadowMapStats {
        fragments: counts.fragments,
        taps: counts.taps,
        taps_per_fragment: if counts.fragments == 0 {
            0.0
        } else {
            counts.taps as f64 / counts.fragments as f64
        },
        differs_from_hard: counts.differs_from_hard,
        no_blocker: counts.no_blocker,
    };
    let mut out = StatsReport::default();
    out.rows(&map_stats).rows(&stats);
    AlgorithmFrame {
        visibility,
        stats: out,
    }
}

/// Looks every sample (grouped by face) up in its face's map, as tasks of [`LOOKUP_CHUNK`] samples of
/// step `lookup`; writes the visibilities into `values` (sample order).
pub fn lookups(
    phase: &mut Phase,
    maps: &LightMaps,
    samples: &[SampleIn],
    receivers: &[Option<crate::frame::Receiver>],
    shift: glam::Vec3,
    method: &Method,
    values: &mut [f32],
) -> LookupCounts {
    let tasks = face_tasks(samples, values);
    let counts = phase.run_par(
        "lookup",
        tasks.into_par_iter().map(|(face, range, out)| LookupTask {
            map: &maps.faces[face as usize],
            receivers,
            shift,
            samples: &samples[range],
            method,
            out,
        }),
    );
    let mut total = LookupCounts::default();
    for c in counts {
        total += c;
    }
    total
}
