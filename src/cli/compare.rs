//! `sism compare`: error of a visibility image against a reference, with ꟻLIP between the two
//! frames' shaded views where the shading is known.

use std::path::{Path, PathBuf};

use anyhow::Context;

use sism::metrics;
use sism::output::pictures;
use sism::perceptual::{self, FlipMap};

use super::print_stdout;

#[derive(clap::Args)]
pub struct Args {
    /// Reference visibility (PFM or OpenEXR, told apart by content).
    reference: PathBuf,
    /// Visibility to score (PFM or OpenEXR).
    test: PathBuf,
    /// The scene both images are frames of: the two are shaded with its receivers and light (at
    /// the images' size) for ꟻLIP. Without it, ꟻLIP compares the `shaded.png` that a render wrote
    /// beside each input, when both are there; else it is not reported.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Write an error heat map PNG here (see --heatmap-metric).
    #[arg(long)]
    heatmap: Option<PathBuf>,
    /// What the heat map draws: `abs` (|V error|: black 0, red, yellow at --heatmap-scale) or
    /// `flip` (ꟻLIP's per-pixel error in NVIDIA's magma colours; needs the shading, as above).
    #[arg(long, default_value = "abs", value_parser = ["abs", "flip"])]
    heatmap_metric: String,
    /// |error| shown as full yellow in the `abs` heat map.
    #[arg(long, default_value_t = 0.25)]
    heatmap_scale: f32,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

/// Where ꟻLIP's shaded views come from.
enum Shading {
    Scene(sism::Scene),
    Beside(PathBuf, PathBuf),
    None,
}

fn shaded_beside(image: &Path) -> PathBuf {
    image.parent().unwrap_or(Path::new("")).join("shaded.png")
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let r = sism::output::read_visibility(&a.reference)?;
    let t = sism::output::read_visibility(&a.test)?;
    let mut report = metrics::compare(&r, &t)
        .with_context(|| format!("comparing {} with {}", a.test.display(), a.reference.display()))?;
    let shading = match &a.scene {
        Some(path) => {
            let mut scene = sism::Scene::load(path)?;
            scene.camera.width = r.width;
            scene.camera.height = r.height;
            if let Err((key, msg)) = scene.camera.validate() {
                anyhow::bail!("--scene {}: at the images' size, {key} {msg}", path.display());
            }
            Shading::Scene(scene)
        }
        None => {
            let (sr, st) = (shaded_beside(&a.reference), shaded_beside(&a.test));
            if sr.is_file() && st.is_file() {
                Shading::Beside(sr, st)
            } else {
                Shading::None
            }
        }
    };
    let flip: Option<FlipMap> = match &shading {
        Shading::Scene(scene) => {
            let (receivers, _) = sism::raster::eye::receivers(scene);
            Some(perceptual::flip_of_frame(scene, &receivers, &r, &t)?)
        }
        Shading::Beside(sr, st) => {
            let (ir, it) = (perceptual::read_png(sr)?, perceptual::read_png(st)?);
            Some(
                perceptual::flip_ldr(&ir, &it)
                    .with_context(|| format!("ꟻLIP between {} and {}", sr.display(), st.display()))?,
            )
        }
        Shading::None => None,
    };
    report.flip = flip.as_ref().map(FlipMap::mean);
    if a.json {
        print_stdout(&serde_json::to_string_pretty(&report)?)?;
    } else {
        let mut text = report.to_string();
        match &shading {
            Shading::Scene(s) => {
                text += &format!("\nꟻLIP shading: {} (its receivers and light)", s.source.display())
            }
            Shading::Beside(sr, st) => {
                text += &format!("\nꟻLIP shading: {} against {}", st.display(), sr.display())
            }
            Shading::None => {
                text += "\nꟻLIP: not reported (no --scene, and no shaded.png beside both inputs)"
            }
        }
        print_stdout(&text)?;
    }
    if let Some(path) = a.heatmap {
        if a.heatmap_metric == "flip" {
            let map = flip.context(
                "--heatmap-metric flip needs the shading: give --scene, or compare images a render \
wrote (shaded.png beside each)",
            )?;
            sism::output::save_png(&path, &map.magma())?;
        } else {
            anyhow::ensure!(
                a.heatmap_scale > 0.0 && a.heatmap_scale.is_finite(),
                "--heatmap-scale must be > 0"
            );
            let errors = metrics::abs_error_map(&r, &t)?;
            pictures::write_error_heatmap(&path, r.width, r.height, &errors, a.heatmap_scale)?;
        }
    }
    Ok(())
}
