//! `sism trace`: make a frame trace (orbit, walk-through, light sweep) or render one, frame by frame,
//! natively or on the modelled chip, with per-frame times, counters, error and flicker.

use std::path::{Path, PathBuf};

use anyhow::Context;

use sism::algorithms::PreparedScene;
use sism::machine::MachineConfig;
use sism::output::pfm;
use sism::render::{self, RenderOptions};
use sism::scene::Scene;
use sism::trace::{self, Trace};

use super::{algorithm, algorithm_values, create_dir, write_file, ParamArgs};

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand)]
enum Command {
    /// Write a trace over a scene: `orbit` (the camera turns about the look-at point), `walk` (the
    /// camera moves along its view direction) or `light-sweep` (the light turns about the look-at
    /// point).
    Make(MakeArgs),
    /// Render every frame of a trace: visibility PFMs (frame_NNNN.pfm), frames.csv (per frame: host
    /// ms, simulated ms with --machine, receivers, error and flicker with --reference), summary.txt
    /// and frames.png.
    Run(RunArgs),
}

#[derive(clap::Args)]
struct MakeArgs {
    #[arg(value_parser = ["orbit", "walk", "light-sweep"])]
    kind: String,
    /// Scene file the trace moves through.
    scene: PathBuf,
    /// Frames, 2..=10000.
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(2..=10000))]
    frames: u32,
    /// Orbit and light sweep: degrees turned over the trace. Walk: share of the eye's distance to the
    /// look-at point travelled.
    #[arg(long, default_value_t = 30.0)]
    amount: f32,
    /// The trace file to write.
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Args)]
struct RunArgs {
    /// The trace file.
    trace: PathBuf,
    /// Algorithm (see `sism algorithms`).
    #[arg(long, default_value = "sism", value_parser = algorithm_values(false))]
    algo: String,
    #[command(flatten)]
    params: ParamArgs,
    /// Override the image width, pixels.
    #[arg(long)]
    width: Option<u32>,
    /// Override the image height, pixels.
    #[arg(long)]
    height: Option<u32>,
    /// Also time every frame on this modelled chip (counted frames: slower).
    #[arg(long)]
    machine: Option<String>,
    /// A folder of an earlier `trace run` of the same trace (the reference, say): per-frame error
    /// against its frames and flicker against its frame-to-frame change.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Output folder.
    #[arg(long, default_value = "out/trace")]
    out: PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    match a.command {
        Command::Make(m) => make(m),
        Command::Run(r) => run_trace(r),
    }
}

fn make(a: MakeArgs) -> anyhow::Result<()> {
    anyhow::ensure!(a.amount.is_finite(), "--amount must be finite");
    let scene = Scene::load(&a.scene)?;
    // The trace names its scene relative to its own folder when it can.
    let dir = a
        .out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let scene_path = relative_to(&a.scene, dir);
    let n = a.frames as usize;
    let t = match a.kind.as_str() {
        "orbit" => trace::orbit(&scene_path, &scene, n, a.amount),
        "walk" => trace::walk(&scene_path, &scene, n, a.amount),
        _ => trace::light_sweep(&scene_path, &scene, n, a.amount),
    };
    write_file(&a.out, &trace::write(&t))?;
    eprintln!("wrote {} ({} frames)", a.out.display(), t.frames.len());
    Ok(())
}

/// `path` relative to `dir` when both are relative or both absolute (`../x` steps), else `path`.
fn relative_to(path: &Path, dir: &Path) -> PathBuf {
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

/// Loads a trace file and its scene (relative to the trace's folder).
fn load(path: &Path, width: Option<u32>, height: Option<u32>) -> anyhow::Result<(Trace, Scene)> {
    let text = sism::input::read_text(path, "trace file", sism::input::MAX_TEXT_BYTES)?;
    // The scene line comes first; the frames start from the scene's own view.
    let head = trace::parse(&text, path, &placeholder()).map(|t| t.scene);
    let scene_rel = head.map_err(|e| anyhow::anyhow!("{e}"))?;
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
        anyhow::bail!("--width/--height: {} {msg}", key.replace("camera.", ""));
    }
    let t = trace::parse(&text, path, &trace::initial_frame(&scene)).map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok((t, scene))
}

/// A start frame for reading the scene line only (its values are never used).
fn placeholder() -> trace::TraceFrame {
    trace::TraceFrame {
        eye: glam::Vec3::Z,
        look_at: glam::Vec3::ZERO,
        fov_y_deg: 45.0,
        light_center: glam::Vec3::Y,
        light_radius: 0.0,
        mesh_moves: Vec::new(),
    }
}

fn run_trace(a: RunArgs) -> anyhow::Result<()> {
    let (t, base) = load(&a.trace, a.width, a.height)?;
    let algo = algorithm(&a.algo)?;
    let params = a.params.resolve(algo)?;
    let config = a
        .machine
        .as_deref()
        .map(MachineConfig::resolve)
        .transpose()
        .context("--machine")?;
    anyhow::ensure!(
        config.is_none() || algo.kernels,
        "--machine times algorithms that run on the simd kernels; {} is not one",
        algo.name
    );
    let out = create_dir(&a.out)?;
    let bar = sism::progress::bar(t.frames.len() as u64, "frames", !a.quiet);
    let options = RenderOptions {
        progress: false,
        ..Default::default()
    };
    let mut csv =
        String::from("frame,host_ms,sim_ms,receivers,mae,p99,penumbra_mae,flicker_mean,flicker_p99\n");
    let mut all_flicker: Vec<f32> = Vec::new();
    let (mut prev, mut prev_ref): (
        Option<sism::frame::VisibilityImage>,
        Option<sism::frame::VisibilityImage>,
    ) = (None, None);
    // One scene for the whole trace, set to each frame in turn; the per-scene data (adjacency, BVH)
    // carries over while no mesh moves differently from the frame before.
    let mut scene = base.clone();
    let mut cache: Option<sism::algorithms::SceneCache> = None;
    let mut shown_moves: Option<&[(usize, glam::Vec3)]> = None;
    let mut host = Vec::new();
    let mut flicker_per_frame = Vec::new();
    for (k, f) in t.frames.iter().enumerate() {
        let same_geometry = shown_moves == Some(&f.mesh_moves[..]);
        trace::apply_to(&mut scene, &base, f, !same_geometry)
            .map_err(|e| anyhow::anyhow!("{} frame {k}: {e}", a.trace.display()))?;
        shown_moves = Some(&f.mesh_moves);
        let prepared = match cache.take() {
            Some(c) if same_geometry => PreparedScene::with_cache(&scene, c),
            _ => PreparedScene::new(&scene),
        };
        let result = render::render_prepared(&prepared, algo, &params, &options);
        let sim_ms = config.as_ref().map(|c| {
            render::render_on_machine(&scene, algo, &params, c, false)
                .report
                .frame
                .ms
        });
        cache = Some(prepared.into_cache());
        let v = result.visibility;
        pfm::write_pfm(&out.join(format!("frame_{k:04}.pfm")), &v)
            .with_context(|| format!("cannot write a frame into {}", out.display()))?;
        let reference = match &a.reference {
            Some(dir) => {
                let p = dir.join(format!("frame_{k:04}.pfm"));
                Some(pfm::read_pfm(&p).with_context(|| format!("--reference: frame {k}"))?)
            }
            None => None,
        };
        let error = match &reference {
            Some(r) => {
                Some(sism::metrics::compare(r, &v).with_context(|| format!("--reference: frame {k}"))?)
            }
            None => None,
        };
        let flicker = match (&prev, &reference, &prev_ref) {
            (Some(p), Some(r), Some(pr)) => Some(trace::flicker_values(p, &v, Some((pr, r)))),
            (Some(p), None, _) => Some(trace::flicker_values(p, &v, None)),
            _ => None,
        };
        let fl = flicker.map(|mut f| {
            let s = trace::summarize(&mut f);
            all_flicker.extend_from_slice(&f);
            s
        });
        let host_ms = result.stats.get("time.frame").unwrap_or(f64::NAN);
        host.push(host_ms);
        flicker_per_frame.push(fl.map_or(f64::NAN, |f| f.0));
        let opt = |x: Option<f64>, digits: usize| x.map_or(String::new(), |v| format!("{v:.digits$}"));
        csv += &format!(
            "{k},{host_ms:.3},{},{},{},{},{},{},{}\n",
            opt(sim_ms, 3),
            v.values.iter().filter(|x| (0.0..=1.0).contains(*x)).count(),
            opt(error.as_ref().map(|e| e.mae), 6),
            opt(error.as_ref().map(|e| e.p99), 6),
            opt(error.as_ref().map(|e| e.penumbra_mae), 6),
            opt(fl.map(|f| f.0), 6),
            opt(fl.map(|f| f.1), 6),
        );
        prev = Some(v);
        prev_ref = reference;
        bar.inc(1);
    }
    bar.finish_and_clear();
    let (mean, p99) = trace::summarize(&mut all_flicker);
    let mut sorted = host.clone();
    sorted.sort_by(f64::total_cmp);
    let summary = format!(
        "trace {}\nalgorithm {} ({})\nframes {}\nhost_ms_median {:.3}\nflicker_mean {mean:.6}\nflicker_p99 {p99:.6}\nflicker_against {}\n",
        a.trace.display(),
        algo.name,
        params.describe(),
        t.frames.len(),
        sorted[sorted.len() / 2],
        if a.reference.is_some() { "the reference's frame-to-frame change" } else { "zero (the frames' own change)" }
    );
    write_file(&out.join("frames.csv"), &csv)?;
    write_file(&out.join("summary.txt"), &summary)?;
    write_plot(
        &out.join("frames.png"),
        &a.trace,
        algo.name,
        &host,
        &flicker_per_frame,
    )?;
    if !a.quiet {
        eprint!("{summary}");
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// `frames.png`: host ms per frame and, on a second axis scale, the frame's mean flicker.
fn write_plot(path: &Path, trace: &Path, algo: &str, host: &[f64], flicker: &[f64]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    super::plot::register_fonts();
    let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("cannot draw {}: {e}", path.display());
    let n = host.len().max(2) as f64;
    let tmax = host
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-3)
        * 1.15;
    let fmax = flicker
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-6)
        * 1.15;
    let mut rgb = super::plot::canvas();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, super::plot::PLOT_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let name = trace
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("{name}: {algo} per frame"), ("sans-serif", 24))
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .right_y_label_area_size(80)
            .build_cartesian_2d(0f64..n - 1.0, 0f64..tmax)
            .map_err(|e| err(&e))?
            .set_secondary_coord(0f64..n - 1.0, 0f64..fmax);
        chart
            .configure_mesh()
            .x_desc("frame")
            .y_desc("host ms")
            .axis_desc_style(("sans-serif", 18))
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;
        chart
            .configure_secondary_axes()
            .y_desc("mean flicker")
            .axis_desc_style(("sans-serif", 18))
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;
        let blue = RGBColor(31, 119, 180);
        let red = RGBColor(214, 39, 40);
        chart
            .draw_series(LineSeries::new(
                host.iter().enumerate().map(|(k, &v)| (k as f64, v)),
                blue.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label("host ms")
            .legend(move |(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], blue.stroke_width(2)));
        chart
            .draw_secondary_series(LineSeries::new(
                flicker
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| v.is_finite())
                    .map(|(k, &v)| (k as f64, v)),
                red.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label("mean flicker")
            .legend(move |(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], red.stroke_width(2)));
        super::plot::legend(&mut chart, SeriesLabelPosition::UpperLeft).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    super::plot::save(path, rgb)
}
