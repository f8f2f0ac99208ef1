//! One render from a scene to the CONTRACTS.md outputs: the algorithm runs, then the images and
//! counters are written. The CLI and the tests both go through here.

use std::path::Path;
use std::time::Instant;

use crate::bvh::SceneBvh;
use crate::frame::{Receivers, VisibilityImage};
use crate::output::stats::StatsReport;
use crate::output::{pfm, pictures};
use crate::reference::{self, ReferenceOptions};
use crate::scene::Scene;
use crate::sism;

/// The visibility algorithms sism can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Algorithm {
    /// Ray-traced reference: stratified light-disk samples, one shadow ray each.
    Reference,
    /// Soft irregular shadow mapping (Johnson et al. 2009) on the 16-wide kernels, run natively, with
    /// the paper's additive composition (Eq. 4, C = 0).
    Sism,
    /// SISM with connected components composed as independent occluders instead of added.
    SismIndependent,
    /// SISM with occluders counted at 64 points of each receiver's light disk: overlaps compose
    /// exactly instead of being added (no C = 0 darkening), at several times the penumbra cost.
    SismSampled,
    /// Ray-traced SISM model without its projection approximation: occluders' coverages added as if
    /// they never overlapped (the paper's C = 0). For attributing SISM's error.
    ReferenceAdditive,
}

impl Algorithm {
    /// The name used on the command line and in statistics.
    pub fn name(self) -> &'static str {
        match self {
            Algorithm::Reference => "reference",
            Algorithm::Sism => "sism",
            Algorithm::SismIndependent => "sism-independent",
            Algorithm::SismSampled => "sism-sampled",
            Algorithm::ReferenceAdditive => "reference-additive",
        }
    }

    /// The SISM composition this algorithm runs, `None` for the ray-traced ones.
    pub fn composition(self) -> Option<sism::Composition> {
        match self {
            Algorithm::Sism => Some(sism::Composition::Additive),
            Algorithm::SismIndependent => Some(sism::Composition::Independent),
            Algorithm::SismSampled => Some(sism::Composition::Sampled),
            Algorithm::Reference | Algorithm::ReferenceAdditive => None,
        }
    }
}

/// Everything one render produced.
pub struct RenderResult {
    pub receivers: Receivers,
    pub visibility: VisibilityImage,
    pub stats: StatsReport,
}

/// Runs `algorithm` on `scene`. `reference_options` sets the reference's samples and seed.
pub fn render(scene: &Scene, algorithm: Algorithm, reference_options: &ReferenceOptions) -> RenderResult {
    let mut stats = StatsReport::default();
    stats
        .fact("scene", scene.source.display())
        .fact("algorithm", algorithm.name())
        .fact("width", scene.camera.width)
        .fact("height", scene.camera.height)
        .fact("host_threads", rayon::current_num_threads());
    stats.stat(
        "scene.triangles",
        scene.triangle_count() as f64,
        "triangles",
        "triangles in the scene",
    );
    stats.stat(
        "scene.light_radius",
        scene.light.radius as f64,
        "world units",
        "light radius (0 = point light)",
    );

    let t0 = Instant::now();
    let (receivers, visibility) = match algorithm {
        Algorithm::Sism | Algorithm::SismIndependent | Algorithm::SismSampled => {
            let prepared = sism::PreparedScene::new(scene);
            let options = sism::SismOptions {
                composition: algorithm.composition().unwrap_or_default(),
                ..Default::default()
            };
            let frame = sism::render_frame(scene, &prepared, &options);
            stats
                .fact("simd_backend", format!("{:?}", sism_simd::selected_backend()))
                .stat(
                    "time.prepare_scene",
                    prepared.build_time.as_secs_f64() * 1e3,
                    "ms",
                    "edge adjacency, built once per scene and reused across frames (host wall time)",
                );
            sism::report(&frame.stats, &mut stats);
            (frame.receivers, frame.visibility)
        }
        Algorithm::Reference | Algorithm::ReferenceAdditive => {
            let bvh = SceneBvh::build(scene);
            let time_bvh = t0.elapsed();
            let mut options = *reference_options;
            if algorithm == Algorithm::ReferenceAdditive {
                options.mode = reference::ReferenceMode::AdditiveOverlap;
            }
            let (receivers, visibility, s) = reference::render(scene, &bvh, &options);
            let shadow_s = s.time_shadow.as_secs_f64();
            stats
                .fact("seed", reference_options.seed)
                .stat(
                    "reference.spp",
                    reference_options.spp as f64,
                    "samples",
                    "light-disk samples per receiver",
                )
                .stat(
                    "time.bvh_build",
                    time_bvh.as_secs_f64() * 1e3,
                    "ms",
                    "CWBVH build (host wall time)",
                )
                .stat(
                    "time.primary",
                    s.time_primary.as_secs_f64() * 1e3,
                    "ms",
                    "primary ray casting (host wall time)",
                )
                .stat(
                    "time.shadow",
                    shadow_s * 1e3,
                    "ms",
                    "shadow rays (host wall time)",
                )
                .stat(
                    "rays.primary",
                    s.primary_rays as f64,
                    "rays",
                    "primary rays, one per pixel",
                )
                .stat(
                    "receivers",
                    s.receivers as f64,
                    "pixels",
                    "pixels whose eye ray hits a surface",
                )
                .stat(
                    "receivers.facing_away",
                    s.receivers_facing_away as f64,
                    "pixels",
                    "receivers facing away from the light (V = -1, no shadow rays)",
                )
                .stat("rays.shadow", s.shadow_rays as f64, "rays", "shadow rays cast")
                .stat(
                    "rays.shadow_per_second",
                    if shadow_s > 0.0 {
                        s.shadow_rays as f64 / shadow_s
                    } else {
                        0.0
                    },
                    "rays/s",
                    "shadow-ray throughput on this host",
                );
            (receivers, visibility)
        }
    };
    stats.stat(
        "time.total",
        t0.elapsed().as_secs_f64() * 1e3,
        "ms",
        "whole render after loading (host wall time)",
    );
    RenderResult {
        receivers,
        visibility,
        stats,
    }
}

/// Writes `visibility.pfm`, `visibility.png`, `shaded.png`, `stats.json` and `stats.txt` into `dir`
/// (created if missing).
pub fn write_outputs(dir: &Path, scene: &Scene, result: &RenderResult) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow::anyhow!("cannot create output folder {}: {e}", dir.display()))?;
    pfm::write_pfm(&dir.join("visibility.pfm"), &result.visibility)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", dir.join("visibility.pfm").display()))?;
    pictures::write_visibility_png(&dir.join("visibility.png"), &result.visibility)?;
    let (lo, hi) = scene.bounds();
    pictures::write_shaded_png(
        &dir.join("shaded.png"),
        &result.receivers,
        &result.visibility,
        &scene.light,
        (lo + hi) * 0.5,
    )?;
    result.stats.write(dir)
}
