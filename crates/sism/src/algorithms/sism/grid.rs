//! The light-space 3D perspective grid of the paper's Figure 3: receiver samples sorted so that each
//! cell's samples are contiguous in memory, cells ordered bin by bin (the light-view tiles that are the
//! tasks of the umbra and penumbra stages), columns within a bin row by row, depth slices innermost. A
//! column's samples from a given slice onward are therefore one contiguous range: depth culling is a
//! change of start index.
//!
//! Built by counting sort, as a many-core chip would: classify samples 16 at a time (cell and bin
//! indices), histogram bins per chunk with conflict-detecting vector fetch-add, prefix sum, scatter,
//! then per bin a second counting sort by cell. Every step is deterministic (chunks and bins are fixed
//! by the data, never by the host thread count).

use crate::counted::LaneArray;
use std::ops::Range;

use glam::{UVec2, Vec2, Vec3};
use rayon::prelude::*;
use sism_simd::{as_i32_mut, Kernel, ScalarClass, Simd};

use super::light_view::LightFace;
use crate::counted::v2;
use crate::exec::{task_kind, Phase};
use crate::stats::{percentiles, Dist};

crate::declare_stats! {
    /// Counters of the grid.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct GridStats {
        /// Samples in the grid (receivers facing the light).
        pub samples: u64 => ("grid.samples", "samples", "samples in the light-space grid"),
        /// Light views: 1 frustum or 6 cube faces.
        pub light_faces: u64 => ("grid.light_faces", "faces", "light views: 1 frustum or 6 cube faces"),
        /// Image-plane cells over all faces.
        pub columns: u64 => ("grid.columns", "columns", "image-plane cells over all faces"),
        /// 3D cells (columns × depth slices, whole bins).
        pub cells: u64 => ("grid.cells", "cells", "3D cells (columns x depth slices, whole bins)"),
        /// Cells holding at least one sample.
        pub occupied_cells: u64 => ("grid.occupied_cells", "cells", "cells holding at least one sample"),
        /// Light-view bins (the tasks of the umbra and penumbra stages).
        pub bins: u64 => ("grid.bins", "bins", "light-view bins (tasks)"),
        /// Bins holding samples.
        pub occupied_bins: u64 => ("grid.occupied_bins", "bins", "bins holding samples; empty bins cost nothing"),
        /// Samples per occupied cell.
        pub samples_per_cell: Dist => ("dist.samples_per_cell", "samples", "samples per occupied grid cell (distribution)"),
    }
}

/// Tuning of the grid resolution.
#[derive(Clone, Copy, Debug)]
pub struct GridParams {
    /// Target mean number of samples per grid column (image-plane cell) over a face's image bounds;
    /// the column count is `samples / samples_per_column`. Range 1..=64, default 4: small columns
    /// make the conservative triangle and quad coverage tight, 16-lane vectors are filled by walking
    /// several columns' contiguous samples.
    pub samples_per_column: f32,
    /// Depth slices per column, logarithmically spaced between the face's nearest and farthest
    /// sample (a perspective grid). Range 1..=64, default 8.
    pub slices: u32,
    /// Bin side in columns: a bin is `bin_columns x bin_columns` columns. Range 1..=64, default 4:
    /// under foliage a bin's penumbra work is heavy, and on the modelled chip the heaviest bin bounds
    /// the phase (palm on 24 cores: 487 ms per frame with 8x8-column bins, 178 ms with 4x4).
    pub bin_columns: u32,
}

impl Default for GridParams {
    fn default() -> Self {
        Self {
            samples_per_column: 4.0,
            slices: 8,
            bin_columns: 4,
        }
    }
}

/// One receiver sample entering the grid: position relative to the light centre, its face and
/// face coordinates, and the pixel it shades.
///
/// `repr(C)` of 4-byte fields only (no padding), so kernels may gather its words
/// ([`SampleIn::words`]).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct SampleIn {
    /// Position relative to the light centre, world units.
    pub q: Vec3,
    /// Its light face (index into the light view's faces).
    pub face: u32,
    /// Image-plane position in its face.
    pub uv: Vec2,
    /// Depth along the face axis, world units.
    pub depth: f32,
    /// The pixel it shades (row-major index).
    pub pixel: u32,
    /// Cosine between the receiver normal and the direction to the light centre, in (0, 1].
    pub cos_theta: f32,
}

impl SampleIn {
    /// 32-bit words per sample.
    pub const WORDS: usize = std::mem::size_of::<SampleIn>() / 4;
    /// Word of `q.x` within a sample (`q.y`, `q.z` follow).
    pub const Q_WORD: usize = std::mem::offset_of!(SampleIn, q) / 4;

    /// `samples` as one flat slice of 32-bit words read as `f32` (only float fields should be
    /// read from it), for gathers.
    pub fn words(samples: &[SampleIn]) -> &[f32] {
        const _: () = assert!(
            std::mem::size_of::<SampleIn>() == 36 && std::mem::align_of::<SampleIn>() == 4,
            "SampleIn is nine 4-byte fields without padding"
        );
        // SAFETY: `SampleIn` is `repr(C)` of nine 4-byte fields (glam's `Vec3` and `Vec2` are
        // `repr(C)` f32 triples and pairs), 36 bytes with no padding (checked above), so `len`
        // samples are `9 * len` initialised, 4-aligned words; every bit pattern is a valid `f32`.
        unsafe { std::slice::from_raw_parts(samples.as_ptr().cast::<f32>(), samples.len() * Self::WORDS) }
    }
}

/// The grid laid over one light face.
#[derive(Clone, Copy, Debug)]
pub struct FaceGrid {
    /// The light face it covers.
    pub face: LightFace,
    /// Image-plane position of the grid's lower corner.
    pub uv_min: Vec2,
    /// Image-plane size of one column.
    pub cell_size: Vec2,
    /// Columns along u and v.
    pub columns: UVec2,
    /// Bins along u and v.
    pub bins: UVec2,
    /// Index of this face's first bin in [`Grid::bins`].
    pub first_bin: u32,
    /// Nearest and farthest sample depth in this face (world units along the face axis).
    pub z_min: f32,
    /// Farthest sample depth in this face (world units along the face axis).
    pub z_max: f32,
    /// Slices per unit of `ln(z)`: `slices / ln(z_max / z_min)`.
    pub slice_scale: f32,
    /// Where each depth slice begins: `slice_from[k]` (`1 <= k < slices`) is the smallest depth in
    /// slice `k` or beyond, non-decreasing in `k`; `slice_from[0]` is `-inf`, and NaN pads the array
    /// past the last slice (and marks slices no depth reaches). See [`slice_thresholds`].
    pub slice_from: [f32; MAX_SLICES],
    /// Sample count.
    pub samples: u32,
}

impl FaceGrid {
    /// Depth slice of depth `z`, in `0..slices`. Monotonic in `z`, so every sample in a slice below
    /// `slice_of(z)` is nearer than `z`: skipping those slices is conservative.
    ///
    /// A branch-free binary search of [`FaceGrid::slice_from`]: `log2(slices)` rounds of a load, a
    /// compare and a select, counted by `s` (a native context counts nothing). Equal, depth for depth,
    /// to the logarithmic rule the thresholds were found from ([`slice_thresholds`]), without the
    /// logarithm's library call (some twenty operations the model could only have declared).
    #[inline(always)]
    pub fn slice_of<S: Simd>(&self, s: S, z: f32, slices: u32) -> u32 {
        let mut k = 0u32;
        let mut step = search_span(slices) / 2;
        while step > 0 {
            let cand = s.s_add(k, step);
            // `z >= NaN` (the padding) is false: the search never passes the last slice.
            let ge = s.s_le(s.s_load(&self.slice_from, cand as usize), z);
            k = if ge { cand } else { k };
            step /= 2;
        }
        k
    }

    /// [`FaceGrid::slice_of`] on 16 depths: the same search, the thresholds permuted out of one
    /// vector when `slices <= 16` and gathered beyond. Equal lane for lane to the scalar search.
    #[inline(always)]
    pub fn slice_of_lanes<S: Simd>(&self, s: S, z: S::F32, slices: u32) -> S::I32 {
        let span = search_span(slices);
        let mut k = s.splat_i(0);
        if span == 1 {
            return k;
        }
        let small = span <= 16;
        let table = if small {
            s.load_f(&self.slice_from[..16])
        } else {
            s.splat_f(0.0)
        };
        let mut step = span / 2;
        while step > 0 {
            let cand = s.add_i(k, s.splat_i(step as i32));
            let t = if small {
                s.permute_f(table, cand)
            } else {
                s.gather_f(&self.slice_from, cand)
            };
            k = s.select_i(s.cmp_ge_f(z, t), cand, k);
            step /= 2;
        }
        k
    }

    /// Near-plane distance of the face for clipping occluders, world units: a tiny fraction of the
    /// nearest sample's depth (geometry nearer than that to the light centre is inside the light).
    /// Its multiply is counted by `s`.
    #[inline(always)]
    pub fn near_plane<S: Simd>(&self, s: S) -> f32 {
        s.s_mul(self.z_min, 1e-4)
    }

    /// Bins of this face overlapped by the column range `[c0, c1)`, as global bin indices.
    #[inline]
    pub fn bins_of_columns(
        &self,
        bin_columns: u32,
        c0: UVec2,
        c1: UVec2,
    ) -> impl Iterator<Item = usize> + '_ {
        let b0 = c0 / bin_columns;
        let b1 = (c1 - UVec2::ONE) / bin_columns;
        (b0.y..=b1.y).flat_map(move |by| {
            (b0.x..=b1.x).map(move |bx| (self.first_bin + by * self.bins.x + bx) as usize)
        })
    }

    /// Column range (inclusive lower, exclusive upper) covered by the image-plane box `[lo, hi]`,
    /// clamped to the grid; empty when the box misses it.
    /// Its operations are counted by `s` (a native context counts nothing).
    #[inline(always)]
    pub fn column_range<S: Simd>(&self, s: S, lo: Vec2, hi: Vec2) -> (UVec2, UVec2) {
        // glam's `((p - uv_min) / cell_size).floor()`, `+ 1`, `.clamp(0, columns)`, `.as_uvec2()`.
        let cell =
            |p: f32, o: f32, size: f32| s.s_fn(ScalarClass::Alu, s.s_div(s.s_sub(p, o), size), f32::floor);
        let max_x = s.s_fn(ScalarClass::Alu, self.columns.x, |c| c as f32);
        let max_y = s.s_fn(ScalarClass::Alu, self.columns.y, |c| c as f32);
        let clamp = |v: f32, m: f32| s.s_fn(ScalarClass::Alu, s.s_min(s.s_max(v, 0.0), m), |x| x as u32);
        let (o, size) = (self.uv_min, self.cell_size);
        let a = UVec2::new(
            clamp(cell(lo.x, o.x, size.x), max_x),
            clamp(cell(lo.y, o.y, size.y), max_y),
        );
        let b = UVec2::new(
            clamp(s.s_add(cell(hi.x, o.x, size.x), 1.0), max_x),
            clamp(s.s_add(cell(hi.y, o.y, size.y), 1.0), max_y),
        );
        (a, b)
    }
}

/// Most depth slices a grid may have (the `slices` parameter's range is `1..=64`).
pub const MAX_SLICES: usize = 64;

/// Entries of [`FaceGrid::slice_from`] the binary search spans: `slices` rounded up to a power of
/// two (the entries past the last slice are NaN, which no depth reaches).
#[inline(always)]
fn search_span(slices: u32) -> u32 {
    slices.clamp(1, MAX_SLICES as u32).next_power_of_two()
}

/// The logarithmic slice rule [`slice_thresholds`] reads its thresholds from: depth `z`'s slice
/// for a face of nearest depth `z_min` and `slice_scale` slices per unit of `ln(z)`, in `0..slices`.
pub fn log_slice(z_min: f32, slice_scale: f32, slices: u32, z: f32) -> u32 {
    let k = ((z / z_min).max(1.0).ln() * slice_scale) as i64;
    k.clamp(0, slices as i64 - 1) as u32
}

/// The depths where slices begin for a face of nearest depth `z_min` and `slice_scale` slices per
/// unit of `ln(z)`: the slices are logarithmically spaced, slice `k` holding the depths with
/// `floor(ln(max(z / z_min, 1)) * slice_scale) = k` (clamped to `0..slices`). Each threshold is the
/// smallest f32 depth the rule puts at `k` or beyond, found by bisection on the depth's bits, so
/// [`FaceGrid::slice_of`]'s search returns, for every depth, the slice the rule gives (the rule is
/// monotonic; the thresholds are made non-decreasing besides, so the search is monotonic whatever
/// the float library's logarithm does in its last ulp).
pub fn slice_thresholds(z_min: f32, slice_scale: f32, slices: u32) -> [f32; MAX_SLICES] {
    let slices = slices.clamp(1, MAX_SLICES as u32);
    let rule = |z: f32| log_slice(z_min, slice_scale, slices, z);
    let mut t = [f32::NAN; MAX_SLICES];
    t[0] = f32::NEG_INFINITY;
    for k in 1..slices {
        if rule(f32::INFINITY) < k {
            break;
        }
        // Non-negative floats order as their bits: bisect for the first with rule(z) >= k.
        let (mut lo, mut hi) = (0u32, f32::INFINITY.to_bits());
        if rule(0.0) >= k {
            hi = 0;
        }
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            if rule(f32::from_bits(mid)) >= k {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        t[k as usize] = f32::from_bits(hi).max(t[k as usize - 1]);
    }
    t
}

/// One bin: `bin_columns^2` columns of one face, a task of the umbra and penumbra stages.
#[derive(Clone, Debug)]
pub struct Bin {
    /// Index of its face in [`Grid::faces`].
    pub face: u32,
    /// First column (u, v) of the bin in its face grid.
    pub column0: UVec2,
    /// Image-plane rectangle of the bin.
    pub uv_min: Vec2,
    /// Upper corner of the bin's image-plane rectangle.
    pub uv_max: Vec2,
    /// Range of the bin's samples in the sorted arrays.
    pub samples: Range<u32>,
    /// Nearest and farthest sample depth in the bin (0 and 0 when empty).
    pub z_min: f32,
    /// Farthest sample depth in the bin (0 when empty).
    pub z_max: f32,
}

/// Samples sorted by cell, structure of arrays (what the 16-wide kernels load).
#[derive(Clone, Debug, Default)]
pub struct SortedSamples {
    /// Position relative to the light centre, world axes.
    pub x: Vec<f32>,
    /// `y` of the position relative to the light centre, world axes.
    pub y: Vec<f32>,
    /// `z` of the position relative to the light centre, world axes.
    pub z: Vec<f32>,
    /// Image-plane position in the sample's light face.
    pub u: Vec<f32>,
    /// `v` of the image-plane position in the sample's light face.
    pub v: Vec<f32>,
    /// Depth along the face axis.
    pub depth: Vec<f32>,
    /// Pixel index (row-major from the top left) the sample shades.
    pub pixel: Vec<u32>,
    /// Cosine between the receiver normal and the direction to the light centre, in (0, 1].
    pub cos_theta: Vec<f32>,
}

/// The grid over all light faces.
#[derive(Clone, Debug)]
pub struct Grid {
    /// The parameters it was built with.
    pub params: GridParams,
    /// One per light face.
    pub faces: Vec<FaceGrid>,
    /// Every bin, face after face (a face's first at [`FaceGrid::first_bin`]).
    pub bins: Vec<Bin>,
    /// `cell_start[c]..cell_start[c + 1]` are cell `c`'s samples; cells are numbered bin-major, then
    /// column row-major within the bin, then slice. Length: cells + 1.
    pub cell_start: Vec<u32>,
    /// The samples, sorted by cell.
    pub samples: SortedSamples,
}

impl Grid {
    /// Cells per bin.
    #[inline]
    pub fn cells_per_bin(&self) -> usize {
        (self.params.bin_columns * self.params.bin_columns * self.params.slices) as usize
    }

    /// Index of the first cell of column `(cu, cv)` (in the bin's face grid) of bin `bin`. Its
    /// operations are counted by `s`.
    #[inline(always)]
    pub fn column_first_cell<S: Simd>(&self, s: S, bin: usize, column: UVec2) -> usize {
        let b = &self.bins[bin];
        let row = s.s_mul(s.s_sub(column.y, s.s_read(&b.column0.y)), self.params.bin_columns);
        let local = s.s_add(row, s.s_sub(column.x, s.s_read(&b.column0.x)));
        s.s_add(
            s.s_mul(bin, self.cells_per_bin()),
            s.s_mul(local, self.params.slices) as usize,
        )
    }

    /// Number of cells holding at least one sample.
    pub fn occupied_cells(&self) -> usize {
        self.cell_start.windows(2).filter(|w| w[1] > w[0]).count()
    }

    /// Number of bins holding at least one sample.
    pub fn occupied_bins(&self) -> usize {
        self.bins.iter().filter(|b| !b.samples.is_empty()).count()
    }

    /// Sample range of row `row` of the columns `[c0, c1)` of bin `bin`: from the first column's slice
    /// `first_slice` to the last column's end. Columns of one bin row are contiguous in memory, so this
    /// is one range; the nearer slices of the columns in between are included (work for lanes, never
    /// a missed sample).
    ///
    /// Its operations are counted by `s` (a native context counts nothing): the two columns' first
    /// cells ([`Grid::column_first_cell`]) and the two loads of cell starts.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn row_span<S: Simd>(
        &self,
        s: S,
        bin: usize,
        c0: UVec2,
        c1: UVec2,
        row: u32,
        first_slice: u32,
    ) -> (usize, usize) {
        let first = self.column_first_cell(s, bin, UVec2::new(c0.x, row));
        let last = self.column_first_cell(s, bin, UVec2::new(s.s_sub(c1.x, 1), row));
        let start = s.s_load(&self.cell_start, s.s_add(first, first_slice as usize));
        let end = s.s_load(&self.cell_start, s.s_add(last, self.params.slices as usize));
        (start as usize, end as usize)
    }

    /// Disjoint mutable pieces of `data` (one entry per sorted sample) for the sample ranges `ranges`
    /// (ascending, non-overlapping; gaps are skipped).
    pub fn split_samples<T>(
        data: &mut [T],
        ranges: impl Iterator<Item = std::ops::Range<usize>>,
    ) -> Vec<&mut [T]> {
        let mut rest = data;
        let mut at = 0;
        let mut out = Vec::new();
        for r in ranges {
            let (_, tail) = rest.split_at_mut(r.start - at);
            let (head, tail) = tail.split_at_mut(r.len());
            out.push(head);
            rest = tail;
            at = r.end;
        }
        out
    }

    /// Each bin's piece of `data` (one entry per sorted sample), in bin order.
    pub fn split_by_bins<'a, T>(&self, data: &'a mut [T]) -> Vec<&'a mut [T]> {
        Self::split_samples(
            data,
            self.bins
                .iter()
                .map(|b| b.samples.start as usize..b.samples.end as usize),
        )
    }

    /// The grid's counters.
    pub fn stats(&self) -> GridStats {
        GridStats {
            samples: self.samples.pixel.len() as u64,
            light_faces: self.faces.len() as u64,
            columns: self
                .faces
                .iter()
                .map(|g| (g.columns.x * g.columns.y) as u64)
                .sum(),
            cells: (self.cell_start.len() - 1) as u64,
            occupied_cells: self.occupied_cells() as u64,
            bins: self.bins.len() as u64,
            occupied_bins: self.occupied_bins() as u64,
            samples_per_cell: percentiles(
                self.cell_start
                    .windows(2)
                    .map(|w| (w[1] - w[0]) as u64)
                    .filter(|&n| n > 0),
            ),
        }
    }
}

/// Samples classified per chunk; the unit of the first counting-sort pass. Large enough that the
/// per-chunk bin histograms and their prefix sum (bins x chunks) stay small, small enough that the
/// modelled chip's cores all get a chunk. (The sorted order does not depend on it: a bin's samples
/// keep their global order whatever the chunking.)
const CHUNK: usize = 16_384;

/// Lays the grid over `faces` and sorts `samples` (grouped by face, in face order) into it, as the
/// steps of `phase`: `face_bounds` (per face the samples' image bounds and depth range), `classify`
/// (bin and cell of every sample, per-chunk bin histograms), `scatter` (sample indices to their bins'
/// ranges), `cell_sort` (per bin, a counting sort by cell), `gather` (the sorted structure of arrays)
/// and `bins` (each bin's descriptor).
pub fn build(phase: &mut Phase, faces: &[LightFace], samples: &[SampleIn], params: &GridParams) -> Grid {
    debug_assert!(
        samples.windows(2).all(|w| w[0].face <= w[1].face),
        "samples grouped by face"
    );
    let b = params.bin_columns;
    // Each face's samples (they are grouped by face).
    let mut ranges = Vec::with_capacity(faces.len());
    let mut start = 0usize;
    for f in 0..faces.len() {
        let end = start + samples[start..].partition_point(|s| s.face as usize == f);
        ranges.push(start..end);
        start = end;
    }
    // Per face the image bounds and depth range of its samples, reduced over chunks (min and max are
    // exact: the chunking does not change them).
    let chunks: Vec<(usize, std::ops::Range<usize>)> = ranges
        .iter()
        .enumerate()
        .flat_map(|(f, r)| {
            (r.start..r.end)
                .step_by(GATHER_CHUNK)
                .map(move |a| (f, a..(a + GATHER_CHUNK).min(r.end)))
        })
        .collect();
    let partial = phase.run_par(
        "face_bounds",
        chunks.par_iter().map(|(_, r)| FaceBounds {
            samples: &samples[r.clone()],
        }),
    );
    let mut bounds = vec![
        (
            Vec2::splat(f32::INFINITY),
            Vec2::splat(f32::NEG_INFINITY),
            f32::INFINITY,
            0.0f32
        );
        faces.len()
    ];
    for ((f, _), (lo, hi, z0, z1)) in chunks.iter().zip(partial) {
        let b = &mut bounds[*f];
        *b = (b.0.min(lo), b.1.max(hi), b.2.min(z0), b.3.max(z1));
    }
    // Per-face resolution from the face's sample count and image bounds.
    let mut face_grids = Vec::with_capacity(faces.len());
    let mut first_bin = 0u32;
    for ((face, range), &(lo, hi, z_min, z_max)) in faces.iter().zip(&ranges).zip(&bounds) {
        let count = range.len();
        let (columns, uv_min, cell_size) = if count == 0 {
            (UVec2::ZERO, Vec2::ZERO, Vec2::ONE)
        } else {
            // Pad the bounds by a hair so the largest sample lands inside the last column.
            let extent = (hi - lo).max(Vec2::splat(1e-6)) * (1.0 + 1e-5);
            let total = (count as f32 / params.samples_per_column).max(1.0);
            let aspect = extent.x / extent.y;
            let gu = (total * aspect).sqrt().ceil().clamp(1.0, 8192.0);
            let gv = (total / gu).ceil().clamp(1.0, 8192.0);
            let columns = UVec2::new(gu as u32, gv as u32);
            (columns, lo, extent / columns.as_vec2())
        };
        let bins = UVec2::new(columns.x.div_ceil(b), columns.y.div_ceil(b));
        let z_min = if count == 0 { 1.0 } else { z_min };
        let z_max = z_max.max(z_min);
        let ratio_ln = (z_max / z_min).ln();
        let slice_scale = if ratio_ln > 0.0 {
            params.slices as f32 / ratio_ln * (1.0 - 1e-6)
        } else {
            0.0
        };
        face_grids.push(FaceGrid {
            face: *face,
            uv_min,
            cell_size,
            columns,
            bins,
            first_bin,
            z_min,
            z_max,
            slice_scale,
            slice_from: slice_thresholds(z_min, slice_scale, params.slices),
            samples: count as u32,
        });
        first_bin += bins.x * bins.y;
    }
    let n_bins = first_bin as usize;

    // Pass 1 (parallel over chunks): bin and local cell of every sample, and per-chunk bin counts.
    let mut bin_of = vec![0u32; samples.len()];
    let mut cell_of = vec![0u32; samples.len()];
    let chunk_counts: Vec<Vec<u32>> = phase.run_par(
        "classify",
        bin_of
            .par_chunks_mut(CHUNK)
            .zip(cell_of.par_chunks_mut(CHUNK))
            .zip(samples.par_chunks(CHUNK))
            .map(|((bins_out, cells_out), chunk)| Classify {
                samples: chunk,
                faces: &face_grids,
                params,
                bin_out: bins_out,
                cell_out: cells_out,
                counts: vec![0u32; n_bins],
            }),
    );

    // Prefix sum, bin-major then chunk: each chunk's first write position in each bin (a task of
    // the scatter step, so its work is counted with it).
    let mut bin_start = vec![0u32; n_bins + 1];
    let mut write_pos: Vec<Vec<u32>> = vec![vec![0; n_bins]; chunk_counts.len()];
    phase.run(
        "scatter",
        BinPrefix {
            chunk_counts: &chunk_counts,
            bin_start: &mut bin_start,
            write_pos: &mut write_pos,
        },
    );

    // Pass 2: scatter sample indices to their bin's range (vector fetch-add on the write positions).
    // The chunks share the output, so the host runs them one after another.
    let mut by_bin = vec![0u32; samples.len()];
    for (k, pos) in write_pos.iter_mut().enumerate() {
        let lo = k * CHUNK;
        let hi = (lo + CHUNK).min(samples.len());
        phase.run(
            "scatter",
            ScatterToBins {
                first_index: lo as u32,
                bin_of: &bin_of[lo..hi],
                write_pos: pos,
                out: &mut by_bin,
            },
        );
    }

    // Pass 3 (parallel over bins): counting sort of each bin's samples by cell.
    let cells_per_bin = (b * b * params.slices) as usize;
    let mut cell_start = vec![0u32; n_bins * cells_per_bin + 1];
    let mut sorted_index = vec![0u32; samples.len()];
    {
        let mut rest: &mut [u32] = &mut sorted_index;
        let mut bin_slices = Vec::with_capacity(n_bins);
        for bin in 0..n_bins {
            let (head, tail) = rest.split_at_mut((bin_start[bin + 1] - bin_start[bin]) as usize);
            bin_slices.push(head);
            rest = tail;
        }
        phase.run_par(
            "cell_sort",
            bin_slices
                .into_par_iter()
                .zip(cell_start[..n_bins * cells_per_bin].par_chunks_mut(cells_per_bin))
                .enumerate()
                .map(|(bin, (out, starts))| CellSort {
                    members: &by_bin[bin_start[bin] as usize..bin_start[bin + 1] as usize],
                    cell_of: &cell_of,
                    bin_first: bin_start[bin],
                    starts,
                    out,
                }),
        );
    }
    cell_start[n_bins * cells_per_bin] = samples.len() as u32;

    // Gather the sorted structure of arrays in one parallel pass: each sample is read once (its fields
    // share a cache line) and its eight fields written to eight streams.
    let n = sorted_index.len();
    let mut sorted = SortedSamples {
        x: vec![0.0; n],
        y: vec![0.0; n],
        z: vec![0.0; n],
        u: vec![0.0; n],
        v: vec![0.0; n],
        depth: vec![0.0; n],
        pixel: vec![0; n],
        cos_theta: vec![0.0; n],
    };
    {
        let SortedSamples {
            x,
            y,
            z,
            u,
            v,
            depth,
            pixel,
            cos_theta,
        } = &mut sorted;
        phase.run_par(
            "gather",
            x.par_chunks_mut(GATHER_CHUNK)
                .zip(y.par_chunks_mut(GATHER_CHUNK))
                .zip(z.par_chunks_mut(GATHER_CHUNK))
                .zip(u.par_chunks_mut(GATHER_CHUNK))
                .zip(v.par_chunks_mut(GATHER_CHUNK))
                .zip(depth.par_chunks_mut(GATHER_CHUNK))
                .zip(pixel.par_chunks_mut(GATHER_CHUNK))
                .zip(cos_theta.par_chunks_mut(GATHER_CHUNK))
                .zip(sorted_index.par_chunks(GATHER_CHUNK))
                .map(
                    |((((((((x, y), z), u), v), depth), pixel), cos_theta), index)| Gather {
                        samples,
                        index,
                        out: [x, y, z, u, v, depth, cos_theta],
                        pixel,
                    },
                ),
        );
    }
    drop(sorted_index);

    // Bin descriptors with their sample ranges and depth bounds.
    let mut coords = Vec::with_capacity(n_bins);
    for (f, g) in face_grids.iter().enumerate() {
        for by in 0..g.bins.y {
            for bx in 0..g.bins.x {
                coords.push((f as u32, UVec2::new(bx * b, by * b)));
            }
        }
    }
    let bins: Vec<Bin> = phase
        .run_par(
            "bins",
            coords
                .par_chunks(BINS_CHUNK)
                .enumerate()
                .map(|(k, coords)| BinDescriptors {
                    first: k * BINS_CHUNK,
                    coords,
                    faces: &face_grids,
                    bin_start: &bin_start,
                    depth: &sorted.depth,
                    bin_columns: b,
                }),
        )
        .into_iter()
        .flatten()
        .collect();
    Grid {
        params: *params,
        faces: face_grids,
        bins,
        cell_start,
        samples: sorted,
    }
}

/// Samples per `gather` task.
const GATHER_CHUNK: usize = 16_384;

/// Bins per `bins` task.
const BINS_CHUNK: usize = 1024;

/// Step `face_bounds`: a face's samples' image-plane bounds and depth range `(lo, hi, z_min, z_max)`.
struct FaceBounds<'a> {
    samples: &'a [SampleIn],
}

impl Kernel for FaceBounds<'_> {
    type Output = (Vec2, Vec2, f32, f32);
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> (Vec2, Vec2, f32, f32) {
        s.begin_task(task_kind::GRID_BINS);
        let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        let (mut z_min, mut z_max) = (f32::INFINITY, 0.0f32);
        for smp in self.samples {
            let (uv, z) = (s.s_read(&smp.uv), s.s_read(&smp.depth));
            s.scalar_op(ScalarClass::Mem); // uv is two loads
            lo = v2::min(s, lo, uv);
            hi = v2::max(s, hi, uv);
            z_min = s.s_min(z_min, z);
            z_max = s.s_max(z_max, z);
            s.scalar_op(ScalarClass::Branch); // the loop
        }
        s.end_task();
        (lo, hi, z_min, z_max)
    }
}

/// Step `cell_sort`: counting sort of one bin's samples (`members`, global indices) by local cell.
/// Writes the cells' global start offsets into `starts` (one per cell of the bin) and the sorted
/// indices into `out`.
struct CellSort<'a> {
    members: &'a [u32],
    cell_of: &'a [u32],
    bin_first: u32,
    starts: &'a mut [u32],
    out: &'a mut [u32],
}

impl Kernel for CellSort<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::GRID_CELL_SORT);
        let mut counts = vec![0u32; self.starts.len()];
        s.scalar_write(&counts); // zeroed
        for k in 0..self.members.len() {
            let i = s.s_load(self.members, k);
            let c = s.s_load(self.cell_of, i as usize) as usize;
            let n = s.s_load(&counts, c);
            s.s_store(&mut counts, c, s.s_add(n, 1));
            s.scalar_op(ScalarClass::Branch); // the loop
        }
        let mut running = 0u32;
        for c in 0..self.starts.len() {
            s.s_store(self.starts, c, s.s_add(self.bin_first, running));
            let n = s.s_load(&counts, c);
            s.s_store(&mut counts, c, running);
            running = s.s_add(running, n);
            s.scalar_op(ScalarClass::Branch);
        }
        for k in 0..self.members.len() {
            let i = s.s_load(self.members, k);
            let c = s.s_load(self.cell_of, i as usize) as usize;
            let slot = s.s_load(&counts, c);
            s.s_store(self.out, slot as usize, i);
            s.s_store(&mut counts, c, s.s_add(slot, 1));
            s.scalar_op(ScalarClass::Branch);
        }
        s.end_task();
    }
}

/// Step `gather`: a chunk of the sorted structure of arrays from the samples, by sorted index.
struct Gather<'a> {
    samples: &'a [SampleIn],
    index: &'a [u32],
    /// x, y, z, u, v, depth, cos θ.
    out: [&'a mut [f32]; 7],
    pixel: &'a mut [u32],
}

impl Kernel for Gather<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::GRID_GATHER);
        let [x, y, z, u, v, depth, cos_theta] = self.out;
        for k in 0..self.index.len() {
            let smp = &self.samples[s.s_load(self.index, k) as usize];
            // Eight loads of the sample's fields and eight stores, counted on their lines.
            s.s_store(x, k, s.s_read(&smp.q.x));
            s.s_store(y, k, s.s_read(&smp.q.y));
            s.s_store(z, k, s.s_read(&smp.q.z));
            s.s_store(u, k, s.s_read(&smp.uv.x));
            s.s_store(v, k, s.s_read(&smp.uv.y));
            s.s_store(depth, k, s.s_read(&smp.depth));
            s.s_store(self.pixel, k, s.s_read(&smp.pixel));
            s.s_store(cos_theta, k, s.s_read(&smp.cos_theta));
            s.scalar_op(ScalarClass::Branch);
        }
        s.end_task();
    }
}

/// Step `bins`: the descriptors of a chunk of bins (global indices from `first`).
struct BinDescriptors<'a> {
    first: usize,
    /// Face and first column of each bin.
    coords: &'a [(u32, UVec2)],
    faces: &'a [FaceGrid],
    bin_start: &'a [u32],
    /// Sorted sample depths.
    depth: &'a [f32],
    bin_columns: u32,
}

impl Kernel for BinDescriptors<'_> {
    type Output = Vec<Bin>;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> Vec<Bin> {
        s.begin_task(task_kind::GRID_BINS);
        let mut out = Vec::with_capacity(self.coords.len());
        for k in 0..self.coords.len() {
            let (f, column0) = s.s_load(self.coords, k);
            let index = self.first + k;
            let g = &self.faces[f as usize];
            let range = s.s_load(self.bin_start, index)..s.s_load(self.bin_start, index + 1);
            let depths = &self.depth[range.start as usize..range.end as usize];
            let (mut z_min, mut z_max) = (f32::INFINITY, 0.0f32);
            for i in 0..depths.len() {
                let z = s.s_load(depths, i);
                z_min = s.s_min(z_min, z);
                z_max = s.s_max(z_max, z);
                s.scalar_op(ScalarClass::Branch);
            }
            let column1 = column0 + UVec2::splat(self.bin_columns);
            // Per corner: the face's origin and cell size loaded, two conversions, two multiply-adds.
            let corner = |c: UVec2| {
                let (o, size) = (s.s_read(&g.uv_min), s.s_read(&g.cell_size));
                let (x, y) = (
                    s.s_fn(ScalarClass::Alu, c.x, |v| v as f32),
                    s.s_fn(ScalarClass::Alu, c.y, |v| v as f32),
                );
                Vec2::new(s.s_add(o.x, s.s_mul(x, size.x)), s.s_add(o.y, s.s_mul(y, size.y)))
            };
            let (uv_min, uv_max) = (corner(column0), corner(column1));
            s.scalar_op(ScalarClass::Branch); // empty bin
            s.s_push(
                &mut out,
                Bin {
                    face: f,
                    column0,
                    uv_min,
                    uv_max,
                    samples: range,
                    z_min: if depths.is_empty() { 0.0 } else { z_min },
                    z_max,
                },
            );
        }
        s.end_task();
        out
    }
}

/// Pass-1 kernel: per sample, its bin (global index) and cell within the bin; bin histogram.
struct Classify<'a> {
    samples: &'a [SampleIn],
    faces: &'a [FaceGrid],
    params: &'a GridParams,
    bin_out: &'a mut [u32],
    cell_out: &'a mut [u32],
    /// The chunk's bin histogram (zeros on entry, one per bin).
    counts: Vec<u32>,
}

impl Kernel for Classify<'_> {
    /// The chunk's bin histogram.
    type Output = Vec<u32>;
    #[inline(always)]
    fn run<S: Simd>(mut self, s: S) -> Vec<u32> {
        s.begin_task(task_kind::GRID_CLASSIFY);
        let b = self.params.bin_columns as i32;
        let slices = self.params.slices;
        let counts = as_i32_mut(&mut self.counts);
        let one = s.splat_i(1);
        for (k, chunk) in self.samples.chunks(16).enumerate() {
            // Samples of a chunk may straddle a face boundary: take the face per lane (scalar setup of
            // the lane's grid parameters, then 16-wide arithmetic).
            // Line-aligned lanes: their counted stores' lines do not depend on the stack's layout.
            let mut u = LaneArray([0f32; 16]);
            let mut v = LaneArray([0f32; 16]);
            let mut umin = LaneArray([0f32; 16]);
            let mut vmin = LaneArray([0f32; 16]);
            let mut inv_cu = LaneArray([0f32; 16]);
            let mut inv_cv = LaneArray([0f32; 16]);
            let mut gu = LaneArray([1i32; 16]);
            let mut gv = LaneArray([1i32; 16]);
            let mut bins_u = LaneArray([1i32; 16]);
            let mut first_bin = LaneArray([0i32; 16]);
            let mut slice = LaneArray([0i32; 16]);
            for (lane, smp) in chunk.iter().enumerate() {
                let g = &self.faces[s.s_read(&smp.face) as usize];
                // Loads into the lane arrays (a load and a store each, the store counted), two
                // reciprocals, the slice.
                let put = |dst: &mut [f32; 16], x: &f32| s.s_store(dst, lane, s.s_read(x));
                put(&mut u.0, &smp.uv.x);
                put(&mut v.0, &smp.uv.y);
                put(&mut umin.0, &g.uv_min.x);
                put(&mut vmin.0, &g.uv_min.y);
                let put_i = |dst: &mut [i32; 16], x: &u32| s.s_store(dst, lane, s.s_read(x) as i32);
                put_i(&mut gu.0, &g.columns.x);
                put_i(&mut gv.0, &g.columns.y);
                put_i(&mut bins_u.0, &g.bins.x);
                put_i(&mut first_bin.0, &g.first_bin);
                s.s_store(&mut inv_cu.0, lane, s.s_div(1.0, s.s_read(&g.cell_size.x)));
                s.s_store(&mut inv_cv.0, lane, s.s_div(1.0, s.s_read(&g.cell_size.y)));
                let depth = s.s_read(&smp.depth);
                s.s_store(&mut slice.0, lane, g.slice_of(s, depth, slices) as i32);
                s.scalar_op(ScalarClass::Branch);
            }
            let m = s.mask_first_n(chunk.len());
            let zero = s.splat_i(0);
            let cu = s.floor_i(s.mul_f(
                s.sub_f(s.from_array_f(u.0), s.from_array_f(umin.0)),
                s.from_array_f(inv_cu.0),
            ));
            let cv = s.floor_i(s.mul_f(
                s.sub_f(s.from_array_f(v.0), s.from_array_f(vmin.0)),
                s.from_array_f(inv_cv.0),
            ));
            let cu = s.min_i(s.max_i(cu, zero), s.sub_i(s.from_array_i(gu.0), one));
            let cv = s.min_i(s.max_i(cv, zero), s.sub_i(s.from_array_i(gv.0), one));
            // b is a small constant (bin side), division by it is by shifts when a power of two;
            // written generally here as multiply-free lane arithmetic on integers.
            let (bu, lu) = div_rem(s, cu, b);
            let (bv, lv) = div_rem(s, cv, b);
            let bin = s.add_i(
                s.add_i(s.mul_i(bv, s.from_array_i(bins_u.0)), bu),
                s.from_array_i(first_bin.0),
            );
            let local_col = s.add_i(s.mul_i(lv, s.splat_i(b)), lu);
            let cell = s.add_i(
                s.mul_i(local_col, s.splat_i(slices as i32)),
                s.from_array_i(slice.0),
            );
            let at = k * 16;
            s.mask_store_i(as_i32_mut(&mut self.bin_out[at..]), m, bin);
            s.mask_store_i(as_i32_mut(&mut self.cell_out[at..]), m, cell);
            s.fetch_add_i(counts, m, bin, one);
        }
        s.end_task();
        self.counts
    }
}

/// Lane-wise `(x / d, x % d)` for non-negative `x` and a positive constant `d`, via float division
/// (exact for the grid's index ranges, < 2^24).
#[inline(always)]
fn div_rem<S: Simd>(s: S, x: S::I32, d: i32) -> (S::I32, S::I32) {
    let q = s.cvtt_f_i(s.mul_f(s.add_f(s.cvt_i_f(x), s.splat_f(0.5)), s.splat_f(1.0 / d as f32)));
    (q, s.sub_i(x, s.mul_i(q, s.splat_i(d))))
}

/// The bins x chunks prefix sum of the chunks' bin histograms: each bin's first sample
/// (`bin_start`, one more than the bins) and each chunk's first write position in each bin.
struct BinPrefix<'a> {
    chunk_counts: &'a [Vec<u32>],
    bin_start: &'a mut [u32],
    write_pos: &'a mut [Vec<u32>],
}

impl Kernel for BinPrefix<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::GRID_SCATTER);
        let n_bins = self.bin_start.len() - 1;
        // Chunk-major, 16 bins a vector, so that every chunk's array is streamed once. Bin-major
        // order (one bin across every chunk's array, then the next) put the chunks' same-offset
        // entries in one L1 set: on the Intel Xeon VM it took 27 cycles a bin and chunk (15 ms of
        // a 1600×1200 frame's 18 ms scatter step), which the model, placing lines by first touch,
        // could not see.
        // Pass 1: each bin's total over the chunks, into `bin_start[..n_bins]`.
        let totals = as_i32_mut(&mut self.bin_start[..n_bins]);
        for (c, counts) in self.chunk_counts.iter().enumerate() {
            let counts = sism_simd::as_i32(counts);
            let first = s.s_branch(c == 0);
            for at in (0..n_bins).step_by(16) {
                let m = s.mask_first_n(n_bins - at);
                let add = s.mask_load_i(s.splat_i(0), m, &counts[at..]);
                let sum = if first {
                    add
                } else {
                    s.add_i(s.mask_load_i(s.splat_i(0), m, &totals[at..]), add)
                };
                s.mask_store_i(&mut totals[at..], m, sum);
            }
        }
        // Pass 2: exclusive prefix over the bins (scalar: a chain through `running`).
        let mut running = 0u32;
        for bin in 0..n_bins {
            let total = s.s_load(self.bin_start, bin);
            s.s_store(self.bin_start, bin, running);
            running = s.s_add(running, total);
            s.scalar_op(ScalarClass::Branch);
        }
        s.s_store(self.bin_start, n_bins, running);
        // Pass 3: each chunk's first position in each bin: the bin's start plus the counts of the
        // chunks before, chunk after chunk.
        for c in 0..self.write_pos.len() {
            let (before, rest) = self.write_pos.split_at_mut(c);
            let pos = as_i32_mut(&mut rest[0]);
            let first = s.s_branch(c == 0);
            for at in (0..n_bins).step_by(16) {
                let m = s.mask_first_n(n_bins - at);
                let start = if first {
                    s.mask_load_i(s.splat_i(0), m, sism_simd::as_i32(&self.bin_start[at..n_bins]))
                } else {
                    let prev = sism_simd::as_i32(&before[c - 1][at..]);
                    let prev_counts = sism_simd::as_i32(&self.chunk_counts[c - 1][at..]);
                    s.add_i(
                        s.mask_load_i(s.splat_i(0), m, prev),
                        s.mask_load_i(s.splat_i(0), m, prev_counts),
                    )
                };
                s.mask_store_i(&mut pos[at..], m, start);
            }
        }
        s.end_task();
    }
}

/// Pass-2 kernel: each sample's position in its bin's range, by vector fetch-add on the chunk's write
/// positions (lanes of the same bin get consecutive slots, in lane order); scatter of the indices.
struct ScatterToBins<'a> {
    first_index: u32,
    bin_of: &'a [u32],
    write_pos: &'a mut [u32],
    out: &'a mut [u32],
}

impl Kernel for ScatterToBins<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::GRID_SCATTER);
        let pos = as_i32_mut(self.write_pos);
        let out = as_i32_mut(self.out);
        let one = s.splat_i(1);
        for (k, chunk) in self.bin_of.chunks(16).enumerate() {
            let m = s.mask_first_n(chunk.len());
            let bins = s.mask_load_i(s.splat_i(0), m, sism_simd::as_i32(chunk));
            let slot = s.fetch_add_i(pos, m, bins, one);
            let index = s.add_i(
                s.index_i(),
                s.splat_i((self.first_index as usize + k * 16) as i32),
            );
            s.mask_scatter_i(out, m, slot, index);
        }
        s.end_task();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn face(z_min: f32, z_max: f32, slices: u32) -> FaceGrid {
        let ratio_ln = (z_max / z_min).ln();
        let slice_scale = if ratio_ln > 0.0 {
            slices as f32 / ratio_ln * (1.0 - 1e-6)
        } else {
            0.0
        };
        FaceGrid {
            face: LightFace {
                axis: Vec3::Z,
                right: Vec3::X,
                up: Vec3::Y,
            },
            uv_min: Vec2::ZERO,
            cell_size: Vec2::ONE,
            columns: UVec2::ONE,
            bins: UVec2::ONE,
            first_bin: 0,
            z_min,
            z_max,
            slice_scale,
            slice_from: slice_thresholds(z_min, slice_scale, slices),
            samples: 1,
        }
    }

    /// The bin-major definition: `bin_start[b]` is the samples of every bin before `b`, and chunk
    /// `c` writes bin `b` from `bin_start[b]` plus the counts of the chunks before it in bin `b`.
    fn prefix_by_definition(counts: &[Vec<u32>], n_bins: usize) -> (Vec<u32>, Vec<Vec<u32>>) {
        let mut bin_start = vec![0; n_bins + 1];
        let mut write_pos = vec![vec![0; n_bins]; counts.len()];
        let mut running = 0;
        for bin in 0..n_bins {
            bin_start[bin] = running;
            for (c, chunk) in counts.iter().enumerate() {
                write_pos[c][bin] = running;
                running += chunk[bin];
            }
        }
        bin_start[n_bins] = running;
        (bin_start, write_pos)
    }

    #[test]
    fn bin_prefix_streamed_chunk_by_chunk_equals_the_bin_major_definition() {
        let mut state = 7u32;
        // Bin counts that are no multiple of 16 (the masked tails), one chunk and several.
        for (n_bins, chunks) in [(1, 1), (37, 1), (16, 3), (53, 5), (200, 9)] {
            let counts: Vec<Vec<u32>> = (0..chunks)
                .map(|_| {
                    (0..n_bins)
                        .map(|_| {
                            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                            (state >> 24) % 7
                        })
                        .collect()
                })
                .collect();
            let want = prefix_by_definition(&counts, n_bins);
            for counted in [false, true] {
                let mut bin_start = vec![0u32; n_bins + 1];
                let mut write_pos = vec![vec![0u32; n_bins]; chunks];
                let k = BinPrefix {
                    chunk_counts: &counts,
                    bin_start: &mut bin_start,
                    write_pos: &mut write_pos,
                };
                if counted {
                    crate::exec::counting(&sism_simd::Recorder::new(), k);
                } else {
                    crate::exec::native(k);
                }
                assert_eq!((bin_start, write_pos), want, "{n_bins} bins, {chunks} chunks");
            }
        }
    }

    #[test]
    fn slices_by_thresholds_equal_the_logarithmic_rule() {
        let s = sism_simd::Portable;
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        for &(z_min, z_max) in &[
            (0.1f32, 50.0f32),
            (1.0, 1.0),
            (3.0, 3.5),
            (1e-3, 1e4),
            (7.0, 7.000_01),
        ] {
            for slices in [1u32, 2, 3, 8, 16, 17, 64] {
                let g = face(z_min, z_max, slices);
                let mut zs = vec![0.0, -1.0, f32::NAN, f32::INFINITY, z_min, z_max, f32::MAX];
                for _ in 0..4000 {
                    let t = (next() >> 40) as f32 / (1u64 << 24) as f32;
                    zs.push(z_min * (z_max / z_min).powf(t * 1.2 - 0.1));
                }
                // Every threshold and its neighbours in ulps.
                for &t in &g.slice_from[1..slices as usize] {
                    if t.is_finite() && t > 0.0 {
                        zs.extend([
                            f32::from_bits(t.to_bits() - 1),
                            t,
                            f32::from_bits(t.to_bits() + 1),
                        ]);
                    }
                }
                for chunk in zs.chunks(16) {
                    let mut lanes = [0f32; 16];
                    lanes[..chunk.len()].copy_from_slice(chunk);
                    let v = s.to_array_i(g.slice_of_lanes(s, s.from_array_f(lanes), slices));
                    for (l, &z) in chunk.iter().enumerate() {
                        let want = log_slice(z_min, g.slice_scale, slices, z);
                        assert_eq!(
                            g.slice_of(s, z, slices),
                            want,
                            "z {z} z_min {z_min} slices {slices}"
                        );
                        assert_eq!(v[l] as u32, want, "lanes: z {z} z_min {z_min} slices {slices}");
                    }
                }
            }
        }
    }
}
