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
use sism_simd::{Kernel, ScalarClass, Simd};

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
            s.scalar_op(ScalarClass::Alu); // the clamp's two bounds
            s.s_fn(ScalarClass::Alu, t, |t: f32| t.clamp(0.0, 1.0))
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

/// A penumbra quad prepared for the samples of one bin.
#[derive(Clone, Copy, Debug)]
pub struct QuadInBin {
    /// Columns of the bin it may reach, `[c0, c1)`.
    pub c0: UVec2,
    /// End (exclusive) of the columns of the bin it may reach.
    pub c1: UVec2,
    /// Projected (clipped) edge: endpoint `a`, direction `ab`, `1 / |ab|^2` (0 for a point).
    pub a: Vec2,
    /// The projected (clipped) edge's other endpoint.
    pub b: Vec2,
    /// `1 / |ab|^2` (0 for a point).
    pub inv_len2: f32,
    /// `1 / z` of the edge's nearest point.
    pub inv_near: f32,
    /// Widened light radius `r'`, with a hair of slack for f32 rounding.
    pub r: f32,
}

/// Prepares edge `e`'s quad for bin `bin`; `None` when it misses.
///
/// Its operations are counted by `s`.
#[inline(always)]
pub fn quad_in_bin<S: Simd>(
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

/// Packs into `selected` (part-local indices, by compress-store) the part's samples inside quad `q`'s
/// wedge: rows the wedge misses are skipped, then slices nearer than where it enters the row, then
/// each sample is tested exactly against the wedge half-width at its depth. Returns how many were
/// packed; adds `[rows culled, samples culled]` into `culled`. `radii` are the part's
/// [`sample_wedge_radii`]. With `reached` (part-local, one per
/// sample), adds 1 for each packed sample: statistics only (the quads per sample), three vector
/// operations a chunk, counted (a scalar pass over `selected` was 6% of a penumbra; plain code
/// the compiler vectorized, as it was until this stop, went uncounted).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn select_in_wedge<S: Simd>(
    s: S,
    grid: &Grid,
    part: &BinPart,
    q: &QuadInBin,
    radii: &[f32],
    selected: &mut [i32],
    culled: &mut [u64; 2],
    mut reached: Option<&mut [i32]>,
) -> usize {
    let bin = part.bin;
    let bn = &grid.bins[bin];
    let g = &grid.faces[bn.face as usize];
    let base = part.samples.start;
    let smp = &grid.samples;
    let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
    let ab = q.b - q.a;
    let (ax, ay, abx, aby) = (
        s.splat_f(q.a.x),
        s.splat_f(q.a.y),
        s.splat_f(ab.x),
        s.splat_f(ab.y),
    );
    let (inv_len2, inv_near) = (s.splat_f(q.inv_len2), s.splat_f(q.inv_near));
    let lane = s.index_i();
    let mut n = 0usize;
    for row in q.c0.y.max(part.rows.start)..q.c1.y.min(part.rows.end) {
        // Wedge test for the row (Section 2.5): where the wedge enters it in depth.
        // `uv_min + column.as_vec2() * cell_size` for the row's two corners.
        let corner = |x: u32, y: u32| {
            let f = |c: u32| s.s_fn(ScalarClass::Alu, c, |c| c as f32);
            Vec2::new(
                s.s_add(g.uv_min.x, s.s_mul(f(x), g.cell_size.x)),
                s.s_add(g.uv_min.y, s.s_mul(f(y), g.cell_size.y)),
            )
        };
        let lo = corner(q.c0.x, row);
        let hi = corner(q.c1.x, s.s_add(row, 1));
        let d = segment_rect_distance(s, q.a, q.b, lo, hi);
        let (first, end) = grid.row_span(s, bin, q.c0, q.c1, row, 0);
        let inv_enter = s.s_sub(q.inv_near, s.s_div(d, q.r));
        s.scalar_op(ScalarClass::Branch); // the rows loop
        if s.s_le(inv_enter, s.s_div(1.0, bn.z_max)) {
            culled[0] += 1;
            culled[1] += (end - first) as u64;
            continue;
        }
        let slice = g.slice_of(s, s.s_div(1.0, inv_enter), grid.params.slices);
        let (start, _) = grid.row_span(s, bin, q.c0, q.c1, row, slice);
        culled[1] += (start - first) as u64;
        let mut i = start;
        while i < end {
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
            culled[1] += (s.mask_popcnt(m) - s.mask_popcnt(inside)) as u64;
            i += 16;
        }
    }
    n
}

/// The per-quad wedge selection over one bin part: each quad is prepared for the part
/// ([`quad_in_bin`]) and the samples inside its wedge packed into [`WedgeScan::selected`]
/// ([`select_in_wedge`]); the compositions do their per-quad work on those samples.
pub struct WedgeScan<'a> {
    grid: &'a Grid,
    part: &'a BinPart,
    light: &'a SismLight,
    radii: Vec<f32>,
    /// Part-local indices of the samples inside the last quad's wedge, packed by compress-store so
    /// the costly per-sample kernels run on full vectors (Larrabee's binning idiom); 16 lanes of
    /// slack past the part's samples.
    pub selected: Vec<i32>,
    /// `[rows culled, samples culled]` over the quads so far.
    pub culled: [u64; 2],
    /// Samples selected over the quads so far.
    pub evaluated: u64,
    /// With statistics, the quads that selected each part-local sample.
    pub reached: Option<Vec<i32>>,
}

impl<'a> WedgeScan<'a> {
    /// Computes the part's [`sample_wedge_radii`]; `reached` keeps the quads-per-sample statistics.
    #[inline(always)]
    pub fn new<S: Simd>(
        s: S,
        grid: &'a Grid,
        part: &'a BinPart,
        light: &'a SismLight,
        reached: bool,
    ) -> WedgeScan<'a> {
        let n = part.samples.len();
        let selected = vec![0i32; n + 16];
        let radii = sample_wedge_radii(s, grid, part, light);
        WedgeScan {
            grid,
            part,
            light,
            radii,
            selected,
            culled: [0; 2],
            evaluated: 0,
            reached: reached.then(|| vec![0i32; n]),
        }
    }

    /// Packs the samples inside `edge`'s wedge into `selected` and returns how many; `None` when its
    /// quad misses the part.
    #[inline(always)]
    pub fn select<S: Simd>(&mut self, s: S, edge: &EdgeRecord) -> Option<usize> {
        let q = quad_in_bin(s, self.grid, self.part.bin, edge, self.light)?;
        let n = select_in_wedge(
            s,
            self.grid,
            self.part,
            &q,
            &self.radii,
            &mut self.selected,
            &mut self.culled,
            self.reached.as_deref_mut(),
        );
        self.evaluated += n as u64;
        Some(n)
    }

    /// The part's samples inside `edge`'s wedge (part-local indices), `None` when its quad misses
    /// the part. Callers loop over their quads themselves: a closure per quad would be compiled
    /// without the kernel's target features, and the vector operations inside it would become
    /// calls (measured: `sism-sampled`'s light points 7× slower on AVX-512).
    #[inline(always)]
    pub fn quad<S: Simd>(&mut self, s: S, edge: &EdgeRecord) -> Option<&[i32]> {
        let n = self.select(s, edge)?;
        Some(&self.selected[..n])
    }

    /// A penumbra task's output ([`run_parts`]): `[rows culled, samples culled, samples evaluated,
    /// 0]` and the quads per part-local sample.
    pub fn output(self) -> (BinCounts, Vec<i32>) {
        (
            [self.culled[0], self.culled[1], self.evaluated, 0, 0, 0, 0],
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
    while k < n {
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
        let mut wedge = WedgeScan::new(s, self.grid, self.part, self.light, true);
        for &e in self.quads {
            let edge = &self.edges[e as usize];
            if let Some(selected) = wedge.quad(s, edge) {
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
}
