//! `sism render`: one frame of one algorithm, natively or timed on a modelled machine.

use std::path::PathBuf;

use anyhow::Context;

use sism::machine;
use sism::render::{self, RenderOptions};

use super::{algorithm, algorithm_values, ParamArgs, SceneArgs};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Algorithm (see `sism algorithms` for each one's parameters).
    #[arg(long, default_value = "reference", value_parser = algorithm_values(false))]
    algo: String,
    #[command(flatten)]
    params: ParamArgs,
    /// Output folder (created if missing).
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Time the frame on a modelled many-core chip: a preset (larrabee-8/16/24/32/48/64) or a
    /// machine TOML file. Runs the kernels under the counting context (same image, bit for bit) and
    /// also writes machine.toml and records.bin (for `sism replay`). Needs an algorithm that runs on
    /// the simd kernels (`sism algorithms` says which).
    #[arg(long)]
    machine: Option<String>,
    /// Render the frame this many times natively (1..=1000), keeping the per-scene data (edge
    /// adjacency, BVH) and the allocator's pages across frames, and write the last: its stats are a
    /// steady-state frame's (no scene preparation, no first-touch page faults), with `frames`,
    /// `time.frame_first` and `time.frame_median` added. Every frame gives the same image.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// With --machine: also write the frame's roofline, roofline.md (per phase and step the
    /// vector lane operations per cycle against bytes per cycle from L2 and DRAM, under the
    /// machine's ceilings, and the roof that bounds each) and roofline.png.
    #[arg(long, requires = "machine")]
    roofline: bool,
    /// No progress bar and no summary.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let scene = a.scene.load()?;
    let algo = algorithm(&a.algo)?;
    let params = a.params.resolve(algo)?;
    if let Some(m) = a.machine {
        anyhow::ensure!(
            a.frames == 1,
            "--frames repeats native frames; a --machine frame is counted once (its cycles do not \
depend on the host's state)"
        );
        sism::algorithms::ensure_kernels(algo, "--machine")?;
        let config = super::resolve_machine(&m).context("--machine")?;
        let r = render::render_on_machine(&scene, algo, &params, &config, !a.quiet);
        render::write_outputs(&a.out, &scene, &r.result)?;
        machine::write_config(&a.out, &config)?;
        machine::save_records(&a.out.join("records.bin"), &r.records)?;
        if a.roofline {
            let title = format!(
                "{} {}x{}, {} on {}",
                a.scene
                    .scene
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                scene.camera.width,
                scene.camera.height,
                algo.name,
                config.name
            );
            machine::roofline::write(&a.out, &title, &r.report)?;
        }
        if !a.quiet {
            note_inline!("{}", r.result.stats.to_text());
            note_inline!("{}", r.report.to_table());
            note!("wrote {}", a.out.display());
        }
        return Ok(());
    }
    let options = RenderOptions {
        progress: !a.quiet,
        ..Default::default()
    };
    let result = if a.frames > 1 {
        render::render_frames(&scene, algo, &params, &options, a.frames as usize)
    } else {
        render::render(&scene, algo, &params, &options)
    };
    render::write_outputs(&a.out, &scene, &result)?;
    if result.receivers.pixels.iter().all(|p| p.is_none()) {
        note!("warning: no pixel sees a surface: the image holds only misses (check the camera)");
    }
    if !a.quiet {
        note_inline!("{}", result.stats.to_text());
        note!("wrote {}", a.out.display());
    }
    Ok(())
}
