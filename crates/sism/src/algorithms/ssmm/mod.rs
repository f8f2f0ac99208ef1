//! Soft shadow mip-maps (Shen, MSc thesis, Utah 2016): a light-centre depth map of world distances
//! with a MIN 2×2 mip chain, filtered per receiver with a constant `n × n` kernel on every layer and
//! the layers blended by filter sizes derived exactly from the light size and the blocker and
//! receiver distances (Eq. 3.3, [`filter_size`]).
//!
//! * `ssmm-v2`: PCSS's blocker search and mean blocker distance, then the two layers around its
//!   filter size, box-filtered binary tests, blended linearly in `r` (Eqs. 3.8–3.10).
//! * `ssmm`: every texel of every layer's region a blocker with its own filter size, hat weights over
//!   `(ρ_i / 2, 2 ρ_i)` with the first and last layers' extensions (Eqs. 3.11–3.14),
//!   `V = 1 − Σ f_j w_ij` (Eqs. 3.16–3.17); box kernel area-weighted, or a tent ("pyramid").
//!
//! Phases: `light_samples` and `depth_map` (the shadow-map family's, rendered without bias: the
//! method biases per layer), then `lookup` with steps `mip_base`, `mip_levels` (the chain, per face)
//! `lookup` (the filter, [`lookup::SsmmTask`]) and `scatter`. All kernels: `--machine` times them.
//! Known limits, the thesis' own: light bleeds where blockers overlap at different depths (the map
//! holds only the nearest), and shadows move in steps of the coarse layers' texels.

pub mod chain;
pub mod filter_size;
pub mod lookup;

use rayon::prelude::*;

use super::params::{ChoiceParam, FloatParam, IntParam};
use super::shadow_map::{self as sm, depth_map::MapParams};
use super::{AlgorithmFrame, BenchPlan, Family, FrameInputs, ParamKind, ParamSpec, Params, ReceiverSource};
use crate::exec::FrameLog;
use crate::stats::StatsReport;
use lookup::{FilterKernel, Setup, SsmmCounts, SsmmTask, Variant};

crate::declare_stats! {
    /// Counters of a soft-shadow-mip-map frame.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct SsmmStats {
        /// Layers of the chain.
        pub layers: u64 => ("ssmm.layers", "layers", "layers of the mip chain (levels with at least n texels a side)"),
        /// Receivers filtered.
        pub fragments: u64 => ("ssmm.fragments", "fragments", "receivers filtered (facing the light)"),
        /// Layers visited per receiver.
        pub layers_per_fragment: f64 => ("ssmm.layers_per_fragment", "layers", "layers whose region a receiver read (mean)"),
        /// Layers skipped: no blocker they could weigh.
        pub layers_skipped: u64 => ("ssmm.layers_skipped", "layers", "receiver-layers not read: the nearer layers' bound (or no blocker) says they add nothing"),
        /// Texels read per receiver.
        pub texels_per_fragment: f64 => ("ssmm.texels_per_fragment", "texels", "texel reads per receiver (mean, blocker search included)"),
        /// Texels read.
        pub texels: u64 => ("ssmm.texels", "texels", "texel reads over all receivers"),
        /// Receivers with light blocked.
        pub blocked: u64 => ("ssmm.blocked", "fragments", "receivers with some light blocked (V < 1)"),
        /// ssmm-v2: receivers without blockers.
        pub no_blocker: u64 => ("ssmm.no_blocker", "fragments", "ssmm-v2 receivers whose blocker search found nothing (no filter)"),
    }
}

const MAP_SIZE: IntParam = IntParam::new(ParamSpec {
    key: "map_size",
    kind: ParamKind::Int { min: 256, max: 8192 },
    default: "1024",
    description: "side of the base layer of each light face's mip chain, texels",
});
const N: IntParam = IntParam::new(ParamSpec {
    key: "n",
    kind: ParamKind::Int {
        min: 2,
        max: lookup::MAX_N as i64,
    },
    default: "4",
    description: "kernel side on every layer, texels (cost grows as (n+1)² per layer)",
});
const BIAS_CONSTANT: FloatParam = FloatParam::new(ParamSpec {
    key: "bias_constant",
    kind: ParamKind::Float { min: 0.0, max: 0.1 },
    default: "1e-3",
    description: "constant depth bias, a share of the receiver's distance to the light",
});
const BIAS_SLOPE: FloatParam = FloatParam::new(ParamSpec {
    key: "bias_slope",
    kind: ParamKind::Float { min: 0.0, max: 16.0 },
    default: "1",
    description: "per-layer slope bias: times tan θ · the layer's texel width · (n/2 + 1) (1 clears a plane)",
});
const KERNEL: ChoiceParam<FilterKernel> = ChoiceParam::new(
    ParamSpec {
        key: "kernel",
        kind: ParamKind::Choice(&["box", "pyramid"]),
        default: "box",
        description: "filter kernel over a layer's region: box (area-weighted) or pyramid (separable tent)",
    },
    &[FilterKernel::Box, FilterKernel::Pyramid],
);
const BLOCKER_SAMPLES: IntParam = IntParam::new(ParamSpec {
    key: "blocker_samples",
    kind: ParamKind::Int { min: 1, max: 64 },
    default: "16",
    description: "taps of the PCSS blocker search (Poisson disk over the nearest surface's region)",
});

const FULL_PARAMS: [ParamSpec; 5] = [
    MAP_SIZE.spec(),
    N.spec(),
    BIAS_CONSTANT.spec(),
    BIAS_SLOPE.spec(),
    KERNEL.spec(),
];
const V2_PARAMS: [ParamSpec; 6] = [
    MAP_SIZE.spec(),
    N.spec(),
    BIAS_CONSTANT.spec(),
    BIAS_SLOPE.spec(),
    KERNEL.spec(),
    BLOCKER_SAMPLES.spec(),
];

/// `ssmm`: soft shadow mip-maps, every texel a blocker.
pub static SSMM: super::Algorithm = super::Algorithm {
    name: "ssmm",
    family: Family::ShadowMap,
    summary:
        "soft shadow mip-maps (Shen 2016): MIN mip chain, n×n texels per layer, each a blocker with its \
own filter size (Eq. 3.3), hat-weighted over the layers",
    params: &FULL_PARAMS,
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Sweep {
        key: "n",
        values: &["2", "4", "9"],
    },
    run: |inputs, params, log| run(inputs, params, log, Variant::Full),
};

/// `ssmm-v2`: soft shadow mip-maps with PCSS's blocker average.
pub static SSMM_V2: super::Algorithm = super::Algorithm {
    name: "ssmm-v2",
    family: Family::ShadowMap,
    summary:
        "soft shadow mip-maps (Shen 2016) with PCSS's mean blocker: the two layers around its filter size, \
blended linearly in r",
    params: &V2_PARAMS,
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Sweep {
        key: "n",
        values: &["2", "4", "9"],
    },
    run: |inputs, params, log| {
        let blocker = sm::lookup::poisson_disk(params.get(&BLOCKER_SAMPLES) as usize);
        run(inputs, params, log, Variant::V2 { blocker })
    },
};

fn run(inputs: &FrameInputs<'_>, params: &Params, log: &mut FrameLog, variant: Variant) -> AlgorithmFrame {
    let size = params.get(&MAP_SIZE) as u32;
    let n = params.get(&N) as u32;
    let setup = Setup {
        n,
        layers: filter_size::layer_count(size, n),
        light_radius: inputs.prepared.scene.light.radius,
        bias_constant: params.get(&BIAS_CONSTANT) as f32,
        bias_slope: params.get(&BIAS_SLOPE) as f32,
        kernel: params.get(&KERNEL),
        variant,
    };
    // The maps hold the surfaces' own depths: the method biases per layer.
    let map_params = MapParams {
        size,
        bias_constant: 0.0,
        bias_slope: 0.0,
    };
    let (visibility, map_stats, counts) = sm::map_frame_with(
        inputs,
        &map_params,
        log,
        "the mip chain and the soft shadow mip-map filter per receiver",
        |p, maps, samples, shift, values| {
            let chains: Vec<chain::MipChain> = maps
                .faces
                .iter()
                .map(|f| chain::build(p, f, setup.layers))
                .collect();
            let tasks = sm::face_tasks(samples, values);
            let counts = p.run_par(
                "lookup",
                tasks.into_par_iter().map(|(face, range, out)| SsmmTask {
                    map: &maps.faces[face as usize],
                    chain: &chains[face as usize],
                    receivers: &inputs.receivers.pixels,
                    shift,
                    samples: &samples[range],
                    setup: &setup,
                    out,
                }),
            );
            let mut total = SsmmCounts::default();
            for c in counts {
                total += c;
            }
            total
        },
    );
    let per = |x: u64| {
        if counts.fragments == 0 {
            0.0
        } else {
            x as f64 / counts.fragments as f64
        }
    };
    let stats = SsmmStats {
        layers: setup.layers as u64,
        fragments: counts.fragments,
        layers_per_fragment: per(counts.layers_visited),
        layers_skipped: counts.layers_skipped,
        texels_per_fragment: per(counts.texels),
        texels: counts.texels,
        blocked: counts.blocked,
        no_blocker: counts.no_blocker,
    };
    let mut out = StatsReport::default();
    out.rows(&map_stats).rows(&stats);
    AlgorithmFrame {
        visibility,
        stats: out,
    }
}
