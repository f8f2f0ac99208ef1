//! Soft irregular shadow mapping (Johnson et al., I3D 2009), one module per stage of the algorithm.
//! Every kernel is written once against `sism_simd` and runs natively (AVX-512 or portable) or under
//! the counting context.
//!
//! [`render_frame`] reads as the paper: (eye pass, done by the caller) → light samples → grid → umbra
//! → silhouettes → penumbra → resolve, each stage one phase of the frame's [`FrameLog`].

pub mod binning;
pub mod grid;
pub mod independent;
pub mod light_samples;
pub mod light_view;
pub mod occlusion;
pub mod penumbra;
pub mod resolve;
pub mod sampled;
pub mod silhouettes;
pub mod umbra;

use glam::Vec3;

use super::params::{ChoiceParam, FloatParam, IntParam};
use super::{AlgorithmFrame, BenchPlan, Family, FrameInputs, ParamKind, ParamSpec, Params, ReceiverSource};
use crate::bvh::SceneBvh;
use crate::exec::{Exec, FrameLog};
use crate::frame::{Receivers, VisibilityImage};
use crate::scene::topology::SceneTopology;
use crate::scene::{Light, Scene};
use crate::stats::StatsReport;
use binning::BinLists;
use grid::{Grid, GridParams, GridStats};
use penumbra::PenumbraStats;
use silhouettes::Silhouettes;
use umbra::UmbraStats;

/// How the occluders' coverages combine at a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Composition {
    /// The paper's Eq. 4: coverages added, as if occluders never overlapped (C = 0).
    #[default]
    Additive,
    /// Connected components as independent occluders: `V = prod (1 - coverage_k)` (see `independent`).
    Independent,
    /// Eq. 3's regions counted at fixed points of each sample's light disk (128 by default); `V` =
    /// share of points no occluder covers, so overlaps compose exactly (see `sampled`).
    Sampled,
}

/// Settings of the SISM algorithm.
#[derive(Clone, Copy, Debug, Default)]
pub struct SismOptions {
    /// How the grid is laid over the light faces.
    pub grid: GridParams,
    /// How the occluders' coverages combine.
    pub composition: Composition,
    /// Estimator of the light-point composition (`Composition::Sampled` only).
    pub light_point_estimator: sampled::LightPointEstimator,
    /// Light points per sample (`Composition::Sampled` only).
    pub light_points: sampled::LightPoints,
    /// `Composition::Sampled` with a BVH given: estimated Eq. 3 work per sample, in 64-point
    /// evaluations ([`sampled::LightPoints::evaluation_cost_eighths`]), at or above
    /// which a bin part measures what its samples' rays to their light points cost, and casts them
    /// where they are cheaper ([`sampled::RayFallback`]); 0: never.
    pub ray_evaluations: u32,
    /// Rays a ray-cast sample adds where its first rays (one per light point) disagree ([`sampled::RayFallback::refine_points`]).
    pub ray_refine_points: u32,
    /// Which probed parts cast rays ([`sampled::RayFallback::choice`]).
    pub ray_choice: sampled::RayChoice,
    /// Triangles of the scene's BVH if it is not built yet (0 when it is): see
    /// [`sampled::RayFallback::unbuilt_triangles`].
    pub unbuilt_bvh_triangles: usize,
}

/// The light as SISM's stages see it: a sphere of `radius` at `center`, and per light face the width
/// factor of penumbra quads.
#[derive(Clone, Debug, PartialEq)]
pub struct SismLight {
    /// Centre, world units.
    pub center: Vec3,
    /// Radius, world units, >= 0 (0: a point light, no penumbra work).
    pub radius: f32,
    /// Per light face, `1 / cos(alpha)`: alpha bounds the angle between a line of sight from a sample
    /// through an edge and the face axis (see `penumbra`), so `r' = r / cos(alpha)` bounds the light's
    /// footprint in the face's image plane.
    pub widen: Vec<f32>,
}

impl SismLight {
    /// The light of `light` with the faces' width factors `widen`.
    pub fn new(light: &Light, widen: Vec<f32>) -> SismLight {
        SismLight {
            center: light.center(),
            radius: light.radius,
            widen,
        }
    }

    /// `r' = r · widen[face]`: the quad half-width's scale in face `face`, as binning uses it.
    /// Its operations are counted by `s`.
    #[inline(always)]
    pub fn face_radius<S: sism_simd::Simd>(&self, s: S, face: usize) -> f32 {
        s.s_mul(s.s_read(&self.radius), s.s_load(&self.widen, face))
    }

    /// `r'` with [`penumbra::WEDGE_SLACK`] for f32 rounding, as the per-sample wedge test uses it.
    /// (Binning uses [`SismLight::face_radius`] without the slack; both are kept as they were when
    /// the images were validated, so renders stay bit-identical.)
    /// Its operations are counted by `s`.
    #[inline(always)]
    pub fn wedge_radius<S: sism_simd::Simd>(&self, s: S, face: usize) -> f32 {
        s.s_mul(self.face_radius(s, face), 1.0 + penumbra::WEDGE_SLACK)
    }
}

/// What every occlusion stage reads: the scene's topology, the light and the grid.
#[derive(Clone, Copy)]
pub struct StageInputs<'a> {
    /// The scene's topology (triangles, edges, objects).
    pub topo: &'a SceneTopology,
    /// The light.
    pub light: &'a SismLight,
    /// The grid over the light faces, with the sorted samples.
    pub grid: &'a Grid,
}

/// The occluders binned into the grid: counted triangles (umbra), silhouette edges and their
/// penumbra quads.
#[derive(Clone, Copy)]
pub struct Occluders<'a> {
    /// Counted triangles per bin.
    pub triangles: &'a BinLists,
    /// The frame's silhouette edges and their objects.
    pub silhouettes: &'a Silhouettes,
    /// Silhouette edges (penumbra quads) per bin.
    pub quads: &'a BinLists,
}

crate::declare_stats! {
    /// Counters of one SISM frame (the eye pass's are the caller's).
    #[derive(Clone, Debug, Default)]
    pub struct SismStats {
        /// The grid stage's counters.
        pub grid: GridStats => nested,
        /// The umbra stage's counters.
        pub umbra: UmbraStats => nested,
        /// The penumbra stage's counters.
        pub penumbra: PenumbraStats => nested,
    }
}

/// One SISM frame's result.
pub struct SismFrame {
    /// `V` per pixel.
    pub visibility: VisibilityImage,
    /// The stages' counters.
    pub stats: SismStats,
}

/// Renders the visibility of `receivers` with SISM: the stages as phases of `log`, in the paper's
/// order. `topo` is the scene's topology (built once per scene).
/// `bvh` gives the scene's BVH (built once per scene, and only when asked): with it the light-point
/// composition casts rays where they are cheaper than Eq. 3 (see [`SismOptions::ray_evaluations`]).
pub fn render_frame<'a>(
    log: &mut FrameLog,
    topo: &SceneTopology,
    bvh: Option<&'a (dyn Fn() -> &'a SceneBvh + Sync)>,
    light: &Light,
    receivers: &'a Receivers,
    options: &SismOptions,
) -> SismFrame {
    let mut stats = SismStats::default();
    let samples = log.phase(
        "light_samples",
        "light view fitted to the receivers and their light-space samples",
        |p| light_samples::build(p, receivers, light),
    );
    let grid = log.phase("grid", "light-space perspective grid construction", |p| {
        grid::build(p, &samples.view.faces, &samples.samples, &options.grid)
    });
    stats.grid = grid.stats();
    let mut visibility = samples.image;
    let light = samples.light;
    let inputs = StageInputs {
        topo,
        light: &light,
        grid: &grid,
    };
    let composition = options.composition;

    // Umbra: counted triangles binned, then the depth complexity at the light centre of every sample
    // (the independent composition fuses the latter into its occlusion pass).
    let (triangles, mut depth) = log.phase("umbra", "umbra: triangle binning and depth complexity", |p| {
        let triangles = umbra::bin_triangles(p, &inputs, &mut stats.umbra);
        let depth = (composition != Composition::Independent).then(|| {
            let depth = umbra::depth_complexity(p, &inputs, &triangles, &mut stats.umbra);
            stats.umbra.set_depth_complexity(&depth);
            depth
        });
        (triangles, depth)
    });
    // A point light has no penumbra: no silhouette or penumbra work at all.
    let penumbra_work = light.radius > 0.0;
    let silhouettes = if penumbra_work {
        log.phase("silhouettes", "silhouette edges w.r.t. the light centre", |p| {
            silhouettes::extract(p, topo, light.center, composition == Composition::Independent)
        })
    } else {
        Silhouettes::default()
    };

    let occlusion = if !penumbra_work && composition != Composition::Independent {
        // Umbra only: Eq. 4 with no edge terms (the light-point composition's counts would all be the
        // depth complexity, and its estimate this same value).
        resolve::Occlusion::Additive {
            umbra: depth.take().expect("computed above"),
            penumbra: None,
        }
    } else {
        log.phase("penumbra", "penumbra: quad binning and Eq. 3", |p| {
            let quads = if penumbra_work {
                penumbra::bin_quads(p, &inputs, &silhouettes, &mut stats.penumbra)
            } else {
                BinLists::empty(grid.bins.len())
            };
            let occluders = Occluders {
                triangles: &triangles,
                silhouettes: &silhouettes,
                quads: &quads,
            };
            match composition {
                Composition::Additive => {
                    let sums = penumbra::edge_sums(p, &inputs, &occluders, &mut stats.penumbra);
                    resolve::Occlusion::Additive {
                        umbra: depth.take().expect("computed above"),
                        penumbra: Some(sums),
                    }
                }
                Composition::Sampled => resolve::Occlusion::Visible(sampled::visible_fraction(
                    p,
                    &inputs,
                    &occluders,
                    depth.as_deref().expect("computed above"),
                    options.light_point_estimator,
                    options.light_points,
                    bvh.filter(|_| options.ray_evaluations > 0)
                        .map(|bvh| sampled::RayFallback {
                            bvh,
                            receivers,
                            unbuilt_triangles: options.unbuilt_bvh_triangles,
                            min_evaluations: options.ray_evaluations,
                            refine_points: options.ray_refine_points,
                            choice: options.ray_choice,
                        }),
                    &mut stats.penumbra,
                )),
                Composition::Independent => resolve::Occlusion::Visible(independent::visible_fraction(
                    p,
                    &inputs,
                    &occluders,
                    &mut stats.umbra,
                    &mut stats.penumbra,
                )),
            }
        })
    };
    stats.penumbra.finish(stats.grid.samples);

    log.phase("resolve", "Eq. 4 composition into pixels", |p| {
        resolve::compose(p, &inputs, &occlusion, &mut visibility)
    });
    SismFrame { visibility, stats }
}

/// A whole SISM frame of a scene, outside the registry.
pub struct SceneFrame {
    /// The eye pass's receivers, one per pixel.
    pub receivers: Receivers,
    /// `V` per pixel.
    pub visibility: VisibilityImage,
    /// The stages' counters.
    pub stats: SismStats,
    /// The eye pass's counts.
    pub eye: crate::raster::RasterStats,
    /// Host times per phase and, counted, the task records.
    pub log: FrameLog,
}

/// The eye pass and the SISM stages of `scene` (for tests, benches and tools; the CLI goes through
/// the registry and [`crate::render`]), executed as `exec` says. `topo` is the scene's topology.
pub fn render_scene(scene: &Scene, topo: &SceneTopology, options: &SismOptions, exec: Exec) -> SceneFrame {
    let mut log = FrameLog::new(exec);
    let eye = log.phase("eye_pass", "eye pass: receivers of every pixel", |p| {
        crate::raster::eye::eye_pass(p, scene)
    });
    let frame = render_frame(&mut log, topo, None, &scene.light, &eye.receivers, options);
    SceneFrame {
        receivers: eye.receivers,
        visibility: frame.visibility,
        stats: frame.stats,
        eye: eye.stats,
        log,
    }
}

const SAMPLES_PER_COLUMN: FloatParam = FloatParam::new(ParamSpec {
    key: "samples_per_column",
    kind: ParamKind::Float { min: 1.0, max: 64.0 },
    default: "4",
    description: "target mean samples per grid column (image-plane cell) of a light face",
});
const SLICES: IntParam = IntParam::new(ParamSpec {
    key: "slices",
    kind: ParamKind::Int { min: 1, max: 64 },
    default: "8",
    description: "depth slices per column, log-spaced between a face's nearest and farthest sample",
});
const BIN_COLUMNS: IntParam = IntParam::new(ParamSpec {
    key: "bin_columns",
    kind: ParamKind::Int { min: 1, max: 64 },
    default: "4",
    description: "bin side in columns (a bin is a task of the umbra and penumbra stages)",
});
const ESTIMATOR: ChoiceParam<sampled::LightPointEstimator> = ChoiceParam::new(
    ParamSpec {
        key: "estimator",
        kind: ParamKind::Choice(&["hybrid", "fraction"]),
        default: "hybrid",
        description: "hybrid: Eq. 4's analytic value where no light point sees an overlap, the lit share \
elsewhere; fraction: the lit share everywhere",
    },
    &[
        sampled::LightPointEstimator::Hybrid,
        sampled::LightPointEstimator::Fraction,
    ],
);
const LIGHT_POINTS: ChoiceParam<sampled::LightPoints> = ChoiceParam::new(
    ParamSpec {
        key: "light_points",
        kind: ParamKind::Choice(&["64", "128", "256"]),
        default: "128",
        description: "points of each sample's light disk at which occluders are counted: more points, less \
quantisation noise in the penumbrae, at a cost that grows more slowly than their number",
    },
    &[
        sampled::LightPoints::P64,
        sampled::LightPoints::P128,
        sampled::LightPoints::P256,
    ],
);
const RAY_EVALUATIONS: IntParam = IntParam::new(ParamSpec {
    key: "ray_evaluations",
    kind: ParamKind::Int { min: 0, max: 1 << 24 },
    default: RAY_EVALUATIONS_DEFAULT,
    description: "estimated Eq. 3 work per sample (in 64-point evaluations) at or above which a bin part probes what its \
samples' shadow rays to their light points cost, and casts them where they cost less than its Eq. 3 \
work (cost-aware penumbra); 0: never",
});

const RAY_REFINE_POINTS: IntParam = IntParam::new(ParamSpec {
    key: "ray_refine_points",
    kind: ParamKind::Int {
        min: 0,
        max: sampled::MAX_REFINE_POINTS as i64,
    },
    default: "192",
    description: "shadow rays a ray-cast sample adds when its rays to its light points disagree (some \
hidden, some not): the penumbra's noise is there; 0: none",
});

const RAY_CHOICE: ChoiceParam<sampled::RayChoice> = ChoiceParam::new(
    ParamSpec {
        key: "ray_parts",
        kind: ParamKind::Choice(&["cost", "all"]),
        default: "cost",
        description: "cost: a part whose estimate reaches ray_evaluations casts rays where its probed rays \
cost less than its Eq. 3 work; all: every such part casts them (the rays alone, to test or measure them)",
    },
    &[sampled::RayChoice::Cost, sampled::RayChoice::All],
);

/// SISM's parameters (the grid's resolution).
const GRID_PARAMS: [ParamSpec; 3] = [SAMPLES_PER_COLUMN.spec(), SLICES.spec(), BIN_COLUMNS.spec()];

/// The light-point composition's parameters: the grid's and the estimator.
const SAMPLED_PARAMS: [ParamSpec; 8] = [
    GRID_PARAMS[0],
    GRID_PARAMS[1],
    GRID_PARAMS[2],
    ESTIMATOR.spec(),
    LIGHT_POINTS.spec(),
    RAY_EVALUATIONS.spec(),
    RAY_REFINE_POINTS.spec(),
    RAY_CHOICE.spec(),
];

/// Default of `ray_evaluations`: below it a sample's Eq. 3 light-point work is cheaper than its 64
/// shadow rays in all but open scenes, so probing the rays' cost would not pay (see ARCHITECTURE.md,
/// "The cost-aware penumbra").
const RAY_EVALUATIONS_DEFAULT: &str = "2048";

/// `sism`: the paper's additive composition.
pub static SISM: super::Algorithm = super::Algorithm {
    name: "sism",
    family: Family::Sism,
    summary: "soft irregular shadow mapping as the paper writes it: binned rasterized eye pass, light-space \
perspective grid, umbra depth complexity, penumbra quads and Eq. 3, composed additively (Eq. 4, C = 0)",
    params: &GRID_PARAMS,
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Defaults,
    run: |inputs, params, log| run(inputs, params, log, Composition::Additive),
};

/// `sism-independent`: components composed as independent occluders.
pub static SISM_INDEPENDENT: super::Algorithm = super::Algorithm {
    name: "sism-independent",
    family: Family::Sism,
    summary: "the same kernels, with each connected component of the meshes composed as an independent \
occluder, `V = Π(1 − coverage)`: much less overlap darkening in foliage",
    params: &GRID_PARAMS,
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Defaults,
    run: |inputs, params, log| run(inputs, params, log, Composition::Independent),
};

/// `sism-sampled`: occluders counted at light points of each receiver (128 by default).
pub static SISM_SAMPLED: super::Algorithm = super::Algorithm {
    name: "sism-sampled",
    family: Family::Sism,
    summary:
        "the same kernels, with each receiver counting occluders at fixed points of its light disk (128) \
(Eq. 3's regions tested point by point) instead of adding coverages: overlaps compose exactly, no C = 0 \
darkening",
    params: &SAMPLED_PARAMS,
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Defaults,
    run: |inputs, params, log| run(inputs, params, log, Composition::Sampled),
};

impl SismOptions {
    /// The options of `composition` with the registry's checked `params`.
    pub fn from_params(params: &Params, composition: Composition) -> SismOptions {
        SismOptions {
            grid: GridParams {
                samples_per_column: params.get(&SAMPLES_PER_COLUMN) as f32,
                slices: params.get(&SLICES) as u32,
                bin_columns: params.get(&BIN_COLUMNS) as u32,
            },
            composition,
            light_point_estimator: match composition {
                Composition::Sampled => params.get(&ESTIMATOR),
                _ => sampled::LightPointEstimator::Hybrid,
            },
            light_points: match composition {
                Composition::Sampled => params.get(&LIGHT_POINTS),
                _ => sampled::LightPoints::default(),
            },
            ray_evaluations: match composition {
                Composition::Sampled => params.get(&RAY_EVALUATIONS) as u32,
                _ => 0,
            },
            ray_choice: match composition {
                Composition::Sampled => params.get(&RAY_CHOICE),
                _ => sampled::RayChoice::Cost,
            },
            ray_refine_points: match composition {
                Composition::Sampled => params.get(&RAY_REFINE_POINTS) as u32,
                _ => 0,
            },
            unbuilt_bvh_triangles: 0,
        }
    }
}

/// The registry's entry point.
fn run(
    inputs: &FrameInputs<'_>,
    params: &Params,
    log: &mut FrameLog,
    composition: Composition,
) -> AlgorithmFrame {
    let prepared = inputs.prepared;
    let options = SismOptions {
        unbuilt_bvh_triangles: if prepared.bvh_time().is_some() {
            0
        } else {
            prepared.scene.triangle_count()
        },
        ..SismOptions::from_params(params, composition)
    };
    let bvh = || prepared.bvh();
    let frame = render_frame(
        log,
        prepared.topology(),
        Some(&bvh),
        &prepared.scene.light,
        inputs.receivers,
        &options,
    );
    let mut stats = StatsReport::default();
    stats.rows(&frame.stats);
    AlgorithmFrame {
        visibility: frame.visibility,
        stats,
    }
}
