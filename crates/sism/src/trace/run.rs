//! Running a trace: every frame rendered in turn (natively, and on a modelled chip when asked), the
//! per-scene data reused while the geometry is unchanged, each frame's error against a reference run
//! of the same trace and its flicker; the frames and a summary written to a folder.

use std::path::{Path, PathBuf};

use glam::Vec3;

use super::{apply_to, flicker_values, parse, summarize, Trace, TraceFrame};
use crate::algorithms::{Algorithm, Params, PreparedScene, SceneCache};
use crate::error::Context;
use crate::frame::VisibilityImage;
use crate::machine::MachineConfig;
use crate::output::{pfm, pictures};
use crate::render::{self, RenderOptions};
use crate::scene::Scene;

/// Loads a trace file and its scene (relative to the trace's folder), with the image size overridden
/// by `width`/`height` when given.
pub fn load(path: &Path, width: Option<u32>, height: Option<u32>) -> crate::Result<(Trace, Scene)> {
    let text = crate::input::read_text(path, "trace file", crate::input::MAX_TEXT_BYTES)?;
    // The scene line comes first; the frames start from the scene's own view.
    let scene_rel = parse(&text, path, &placeholder())
        .map(|t| t.scene)
        .map_err(|e| crate::Error::invalid(e.to_string()))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let scene_path = if scene_rel.is_absolute() {
        scene_rel
    } else {
        dir.join(scene_rel)
    };
    let mut scene = Scene::load(&scene_path).with_context(|| format!("the scene of {}", path.display()))?;
    if let Some(w) = width {
        scene.camera.width = w;
    }
    if let Some(h) = height {
        scene.camera.height = h;
    }
    if let Err((key, msg)) = scene.camera.validate() {
        crate::error::bail!("--width/--height: {} {msg}", key.replace("camera.", ""));
    }
    let t = super::parse_over(&text, path, &scene).map_err(|e| crate::Error::invalid(e.to_string()))?;
    super::check(&t, &scene).map_err(|e| crate::Error::invalid(format!("{}: {e}", path.display())))?;
    Ok((t, scene))
}

/// A start frame for reading the scene line only (its values are never used).
fn placeholder() -> TraceFrame {
    TraceFrame {
        eye: Vec3::Z,
        look_at: Vec3::ZERO,
        fov_y_deg: 45.0,
        light_center: Vec3::Y,
        light_radius: 0.0,
        mesh_moves: Vec::new(),
    }
}

/// The kind of run a trace run's folder marker names ([`crate::output::staged`]).
pub const RUN_KIND: &str = "trace run";

/// What [`run`] renders and where it writes.
pub struct RunOptions<'a> {
    /// The algorithm and its resolved parameters.
    pub algorithm: &'static Algorithm,
    /// Its parameters (resolved against `algorithm`).
    pub params: &'a Params,
    /// Also time every frame on this modelled chip (counted frames: slower).
    pub machine: Option<&'a MachineConfig>,
    /// A folder of an earlier run of the same trace (`frame_NNNN.pfm`): per-frame error against its
    /// frames and flicker against its frame-to-frame change.
    pub reference: Option<&'a Path>,
    /// The output folder: written whole or not at all ([`crate::output::staged`]); an existing
    /// folder is replaced only when it is a complete trace run.
    pub out: &'a Path,
    /// Show a progress bar of frames.
    pub progress: bool,
}

/// What a trace run measured.
#[derive(Clone, Debug)]
pub struct TraceRun {
    /// Host ms of every frame (`time.frame`).
    pub host_ms: Vec<f64>,
    /// Simulated ms of every frame (with a machine).
    pub sim_ms: Vec<Option<f64>>,
    /// Mean flicker of every frame (NaN for the first).
    pub flicker_mean: Vec<f64>,
    /// `summary.txt`'s text.
    pub summary: String,
}

/// Renders every frame of `trace` over `base` and writes, into `options.out`, `frame_NNNN.pfm`,
/// `frames.csv` (per frame: host ms, simulated ms, receivers, error and flicker), `summary.txt` and
/// `frames.png`. `trace_path` names the trace in the summary and the plot.
pub fn run(trace_path: &Path, trace: &Trace, base: &Scene, options: &RunOptions) -> crate::Result<TraceRun> {
    let algo = options.algorithm;
    let params = options.params;
    if options.machine.is_some() {
        crate::algorithms::ensure_kernels(algo, "--machine")?;
    }
    if let Some(r) = options.reference {
        crate::output::guard::protect_dir(r, "--reference");
        crate::output::staged::ensure_complete(r, RUN_KIND, "--reference")?;
    }
    let staged = crate::output::staged::StagedDir::new(options.out, RUN_KIND)?;
    let out = staged.path();
    let bar = crate::progress::bar(trace.frames.len() as u64, "frames", options.progress);
    let render_options = RenderOptions {
        progress: false,
        ..Default::default()
    };
    let mut csv =
        String::from("frame,host_ms,sim_ms,receivers,mae,p99,penumbra_mae,flicker_mean,flicker_p99,flip\n");
    let mut all_flicker: Vec<f32> = Vec::new();
    let (mut prev, mut prev_ref): (Option<VisibilityImage>, Option<VisibilityImage>) = (None, None);
    // One scene for the whole trace, set to each frame in turn; the per-scene data (adjacency, BVH)
    // carries over while no mesh moves differently from the frame before.
    let mut scene = base.clone();
    let mut cache: Option<SceneCache> = None;
    let mut shown_moves: Option<&[(usize, Vec3)]> = None;
    let mut host = Vec::new();
    let mut sims = Vec::new();
    let mut flicker_per_frame = Vec::new();
    let mut flips = Vec::new();
    for (k, f) in trace.frames.iter().enumerate() {
        let same_geometry = shown_moves == Some(&f.mesh_moves[..]);
        apply_to(&mut scene, base, f, !same_geometry)
            .map_err(|e| crate::Error::invalid(format!("{} frame {k}: {e}", trace_path.display())))?;
        shown_moves = Some(&f.mesh_moves);
        let prepared = match cache.take() {
            Some(c) if same_geometry => PreparedScene::with_cache(&scene, c),
            _ => PreparedScene::new(&scene),
        };
        let result = render::render_prepared(&prepared, algo, params, &render_options);
        let sim_ms = options.machine.map(|c| {
            render::render_on_machine(&scene, algo, params, c, false)
                .report
                .frame
                .ms
        });
        cache = Some(prepared.into_cache());
        let v = result.visibility;
        pfm::write_pfm(&out.join(format!("frame_{k:04}.pfm")), &v)?;
        crate::output::exr::write_visibility_exr(&out.join(format!("frame_{k:04}.exr")), &v)?;
        let shades = pictures::shade_scene(&scene, &result.receivers, &v);
        crate::output::exr::write_rgb_half_exr(
            &out.join(format!("frame_{k:04}.shaded.exr")),
            v.width,
            v.height,
            &pictures::shaded_linear(&shades),
        )?;
        let reference = match options.reference {
            Some(dir) => {
                Some(read_reference_frame(dir, k).with_context(|| format!("--reference: frame {k}"))?)
            }
            None => None,
        };
        let error = match &reference {
            Some(r) => Some(
                crate::metrics::compare_frame(&scene, &result.receivers, r, &v)
                    .with_context(|| format!("--reference: frame {k}"))?,
            ),
            None => None,
        };
        if let Some(f) = error.as_ref().and_then(|e| e.flip) {
            flips.push(f);
        }
        let flicker = match (&prev, &reference, &prev_ref) {
            (Some(p), Some(r), Some(pr)) => Some(flicker_values(p, &v, Some((pr, r)))),
            (Some(p), None, _) => Some(flicker_values(p, &v, None)),
            _ => None,
        };
        let fl = flicker.map(|mut f| {
            let s = summarize(&mut f);
            all_flicker.extend_from_slice(&f);
            s
        });
        let host_ms = result.stats.get("time.frame").unwrap_or(f64::NAN);
        host.push(host_ms);
        sims.push(sim_ms);
        flicker_per_frame.push(fl.map_or(f64::NAN, |f| f.0));
        let opt = |x: Option<f64>, digits: usize| x.map_or(String::new(), |v| format!("{v:.digits$}"));
        csv += &format!(
            "{k},{host_ms:.3},{},{},{},{},{},{},{},{}\n",
            opt(sim_ms, 3),
            v.values.iter().filter(|x| (0.0..=1.0).contains(*x)).count(),
            opt(error.as_ref().map(|e| e.mae), 6),
            opt(error.as_ref().map(|e| e.p99), 6),
            opt(error.as_ref().map(|e| e.penumbra_mae), 6),
            opt(fl.map(|f| f.0), 6),
            opt(fl.map(|f| f.1), 6),
            opt(error.as_ref().and_then(|e| e.flip), 6),
        );
        prev = Some(v);
        prev_ref = reference;
        bar.inc(1);
    }
    bar.finish_and_clear();
    let (mean, p99) = summarize(&mut all_flicker);
    let summary = format!(
        "trace {}\nalgorithm {} ({})\nframes {}\nhost_ms_median {:.3}\nflicker_mean {mean:.6}\nflicker_p99 {p99:.6}\nflicker_against {}\n",
        trace_path.display(),
        algo.name,
        params.describe(),
        trace.frames.len(),
        crate::metrics::median(&host),
        if options.reference.is_some() { "the reference's frame-to-frame change" } else { "zero (the frames' own change)" }
    );
    let mut summary = summary;
    if !flips.is_empty() {
        summary += &format!(
            "flip_mean {:.6}\n",
            flips.iter().sum::<f64>() / flips.len() as f64
        );
    }
    crate::output::write_atomic(&out.join("frames.csv"), csv.as_bytes())?;
    crate::output::write_atomic(&out.join("summary.txt"), summary.as_bytes())?;
    crate::output::plots::trace::frames(
        &out.join("frames.png"),
        trace_path,
        algo.name,
        &host,
        &flicker_per_frame,
    )?;
    staged.commit()?;
    Ok(TraceRun {
        host_ms: host,
        sim_ms: sims,
        flicker_mean: flicker_per_frame,
        summary,
    })
}

/// Frame `k` of a reference run: `frame_NNNN.pfm`, or `frame_NNNN.exr` where no PFM is (a run
/// whose PFMs were removed to save space).
fn read_reference_frame(dir: &Path, k: usize) -> crate::Result<VisibilityImage> {
    let pfm_path = dir.join(format!("frame_{k:04}.pfm"));
    let exr_path = dir.join(format!("frame_{k:04}.exr"));
    let path = if !pfm_path.exists() && exr_path.exists() {
        exr_path
    } else {
        pfm_path
    };
    Ok(crate::output::read_visibility(&path)?)
}

/// `path` relative to `dir` when both are relative or both absolute (`../x` steps), else `path`:
/// how a trace written into `dir` names its scene.
pub fn relative_to(path: &Path, dir: &Path) -> PathBuf {
    let (p, d) = match (std::path::absolute(path), std::path::absolute(dir)) {
        (Ok(p), Ok(d)) => (p, d),
        _ => return path.to_path_buf(),
    };
    let pc: Vec<_> = p.components().collect();
    let dc: Vec<_> = d.components().collect();
    let common = pc.iter().zip(&dc).take_while(|(a, b)| a == b).count();
    let mut out = PathBuf::new();
    for _ in common..dc.len() {
        out.push("..");
    }
    for c in &pc[common..] {
        out.push(c);
    }
    out
}
