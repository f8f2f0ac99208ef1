//! One render, whatever the algorithm: prepare the scene, find the receivers of every pixel (the
//! algorithm's [`ReceiverSource`]), run the algorithm, and gather its image, statistics and task
//! records; then, on request, time the records on a modelled machine, and write the CONTRACTS.md
//! outputs. The CLI, the benches and the tests all go through here.

use std::path::Path;
use std::time::Instant;

use crate::algorithms::{self, Algorithm, FrameInputs, Params, PreparedScene, ReceiverSource};
use crate::exec::{Exec, FrameLog, PhaseRecords};
use crate::frame::{Receivers, VisibilityImage, V_FACING_AWAY};
use crate::machine::{self, MachineConfig, MachineReport};
use crate::output::{pfm, pictures};
use crate::raster::eye;
use crate::scene::Scene;
use crate::stats::StatsReport;

/// How to render.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderOptions {
    /// Native kernels (default) or counted, with task records for the machine model.
    pub exec: Exec,
    /// Progress bars for long work on stderr (hidden anyway when stderr is not a terminal).
    pub progress: bool,
}

/// Everything one render produced.
pub struct RenderResult {
    /// The receivers of every pixel.
    pub receivers: Receivers,
    /// `V` per pixel.
    pub visibility: VisibilityImage,
    /// Facts about the run and every counter (algorithm, eye pass, host times).
    pub stats: StatsReport,
    /// Every step's task records under [`Exec::Counting`]; empty natively.
    pub records: Vec<PhaseRecords>,
}

/// Renders `scene` with `algorithm` (its `params` resolved against its declarations), preparing the
/// per-scene data fresh (its build time counts in `time.total`).
pub fn render(
    scene: &Scene,
    algorithm: &Algorithm,
    params: &Params,
    options: &RenderOptions,
) -> RenderResult {
    render_prepared(&PreparedScene::new(scene), algorithm, params, options)
}

/// [`render`] with per-scene data kept across frames in `prepared`.
pub fn render_prepared(
    prepared: &PreparedScene<'_>,
    algorithm: &Algorithm,
    params: &Params,
    options: &RenderOptions,
) -> RenderResult {
    let scene = prepared.scene;
    let t0 = Instant::now();
    let built_topology = prepared.topology_time().is_none();
    let built_bvh = prepared.bvh_time().is_none();
    // Counted frames hold frees: with `LineAlloc` as the global allocator no address is reused within
    // the frame, so its records (and the simulated cycles) are the same in every run and for any host
    // thread count.
    // The hold is bounded ([`counted_hold_limit`]): a frame that frees more than that (thousands of
    // large depth maps) completes instead of exhausting memory, and says so (`counting.frees_released`).
    let _hold = (options.exec == Exec::Counting).then(|| {
        sism_simd::HoldFrees::set_limit(counted_hold_limit());
        sism_simd::HoldFrees::new()
    });
    let mut log = FrameLog::new(options.exec);
    let mut stats = StatsReport::default();
    stats
        .fact("scene", scene.source.display())
        .fact("algorithm", algorithm.name)
        .fact("params", params.describe())
        .fact("width", scene.camera.width)
        .fact("height", scene.camera.height)
        .fact("host_threads", rayon::current_num_threads())
        .fact(
            "simd_backend",
            match options.exec {
                Exec::Native => sism_simd::selected_backend().name(),
                Exec::Counting => "counting",
            },
        );
    stats
        .stat(
            "scene.triangles",
            scene.triangle_count() as f64,
            "triangles",
            "triangles in the scene",
        )
        .stat(
            "scene.light_radius",
            scene.light.radius as f64,
            "world_units",
            "light radius (0 = point light)",
        );

    let receivers = match algorithm.receivers {
        ReceiverSource::Raster => {
            let out = log.phase("eye_pass", "eye pass: receivers of every pixel", |p| {
                eye::eye_pass(p, scene)
            });
            out.stat_rows(&mut stats);
            out.receivers
        }
        ReceiverSource::RayCast => {
            let bvh = log.phase("bvh_build", "CWBVH build", |_| prepared.bvh());
            let receivers = log.phase("primary", "primary ray casting", |_| {
                algorithms::reference::cast_primary_rays(scene, bvh)
            });
            stats.stat(
                "rays.primary",
                receivers.pixels.len() as f64,
                "rays",
                "primary rays, one per pixel",
            );
            receivers
        }
    };
    let inputs = FrameInputs {
        prepared,
        receivers: &receivers,
        progress: options.progress,
    };
    let frame = (algorithm.run)(&inputs, params, &mut log);
    let visibility = frame.visibility;
    stats
        .stat(
            "receivers",
            receivers.pixels.iter().filter(|r| r.is_some()).count() as f64,
            "pixels",
            "pixels whose eye ray hits a surface",
        )
        .stat(
            "receivers.facing_away",
            visibility.values.iter().filter(|&&v| v == V_FACING_AWAY).count() as f64,
            "pixels",
            "receivers facing away from the light (V = -1, no shadow work)",
        );
    stats.stats.extend(frame.stats.stats);
    stats.facts.extend(frame.stats.facts);
    log.time_rows(&mut stats);
    if built_topology {
        if let Some(t) = prepared.topology_time() {
            stats.stat(
                "time.prepare_scene",
                t.as_secs_f64() * 1e3,
                "ms",
                "edge adjacency, built once per scene and reused across frames (host wall time)",
            );
        }
    }
    if built_bvh && prepared.bvh_time().is_some() && algorithm.receivers != ReceiverSource::RayCast {
        let t = prepared.bvh_time().expect("checked");
        stats.stat(
            "time.bvh_build",
            t.as_secs_f64() * 1e3,
            "ms",
            "CWBVH build (host wall time)",
        );
    }
    log.untimed_rows(&mut stats);
    if options.exec == Exec::Counting {
        stats.stat(
            "counting.frees_released",
            sism_simd::HoldFrees::released() as f64,
            "frees",
            "frees given back during the counted frame because the held blocks reached the hold limit \
             (half the host's memory): when not 0, addresses may have been reused and the simulated \
             figures may differ between runs",
        );
    }
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
        records: log.take_records(),
    }
}

/// Most bytes of freed blocks a counted frame holds: half the host's physical memory (`/proc/meminfo`),
/// 8 GiB where that cannot be read.
pub fn counted_hold_limit() -> usize {
    let total_kib = crate::input::read_text(std::path::Path::new("/proc/meminfo"), "memory facts", 1 << 20)
        .ok()
        .and_then(|t| {
            t.lines()
                .find_map(|l| l.strip_prefix("MemTotal:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        });
    match total_kib {
        Some(k) => (k.saturating_mul(1024) / 2).min(usize::MAX as u64) as usize,
        None => 8 << 30,
    }
}

/// Renders `frames` (>= 1) frames of `scene` one after another with the per-scene data prepared once,
/// and returns the last: a steady-state frame, whose buffers come from pages the earlier frames
/// touched (see `main.rs` on the allocator). Its stats gain `frames`, `time.frame_first` (the first
/// frame's `time.frame`) and `time.frame_median` (over all frames). Panics if two frames' images
/// differ: frames are deterministic.
pub fn render_frames(
    scene: &Scene,
    algorithm: &Algorithm,
    params: &Params,
    options: &RenderOptions,
    frames: usize,
) -> RenderResult {
    assert!(frames >= 1, "at least one frame");
    let prepared = PreparedScene::new(scene);
    let mut times = Vec::with_capacity(frames);
    let mut last: Option<RenderResult> = None;
    for _ in 0..frames {
        let r = render_prepared(&prepared, algorithm, params, options);
        times.push(r.stats.get("time.frame").unwrap_or(0.0));
        if let Some(prev) = &last {
            let same = prev.visibility.values.len() == r.visibility.values.len()
                && prev
                    .visibility
                    .values
                    .iter()
                    .zip(&r.visibility.values)
                    .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "two frames of the same inputs differ");
        }
        last = Some(r);
    }
    let mut result = last.expect("frames >= 1");
    let first = times[0];
    let median = crate::metrics::median(&times);
    result
        .stats
        .stat(
            "frames",
            frames as f64,
            "frames",
            "frames rendered in a row (the last is reported)",
        )
        .stat(
            "time.frame_first",
            first,
            "ms",
            "the first frame's time.frame: scene data and pages touched for the first time",
        )
        .stat(
            "time.frame_median",
            median,
            "ms",
            "median time.frame over the frames (steady state)",
        );
    result
}

/// A render timed on a modelled machine: counted, then its records replayed.
pub struct MachineRender {
    /// The render (its raw `records` already replaced by `records` below: empty).
    pub result: RenderResult,
    /// The frame's records with first-touch line ids, as a records file holds them.
    pub records: machine::CanonicalRecords,
    /// The frame timed on the modelled machine.
    pub report: MachineReport,
    /// Host seconds of the counted render and of the replay.
    pub render_seconds: f64,
    /// Host seconds of the replay.
    pub simulate_seconds: f64,
}

/// Renders `scene` with `algorithm` under [`Exec::Counting`] (same image, bit for bit), then times its
/// records on `config`; the stats gain `machine.*` rows. The algorithm must run on the kernels
/// ([`Algorithm::kernels`]); a ray-traced one has nothing for the machine to time.
pub fn render_on_machine(
    scene: &Scene,
    algorithm: &Algorithm,
    params: &Params,
    config: &MachineConfig,
    progress: bool,
) -> MachineRender {
    let t0 = Instant::now();
    let mut result = render(
        scene,
        algorithm,
        params,
        &RenderOptions {
            exec: Exec::Counting,
            progress,
        },
    );
    let render_seconds = t0.elapsed().as_secs_f64();
    // The replay maps lines to first-touch ids itself, so it runs on the raw records (the same
    // result as on their canonical form) and encodes the canonical form, for the records file,
    // from its own mapped lines as it goes.
    let t2 = Instant::now();
    let (report, records) = machine::simulate_canonical(&result.records, config);
    result.records = Vec::new();
    let simulate_seconds = t2.elapsed().as_secs_f64();
    let c = &report.frame.counters;
    let vector = c.vector_ops as f64;
    // Every scalar class (integer, float, divides, branches, memory) and the mask instructions: all
    // instructions but the vector ones (until this stop only the declared `scalar` and masks).
    let scalar = c.instructions().saturating_sub(c.vector_ops) as f64;
    result
        .stats
        .stat(
            "time.counting_render",
            render_seconds * 1e3,
            "ms",
            "the frame under the counting context, recording tasks (host wall time)",
        )
        .stat(
            "time.machine_simulation",
            simulate_seconds * 1e3,
            "ms",
            "replaying the records on the machine model, and their first-touch form for the records file (host wall time)",
        )
        .stat(
            "machine.simulated_instructions.vector",
            vector,
            "instructions",
            "16-lane vector instructions the frame's records hold",
        )
        .stat(
            "machine.simulated_instructions.scalar",
            scalar,
            "instructions",
            "scalar and mask instructions the frame's records hold",
        )
        .stat(
            "machine.counting_mips",
            (vector + scalar) / render_seconds.max(1e-9) / 1e6,
            "MIPS",
            "simulated instructions recorded per host second of the counted render",
        )
        .stat(
            "machine.replay_mips",
            (vector + scalar) / simulate_seconds.max(1e-9) / 1e6,
            "MIPS",
            "simulated instructions re-timed per host second of the replay",
        )
        .stat(
            "machine.simulated_mips",
            (vector + scalar) / (render_seconds + simulate_seconds).max(1e-9) / 1e6,
            "MIPS",
            "simulated instructions per host second of counting and replay together",
        );
    report.add_to(&mut result.stats);
    MachineRender {
        result,
        records,
        report,
        render_seconds,
        simulate_seconds,
    }
}

/// Writes `visibility.pfm`, `visibility.exr`, `visibility.png`, `shaded.png`, `shaded.exr`,
/// `stats.json` and `stats.txt` into `dir` (created if missing).
pub fn write_outputs(dir: &Path, scene: &Scene, result: &RenderResult) -> crate::Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| crate::Error::create_dir(dir, e))?;
    let v = &result.visibility;
    pfm::write_pfm(&dir.join("visibility.pfm"), v)?;
    crate::output::exr::write_visibility_exr(&dir.join("visibility.exr"), v)?;
    pictures::write_visibility_png(&dir.join("visibility.png"), v)?;
    let shades = pictures::shade_scene(scene, &result.receivers, v);
    pictures::write_shaded_png(&dir.join("shaded.png"), &shades, v.width, v.height)?;
    crate::output::exr::write_rgb_half_exr(
        &dir.join("shaded.exr"),
        v.width,
        v.height,
        &pictures::shaded_linear(&shades),
    )?;
    result.stats.write(dir)
}
