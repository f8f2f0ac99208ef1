//! Umbra: the depth complexity between each sample and the light centre (hard irregular shadow mapping,
//! counting every crossing instead of stopping at the first).
//!
//! Front end: every counted triangle (see `silhouettes`) is projected into each light face, clipped to
//! the face's near plane, and binned by its conservative image-plane bounds into the bins whose samples
//! it can reach (bins entirely nearer than the triangle are skipped). Back end, bin by bin: for each of
//! the bin's triangles, the samples of the columns it covers, from the depth slice of the triangle's
//! nearest point onward, are tested 16 at a time: inside the cone from the light centre through the
//! triangle (three edge planes) and the triangle's plane crossed between light and sample.

use glam::{UVec2, Vec2, Vec3};
use rayon::prelude::*;
use sism_simd::{Kernel, Mask16, ScalarClass, Simd};

use super::binning::{bin_items, BinItems, BinLists};
use super::grid::Grid;
use super::light_view::LightFace;
use super::StageInputs;
use crate::counted;
use crate::exec::{task_kind, Phase};
use crate::scene::topology::SceneTopology;
use crate::stats::{percentiles, Dist};

/// Relative tolerance on the crossing parameter: a triangle crosses the segment light -> sample when
/// its plane is hit at `t < 1 - SELF_SHADOW_EPS` (t = 1 at the sample). It keeps a receiver from
/// shadowing itself through f32 rounding; at 5e-5 it is 0.05 mm per metre of light distance.
pub const SELF_SHADOW_EPS: f32 = 5e-5;

crate::declare_stats! {
    /// Counters of the umbra stage.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct UmbraStats {
        /// Triangles that count as occluders (all of open components, light-facing ones of closed ones).
        pub triangles_counted: u64 => ("umbra.triangles_counted", "triangles", "triangles that count as occluders"),
        /// Triangles of closed components facing away from the light: skipped.
        pub triangles_back_facing: u64 => ("umbra.triangles_back_facing", "triangles", "closed-mesh triangles facing away from the light: skipped"),
        /// (face, triangle) pairs dropped: entirely behind the light, behind every sample, or outside
        /// the face's image bounds.
        pub face_triangles_culled: u64 => ("umbra.face_triangles_culled", "pairs", "(face, triangle) pairs behind the light, behind all samples or off-image"),
        /// (bin, triangle) pairs after binning.
        pub triangles_binned: u64 => ("umbra.triangles_binned", "pairs", "(bin, triangle) pairs tested"),
        /// (bin, triangle) pairs skipped because every sample of the bin is nearer than the triangle.
        pub bin_pairs_culled_by_depth: u64 => ("umbra.bin_pairs_culled_by_depth", "pairs", "(bin, triangle) pairs skipped: every sample nearer than the triangle"),
        /// Point-in-triangle tests performed (sample lanes, active).
        pub samples_tested: u64 => ("umbra.samples_tested", "tests", "sample-triangle tests (active lanes)"),
        /// Depth complexity (umbra crossings) per sample; additive and light-point compositions only.
        pub depth_complexity: Dist => ("dist.depth_complexity", "crossings", "umbra depth complexity per sample (distribution; additive composition)"),
        /// Mean depth complexity per sample.
        pub depth_complexity_mean: f64 => ("dist.depth_complexity.mean", "crossings", "mean umbra depth complexity per sample (additive composition)"),
    }
}

impl UmbraStats {
    /// Sets the depth-complexity distribution from every sample's count.
    pub fn set_depth_complexity(&mut self, depth: &[i32]) {
        self.depth_complexity = percentiles(depth.iter().map(|&d| d as u64));
        self.depth_complexity_mean = depth.iter().map(|&d| d as f64).sum::<f64>() / depth.len().max(1) as f64;
    }
}

/// Counters of triangle binning, per task.
#[derive(Clone, Copy, Debug, Default)]
pub struct TriangleBinCounts {
    counted: u64,
    back_facing: u64,
    face_culled: u64,
    depth_culled: u64,
}

impl std::ops::AddAssign for TriangleBinCounts {
    fn add_assign(&mut self, o: Self) {
        self.counted += o.counted;
        self.back_facing += o.back_facing;
        self.face_culled += o.face_culled;
        self.depth_culled += o.depth_culled;
    }
}

/// Image-plane bounds and nearest depth of the polygon `pts` (face coordinates) clipped to `z >= near`;
/// `None` when nothing is in front. Every operation is counted by `s` (natively the plain arithmetic,
/// glam's operation order).
#[inline(always)]
pub fn clipped_bounds<S: Simd>(s: S, pts: &[Vec3], near: f32) -> Option<(Vec2, Vec2, f32)> {
    let mut lo = Vec2::splat(f32::INFINITY);
    let mut hi = Vec2::splat(f32::NEG_INFINITY);
    let mut z_min = f32::INFINITY;
    let mut any = false;
    let mut add = |p: Vec3| {
        let uv = Vec2::new(s.s_div(p.x, p.z), s.s_div(p.y, p.z));
        lo = counted::v2::min(s, lo, uv);
        hi = counted::v2::max(s, hi, uv);
        z_min = s.s_min(z_min, p.z);
        any = true;
    };
    let n = pts.len();
    for i in 0..n {
        let (p, q) = (pts[i], pts[(i + 1) % n]);
        let (p_in, q_in) = (s.s_le(near, p.z), s.s_le(near, q.z));
        if p_in {
            add(p);
        }
        // Where the edge crosses the near plane, its crossing point bounds the clipped polygon.
        if s.s_branch(p_in != q_in) {
            let t = s.s_div(s.s_sub(near, p.z), s.s_sub(q.z, p.z));
            let mut x = counted::add(s, p, counted::scale(s, counted::sub(s, q, p), t));
            x.z = near;
            add(x);
        }
    }
    // Four finiteness tests and their branch.
    for _ in 0..4 {
        s.scalar_op(ScalarClass::Alu);
    }
    s.s_branch(any && lo.is_finite() && hi.is_finite())
        .then_some((lo, hi, z_min))
}

/// Triangle binning: every counted triangle into the bins whose samples it may cover (bins entirely
/// nearer than the triangle are skipped).
struct TriangleBinner<'a> {
    topo: &'a SceneTopology,
    light_center: Vec3,
    grid: &'a Grid,
}

impl BinItems for TriangleBinner<'_> {
    type Counts = TriangleBinCounts;
    #[inline(always)]
    fn emit<S: Simd>(&self, s: S, t: u32, out: &mut Vec<(u32, u32)>, counts: &mut TriangleBinCounts) {
        let grid = self.grid;
        let b = grid.params.bin_columns;
        if !self.topo.counts_counted(s, t as usize, self.light_center) {
            counts.back_facing += 1;
            return;
        }
        counts.counted += 1;
        let q = s
            .s_read_words(&self.topo.triangles[t as usize])
            .map(|v| counted::sub(s, v, self.light_center));
        for g in &grid.faces {
            if !s.s_lt(0, s.s_read(&g.samples)) {
                continue;
            }
            let Some((lo, hi, z_near)) = face_bounds(s, &g.face, &q, g.near_plane(s)) else {
                counts.face_culled += 1;
                continue;
            };
            let (c0, c1) = g.column_range(s, lo, hi);
            if s.s_le(g.z_max, z_near) || s.s_le(c1.x, c0.x) || s.s_le(c1.y, c0.y) {
                counts.face_culled += 1;
                continue;
            }
            for bin in g.bins_of_columns(b, c0, c1) {
                let bn = &grid.bins[bin];
                s.scalar_op(ScalarClass::Branch); // the bins loop
                                                  // The bin's sample range and depth bound: one line.
                let (start, end) = (s.s_read(&bn.samples.start), s.s_read(&bn.samples.end));
                if s.s_le(end, start) {
                    continue;
                }
                if s.s_le(s.s_read(&bn.z_max), z_near) {
                    counts.depth_culled += 1;
                    continue;
                }
                s.s_push(out, (bin as u32, t));
            }
        }
    }
}

/// Bins every counted triangle into the bins whose samples it may cover (steps `bin` and `lists`).
pub fn bin_triangles(phase: &mut Phase, inputs: &StageInputs<'_>, stats: &mut UmbraStats) -> BinLists {
    let binner = TriangleBinner {
        topo: inputs.topo,
        light_center: inputs.light.center,
        grid: inputs.grid,
    };
    let (lists, c) = bin_items(
        phase,
        &binner,
        inputs.grid.bins.len(),
        inputs.topo.triangles.len(),
    );
    stats.triangles_counted += c.counted;
    stats.triangles_back_facing += c.back_facing;
    stats.face_triangles_culled += c.face_culled;
    stats.bin_pairs_culled_by_depth += c.depth_culled;
    stats.triangles_binned += lists.pairs() as u64;
    lists
}

/// Image-plane bounds and nearest depth of triangle `q` (relative to the light) in `face`, counted
/// by `s`.
#[inline(always)]
fn face_bounds<S: Simd>(s: S, face: &LightFace, q: &[Vec3; 3], near: f32) -> Option<(Vec2, Vec2, f32)> {
    clipped_bounds(s, &q.map(|p| face.to_face_counted(s, p)), near)
}

/// Depth complexity of every sample (sorted order), one task per bin with triangles (step `depth`).
pub fn depth_complexity(
    phase: &mut Phase,
    inputs: &StageInputs<'_>,
    lists: &BinLists,
    stats: &mut UmbraStats,
) -> Vec<i32> {
    let grid = inputs.grid;
    let mut counts = vec![0i32; grid.samples.pixel.len()];
    let tested = phase.run_par(
        "depth",
        grid.split_by_bins(&mut counts)
            .into_par_iter()
            .enumerate()
            .filter(|(bin, _)| !lists.of(*bin).is_empty())
            .map(|(bin, out)| UmbraBin {
                topo: inputs.topo,
                light_center: inputs.light.center,
                grid,
                bin,
                triangles: lists.of(bin),
                out,
            }),
    );
    stats.samples_tested += tested.iter().sum::<u64>();
    counts
}

/// The per-bin umbra task.
pub struct UmbraBin<'a> {
    /// The scene's topology, whose triangles `triangles` indexes.
    pub topo: &'a SceneTopology,
    /// Light centre, world units: triangles are tested relative to it.
    pub light_center: Vec3,
    /// The grid.
    pub grid: &'a Grid,
    /// Index of the bin in [`Grid::bins`].
    pub bin: usize,
    /// The bin's counted triangles: indices into the topology's triangles.
    pub triangles: &'a [u32],
    /// Depth complexity of the bin's samples (bin-local indices).
    pub out: &'a mut [i32],
}

/// A triangle prepared for testing the samples of one bin.
#[derive(Clone, Copy, Debug)]
pub struct TriangleInBin {
    /// Columns of the bin it may cover, `[c0, c1)`.
    pub c0: UVec2,
    /// End (exclusive) of the columns of the bin it may cover.
    pub c1: UVec2,
    /// First depth slice that can lie behind it.
    pub first_slice: u32,
    /// Edge-plane normals of the cone from the light centre through the triangle.
    pub edge_planes: [Vec3; 3],
    /// Plane `n · x = k` of the triangle (relative to the light centre); `k != 0`.
    pub n: Vec3,
    /// Offset `k` of the plane `n · x = k` (nonzero).
    pub k: f32,
}

/// Prepares triangle `q` (corners relative to the light centre) for bin `bin`; `None` when it
/// covers none of the bin's columns or is edge-on from the light. Counted by `s`: the bin's and
/// face's records, the projection and clip, the column range, the plane and the three edge planes.
#[inline(always)]
pub fn triangle_in_bin<S: Simd>(s: S, grid: &Grid, bin: usize, q: &[Vec3; 3]) -> Option<TriangleInBin> {
    let b = &grid.bins[bin];
    let g = &grid.faces[s.s_read(&b.face) as usize];
    let column0 = s.s_read(&b.column0);
    let (lo, hi, z_near) = face_bounds(s, &g.face, q, g.near_plane(s))?;
    let (c0, c1) = g.column_range(s, lo, hi);
    let bc = grid.params.bin_columns;
    let bin_c1 = UVec2::new(
        s.s_min(s.s_add(column0.x, bc), g.columns.x),
        s.s_min(s.s_add(column0.y, bc), g.columns.y),
    );
    let c0 = UVec2::new(s.s_max(c0.x, column0.x), s.s_max(c0.y, column0.y));
    let c1 = UVec2::new(s.s_min(c1.x, bin_c1.x), s.s_min(c1.y, bin_c1.y));
    let n = counted::cross(s, counted::sub(s, q[1], q[0]), counted::sub(s, q[2], q[0]));
    let k = counted::dot(s, n, q[0]);
    // k = 0: the plane passes through the light centre; edge-on, it covers nothing.
    let keep = s.s_lt(c0.x, c1.x) && s.s_lt(c0.y, c1.y) && s.s_branch(k != 0.0);
    keep.then(|| TriangleInBin {
        c0,
        c1,
        first_slice: g.slice_of(s, z_near, grid.params.slices),
        edge_planes: [
            counted::cross(s, q[0], q[1]),
            counted::cross(s, q[1], q[2]),
            counted::cross(s, q[2], q[0]),
        ],
        n,
        k,
    })
}

/// Lanes of `m` whose sample `(x, y, z)` (relative to the light centre) lies behind triangle `t`:
/// inside the cone from the light through it (three edge-plane distances of one sign) and beyond its
/// plane, `k / (n·q)` in `(0, 1 - SELF_SHADOW_EPS)`.
#[inline(always)]
pub fn covered<S: Simd>(s: S, t: &TriangleInBin, m: Mask16, x: S::F32, y: S::F32, z: S::F32) -> Mask16 {
    let zero = s.splat_f(0.0);
    let ep = &t.edge_planes;
    let d0 = s.fmadd(
        s.splat_f(ep[0].z),
        z,
        s.fmadd(s.splat_f(ep[0].y), y, s.mul_f(s.splat_f(ep[0].x), x)),
    );
    let d1 = s.fmadd(
        s.splat_f(ep[1].z),
        z,
        s.fmadd(s.splat_f(ep[1].y), y, s.mul_f(s.splat_f(ep[1].x), x)),
    );
    let d2 = s.fmadd(
        s.splat_f(ep[2].z),
        z,
        s.fmadd(s.splat_f(ep[2].y), y, s.mul_f(s.splat_f(ep[2].x), x)),
    );
    let all_pos = s.mask_and(
        s.cmp_ge_f(d0, zero),
        s.mask_and(s.cmp_ge_f(d1, zero), s.cmp_ge_f(d2, zero)),
    );
    let all_neg = s.mask_and(
        s.cmp_le_f(d0, zero),
        s.mask_and(s.cmp_le_f(d1, zero), s.cmp_le_f(d2, zero)),
    );
    let nq = s.fmadd(
        s.splat_f(t.n.z),
        z,
        s.fmadd(s.splat_f(t.n.y), y, s.mul_f(s.splat_f(t.n.x), x)),
    );
    let nq = s.mul_f(nq, s.splat_f(1.0 - SELF_SHADOW_EPS));
    let kv = s.splat_f(t.k);
    // k and n·q of the same sign, |k| < |n·q| (1 - eps).
    // A branch on the host (counted, predicted): its outcome holds for a triangle's vectors.
    let between = if s.s_branch(t.k > 0.0) {
        s.cmp_lt_f(kv, nq)
    } else {
        s.cmp_gt_f(kv, nq)
    };
    s.mask_and(m, s.mask_and(between, s.mask_or(all_pos, all_neg)))
}

impl Kernel for UmbraBin<'_> {
    type Output = u64;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> u64 {
        s.begin_task(task_kind::UMBRA_BIN);
        let grid = self.grid;
        let base = grid.bins[self.bin].samples.start as usize;
        let samples = &grid.samples;
        let zero = s.splat_f(0.0);
        let one = s.splat_i(1);
        let mut tested = 0u64;
        for k in 0..self.triangles.len() {
            let t = s.s_load(self.triangles, k);
            let q = s
                .s_read_words(&self.topo.triangles[t as usize])
                .map(|v| counted::sub(s, v, self.light_center));
            let Some(tri) = triangle_in_bin(s, grid, self.bin, &q) else {
                continue;
            };
            let mut row = tri.c0.y;
            while s.s_lt(row, tri.c1.y) {
                let (start, end) = grid.row_span(s, self.bin, tri.c0, tri.c1, row, tri.first_slice);
                row += 1;
                let mut i = start;
                // Counted loop test: a row's span is 0 to a few vectors, data-dependent.
                while s.s_lt(i, end) {
                    let m = s.mask_first_n(end - i);
                    let x = s.mask_load_f(zero, m, &samples.x[i..]);
                    let y = s.mask_load_f(zero, m, &samples.y[i..]);
                    let z = s.mask_load_f(zero, m, &samples.z[i..]);
                    let hit = covered(s, &tri, m, x, y, z);
                    let local = i - base;
                    let cur = s.mask_load_i(s.splat_i(0), m, &self.out[local..]);
                    s.mask_store_i(&mut self.out[local..], hit, s.add_i(cur, one));
                    tested += s.mask_popcnt(m) as u64;
                    i += 16;
                }
            }
        }
        s.end_task();
        tested
    }
}
