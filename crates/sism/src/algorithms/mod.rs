//! The visibility algorithms, one module each, and the registry that lists them.
//!
//! Every algorithm estimates the same quantity (CONTRACTS.md's `V`) through the same interface: it
//! receives the prepared scene, the receivers of every pixel and its checked parameters, runs its
//! phases through the frame's [`FrameLog`] (host times, and task records when counted), and returns
//! the visibility image and its statistics rows. `render --algo`, `bench`, `study`, `--help` and the
//! README's algorithm table all come from [`REGISTRY`], so a new algorithm is one module plus one
//! registry line.

pub mod gaussian;
pub mod multi_sample;
pub mod params;
pub mod pixels;
pub mod rbsm;
pub mod reference;
pub mod shadow_map;
pub mod sism;
pub mod ssmm;

#[cfg(test)]
mod constant;

use std::sync::OnceLock;
use std::time::{Duration, Instant};

pub use params::{
    ChoiceParam, FloatParam, IntParam, ParamError, ParamKind, ParamSpec, ParamValue, Params, TypedParam,
    U64Param,
};

use crate::bvh::SceneBvh;
use crate::exec::FrameLog;
use crate::frame::{Receivers, VisibilityImage};
use crate::scene::topology::SceneTopology;
use crate::scene::Scene;
use crate::stats::StatsReport;

/// Families of methods, for grouping in tables and plots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Ray-traced visibility (the reference and its variants).
    RayTraced,
    /// Soft irregular shadow mapping and its compositions.
    Sism,
    /// Shadow maps: the hard test, PCF, PCSS.
    ShadowMap,
    /// Test-only algorithms.
    Test,
}

impl Family {
    /// The family's name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Family::RayTraced => "ray-traced",
            Family::Sism => "sism",
            Family::ShadowMap => "shadow-map",
            Family::Test => "test",
        }
    }
}

/// Where an algorithm's receivers come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReceiverSource {
    /// The binned rasterizer's eye pass (phase `eye_pass`, kernels on the simd crate).
    Raster,
    /// Primary rays through the BVH (phases `bvh_build`, `primary`).
    RayCast,
}

/// How `bench` runs an algorithm by default.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchPlan {
    /// Not in the default comparison.
    Skip,
    /// Once, at its defaults.
    Defaults,
    /// Once per value of the parameter `key`, the others at their defaults.
    Sweep {
        /// The swept parameter's key (declared in [`Algorithm::params`]).
        key: &'static str,
        /// The values swept, as users would write them.
        values: &'static [&'static str],
    },
}

/// What an algorithm reads for one frame.
pub struct FrameInputs<'a> {
    /// The scene and its per-scene data (topology, BVH), built on first use.
    pub prepared: &'a PreparedScene<'a>,
    /// The receivers of every pixel (from the algorithm's [`ReceiverSource`]).
    pub receivers: &'a Receivers,
    /// Draw progress bars for long work (hidden when stderr is not a terminal).
    pub progress: bool,
}

/// What an algorithm returns for one frame.
pub struct AlgorithmFrame {
    /// `V` per pixel (CONTRACTS.md: NaN at misses, -1 facing away).
    pub visibility: VisibilityImage,
    /// The algorithm's counters (its stats structs' rows).
    pub stats: StatsReport,
}

/// One registered algorithm.
pub struct Algorithm {
    /// The name on the command line and in statistics.
    pub name: &'static str,
    /// The family it is grouped under in tables and plots.
    pub family: Family,
    /// One line: what it computes.
    pub summary: &'static str,
    /// Its parameters, with defaults and ranges.
    pub params: &'static [ParamSpec],
    /// Where its receivers come from.
    pub receivers: ReceiverSource,
    /// True when every phase runs on the simd crate's kernels, so `--machine` can count and time it.
    pub kernels: bool,
    /// How `bench` runs it by default.
    pub bench: BenchPlan,
    /// Computes the frame's visibility. `params` were resolved against [`Algorithm::params`].
    pub run: fn(&FrameInputs<'_>, &Params, &mut FrameLog) -> AlgorithmFrame,
}

impl Algorithm {
    /// Resolves `key=value` pairs against this algorithm's parameters.
    pub fn params(&self, given: &[(String, String)]) -> Result<Params, ParamError> {
        Params::resolve(self.name, self.params, given)
    }

    /// The parameter `key`, if declared.
    pub fn param(&self, key: &str) -> Option<&'static ParamSpec> {
        self.params.iter().find(|p| p.key == key)
    }
}

impl std::fmt::Debug for Algorithm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Algorithm")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

/// Every algorithm, in the order tables list them.
pub static REGISTRY: &[&Algorithm] = &[
    &reference::REFERENCE,
    &reference::REFERENCE_ADDITIVE,
    &sism::SISM,
    &sism::SISM_INDEPENDENT,
    &sism::SISM_SAMPLED,
    &shadow_map::SHADOW_MAP,
    &shadow_map::PCF,
    &shadow_map::PCSS,
    &rbsm::SMSR,
    &rbsm::RSMSS,
    &rbsm::RPCF_SMSR,
    &rbsm::RPCF_RSMSS,
    &multi_sample::LIGHT_SAMPLES,
    &multi_sample::adaptive::RB_ADAPTIVE,
    &gaussian::GAUSSIAN_PCF,
    &gaussian::GAUSSIAN_SINGLE,
    &gaussian::GAUSSIAN_MULTI,
    &ssmm::SSMM_V2,
    &ssmm::SSMM,
    #[cfg(test)]
    &constant::CONSTANT,
];

/// The algorithm called `name`.
pub fn find(name: &str) -> Option<&'static Algorithm> {
    REGISTRY.iter().copied().find(|a| a.name == name)
}

/// Checks that `algorithm` can be counted and timed on a modelled machine (every phase runs on the
/// simd kernels). The error names `option`, how the caller asked for a machine (`--machine`,
/// `machine=`), and the algorithms that can be timed.
pub fn ensure_kernels(algorithm: &Algorithm, option: &str) -> crate::Result<()> {
    if algorithm.kernels {
        return Ok(());
    }
    Err(crate::Error::invalid(format!(
        "{option} times algorithms that run on the simd kernels ({}); {} is not one",
        REGISTRY
            .iter()
            .filter(|a| a.kernels && a.family != Family::Test)
            .map(|a| a.name)
            .collect::<Vec<_>>()
            .join(", "),
        algorithm.name
    )))
}

/// Names of every algorithm, in registry order.
pub fn names() -> impl Iterator<Item = &'static str> {
    REGISTRY.iter().map(|a| a.name)
}

/// The README's algorithm table (Markdown), generated from the registry.
pub fn markdown_table() -> String {
    let mut s = String::from(
        "| name | family | what | parameters: `key=default` (range) | `--machine` |\n|---|---|---|---|---|\n",
    );
    for a in REGISTRY.iter().filter(|a| a.family != Family::Test) {
        let params: Vec<String> = a
            .params
            .iter()
            .map(|p| format!("`{}={}` ({}): {}", p.key, p.default, p.range(), p.description))
            .collect();
        s += &format!(
            "| `{}` | {} | {} | {} | {} |\n",
            a.name,
            a.family.name(),
            a.summary,
            if params.is_empty() {
                "none".to_string()
            } else {
                params.join("; ")
            },
            if a.kernels { "yes" } else { "no" }
        );
    }
    s
}

/// Per-scene data built on first use and reused across frames: the edge adjacency (SISM, the
/// additive reference) and the BVH (ray tracing), each with the host time its build took.
pub struct PreparedScene<'s> {
    /// The scene the data is built from.
    pub scene: &'s Scene,
    topology: OnceLock<(SceneTopology, Duration)>,
    bvh: OnceLock<(SceneBvh, Duration)>,
}

/// A [`PreparedScene`]'s per-scene data without its scene.
pub struct SceneCache {
    topology: OnceLock<(SceneTopology, Duration)>,
    bvh: OnceLock<(SceneBvh, Duration)>,
}

impl<'s> PreparedScene<'s> {
    /// Nothing built yet.
    pub fn new(scene: &'s Scene) -> PreparedScene<'s> {
        PreparedScene {
            scene,
            topology: OnceLock::new(),
            bvh: OnceLock::new(),
        }
    }

    /// The scene's topology (built now if not yet).
    pub fn topology(&self) -> &SceneTopology {
        &self
            .topology
            .get_or_init(|| {
                let t = Instant::now();
                (SceneTopology::build(self.scene), t.elapsed())
            })
            .0
    }

    /// The scene's BVH (built now if not yet).
    pub fn bvh(&self) -> &SceneBvh {
        &self
            .bvh
            .get_or_init(|| {
                let t = Instant::now();
                (SceneBvh::build(self.scene), t.elapsed())
            })
            .0
    }

    /// The per-scene data built so far, detached from the scene (to hand to the next frame of the
    /// same geometry: [`PreparedScene::with_cache`]).
    pub fn into_cache(self) -> SceneCache {
        SceneCache {
            topology: self.topology,
            bvh: self.bvh,
        }
    }

    /// `scene` with the per-scene data of `cache`, which must have been built from the same meshes
    /// (camera and light may differ: neither datum depends on them).
    pub fn with_cache(scene: &'s Scene, cache: SceneCache) -> PreparedScene<'s> {
        PreparedScene {
            scene,
            topology: cache.topology,
            bvh: cache.bvh,
        }
    }

    /// Host time of the topology build, if it was built.
    pub fn topology_time(&self) -> Option<Duration> {
        self.topology.get().map(|t| t.1)
    }

    /// Host time of the BVH build, if it was built.
    pub fn bvh_time(&self) -> Option<Duration> {
        self.bvh.get().map(|t| t.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_defaults_valid() {
        let mut names: Vec<&str> = names().collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), REGISTRY.len());
        for a in REGISTRY {
            Params::defaults(a.name, a.params).unwrap_or_else(|e| panic!("{e}"));
            if let BenchPlan::Sweep { key, values } = a.bench {
                let spec = a
                    .param(key)
                    .unwrap_or_else(|| panic!("{}: sweep of undeclared {key}", a.name));
                for v in values {
                    spec.parse(v)
                        .unwrap_or_else(|e| panic!("{}: sweep {key}={v}: {e}", a.name));
                }
            }
        }
    }

    /// [`Params::get`] debug-asserts that the parameter read is one the algorithm declares (key and
    /// kind), so running every algorithm at its defaults, and at each other value of every choice
    /// (for reads behind a choice), fails here if any read is not declared.
    #[test]
    fn every_parameter_read_is_declared() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/plate.toml");
        let mut scene = Scene::load(&path).unwrap();
        scene.camera.width = 48;
        scene.camera.height = 36;
        for a in REGISTRY {
            // Few rays and small maps: only the reads matter.
            let cheap: Vec<(String, String)> = [("spp", "4"), ("map_size", "256")]
                .into_iter()
                .filter(|(k, _)| a.param(k).is_some())
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
            let mut runs = vec![cheap.clone()];
            for spec in a.params {
                if let ParamKind::Choice(names) = spec.kind {
                    for name in names.iter().filter(|n| **n != spec.default) {
                        let mut given = cheap.clone();
                        given.push((spec.key.to_string(), name.to_string()));
                        runs.push(given);
                    }
                }
            }
            for given in runs {
                let params = a.params(&given).unwrap_or_else(|e| panic!("{e}"));
                crate::render::render(&scene, a, &params, &Default::default());
            }
        }
    }
}
