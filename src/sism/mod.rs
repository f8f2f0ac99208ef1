//! Soft irregular shadow mapping (Johnson et al., I3D 2009), one module per stage of the algorithm.
//! Every kernel is written once against `sism_simd` and runs natively (AVX-512 or portable) or under
//! the counting context.
//!
//! [`render_frame`] reads as the algorithm: eye pass → light view and grid → umbra → silhouettes →
//! penumbra → resolve.

pub mod binning;
pub mod eye_pass;
pub mod grid;
pub mod independent;
pub mod light_view;
pub mod occlusion;
pub mod penumbra;
pub mod resolve;
pub mod sampled;
pub mod silhouettes;
pub mod umbra;

use std::time::{Duration, Instant};

use glam::Vec3;
use rayon::prelude::*;

use crate::frame::{Receivers, VisibilityImage, V_FACING_AWAY, V_MISS};
use crate::output::stats::StatsReport;
use crate::scene::Scene;
use grid::{GridParams, SampleIn};
use penumbra::PenumbraStats;
use silhouettes::SceneTopology;
use umbra::UmbraStats;

/// Per-scene data built once and reused across frames (adjacency, closedness).
pub struct PreparedScene {
    pub topology: SceneTopology,
    /// Host time it took to build.
    pub build_time: Duration,
}

impl PreparedScene {
    /// Builds the per-mesh data of `scene`.
    pub fn new(scene: &Scene) -> PreparedScene {
        let t = Instant::now();
        let topology = SceneTopology::build(scene);
        PreparedScene {
            topology,
            build_time: t.elapsed(),
        }
    }
}

/// How the occluders' coverages combine at a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Composition {
    /// The paper's Eq. 4: coverages added, as if occluders never overlapped (C = 0).
    #[default]
    Additive,
    /// Connected components as independent occluders: `V = prod (1 - coverage_k)` (see `independent`).
    Independent,
    /// Eq. 3's regions counted at 64 points of each sample's light disk; `V` = share of points no
    /// occluder covers, so overlaps compose exactly (see `sampled`).
    Sampled,
}

/// How kernels execute: natively, or under the counting context (same results bit for bit, plus one
/// [`sism_simd::TaskRecord`] per task for the machine model).
pub use eye_pass::Exec;

/// The task records of one phase of a frame, in a fixed task order (never the host's scheduling
/// order), for the machine model to replay.
#[derive(Clone, Debug, Default)]
pub struct PhaseRecords {
    /// Phase name: `eye_pass`, `grid`, `umbra`, `penumbra`, `resolve` (with the independent
    /// composition, umbra and penumbra fuse into `occlusion`).
    pub phase: String,
    pub tasks: Vec<sism_simd::TaskRecord>,
}

/// Runs kernel `k` as one task under `exec`, returning its output and its records (none natively).
#[inline]
pub fn run_task<K: sism_simd::Kernel>(exec: Exec, k: K) -> (K::Output, Vec<sism_simd::TaskRecord>) {
    match exec {
        Exec::Native => (sism_simd::run_native(k), Vec::new()),
        Exec::Counting => {
            let recorder = sism_simd::Recorder::new();
            let out = sism_simd::run_counting(&recorder, k);
            (out, recorder.take_tasks())
        }
    }
}

/// Settings of the SISM algorithm.
#[derive(Clone, Copy, Debug, Default)]
pub struct SismOptions {
    pub grid: GridParams,
    pub composition: Composition,
    /// Estimator of the light-point composition (`Composition::Sampled` only).
    pub light_point_estimator: sampled::LightPointEstimator,
    /// Native (default) or counting execution.
    pub exec: Exec,
}

/// Host wall time of each phase.
#[derive(Clone, Copy, Debug, Default)]
pub struct PhaseTimes {
    pub eye_pass: Duration,
    pub grid: Duration,
    pub umbra: Duration,
    pub silhouettes: Duration,
    pub penumbra: Duration,
    pub resolve: Duration,
}

impl PhaseTimes {
    /// Sum of the phases.
    pub fn total(&self) -> Duration {
        self.eye_pass + self.grid + self.umbra + self.silhouettes + self.penumbra + self.resolve
    }
}

/// Counters of one frame.
#[derive(Clone, Debug, Default)]
pub struct SismStats {
    pub times: PhaseTimes,
    pub eye_pass: eye_pass::EyePassStats,
    pub receivers: u64,
    pub receivers_facing_away: u64,
    pub samples: u64,
    pub light_faces: u64,
    pub grid_columns: u64,
    pub grid_cells: u64,
    pub occupied_cells: u64,
    pub bins: u64,
    pub occupied_bins: u64,
    /// Samples per occupied cell: `[p50, p90, p99, max]`.
    pub samples_per_cell: [u64; 4],
    /// Depth complexity (umbra crossings) per sample, additive composition only: `[p50, p90, p99,
    /// max]`, plus the mean in [`SismStats::depth_complexity_mean`].
    pub depth_complexity: [u64; 4],
    pub depth_complexity_mean: f64,
    pub umbra: UmbraStats,
    pub penumbra: PenumbraStats,
}

/// One SISM frame: receivers and visibility.
pub struct SismFrame {
    pub receivers: Receivers,
    pub visibility: VisibilityImage,
    pub stats: SismStats,
    /// Per-phase task records under [`Exec::Counting`]; empty natively.
    pub records: Vec<PhaseRecords>,
}

/// Renders one frame of `scene` with SISM.
pub fn render_frame(scene: &Scene, prepared: &PreparedScene, options: &SismOptions) -> SismFrame {
    let mut stats = SismStats::default();
    let light = scene.light;
    let c = light.center();

    let exec = options.exec;
    let mut records = Vec::new();
    let mut phase = |name: &str, tasks: Vec<sism_simd::TaskRecord>| {
        if exec == Exec::Counting {
            records.push(PhaseRecords {
                phase: name.to_string(),
                tasks,
            });
        }
    };

    let t = Instant::now();
    let eye = eye_pass::eye_pass_with(scene, exec);
    let receivers = eye.receivers;
    stats.eye_pass = eye.stats;
    stats.times.eye_pass = t.elapsed();
    phase("eye_pass", eye.records);

    let t = Instant::now();
    let (mut visibility, samples, widen, view) = light_samples(&receivers, c, light.radius, &mut stats);
    let (grid, grid_records) = grid::build(&view.faces, &samples, &options.grid, exec);
    phase("grid", grid_records);
    drop(samples);
    stats.light_faces = view.faces.len() as u64;
    stats.grid_columns = grid
        .faces
        .iter()
        .map(|g| (g.columns.x * g.columns.y) as u64)
        .sum();
    stats.grid_cells = (grid.cell_start.len() - 1) as u64;
    stats.occupied_cells = grid.occupied_cells() as u64;
    stats.bins = grid.bins.len() as u64;
    stats.occupied_bins = grid.occupied_bins() as u64;
    stats.samples_per_cell = percentiles(
        grid.cell_start
            .windows(2)
            .map(|w| (w[1] - w[0]) as u64)
            .filter(|&n| n > 0),
    );
    stats.times.grid = t.elapsed();

    let t = Instant::now();
    let topo = &prepared.topology;
    let triangle_lists = umbra::bin_triangles(topo, c, &grid, &mut stats.umbra);
    stats.times.umbra = t.elapsed();

    let (edges, edge_components) = if light.radius > 0.0 {
        let t = Instant::now();
        let silhouettes = topo.silhouettes_by_object(c, options.composition == Composition::Independent);
        stats.times.silhouettes = t.elapsed();
        silhouettes
    } else {
        // A point light has no penumbra: no silhouette or penumbra work at all.
        (Vec::new(), Vec::new())
    };
    let quad_lists =
        |stats: &mut SismStats| penumbra::bin_quads(&edges, light.radius, &widen, &grid, &mut stats.penumbra);

    // The umbra's depth complexity at the light centre of every sample (a separate phase except in
    // the independent composition, which fuses it with the penumbra).
    let mut umbra_pass = |stats: &mut SismStats| {
        let t = Instant::now();
        let (depth, umbra_records) =
            umbra::depth_complexity(topo, c, &grid, &triangle_lists, &mut stats.umbra, exec);
        stats.depth_complexity = percentiles(depth.iter().map(|&d| d as u64));
        stats.depth_complexity_mean =
            depth.iter().map(|&d| d as f64).sum::<f64>() / depth.len().max(1) as f64;
        stats.times.umbra += t.elapsed();
        phase("umbra", umbra_records);
        depth
    };
    let (depth, sums, visible);
    let occlusion = match options.composition {
        Composition::Additive => {
            depth = umbra_pass(&mut stats);
            let pen = (light.radius > 0.0).then(|| {
                let t = Instant::now();
                let lists = quad_lists(&mut stats);
                let out = penumbra::occlusion(
                    &edges,
                    light.radius,
                    &widen,
                    &grid,
                    &lists,
                    &mut stats.penumbra,
                    exec,
                );
                stats.times.penumbra = t.elapsed();
                out
            });
            sums = pen.map(|(out, penumbra_records)| {
                phase("penumbra", penumbra_records);
                out
            });
            resolve::Occlusion::Additive {
                umbra: &depth,
                penumbra: sums.as_deref(),
            }
        }
        Composition::Sampled => {
            depth = umbra_pass(&mut stats);
            let t = Instant::now();
            let lists = quad_lists(&mut stats);
            let (fraction, penumbra_records) = sampled::visible_fraction(
                &edges,
                light.radius,
                &widen,
                &grid,
                &lists,
                &depth,
                options.light_point_estimator,
                &mut stats.penumbra,
                exec,
            );
            visible = fraction;
            stats.times.penumbra = t.elapsed();
            phase("penumbra", penumbra_records);
            resolve::Occlusion::Visible(&visible)
        }
        Composition::Independent => {
            // Umbra and penumbra fuse into one pass per bin; its time is reported as penumbra.
            let t = Instant::now();
            let lists = quad_lists(&mut stats);
            let inputs = independent::Inputs {
                topo,
                light_center: c,
                light_radius: light.radius,
                grid: &grid,
                triangle_lists: &triangle_lists,
                edges: &edges,
                edge_components: &edge_components,
                quad_lists: &lists,
                widen: &widen,
            };
            let (fraction, occlusion_records) =
                independent::visible_fraction(&inputs, &mut stats.umbra, &mut stats.penumbra, exec);
            visible = fraction;
            stats.times.penumbra = t.elapsed();
            phase("occlusion", occlusion_records);
            resolve::Occlusion::Visible(&visible)
        }
    };

    let t = Instant::now();
    let resolve_records = resolve::resolve(&grid, occlusion, light.radius, &mut visibility, exec);
    stats.times.resolve = t.elapsed();
    phase("resolve", resolve_records);
    SismFrame {
        receivers,
        visibility,
        stats,
        records,
    }
}

/// Samples for the grid: the receivers facing the light, relative to its centre, with their light face
/// and face coordinates, grouped by face. Also returns the image initialised with misses and back-facing
/// receivers, each face's width factor `1 / cos(alpha)` for penumbra quads, and the light view.
fn light_samples(
    receivers: &Receivers,
    c: Vec3,
    radius: f32,
    stats: &mut SismStats,
) -> (VisibilityImage, Vec<SampleIn>, Vec<f32>, light_view::LightView) {
    // Per pixel: miss, facing away, or a sample (q relative to the light, cos(theta)). Receivers facing
    // away from the light never enter the grid; one at the light centre has no direction to it and is
    // treated the same way. Rows in parallel, concatenated in row order.
    let mut image = VisibilityImage::filled(receivers.width, receivers.height, V_MISS);
    let width = receivers.width as usize;
    // Per chunk: (q, cos theta, pixel) of its samples, receivers seen, receivers facing away.
    type Chunk = (Vec<(Vec3, f32, u32)>, u64, u64);
    let chunks: Vec<Chunk> = image
        .values
        .par_chunks_mut(width * 16)
        .zip(receivers.pixels.par_chunks(width * 16))
        .enumerate()
        .map(|(chunk, (values, pixels))| {
            let mut out = Vec::with_capacity(values.len());
            let (mut seen, mut away) = (0u64, 0u64);
            for (k, (v, r)) in values.iter_mut().zip(pixels).enumerate() {
                let Some(r) = r else { continue };
                seen += 1;
                let q = r.position - c;
                let facing = r.normal.dot(-q);
                if facing > 0.0 && q.length_squared() > 0.0 {
                    *v = 1.0;
                    out.push((q, (facing / q.length()).min(1.0), (chunk * width * 16 + k) as u32));
                } else {
                    *v = V_FACING_AWAY;
                    away += 1;
                }
            }
            (out, seen, away)
        })
        .collect();
    let n: usize = chunks.iter().map(|c| c.0.len()).sum();
    let (mut points, mut cosines, mut pixels) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for (chunk, seen, away) in chunks {
        stats.receivers += seen;
        stats.receivers_facing_away += away;
        for (q, cos, pixel) in chunk {
            points.push(q);
            cosines.push(cos);
            pixels.push(pixel);
        }
    }
    let (view, face_of) = light_view::fit(&points);
    // Group by face with a stable counting sort (at most six faces): each face keeps pixel order. (A
    // general stable sort of the 40-byte samples costs a dozen copying passes.)
    let mut next = vec![0usize; view.faces.len()];
    for &f in &face_of {
        next[f as usize] += 1;
    }
    let mut first = 0;
    for n in next.iter_mut() {
        (*n, first) = (first, first + *n);
    }
    let mut order = vec![0u32; points.len()];
    for (k, &f) in face_of.iter().enumerate() {
        order[next[f as usize]] = k as u32;
        next[f as usize] += 1;
    }
    let samples: Vec<SampleIn> = order
        .par_iter()
        .map(|&k| {
            let k = k as usize;
            let (q, face) = (points[k], face_of[k]);
            let (uv, depth) = view.faces[face as usize].project(q);
            SampleIn {
                q,
                face,
                uv,
                depth,
                pixel: pixels[k],
                cos_theta: cosines[k],
            }
        })
        .collect();
    // Width factor per face: the line of sight from a sample through an edge deviates from the axis by
    // at most the sample's own angle plus asin(r / distance).
    let n_faces = view.faces.len();
    let (cos_min, dist_min) = samples
        .par_chunks(65_536)
        .map(|chunk| {
            let mut cos_min = vec![1.0f32; n_faces];
            let mut dist_min = vec![f32::INFINITY; n_faces];
            for s in chunk {
                let len = s.q.length();
                let f = s.face as usize;
                cos_min[f] = cos_min[f].min(s.depth / len);
                dist_min[f] = dist_min[f].min(len);
            }
            (cos_min, dist_min)
        })
        .reduce(
            || (vec![1.0f32; n_faces], vec![f32::INFINITY; n_faces]),
            |(a, b), (c, d)| {
                let min =
                    |x: Vec<f32>, y: Vec<f32>| x.iter().zip(&y).map(|(p, q)| p.min(*q)).collect::<Vec<f32>>();
                (min(a, c), min(b, d))
            },
        );
    let widen = cos_min
        .iter()
        .zip(&dist_min)
        .map(|(&cos, &dist)| {
            let alpha = cos.clamp(-1.0, 1.0).acos() + (radius / dist).min(1.0).asin();
            1.0 / alpha.min(89.0f32.to_radians()).cos()
        })
        .collect();
    stats.samples = samples.len() as u64;
    (image, samples, widen, view)
}

/// `[p50, p90, p99, max]` of `values` (nearest rank; zeros when empty).
fn percentiles(values: impl Iterator<Item = u64>) -> [u64; 4] {
    let mut v: Vec<u64> = values.collect();
    if v.is_empty() {
        return [0; 4];
    }
    v.sort_unstable();
    let at = |q: f64| v[((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    [at(0.5), at(0.9), at(0.99), v[v.len() - 1]]
}

/// Adds the frame's counters and phase times to a statistics report.
pub fn report(stats: &SismStats, out: &mut StatsReport) {
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let t = &stats.times;
    out.stat(
        "time.eye_pass",
        ms(t.eye_pass),
        "ms",
        "eye pass: receivers of every pixel (host wall time)",
    )
    .stat(
        "time.grid",
        ms(t.grid),
        "ms",
        "light view and grid construction (host wall time)",
    )
    .stat(
        "time.umbra",
        ms(t.umbra),
        "ms",
        "umbra: triangle binning and depth complexity (host wall time)",
    )
    .stat(
        "time.silhouettes",
        ms(t.silhouettes),
        "ms",
        "silhouette edges w.r.t. the light centre (host wall time)",
    )
    .stat(
        "time.penumbra",
        ms(t.penumbra),
        "ms",
        "penumbra: quad binning and Eq. 3 (host wall time)",
    )
    .stat(
        "time.resolve",
        ms(t.resolve),
        "ms",
        "Eq. 4 composition into pixels (host wall time)",
    )
    .stat(
        "time.frame",
        ms(t.total()),
        "ms",
        "sum of the phases (host wall time)",
    );
    let u = &stats.umbra;
    let p = &stats.penumbra;
    let e = &stats.eye_pass;
    let rows: [(&str, u64, &str, &str); 33] = [
        (
            "eye.triangles_in",
            e.triangles_in,
            "triangles",
            "triangles entering the eye pass",
        ),
        (
            "eye.triangles_clipped",
            e.triangles_clipped,
            "triangles",
            "triangles clipped at the camera near plane",
        ),
        (
            "eye.triangles_culled",
            e.triangles_culled,
            "triangles",
            "triangles off screen or behind the camera: skipped",
        ),
        (
            "eye.tile_triangle_pairs",
            e.tile_triangle_pairs,
            "pairs",
            "(screen tile, triangle) pairs after binning",
        ),
        (
            "eye.blocks_tested",
            e.blocks_tested,
            "blocks",
            "4x4 pixel blocks tested 16-wide",
        ),
        (
            "eye.pixels_covered",
            e.pixels_covered,
            "pixels",
            "pixels with a receiver",
        ),
        (
            "receivers",
            stats.receivers,
            "pixels",
            "pixels whose eye ray hits a surface",
        ),
        (
            "receivers.facing_away",
            stats.receivers_facing_away,
            "pixels",
            "receivers facing away from the light: never enter the grid",
        ),
        (
            "grid.samples",
            stats.samples,
            "samples",
            "samples in the light-space grid",
        ),
        (
            "grid.light_faces",
            stats.light_faces,
            "faces",
            "light views: 1 frustum or 6 cube faces",
        ),
        (
            "grid.columns",
            stats.grid_columns,
            "columns",
            "image-plane cells over all faces",
        ),
        (
            "grid.cells",
            stats.grid_cells,
            "cells",
            "3D cells (columns x depth slices, whole bins)",
        ),
        (
            "grid.occupied_cells",
            stats.occupied_cells,
            "cells",
            "cells holding at least one sample",
        ),
        ("grid.bins", stats.bins, "bins", "light-view bins (tasks)"),
        (
            "grid.occupied_bins",
            stats.occupied_bins,
            "bins",
            "bins holding samples; empty bins cost nothing",
        ),
        (
            "umbra.triangles_counted",
            u.triangles_counted,
            "triangles",
            "triangles that count as occluders",
        ),
        (
            "umbra.triangles_back_facing",
            u.triangles_back_facing,
            "triangles",
            "closed-mesh triangles facing away from the light: skipped",
        ),
        (
            "umbra.face_triangles_culled",
            u.face_triangles_culled,
            "pairs",
            "(face, triangle) pairs behind the light, behind all samples or off-image",
        ),
        (
            "umbra.triangles_binned",
            u.triangles_binned,
            "pairs",
            "(bin, triangle) pairs tested",
        ),
        (
            "umbra.bin_pairs_culled_by_depth",
            u.bin_pairs_culled_by_depth,
            "pairs",
            "(bin, triangle) pairs skipped: every sample nearer than the triangle",
        ),
        (
            "umbra.samples_tested",
            u.samples_tested,
            "tests",
            "sample-triangle tests (active lanes)",
        ),
        (
            "penumbra.silhouettes",
            p.silhouettes,
            "edges",
            "silhouette edge records w.r.t. the light centre",
        ),
        (
            "penumbra.quads",
            p.quads,
            "quads",
            "(face, edge) penumbra quads generated",
        ),
        (
            "penumbra.quads_culled_face",
            p.quads_culled_face,
            "quads",
            "quads behind the light, farther than all samples or off-image",
        ),
        (
            "penumbra.quad_bin_pairs_before_culling",
            p.quad_bin_pairs_before_culling,
            "pairs",
            "(bin, quad) pairs reached with the face-wide width",
        ),
        (
            "penumbra.quad_bin_pairs_culled",
            p.quad_bin_pairs_culled_by_bin_depth,
            "pairs",
            "(bin, quad) pairs dropped by the bin's depth-refined width",
        ),
        (
            "penumbra.quad_bin_pairs",
            p.quad_bin_pairs,
            "pairs",
            "(bin, quad) pairs processed",
        ),
        (
            "penumbra.rows_culled_by_wedge",
            p.rows_culled_by_wedge,
            "rows",
            "rows of columns under a quad the wedge misses",
        ),
        (
            "penumbra.samples_culled_by_wedge",
            p.samples_culled_by_wedge,
            "samples",
            "samples under a quad outside its wedge (by row depth or per sample)",
        ),
        (
            "penumbra.samples_evaluated",
            p.samples_evaluated,
            "evaluations",
            "Eq. 3 evaluations (active lanes)",
        ),
        (
            "penumbra.evaluations_per_sample",
            p.samples_evaluated.checked_div(stats.samples).unwrap_or(0),
            "evaluations",
            "Eq. 3 evaluations per sample (integer mean)",
        ),
        (
            "penumbra.tasks",
            p.tasks,
            "tasks",
            "penumbra tasks: bins, or single rows of columns of bins with more quad-sample pairs than SPLIT_WORK",
        ),
        (
            "penumbra.evaluations_per_quad",
            p.samples_evaluated.checked_div(p.quad_bin_pairs).unwrap_or(0),
            "evaluations",
            "samples evaluated per (bin, quad) pair (integer mean)",
        ),
    ];
    for (name, value, unit, desc) in rows {
        out.stat(name, value as f64, unit, desc);
    }
    let quantiles = ["p50", "p90", "p99", "max"];
    for (q, v) in quantiles.iter().zip(stats.samples_per_cell) {
        out.stat(
            &format!("dist.samples_per_cell.{q}"),
            v as f64,
            "samples",
            "samples per occupied grid cell (distribution)",
        );
    }
    out.stat(
        "penumbra.samples_reached",
        p.samples_reached as f64,
        "samples",
        "samples inside at least one penumbra quad's wedge",
    );
    for (q, v) in quantiles.iter().zip(p.quads_per_sample) {
        out.stat(
            &format!("dist.quads_per_sample.{q}"),
            v as f64,
            "quads",
            "penumbra quads evaluated per reached sample (distribution)",
        );
    }
    for (q, v) in quantiles.iter().zip(stats.depth_complexity) {
        out.stat(
            &format!("dist.depth_complexity.{q}"),
            v as f64,
            "crossings",
            "umbra depth complexity per sample (distribution; additive composition)",
        );
    }
    out.stat(
        "dist.depth_complexity.mean",
        stats.depth_complexity_mean,
        "crossings",
        "mean umbra depth complexity per sample (additive composition)",
    );
}
