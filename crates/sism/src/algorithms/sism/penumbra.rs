//! Penumbra: a penumbra quad per silhouette edge, binned with per-bin width refinement, wedge depth
//! culling per column, and the circle-segment occlusion kernel (paper Eq. 3) at every sample left.
//!
//! Quad width. In a light face (image plane at distance 1), a sample at image position `u_p` and depth
//! `z_p` can see an edge point at `u_q`, depth `z_q`, inside the light's footprint only if
//! `|u_p - u_q| <= r' (1/z_q - 1/z_p)`, with `r' = r / cos(alpha)` (alpha bounds the angle between the
//! line of sight and the face axis; the footprint lies in a plane tilted by at most that much). So the
//! quad around the projected edge has half-width `r' (1/z_edge_min - 1/z_max)`: with the face's farthest
//! sample at first (the paper's Z), then with each bin's farthest sample (quads that no longer reach the
//! bin are dropped), and per column the same bound solved for `z_p` gives the depth where the wedge
//! enters the column: nearer samples are skipped (Section 2.5).

use glam::{UVec2, Vec2, Vec3};
use rayon::prelude::*;
use sism_simd::{Kernel, Mask16, ScalarClass, Simd};

use super::binning::{bin_items, BinItems, BinLists};
use super::grid::{FaceGrid, Grid};
use super::occlusion::{edge_term, EdgeRecord};
use super::silhouettes::Silhouettes;
use super::{Occluders, SismLight, StageInputs};
use crate::counted::{self, v2};
use crate::exec::{task_kind, Phase};
use crate::stats::{percentiles, Dist};

/// Relative slack on the widened radius in the per-sample wedge test ([`SismLight::wedge_radius`]),
/// so f32 rounding never drops a sample the exact test would keep.
pub const WEDGE_SLACK: f32 = 1e-4;

crate::declare_stats! {
    /// Counters of the penumbra stage.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct PenumbraStats {
        /// Silhouette edge records (an edge with two counted same-side triangles is one record).
        pub silhouettes: u64 => ("penumbra.silhouettes", "edges", "silhouette edge records w.r.t. the light centre"),
        /// (face, edge) quads generated (before any culling against bins).
        pub quads: u64 => ("penumbra.quads", "quads", "(face, edge) penumbra quads generated"),
        /// Quads dropped for a face: behind the light, farther than every sample, or outside the image.
        pub quads_culled_face: u64 => ("penumbra.quads_culled_face", "quads", "quads behind the light, farther than all samples or off-image"),
        /// (bin, quad) pairs the face-wide width reaches.
        pub quad_bin_pairs_before_culling: u64 => ("penumbra.quad_bin_pairs_before_culling", "pairs", "(bin, quad) pairs reached with the face-wide width"),
        /// (bin, quad) pairs dropped after refining the width with the bin's farthest sample.
        pub quad_bin_pairs_culled_by_bin_depth: u64 => ("penumbra.quad_bin_pairs_culled", "pairs", "(bin, quad) pairs dropped by the bin's depth-refined width"),
        /// (bin, quad) pairs processed.
        pub quad_bin_pairs: u64 => ("penumbra.quad_bin_pairs", "pairs", "(bin, quad) pairs processed"),
        /// Rows of columns under a quad skipped entirely by the wedge test.
        pub rows_culled_by_wedge: u64 => ("penumbra.rows_culled_by_wedge", "rows", "rows of columns under a quad the wedge misses"),
        /// Samples under a quad skipped by the wedge's entry depth or the per-sample wedge test.
        pub samples_culled_by_wedge: u64 => ("penumbra.samples_culled_by_wedge", "samples", "samples under a quad outside its wedge (by row depth or per sample)"),
        /// Bin parts that cast rays to their light points instead of evaluating Eq. 3 (`sism-sampled`).
        pub ray_parts: u64 => ("penumbra.ray_parts", "parts", "bin parts that cast rays to their light points instead of Eq. 3 (cost-aware penumbra)"),
        /// Parts whose estimated Eq. 3 work reached `ray_evaluations` per sample, and whose rays'
        /// cost was therefore measured on a few samples (step `ray_probe`).
        pub ray_parts_probed: u64 => ("penumbra.ray_parts_probed", "parts", "bin parts whose rays' cost was probed (estimated Eq. 3 work at or above ray_evaluations per sample)"),
        /// Beam-walk steps of the probes (node tests, 16-ray triangle and box tests).
        pub ray_probe_work: u64 => ("penumbra.ray_probe_work", "steps", "beam-walk steps of the probes (node tests, 16-ray triangle and box tests)"),
        /// Samples of those parts.
        pub ray_samples: u64 => ("penumbra.ray_samples", "samples", "samples whose light points were ray-cast"),
        /// Ray-cast samples whose first light points disagreed (some hidden, some not), which then
        /// cast rays to `ray_refine_points` more points.
        pub ray_samples_refined: u64 => ("penumbra.ray_samples_refined", "samples", "ray-cast samples partly lit at their light points, which cast ray_refine_points more rays"),
        /// Shadow rays cast by the ray-cast samples (points below a receiver's horizon cast none).
        pub rays_cast: u64 => ("penumbra.rays_cast", "rays", "shadow rays cast by the ray-cast samples"),
        /// Ray-cast samples that cast no refinement because their first points all agreed.
        pub ray_refinements_skipped: u64 => ("penumbra.ray_refinements_skipped", "samples", "ray-cast samples whose light points all agreed (all lit or all hidden): no refinement rays"),
        /// Sample-edge evaluations of Eq. 3 (active lanes).
        pub samples_evaluated: u64 => ("penumbra.samples_evaluated", "evaluations", "Eq. 3 evaluations (active lanes)"),
        /// `samples_evaluated` per grid sample (mean; see [`PenumbraStats::finish`]).
        pub evaluations_per_sample: f64 => ("penumbra.evaluations_per_sample", "evaluations", "Eq. 3 evaluations per sample (mean)"),
        /// Penumbra tasks (bins, or rows of columns of heavy bins; see [`SPLIT_WORK`]).
        pub tasks: u64 => ("penumbra.tasks", "tasks", "penumbra tasks: bins, or single rows of columns of bins with more quad-sample pairs than SPLIT_WORK"),
        /// `samples_evaluated` per (bin, quad) pair (mean).
        pub evaluations_per_quad: f64 => ("penumbra.evaluations_per_quad", "evaluations", "samples evaluated per (bin, quad) pair (mean)"),
        /// Samples inside at least one quad's wedge.
        pub samples_reached: u64 => ("penumbra.samples_reached", "samples", "samples inside at least one penumbra quad's wedge"),
        /// Quads evaluated per reached sample.
        pub quads_per_sample: Dist => ("dist.quads_per_sample", "quads", "penumbra quads evaluated per reached sample (distribution)"),
    }
}

/// What a penumbra bin task counted: `[rows culled, samples culled, samples evaluated, samples that
/// cast rays instead, of those the samples refined, rays cast, samples whose refinement was skipped]`.
pub type BinCounts = [u64; 7];

impl PenumbraStats {
    /// Adds the counters a bin task returned (see [`BinCounts`]).
    pub fn add_bin(&mut self, c: BinCounts) {
        self.rows_culled_by_wedge += c[0];
        self.samples_culled_by_wedge += c[1];
        self.samples_evaluated += c[2];
        self.ray_samples += c[3];
        self.ray_parts += u64::from(c[3] > 0);
        self.ray_samples_refined += c[4];
        self.rays_cast += c[5];
        self.ray_refinements_skipped += c[6];
    }

    /// The distribution of quads per sample from every bin's per-sample counts (bin-local order;
    /// the distribution does not depend on the order of bins).
    pub fn set_quads_per_sample<'a>(&mut self, per_bin: impl Iterator<Item = &'a Vec<i32>> + Clone) {
        let reached = per_bin.flat_map(|v| v.iter()).filter(|&&n| n > 0);
        self.samples_reached = reached.clone().count() as u64;
        self.quads_per_sample = percentiles(reached.map(|&n| n as u64));
    }

    /// The derived means, once the frame's `samples` are known.
    pub fn finish(&mut self, samples: u64) {
        let mean = |n: u64, d: u64| if d == 0 { 0.0 } else { n as f64 / d as f64 };
        self.evaluations_per_sample = mean(self.samples_evaluated, samples);
        self.evaluations_per_quad = mean(self.samples_evaluated, self.quad_bin_pairs);
    }
}

/// A face-space view of one edge: its clipped projected endpoints and nearest depth.
#[derive(Clone, Copy, Debug)]
struct QuadGeometry {
    a: Vec2,
    b: Vec2,
    z_near: f32,
}

/// Its operations are counted by `s`.
#[inline(always)]
fn quad_geometry<S: Simd>(s: S, g: &FaceGrid, e: &EdgeRecord) -> Option<QuadGeometry> {
    let a = g.face.to_face_counted(s, Vec3::from(s.s_read(&e.a)));
    let b = g.face.to_face_counted(s, Vec3::from(s.s_read(&e.b)));
    // Clipped to the face's near plane, as the umbra clips its triangles.
    let near = g.near_plane(s);
    let clip = |p: Vec3, q: Vec3| -> Option<Vec3> {
        if s.s_le(near, p.z) {
            Some(p)
        } else if s.s_le(near, q.z) {
            let t = s.s_div(s.s_sub(near, p.z), s.s_sub(q.z, p.z));
            let mut x = counted::add(s, p, counted::scale(s, counted::sub(s, q, p), t));
            x.z = near;
            Some(x)
        } else {
            None
        }
    };
    let (ca, cb) = (clip(a, b)?, clip(b, a)?);
    Some(QuadGeometry {
        a: Vec2::new(s.s_div(ca.x, ca.z), s.s_div(ca.y, ca.z)),
        b: Vec2::new(s.s_div(cb.x, cb.z), s.s_div(cb.y, cb.z)),
        z_near: s.s_min(ca.z, cb.z),
    })
}

/// Distance from segment `a b` to the axis-aligned rectangle `[lo, hi]` (0 when they touch).
/// Its operations are counted by `s` (a native context counts nothing).
#[inline(always)]
// The clamp of `t` is a max and a min on purpose (see there).
#[allow(clippy::manual_clamp)]
pub fn segment_rect_distance<S: Simd>(s: S, a: Vec2, b: Vec2, lo: Vec2, hi: Vec2) -> f32 {
    let point_rect = |p: Vec2| {
        let outside = v2::max(s, v2::max(s, v2::sub(s, lo, p), v2::sub(s, p, hi)), Vec2::ZERO);
        v2::length(s, outside)
    };
    let d = v2::sub(s, b, a);
    let len2 = v2::dot(s, d, d);
    let point_segment = |p: Vec2| {
        let t = if s.s_lt(0.0, len2) {
            let t = s.s_div(v2::dot(s, v2::sub(s, p, a), d), len2);
            // The clamp's two bounds, as a max and a min, not `f32::clamp`: the compiler turns the
            // clamp into a data-dependent branch per lane, which the host mispredicts and the model
            // does not count; the same value for every t but NaN.
            s.scalar_op(ScalarClass::Alu);
            s.s_fn(ScalarClass::Alu, t, |t: f32| t.max(0.0).min(1.0))
        } else {
            0.0
        };
        v2::length(s, v2::sub(s, v2::add(s, a, v2::scale(s, d, t)), p))
    };
    // Liang–Barsky: does the segment cross the rectangle?
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    let mut crosses = true;
    for (p, q) in [
        (-d.x, s.s_sub(a.x, lo.x)),
        (d.x, s.s_sub(hi.x, a.x)),
        (-d.y, s.s_sub(a.y, lo.y)),
        (d.y, s.s_sub(hi.y, a.y)),
    ] {
        if s.s_branch(p == 0.0) {
            if s.s_lt(q, 0.0) {
                crosses = false;
            }
        } else {
            let r = s.s_div(q, p);
            if s.s_lt(p, 0.0) {
                t0 = s.s_max(t0, r);
            } else {
                t1 = s.s_min(t1, r);
            }
        }
    }
    if s.s_branch(crosses) && s.s_le(t0, t1) {
        return 0.0;
    }
    let corners = [lo, Vec2::new(hi.x, lo.y), hi, Vec2::new(lo.x, hi.y)];
    let mut best = s.s_min(point_rect(a), point_rect(b));
    for c in corners {
        best = s.s_min(best, point_segment(c));
    }
    best
}

/// Counters of quad binning, per task.
#[derive(Clone, Copy, Debug, Default)]
pub struct QuadBinCounts {
    quads: u64,
    culled_face: u64,
    before: u64,
    culled_bin: u64,
}

impl std::ops::AddAssign for QuadBinCounts {
    fn add_assign(&mut self, o: Self) {
        self.quads += o.quads;
        self.culled_face += o.culled_face;
        self.before += o.before;
        self.culled_bin += o.culled_bin;
    }
}

/// Quad binning: every silhouette edge's quad into the bins its face-wide width reaches, refined by
/// each bin's farthest sample.
struct QuadBinner<'a> {
    edges: &'a [EdgeRecord],
    light: &'a SismLight,
    grid: &'a Grid,
}

impl BinItems for QuadBinner<'_> {
    type Counts = QuadBinCounts;
    #[inline(always)]
    fn emit<S: Simd>(&self, s: S, e: u32, out: &mut Vec<(u32, u32)>, counts: &mut QuadBinCounts) {
        let grid = self.grid;
        let b = grid.params.bin_columns;
        let edge = &self.edges[e as usize];
        s.scalar_read(std::slice::from_ref(edge));
        for (f, g) in grid.faces.iter().enumerate() {
            if !s.s_lt(0, s.s_read(&g.samples)) {
                continue;
            }
            counts.quads += 1;
            let r = self.light.face_radius(s, f);
            let Some(qg) = quad_geometry(s, g, edge).filter(|qg| s.s_lt(qg.z_near, g.z_max)) else {
                counts.culled_face += 1;
                continue;
            };
            let inv_near = s.s_div(1.0, qg.z_near);
            let w = s.s_mul(r, s.s_sub(inv_near, s.s_div(1.0, g.z_max)));
            let w2 = Vec2::splat(w);
            let (c0, c1) = g.column_range(
                s,
                v2::sub(s, v2::min(s, qg.a, qg.b), w2),
                v2::add(s, v2::max(s, qg.a, qg.b), w2),
            );
            if s.s_le(c1.x, c0.x) || s.s_le(c1.y, c0.y) {
                counts.culled_face += 1;
                continue;
            }
            for bin in g.bins_of_columns(b, c0, c1) {
                let bn = &grid.bins[bin];
                s.scalar_op(ScalarClass::Branch); // the bins loop
                if s.s_le(s.s_read(&bn.samples.end), bn.samples.start) {
                    continue;
                }
                counts.before += 1;
                let w_bin = s.s_mul(r, s.s_sub(inv_near, s.s_div(1.0, s.s_read(&bn.z_max))));
                if s.s_le(w_bin, 0.0)
                    || s.s_lt(w_bin, segment_rect_distance(s, qg.a, qg.b, bn.uv_min, bn.uv_max))
                {
                    counts.culled_bin += 1;
                    continue;
                }
                s.s_push(out, (bin as u32, e));
            }
        }
    }
}

/// Bins the silhouette edges' penumbra quads (steps `bin` and `lists`).
pub fn bin_quads(
    phase: &mut Phase,
    inputs: &StageInputs<'_>,
    silhouettes: &Silhouettes,
    stats: &mut PenumbraStats,
) -> BinLists {
    let edges = &silhouettes.edges;
    let binner = QuadBinner {
        edges,
        light: inputs.light,
        grid: inputs.grid,
    };
    let (lists, c) = bin_items(phase, &binner, inputs.grid.bins.len(), edges.len());
    stats.silhouettes += edges.len() as u64;
    stats.quads += c.quads;
    stats.quads_culled_face += c.culled_face;
    stats.quad_bin_pairs_before_culling += c.before;
    stats.quad_bin_pairs_culled_by_bin_depth += c.culled_bin;
    stats.quad_bin_pairs += lists.pairs() as u64;
    lists
}

/// Sum of the signed edge terms at every sample (sorted order), one task per bin part (step `eq3`).
pub fn edge_sums(
    phase: &mut Phase,
    inputs: &StageInputs<'_>,
    occluders: &Occluders<'_>,
    stats: &mut PenumbraStats,
) -> Vec<f32> {
    let grid = inputs.grid;
    let lists = occluders.quads;
    let mut sums = vec![0f32; grid.samples.pixel.len()];
    let parts = bin_parts(grid, lists);
    run_parts(phase, "eq3", &mut sums, &parts, stats, |part, out| PenumbraBin {
        edges: &occluders.silhouettes.edges,
        light: inputs.light,
        grid,
        part,
        quads: lists.of(part.bin),
        out,
    });
    sums
}

/// Runs one penumbra task per part (from [`bin_parts`]; `task` builds it from the part and the part's
/// slice of `data`, in sorted-sample order) as step `step` of `phase`, and folds the tasks' counters
/// into `stats`.
pub fn run_parts<'a, T, K, F>(
    phase: &mut Phase,
    step: &str,
    data: &'a mut [T],
    parts: &'a [BinPart],
    stats: &mut PenumbraStats,
    task: F,
) where
    T: Send,
    K: Kernel<Output = (BinCounts, Vec<i32>)> + Send,
    F: Fn(&'a BinPart, &'a mut [T]) -> K + Sync,
{
    let counters = phase.run_par(
        step,
        Grid::split_samples(data, parts.iter().map(|p| p.samples.clone()))
            .into_par_iter()
            .zip(parts)
            .map(|(out, part)| task(part, out)),
    );
    stats.tasks += parts.len() as u64;
    for c in &counters {
        stats.add_bin(c.0);
    }
    stats.set_quads_per_sample(counters.iter().map(|c| &c.1));
}

/// The per-bin penumbra task.
pub struct PenumbraBin<'a> {
    /// The frame's silhouette edge records (relative to the light centre).
    pub edges: &'a [EdgeRecord],
    /// The light.
    pub light: &'a SismLight,
    /// The grid.
    pub grid: &'a Grid,
    /// The part of the bin this task covers.
    pub part: &'a BinPart,
    /// The bin's penumbra quads: indices into `edges`.
    pub quads: &'a [u32],
    /// Penumbra sums of the part's samples (part-local indices).
    pub out: &'a mut [f32],
}

/// A part's penumbra quads prepared 16 at a time ([`PreparedQuads::new`]): for each quad, the
/// projected edge the per-sample wedge test needs and, for each row of the part, the range of sorted
/// samples its wedge may reach there (empty where the quad misses the row or its wedge enters the row
/// only beyond the bin's farthest sample).
///
/// This is the per-quad and per-row setup Larrabee's renderer would do in vector registers: the
/// endpoints gathered from the edge records, clipped and projected into the bin's face, the quad's
/// columns in the bin, and per row the distance from the projected edge to the row's rectangle, the
/// depth where the wedge enters the row, its slice and the row's sample range (cell starts gathered).
/// Written scalar, it was some 900 counted scalar operations a (bin, quad) pair, which the host ran at
/// about 0.8 cycles each. Every lane computes what the scalar setup computed, with the same
/// operations in the same order (no fused multiply-adds), so the selected samples are the same.
pub struct PreparedQuads {
    /// Quads prepared.
    n: usize,
    /// Lanes per array: `n` rounded up to 16.
    pad: usize,
    /// Rows of the part.
    rows: usize,
    /// 1 where the quad reaches the part (its clipped edge lies in front of the face and its columns
    /// meet the bin's), else 0.
    valid: Vec<i32>,
    /// Projected edge: endpoint `a` (x, y) and direction `ab` (x, y), face image-plane units.
    a_x: Vec<f32>,
    a_y: Vec<f32>,
    ab_x: Vec<f32>,
    ab_y: Vec<f32>,
    /// `1 / |ab|^2` (0 for a point).
    inv_len2: Vec<f32>,
    /// `1 / z` of the edge's nearest point.
    inv_near: Vec<f32>,
    /// Per row `j` of the part and quad `k`, at `j * pad + k`: the sorted samples `[start, end)` to
    /// test (equal when none).
    span_start: Vec<i32>,
    span_end: Vec<i32>,
    /// Rows culled by the wedge's entry depth, over the quads.
    culled_rows: u64,
    /// Samples skipped by the rows' entry depths (whole rows and nearer slices), over the quads.
    culled_samples: u64,
}

impl PreparedQuads {
    /// Prepares quads `quads[0]`, `quads[stride]`, `quads[2 * stride]`, ... (indices into `edges`)
    /// for `part`. `stride >= 1`.
    #[inline(always)]
    pub fn new<S: Simd>(
        s: S,
        grid: &Grid,
        part: &BinPart,
        light: &SismLight,
        edges: &[EdgeRecord],
        quads: &[u32],
        stride: usize,
    ) -> PreparedQuads {
        let stride = stride.max(1);
        let n = quads.len().div_ceil(stride);
        let pad = n.div_ceil(16) * 16;
        let rows = part.rows.len();
        let mut p = PreparedQuads {
            n,
            pad,
            rows,
            valid: vec![0; pad],
            a_x: vec![0.0; pad],
            a_y: vec![0.0; pad],
            ab_x: vec![0.0; pad],
            ab_y: vec![0.0; pad],
            inv_len2: vec![0.0; pad],
            inv_near: vec![0.0; pad],
            span_start: vec![0; rows * pad],
            span_end: vec![0; rows * pad],
            culled_rows: 0,
            culled_samples: 0,
        };
        if n == 0 {
            return p;
        }
        let bin = part.bin;
        let bn = &grid.bins[bin];
        let face = s.s_read(&bn.face) as usize;
        let g = &grid.faces[face];
        let lf = &g.face;
        let params = &grid.params;
        let cells_per_bin = grid.cells_per_bin();
        let cell0 = s.s_mul(bin, cells_per_bin);
        let cells = sism_simd::as_i32(&grid.cell_start[cell0..cell0 + cells_per_bin + 1]);
        // Per-part constants (scalar, once), then splats.
        let near = s.splat_f(g.near_plane(s));
        let r = s.splat_f(light.wedge_radius(s, face));
        let inv_zmax = s.splat_f(s.s_div(1.0, s.s_read(&bn.z_max)));
        let column0 = s.s_read(&bn.column0);
        let bc = params.bin_columns;
        let bin_c1 = UVec2::new(
            s.s_min(s.s_add(column0.x, bc), g.columns.x),
            s.s_min(s.s_add(column0.y, bc), g.columns.y),
        );
        let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
        let zero_i = s.splat_i(0);
        let lane = s.index_i();
        let words = EdgeRecord::words(edges);
        for g0 in (0..n).step_by(16) {
            let m = s.mask_first_n(n - g0);
            let e = if stride == 1 {
                s.mask_load_i(zero_i, m, sism_simd::as_i32(&quads[g0..]))
            } else {
                let at = s.mul_i(s.add_i(lane, s.splat_i(g0 as i32)), s.splat_i(stride as i32));
                s.mask_gather_i(zero_i, m, sism_simd::as_i32(quads), at)
            };
            // Written out, not by `map` with closures: a closure is compiled without the kernel's
            // target features (see segment_rect_distance_lanes).
            let a = [
                edge_word_lanes(s, m, words, e, 0),
                edge_word_lanes(s, m, words, e, 1),
                edge_word_lanes(s, m, words, e, 2),
            ];
            let b = [
                edge_word_lanes(s, m, words, e, 3),
                edge_word_lanes(s, m, words, e, 4),
                edge_word_lanes(s, m, words, e, 5),
            ];
            // Face coordinates of both endpoints (LightFace::to_face_counted, lane-wise).
            let a = [
                dot_lanes(s, a, lf.right),
                dot_lanes(s, a, lf.up),
                dot_lanes(s, a, lf.axis),
            ];
            let b = [
                dot_lanes(s, b, lf.right),
                dot_lanes(s, b, lf.up),
                dot_lanes(s, b, lf.axis),
            ];
            let (ca, ok_a) = clip_lanes(s, near, a, b);
            let (cb, ok_b) = clip_lanes(s, near, b, a);
            let mut valid = s.mask_and(m, s.mask_and(ok_a, ok_b));
            let (ax, ay) = (s.div_f(ca[0], ca[2]), s.div_f(ca[1], ca[2]));
            let (bx, by) = (s.div_f(cb[0], cb[2]), s.div_f(cb[1], cb[2]));
            let inv_near = s.div_f(one, s.min_f(ca[2], cb[2]));
            let w_bin = s.mul_f(r, s.sub_f(inv_near, inv_zmax));
            // The quad's columns in the face (FaceGrid::column_range), then in the bin.
            let lo = [s.sub_f(s.min_f(ax, bx), w_bin), s.sub_f(s.min_f(ay, by), w_bin)];
            let hi = [s.add_f(s.max_f(ax, bx), w_bin), s.add_f(s.max_f(ay, by), w_bin)];
            let (o, size) = (g.uv_min, g.cell_size);
            let c0x = column_lanes(s, lo[0], o.x, size.x, g.columns.x, false);
            let c0y = column_lanes(s, lo[1], o.y, size.y, g.columns.y, false);
            let c1x = column_lanes(s, hi[0], o.x, size.x, g.columns.x, true);
            let c1y = column_lanes(s, hi[1], o.y, size.y, g.columns.y, true);
            let c0x = s.max_i(c0x, s.splat_i(column0.x as i32));
            let c0y = s.max_i(c0y, s.splat_i(column0.y as i32));
            let c1x = s.min_i(c1x, s.splat_i(bin_c1.x as i32));
            let c1y = s.min_i(c1y, s.splat_i(bin_c1.y as i32));
            valid = s.mask_and(valid, s.mask_and(s.cmp_lt_i(c0x, c1x), s.cmp_lt_i(c0y, c1y)));
            let (abx, aby) = (s.sub_f(bx, ax), s.sub_f(by, ay));
            let len2 = s.add_f(s.mul_f(abx, abx), s.mul_f(aby, aby));
            let inv_len2 = s.select_f(s.cmp_lt_f(zero, len2), s.div_f(one, len2), zero);
            s.store_i(&mut p.valid[g0..], s.select_i(valid, s.splat_i(1), zero_i));
            s.store_f(&mut p.a_x[g0..], ax);
            s.store_f(&mut p.a_y[g0..], ay);
            s.store_f(&mut p.ab_x[g0..], abx);
            s.store_f(&mut p.ab_y[g0..], aby);
            s.store_f(&mut p.inv_len2[g0..], inv_len2);
            s.store_f(&mut p.inv_near[g0..], inv_near);

            // Per row: the wedge test (Section 2.5), where the wedge enters the row in depth.
            // `uv_min + column * cell_size` for the columns' sides.
            let (ox, sx) = (s.splat_f(o.x), s.splat_f(size.x));
            let lo_x = s.add_f(ox, s.mul_f(s.cvt_i_f(c0x), sx));
            let hi_x = s.add_f(ox, s.mul_f(s.cvt_i_f(c1x), sx));
            let col0 = s.splat_i(column0.x as i32);
            let last_x = s.sub_i(c1x, s.splat_i(1));
            let slices = s.splat_i(params.slices as i32);
            for (j, row) in part.rows.clone().enumerate() {
                let rv = s.splat_i(row as i32);
                let act = s.mask_and(valid, s.mask_and(s.cmp_le_i(c0y, rv), s.cmp_lt_i(rv, c1y)));
                if !s.s_branch(s.mask_any(act)) {
                    continue;
                }
                let y0 = s.s_fn(ScalarClass::Alu, row, |c| c as f32);
                let y1 = s.s_fn(ScalarClass::Alu, s.s_add(row, 1), |c| c as f32);
                let lo_y = s.splat_f(s.s_add(o.y, s.s_mul(y0, size.y)));
                let hi_y = s.splat_f(s.s_add(o.y, s.s_mul(y1, size.y)));
                let d = segment_rect_distance_lanes(s, [ax, ay], [bx, by], [lo_x, lo_y], [hi_x, hi_y]);
                let inv_enter = s.sub_f(inv_near, s.div_f(d, r));
                let cull = s.mask_and(act, s.cmp_le_f(inv_enter, inv_zmax));
                let keep = s.mask_andn(cull, act);
                let slice = g.slice_of_lanes(s, s.div_f(one, inv_enter), params.slices);
                // First cells of the row's first and last columns (Grid::column_first_cell, bin-local).
                let row_cells = s.splat_i(s.s_mul(s.s_sub(row, column0.y), bc) as i32);
                let first_cell = s.mul_i(s.add_i(row_cells, s.sub_i(c0x, col0)), slices);
                let last_cell = s.mul_i(s.add_i(row_cells, s.sub_i(last_x, col0)), slices);
                let first = s.mask_gather_i(zero_i, act, cells, first_cell);
                let start = s.mask_gather_i(zero_i, keep, cells, s.add_i(first_cell, slice));
                let end = s.mask_gather_i(zero_i, act, cells, s.add_i(last_cell, slices));
                let skipped = s.select_i(cull, end, s.select_i(keep, start, zero_i));
                p.culled_samples += s.reduce_add_i(s.sub_i(skipped, s.select_i(act, first, zero_i))) as u64;
                p.culled_rows += u64::from(s.mask_popcnt(cull));
                let at = j * pad + g0;
                s.store_i(&mut p.span_start[at..], s.select_i(keep, start, zero_i));
                s.store_i(&mut p.span_end[at..], s.select_i(keep, end, zero_i));
            }
        }
        p
    }

    /// Quads prepared.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True when no quad was prepared.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }
}

/// Word `w` of the edge records `e` (lanes of `m`; 0 elsewhere), gathered from the records' words
/// ([`EdgeRecord::words`]); records beyond the reach of 32-bit lane indices are read lane by lane.
#[inline(always)]
fn edge_word_lanes<S: Simd>(s: S, m: Mask16, words: &[f32], e: S::I32, w: usize) -> S::F32 {
    if words.len() <= i32::MAX as usize {
        let at = s.add_i(
            s.mul_i(e, s.splat_i(EdgeRecord::WORDS as i32)),
            s.splat_i(w as i32),
        );
        return s.mask_gather_f(s.splat_f(0.0), m, words, at);
    }
    let (idx, mut v) = (s.to_array_i(e), [0f32; 16]);
    for (l, x) in v.iter_mut().enumerate() {
        if m.0 >> l & 1 != 0 {
            *x = s.s_load(words, idx[l] as u32 as usize * EdgeRecord::WORDS + w);
        }
    }
    s.from_array_f(v)
}

/// `counted::dot(p, d)` lane-wise: `(p.x d.x + p.y d.y) + p.z d.z`, no fused multiply-adds.
#[inline(always)]
fn dot_lanes<S: Simd>(s: S, p: [S::F32; 3], d: Vec3) -> S::F32 {
    s.add_f(
        s.add_f(s.mul_f(p[0], s.splat_f(d.x)), s.mul_f(p[1], s.splat_f(d.y))),
        s.mul_f(p[2], s.splat_f(d.z)),
    )
}

/// `p` clipped against the near plane at depth `near` towards `q` (face coordinates, lane-wise):
/// `p` where it is in front, else the point of `p q` on the plane; the mask is false where neither
/// endpoint is in front. The scalar setup's operations, in its order.
#[inline(always)]
fn clip_lanes<S: Simd>(s: S, near: S::F32, p: [S::F32; 3], q: [S::F32; 3]) -> ([S::F32; 3], Mask16) {
    let keep = s.cmp_le_f(near, p[2]);
    let can = s.cmp_le_f(near, q[2]);
    let t = s.div_f(s.sub_f(near, p[2]), s.sub_f(q[2], p[2]));
    let x = s.add_f(p[0], s.mul_f(s.sub_f(q[0], p[0]), t));
    let y = s.add_f(p[1], s.mul_f(s.sub_f(q[1], p[1]), t));
    (
        [
            s.select_f(keep, p[0], x),
            s.select_f(keep, p[1], y),
            s.select_f(keep, p[2], near),
        ],
        s.mask_or(keep, can),
    )
}

/// [`FaceGrid::column_range`]'s column of image coordinate `p` (lane-wise) along an axis with grid
/// origin `o`, column size `size` and `columns` columns: `floor((p - o) / size)` (plus one for an
/// upper end), clamped to `[0, columns]`.
#[inline(always)]
fn column_lanes<S: Simd>(s: S, p: S::F32, o: f32, size: f32, columns: u32, upper: bool) -> S::I32 {
    let mut c = s.floor_f(s.div_f(s.sub_f(p, s.splat_f(o)), s.splat_f(size)));
    if upper {
        c = s.add_f(c, s.splat_f(1.0));
    }
    s.cvtt_f_i(s.min_f(s.max_f(c, s.splat_f(0.0)), s.splat_f(columns as f32)))
}

/// `|(x, y)|` lane-wise: `sqrt(x x + y y)`.
#[inline(always)]
fn length_lanes<S: Simd>(s: S, x: S::F32, y: S::F32) -> S::F32 {
    s.sqrt_f(s.add_f(s.mul_f(x, x), s.mul_f(y, y)))
}

/// Distance from point `p` to the rectangle `[lo, hi]` (0 inside), lane-wise.
#[inline(always)]
fn point_rect_lanes<S: Simd>(s: S, p: [S::F32; 2], lo: [S::F32; 2], hi: [S::F32; 2]) -> S::F32 {
    let zero = s.splat_f(0.0);
    let x = s.max_f(s.max_f(s.sub_f(lo[0], p[0]), s.sub_f(p[0], hi[0])), zero);
    let y = s.max_f(s.max_f(s.sub_f(lo[1], p[1]), s.sub_f(p[1], hi[1])), zero);
    length_lanes(s, x, y)
}

/// Distance from point `p` to segment `a, a + d` (`len2 = |d|^2`; `has_length` where it is > 0),
/// lane-wise.
#[inline(always)]
fn point_segment_lanes<S: Simd>(
    s: S,
    p: [S::F32; 2],
    a: [S::F32; 2],
    d: [S::F32; 2],
    len2: S::F32,
    has_length: Mask16,
) -> S::F32 {
    let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
    let (px, py) = (s.sub_f(p[0], a[0]), s.sub_f(p[1], a[1]));
    let t = s.div_f(s.add_f(s.mul_f(px, d[0]), s.mul_f(py, d[1])), len2);
    let t = s.select_f(has_length, s.clamp_f(t, zero, one), zero);
    let x = s.sub_f(s.add_f(a[0], s.mul_f(d[0], t)), p[0]);
    let y = s.sub_f(s.add_f(a[1], s.mul_f(d[1], t)), p[1]);
    length_lanes(s, x, y)
}

/// [`segment_rect_distance`] on 16 lanes: the distance from segment `a b` to the rectangle
/// `[lo, hi]` (0 where they touch), each lane with the scalar function's operations in its order,
/// branches as selects, so each lane equals the scalar result (NaN lanes aside). Helpers are
/// functions, not closures: a closure is compiled without the kernel's target features, and its
/// vector operations would become calls.
#[inline(always)]
pub fn segment_rect_distance_lanes<S: Simd>(
    s: S,
    a: [S::F32; 2],
    b: [S::F32; 2],
    lo: [S::F32; 2],
    hi: [S::F32; 2],
) -> S::F32 {
    let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
    let d = [s.sub_f(b[0], a[0]), s.sub_f(b[1], a[1])];
    let len2 = s.add_f(s.mul_f(d[0], d[0]), s.mul_f(d[1], d[1]));
    let has_length = s.cmp_lt_f(zero, len2);
    // Liang–Barsky: does the segment cross the rectangle? (`min_f(r, t)` keeps `t` where `r` is
    // NaN, as the scalar `t.min(r)` does.)
    let (mut t0, mut t1) = (zero, one);
    let mut crosses = s.mask_full();
    for (p, q) in [
        (s.neg_f(d[0]), s.sub_f(a[0], lo[0])),
        (d[0], s.sub_f(hi[0], a[0])),
        (s.neg_f(d[1]), s.sub_f(a[1], lo[1])),
        (d[1], s.sub_f(hi[1], a[1])),
    ] {
        let flat = s.cmp_eq_f(p, zero);
        crosses = s.mask_andn(s.mask_and(flat, s.cmp_lt_f(q, zero)), crosses);
        let r = s.div_f(q, p);
        let negative = s.cmp_lt_f(p, zero);
        let entering = s.mask_andn(flat, negative);
        let leaving = s.mask_andn(flat, s.mask_not(negative));
        t0 = s.select_f(entering, s.max_f(r, t0), t0);
        t1 = s.select_f(leaving, s.min_f(r, t1), t1);
    }
    let touches = s.mask_and(crosses, s.cmp_le_f(t0, t1));
    let mut best = s.min_f(point_rect_lanes(s, b, lo, hi), point_rect_lanes(s, a, lo, hi));
    for c in [lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]] {
        best = s.min_f(point_segment_lanes(s, c, a, d, len2, has_length), best);
    }
    s.select_f(touches, zero, best)
}

/// Per sample of `part` (part-local), the light radius the per-sample wedge test scales by: the
/// face-wide `r'` ([`SismLight::wedge_radius`]) or, when smaller, the sample's own bound
/// `r |q| / (z - r)` (with slack). For a sample at `q` (relative to the light centre, depth `z` along
/// the face axis), a light point `L` of its disk (`|L| <= r`, `L ⊥ q`) moves the line of sight's
/// image position at depth `z_e` by `(L_⊥ - u z_L) · z / (z - z_L) · (1/z_e - 1/z)`; the first factor is
/// at most `r / cos β = r |q| / z` (an oblique projection along `q` of a vector perpendicular to it),
/// the second at most `z / (z - r)`. Near the face's edges the two bounds agree; nearer its axis the
/// sample's own is up to `1 / cos α` (the face's widening) smaller, and the wedge's area with it.
/// Only samples whose edge term is exactly zero are dropped, so images are unchanged.
#[inline(always)]
pub fn sample_wedge_radii<S: Simd>(s: S, grid: &Grid, part: &BinPart, light: &SismLight) -> Vec<f32> {
    let face = grid.bins[part.bin].face as usize;
    let rv = s.splat_f(light.wedge_radius(sism_simd::Portable, face));
    let r = s.splat_f(light.radius);
    let slack = s.splat_f(1.0 + WEDGE_SLACK);
    let smp = &grid.samples;
    let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
    let range = part.samples.clone();
    let mut out = vec![0f32; range.len()];
    let mut i = range.start;
    while i < range.end {
        let m = s.mask_first_n(range.end - i);
        let x = s.mask_load_f(zero, m, &smp.x[i..]);
        let y = s.mask_load_f(zero, m, &smp.y[i..]);
        let z = s.mask_load_f(zero, m, &smp.z[i..]);
        let depth = s.mask_load_f(one, m, &smp.depth[i..]);
        let dist = s.sqrt_f(s.fmadd(z, z, s.fmadd(y, y, s.mul_f(x, x))));
        // Within `2r` of the light's depth the sample's bound is no better than the face's: keep r'.
        let gap = s.sub_f(depth, r);
        let own = s.mul_f(s.div_f(s.mul_f(r, dist), gap), slack);
        let usable = s.cmp_gt_f(gap, r);
        let radius = s.select_f(usable, s.min_f(own, rv), rv);
        s.mask_store_f(&mut out[i - range.start..], m, radius);
        i += 16;
    }
    out
}

/// A projected edge's parameters for the per-sample wedge test, in every lane: endpoint `a`,
/// direction `ab`, `1 / |ab|^2` and `1 / z` of the edge's nearest point.
#[derive(Clone, Copy)]
pub struct WedgeEdge<S: Simd> {
    /// `a.x` of the projected (clipped) edge.
    pub a_x: S::F32,
    /// `a.y` of the projected edge.
    pub a_y: S::F32,
    /// `ab.x` of the projected edge.
    pub ab_x: S::F32,
    /// `ab.y` of the projected edge.
    pub ab_y: S::F32,
    /// `1 / |ab|^2` (0 for a point).
    pub inv_len2: S::F32,
    /// `1 / z` of the edge's nearest point.
    pub inv_near: S::F32,
}

/// Packs into `selected` (part-local indices, by compress-store) the part's samples inside prepared
/// quad `k`'s wedge: each row's span from [`PreparedQuads`] (rows the wedge misses and slices nearer
/// than where it enters the row are already left out), scanned by [`select_span`]. Returns how many
/// were packed; adds the samples the test rejects into `culled`. `radii` are the part's
/// [`sample_wedge_radii`]; `reached` as [`select_span`] says.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn select_in_wedge<S: Simd>(
    s: S,
    part: &BinPart,
    grid: &Grid,
    q: &PreparedQuads,
    k: usize,
    radii: &[f32],
    selected: &mut [i32],
    culled: &mut u64,
    mut reached: Option<&mut [i32]>,
) -> usize {
    let edge = WedgeEdge::<S> {
        a_x: s.splat_f(s.s_load(&q.a_x, k)),
        a_y: s.splat_f(s.s_load(&q.a_y, k)),
        ab_x: s.splat_f(s.s_load(&q.ab_x, k)),
        ab_y: s.splat_f(s.s_load(&q.ab_y, k)),
        inv_len2: s.splat_f(s.s_load(&q.inv_len2, k)),
        inv_near: s.splat_f(s.s_load(&q.inv_near, k)),
    };
    let mut n = 0usize;
    for j in 0..q.rows {
        let start = s.s_load(&q.span_start, j * q.pad + k) as usize;
        let end = s.s_load(&q.span_end, j * q.pad + k) as usize;
        n = select_span(
            s,
            part,
            grid,
            &edge,
            start..end,
            radii,
            selected,
            n,
            culled,
            reached.as_deref_mut(),
        );
    }
    n
}

/// The per-sample wedge test over the sorted samples `span` of `part`: each sample's distance to the
/// projected edge against the wedge half-width at its depth (scaled by its radius in `radii`, the
/// part's [`sample_wedge_radii`]). Packs the part-local indices of those inside into `selected` from
/// position `n` (by compress-store) and returns the new count; adds the rejected samples into
/// `culled`. With `reached` (part-local, one per sample), adds 1 for each packed sample: statistics
/// only (the quads per sample), three vector operations a chunk, counted (a scalar pass over
/// `selected` was 6% of a penumbra; plain code the compiler vectorized went uncounted).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn select_span<S: Simd>(
    s: S,
    part: &BinPart,
    grid: &Grid,
    edge: &WedgeEdge<S>,
    span: std::ops::Range<usize>,
    radii: &[f32],
    selected: &mut [i32],
    mut n: usize,
    culled: &mut u64,
    mut reached: Option<&mut [i32]>,
) -> usize {
    let base = part.samples.start;
    let smp = &grid.samples;
    let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
    let lane = s.index_i();
    let (ax, ay, abx, aby) = (edge.a_x, edge.a_y, edge.ab_x, edge.ab_y);
    let (inv_len2, inv_near) = (edge.inv_len2, edge.inv_near);
    let (mut i, end) = (span.start, span.end);
    while s.s_lt(i, end) {
        let m = s.mask_first_n(end - i);
        let u = s.mask_load_f(zero, m, &smp.u[i..]);
        let v = s.mask_load_f(zero, m, &smp.v[i..]);
        let depth = s.mask_load_f(one, m, &smp.depth[i..]);
        // Distance from the sample's image position to the projected edge, against the wedge
        // half-width at the sample's depth.
        let px = s.sub_f(u, ax);
        let py = s.sub_f(v, ay);
        let t = s.clamp_f(s.mul_f(s.fmadd(py, aby, s.mul_f(px, abx)), inv_len2), zero, one);
        let dx = s.fnmadd(t, abx, px);
        let dy = s.fnmadd(t, aby, py);
        let d2 = s.fmadd(dy, dy, s.mul_f(dx, dx));
        let rv = s.mask_load_f(zero, m, &radii[i - base..]);
        let w = s.mul_f(rv, s.sub_f(inv_near, s.rcp_f(depth)));
        let inside = s.mask_and(m, s.mask_and(s.cmp_gt_f(w, zero), s.cmp_le_f(d2, s.mul_f(w, w))));
        let local = s.add_i(lane, s.splat_i((i - base) as i32));
        n += s.compress_store_i(&mut selected[n..], inside, local);
        if let Some(r) = reached.as_deref_mut() {
            // Statistics, counted as the vector work they are (a load, a masked add, a store).
            let at = i - base;
            let c = s.mask_load_i(s.splat_i(0), m, &r[at..]);
            s.mask_store_i(&mut r[at..], m, s.mask_add_i(c, inside, c, s.splat_i(1)));
        }
        *culled += (s.mask_popcnt(m) - s.mask_popcnt(inside)) as u64;
        i += 16;
    }
    n
}

/// The per-quad wedge selection over one bin part: the part's quads are prepared 16 at a time
/// ([`PreparedQuads`]) and the samples inside each one's wedge packed into [`WedgeScan::selected`]
/// ([`select_in_wedge`]); the compositions do their per-quad work on those samples.
pub struct WedgeScan<'a> {
    grid: &'a Grid,
    part: &'a BinPart,
    radii: Vec<f32>,
    quads: PreparedQuads,
    /// Part-local indices of the samples inside the last quad's wedge, packed by compress-store so
    /// the costly per-sample kernels run on full vectors (Larrabee's binning idiom); 16 lanes of
    /// slack past the part's samples.
    pub selected: Vec<i32>,
    /// Samples rejected by the per-sample wedge test over the quads so far.
    pub culled: u64,
    /// Samples selected over the quads so far.
    pub evaluated: u64,
    /// With statistics, the quads that selected each part-local sample.
    pub reached: Option<Vec<i32>>,
}

impl<'a> WedgeScan<'a> {
    /// Computes the part's [`sample_wedge_radii`] and prepares its quads `quads[0]`,
    /// `quads[stride]`, ... (indices into `edges`; see [`PreparedQuads::new`]); `reached` keeps the
    /// quads-per-sample statistics.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn new<S: Simd>(
        s: S,
        grid: &'a Grid,
        part: &'a BinPart,
        light: &'a SismLight,
        edges: &[EdgeRecord],
        quads: &[u32],
        stride: usize,
        reached: bool,
    ) -> WedgeScan<'a> {
        let n = part.samples.len();
        let selected = vec![0i32; n + 16];
        let radii = sample_wedge_radii(s, grid, part, light);
        let quads = PreparedQuads::new(s, grid, part, light, edges, quads, stride);
        WedgeScan {
            grid,
            part,
            radii,
            quads,
            selected,
            culled: 0,
            evaluated: 0,
            reached: reached.then(|| vec![0i32; n]),
        }
    }

    /// Quads prepared.
    pub fn len(&self) -> usize {
        self.quads.len()
    }

    /// True when no quad was prepared.
    pub fn is_empty(&self) -> bool {
        self.quads.is_empty()
    }

    /// Packs the samples inside prepared quad `k`'s wedge into `selected` and returns how many;
    /// `None` when the quad misses the part.
    #[inline(always)]
    pub fn select<S: Simd>(&mut self, s: S, k: usize) -> Option<usize> {
        if !s.s_branch(s.s_load(&self.quads.valid, k) != 0) {
            return None;
        }
        let n = select_in_wedge(
            s,
            self.part,
            self.grid,
            &self.quads,
            k,
            &self.radii,
            &mut self.selected,
            &mut self.culled,
            self.reached.as_deref_mut(),
        );
        self.evaluated += n as u64;
        Some(n)
    }

    /// The part's samples inside prepared quad `k`'s wedge (part-local indices), `None` when the
    /// quad misses the part. Callers loop over their quads themselves: a closure per quad would be
    /// compiled without the kernel's target features, and the vector operations inside it would
    /// become calls (measured: `sism-sampled`'s light points 7× slower on AVX-512).
    #[inline(always)]
    pub fn quad<S: Simd>(&mut self, s: S, k: usize) -> Option<&[i32]> {
        let n = self.select(s, k)?;
        Some(&self.selected[..n])
    }

    /// A penumbra task's output ([`run_parts`]): `[rows culled, samples culled, samples evaluated,
    /// 0]` and the quads per part-local sample.
    pub fn output(self) -> (BinCounts, Vec<i32>) {
        (
            [
                self.quads.culled_rows,
                self.quads.culled_samples + self.culled,
                self.evaluated,
                0,
                0,
                0,
                0,
            ],
            self.reached.unwrap_or_default(),
        )
    }
}

/// Eq. 3 on packed samples: gathers the positions of `selected` (bin-local indices into `xs`, `ys`,
/// `zs`), evaluates edge `e`'s signed term, and adds it into `out` at the same indices.
#[inline(always)]
pub fn add_edge_terms<S: Simd>(
    s: S,
    selected: &[i32],
    (xs, ys, zs): (&[f32], &[f32], &[f32]),
    e: &EdgeRecord,
    light_radius: f32,
    out: &mut [f32],
) {
    let zero = s.splat_f(0.0);
    let n = selected.len();
    let mut k = 0;
    // The loop's test is a counted branch: its trip count (the quad's selected samples / 16)
    // changes from quad to quad, and the host mispredicts its exit.
    while s.s_lt(k, n) {
        let m = s.mask_first_n(n - k);
        let idx = s.mask_load_i(s.splat_i(0), m, &selected[k..]);
        let x = s.mask_gather_f(zero, m, xs, idx);
        let y = s.mask_gather_f(zero, m, ys, idx);
        let z = s.mask_gather_f(zero, m, zs, idx);
        let term = edge_term(s, m, x, y, z, e, light_radius);
        let acc = s.mask_gather_f(zero, m, out, idx);
        s.mask_scatter_f(out, m, idx, s.add_f(acc, term));
        k += 16;
    }
}

/// One penumbra task: rows `rows` (face column rows) of bin `bin`, whose samples are the contiguous
/// range `samples` of the sorted arrays. Kernels index the part's samples part-locally.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BinPart {
    /// Index of the bin in [`Grid::bins`].
    pub bin: usize,
    /// The face column rows it covers, `[start, end)`.
    pub rows: std::ops::Range<u32>,
    /// Its samples: a contiguous range of the sorted arrays.
    pub samples: std::ops::Range<usize>,
}

impl BinPart {
    /// The whole of bin `bin`.
    pub fn whole(grid: &Grid, bin: usize) -> BinPart {
        let bn = &grid.bins[bin];
        let rows = bin_rows(grid, bin);
        BinPart {
            bin,
            rows,
            samples: bn.samples.start as usize..bn.samples.end as usize,
        }
    }

    /// The part's sample positions (relative to the light centre), indexed part-locally.
    #[inline]
    pub fn positions<'g>(&self, grid: &'g Grid) -> (&'g [f32], &'g [f32], &'g [f32]) {
        let r = self.samples.clone();
        (
            &grid.samples.x[r.clone()],
            &grid.samples.y[r.clone()],
            &grid.samples.z[r],
        )
    }
}

/// Face column rows covered by bin `bin`.
fn bin_rows(grid: &Grid, bin: usize) -> std::ops::Range<u32> {
    let bn = &grid.bins[bin];
    let g = &grid.faces[bn.face as usize];
    bn.column0.y..(bn.column0.y + grid.params.bin_columns).min(g.columns.y)
}

/// A bin whose estimated penumbra work (quads × samples) exceeds this is split into one task per row
/// of columns: on a many-core chip one heavy bin (under a dense crown of leaves) would otherwise
/// outlast every other core's share of the phase. Below it, splitting would only repeat the per-quad
/// setup in each row.
pub const SPLIT_WORK: u64 = 1 << 20;

/// The penumbra tasks of the bins that have quads, in sorted-sample order.
pub fn bin_parts(grid: &Grid, lists: &BinLists) -> Vec<BinPart> {
    let mut parts = Vec::new();
    for bin in 0..grid.bins.len() {
        let whole = BinPart::whole(grid, bin);
        let quads = lists.of(bin).len() as u64;
        if quads == 0 || whole.samples.is_empty() {
            continue;
        }
        if quads * whole.samples.len() as u64 <= SPLIT_WORK {
            parts.push(whole);
            continue;
        }
        let bn = &grid.bins[bin];
        let g = &grid.faces[bn.face as usize];
        let (c0, c1) = (
            bn.column0.x,
            (bn.column0.x + grid.params.bin_columns).min(g.columns.x),
        );
        for row in whole.rows.clone() {
            let (start, end) = grid.row_span(
                sism_simd::Portable,
                bin,
                UVec2::new(c0, row),
                UVec2::new(c1, row + 1),
                row,
                0,
            );
            if start < end {
                parts.push(BinPart {
                    bin,
                    rows: row..row + 1,
                    samples: start..end,
                });
            }
        }
    }
    parts
}

impl Kernel for PenumbraBin<'_> {
    /// `[rows culled, samples culled, samples evaluated]` and the quads evaluated per bin-local sample.
    type Output = (BinCounts, Vec<i32>);
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> (BinCounts, Vec<i32>) {
        s.begin_task(task_kind::PENUMBRA_BIN);
        let positions = self.part.positions(self.grid);
        let mut wedge = WedgeScan::new(
            s, self.grid, self.part, self.light, self.edges, self.quads, 1, true,
        );
        for (k, &e) in self.quads.iter().enumerate() {
            let edge = &self.edges[e as usize];
            if let Some(selected) = wedge.quad(s, k) {
                add_edge_terms(s, selected, positions, edge, self.light.radius, self.out);
            }
        }
        s.end_task();
        wedge.output()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_rect_distance_cases() {
        let (lo, hi) = (Vec2::ZERO, Vec2::ONE);
        assert_eq!(
            segment_rect_distance(
                sism_simd::Portable,
                Vec2::new(-1.0, 0.5),
                Vec2::new(2.0, 0.5),
                lo,
                hi
            ),
            0.0
        );
        assert!(
            (segment_rect_distance(
                sism_simd::Portable,
                Vec2::new(2.0, -1.0),
                Vec2::new(2.0, 3.0),
                lo,
                hi
            ) - 1.0)
                .abs()
                < 1e-6
        );
        assert!(
            (segment_rect_distance(
                sism_simd::Portable,
                Vec2::new(3.0, 3.0),
                Vec2::new(4.0, 4.0),
                lo,
                hi
            ) - 8f32.sqrt())
            .abs()
                < 1e-5
        );
        assert_eq!(
            segment_rect_distance(
                sism_simd::Portable,
                Vec2::new(0.5, 0.5),
                Vec2::new(0.6, 0.6),
                lo,
                hi
            ),
            0.0
        );
    }

    // The per-quad setup as it was written before it ran 16 quads a vector: the oracle the
    // prepared quads must equal, sample for sample.
    /// A penumbra quad prepared for the samples of one bin.
    #[derive(Clone, Copy, Debug)]
    struct QuadInBin {
        /// Columns of the bin it may reach, `[c0, c1)`.
        c0: UVec2,
        /// End (exclusive) of the columns of the bin it may reach.
        c1: UVec2,
        /// Projected (clipped) edge: endpoint `a`, direction `ab`, `1 / |ab|^2` (0 for a point).
        a: Vec2,
        /// The projected (clipped) edge's other endpoint.
        b: Vec2,
        /// `1 / |ab|^2` (0 for a point).
        inv_len2: f32,
        /// `1 / z` of the edge's nearest point.
        inv_near: f32,
        /// Widened light radius `r'`, with a hair of slack for f32 rounding.
        r: f32,
    }

    /// Prepares edge `e`'s quad for bin `bin`; `None` when it misses.
    ///
    /// Its operations are counted by `s`.
    #[inline(always)]
    fn quad_in_bin<S: Simd>(
        s: S,
        grid: &Grid,
        bin: usize,
        e: &EdgeRecord,
        light: &SismLight,
    ) -> Option<QuadInBin> {
        let bn = &grid.bins[bin];
        let face = s.s_read(&bn.face) as usize;
        let g = &grid.faces[face];
        let qg = quad_geometry(s, g, e)?;
        let r = light.wedge_radius(s, face);
        let inv_near = s.s_div(1.0, qg.z_near);
        let w_bin = s.s_mul(r, s.s_sub(inv_near, s.s_div(1.0, s.s_read(&bn.z_max))));
        let w2 = Vec2::splat(w_bin);
        let (c0, c1) = g.column_range(
            s,
            v2::sub(s, v2::min(s, qg.a, qg.b), w2),
            v2::add(s, v2::max(s, qg.a, qg.b), w2),
        );
        let column0 = s.s_read(&bn.column0);
        let bin_c1 = UVec2::new(
            s.s_min(s.s_add(column0.x, grid.params.bin_columns), g.columns.x),
            s.s_min(s.s_add(column0.y, grid.params.bin_columns), g.columns.y),
        );
        let c0 = UVec2::new(s.s_max(c0.x, column0.x), s.s_max(c0.y, column0.y));
        let c1 = UVec2::new(s.s_min(c1.x, bin_c1.x), s.s_min(c1.y, bin_c1.y));
        let ab = v2::sub(s, qg.b, qg.a);
        if !(s.s_lt(c0.x, c1.x) && s.s_lt(c0.y, c1.y)) {
            return None;
        }
        let len2 = v2::dot(s, ab, ab);
        Some(QuadInBin {
            c0,
            c1,
            a: qg.a,
            b: qg.b,
            inv_len2: if s.s_lt(0.0, len2) {
                s.s_div(1.0, len2)
            } else {
                0.0
            },
            inv_near,
            r,
        })
    }

    /// The part's samples inside quad `q`'s wedge, packed into `selected` (part-local); returns how
    /// many. The scalar setup per row (rows the wedge misses skipped, then slices nearer than where
    /// it enters the row), each row's span then scanned by the kernel's own [`select_span`]: what
    /// the oracle checks is the setup.
    fn select_in_wedge_scalar<S: Simd>(
        s: S,
        grid: &Grid,
        part: &BinPart,
        q: &QuadInBin,
        radii: &[f32],
        selected: &mut [i32],
    ) -> usize {
        let bin = part.bin;
        let bn = &grid.bins[bin];
        let g = &grid.faces[bn.face as usize];
        let ab = q.b - q.a;
        let edge = WedgeEdge::<S> {
            a_x: s.splat_f(q.a.x),
            a_y: s.splat_f(q.a.y),
            ab_x: s.splat_f(ab.x),
            ab_y: s.splat_f(ab.y),
            inv_len2: s.splat_f(q.inv_len2),
            inv_near: s.splat_f(q.inv_near),
        };
        let mut n = 0usize;
        let mut culled = 0u64;
        for row in q.c0.y.max(part.rows.start)..q.c1.y.min(part.rows.end) {
            // `uv_min + column.as_vec2() * cell_size` for the row's two corners.
            let corner = |x: u32, y: u32| {
                Vec2::new(
                    g.uv_min.x + x as f32 * g.cell_size.x,
                    g.uv_min.y + y as f32 * g.cell_size.y,
                )
            };
            let d = segment_rect_distance(s, q.a, q.b, corner(q.c0.x, row), corner(q.c1.x, row + 1));
            let (_, end) = grid.row_span(s, bin, q.c0, q.c1, row, 0);
            let inv_enter = q.inv_near - d / q.r;
            if inv_enter <= 1.0 / bn.z_max {
                continue;
            }
            let slice = g.slice_of(s, 1.0 / inv_enter, grid.params.slices);
            let (start, _) = grid.row_span(s, bin, q.c0, q.c1, row, slice);
            n = select_span(
                s,
                part,
                grid,
                &edge,
                start..end,
                radii,
                selected,
                n,
                &mut culled,
                None,
            );
        }
        n
    }

    /// Random receivers around a light at the origin, binned on the six cube faces, and random edges
    /// between (some crossing a face's near plane, some behind it): every prepared quad selects
    /// exactly the samples the scalar setup did, for whole bins and single-row parts, with strides.
    #[test]
    fn prepared_quads_select_what_the_scalar_setup_selected() {
        use super::super::grid::{build, GridParams, SampleIn};
        use super::super::light_view::{cube_face_of, cube_faces};
        use crate::exec::{Exec, FrameLog};
        let mut rng = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move |lo: f32, hi: f32| {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            lo + (hi - lo) * ((rng >> 40) as f32 / (1u64 << 24) as f32)
        };
        let faces = cube_faces();
        let mut samples = Vec::new();
        for i in 0..6000u32 {
            let q = Vec3::new(uniform(-8.0, 8.0), uniform(-9.0, -1.5), uniform(-8.0, 8.0));
            let face = cube_face_of(q);
            let (uv, depth) = faces[face].project(q);
            samples.push(SampleIn {
                q,
                face: face as u32,
                uv,
                depth,
                pixel: i,
                cos_theta: 1.0,
            });
        }
        samples.sort_by_key(|s| s.face); // grid::build takes them grouped by face
        let mut edges = Vec::new();
        for _ in 0..400 {
            let mut p = || [uniform(-4.0, 4.0), uniform(-2.5, 0.3), uniform(-4.0, 4.0)];
            let (a, b, c) = (p(), p(), p());
            edges.push(EdgeRecord::single(a, b, c));
        }
        let quads: Vec<u32> = (0..edges.len() as u32).collect();
        let light = SismLight {
            center: Vec3::ZERO,
            radius: 0.4,
            widen: vec![1.3; 6],
        };
        for params in [
            GridParams::default(),
            GridParams {
                slices: 23,
                bin_columns: 3,
                samples_per_column: 2.0,
            },
        ] {
            let mut log = FrameLog::new(Exec::Native);
            let grid = log.phase("grid", "", |p| build(p, &faces, &samples, &params));
            let s = sism_simd::Portable;
            let (mut compared, mut selected_total) = (0, 0);
            for bin in 0..grid.bins.len() {
                let whole = BinPart::whole(&grid, bin);
                if whole.samples.is_empty() {
                    continue;
                }
                let mut parts = vec![whole.clone()];
                for row in whole.rows.clone() {
                    parts.push(BinPart {
                        bin,
                        rows: row..row + 1,
                        samples: whole.samples.clone(),
                    });
                }
                for part in &parts {
                    for stride in [1, 3] {
                        let mut wedge = WedgeScan::new(s, &grid, part, &light, &edges, &quads, stride, false);
                        for k in 0..wedge.len() {
                            let e = &edges[quads[k * stride] as usize];
                            let mut sel = vec![0i32; part.samples.len() + 16];
                            let want = quad_in_bin(s, &grid, bin, e, &light).map(|q| {
                                let n = select_in_wedge_scalar(s, &grid, part, &q, &wedge.radii, &mut sel);
                                sel[..n].to_vec()
                            });
                            let got = wedge.quad(s, k).map(|v| v.to_vec());
                            assert_eq!(got, want, "bin {bin} rows {:?} quad {k}", part.rows);
                            compared += 1;
                            selected_total += want.map_or(0, |v| v.len());
                        }
                    }
                }
            }
            assert!(
                compared > 1000 && selected_total > 1000,
                "{compared} quads, {selected_total} samples"
            );
        }
    }
}
