//! Light-view depth maps, rendered by the project's binned sort-middle rasterizer (the eye pass's),
//! one per light face: one frustum when every receiver lies within 60° of a common direction from
//! the light, a cube of six faces otherwise (the rule of SISM's light view, [`light_view::fit`]).
//!
//! **Frustum.** Each face is a square perspective view from the light point along the face axis,
//! fitted to the receivers it holds (the largest `|x/z|`, `|y/z|` of their face coordinates) and
//! widened by [`PAD_TEXELS`] on every side, so filters and revectorization walks of receivers at the
//! rim read texels of the map, not its border.
//!
//! **Depth.** A texel holds the normalised linear depth `d = (z − z0) / (z1 − z0)` of the surface its
//! centre sees (`z` the view depth along the axis, world units; `z0`, `z1` the nearest and farthest
//! receiver depth of the face, so receivers lie in [0, 1] and nearer occluders below 0; the range
//! is at least [`MIN_RANGE_SHARE`] of `z1`), 32-bit
//! float, plus the bias of [`MapParams`] — a constant and a slope-scaled term, as a polygon offset
//! adds them when a map is rendered. Texels that see nothing hold `+∞` (lit for any receiver).
//! Reads outside the map are [`Lookup::Outside`]; each method says what they mean.

use std::mem::MaybeUninit;

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use sism_simd::{Kernel, Mask16, ScalarClass, Simd};

use super::face_chunks;
use crate::algorithms::sism::grid::SampleIn;
use crate::algorithms::sism::light_samples::LightSamples;
use crate::algorithms::sism::light_view::LightFace;
use crate::exec::{task_kind, Phase};
use crate::raster::{rasterize, tile_rows, RasterView, TileBuf, TileRaster, TileResolve, TileRows};
use crate::scene::{CameraFrame, Scene};
use crate::vmath::{dot3_unfused, splat3};

/// Texels of margin around the receivers on every side of a face (at least a revectorization walk,
/// 16 texels, plus the 4-neighbourhood, and half the largest PCF kernel, 33 texels).
pub const PAD_TEXELS: u32 = 20;

/// The smallest depth range a face's normalised depth spans, as a share of its farthest receiver's
/// depth (see [`render_maps`]).
pub const MIN_RANGE_SHARE: f32 = 0.1;

/// Depth of a texel that sees nothing: lit whatever the receiver.
pub const NOTHING: f32 = f32::INFINITY;

/// How a depth map is made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapParams {
    /// Map side, texels, 256..=8192.
    pub size: u32,
    /// Constant depth bias, in normalised depth (a face's receivers span [0, 1]).
    pub bias_constant: f32,
    /// Slope-scaled depth bias: times the surface's largest depth change per texel.
    pub bias_slope: f32,
}

/// One face's depth map.
#[derive(Clone, Debug)]
pub struct FaceMap {
    /// The face (axis and image-plane basis) and the light point it looks from.
    pub face: LightFace,
    /// The light point the map looks from, world space.
    pub origin: Vec3,
    /// `tan` of the half field of view: the image plane spans `[-extent, extent]²`.
    pub extent: f32,
    /// Map side, texels.
    pub size: u32,
    /// Nearest receiver depth of the face (world units along the axis): normalised depth 0.
    pub z0: f32,
    /// `1 / (z1 − z0)`, 1/world units.
    pub inv_range: f32,
    /// Depth per texel, row-major from the top row (`+up` side), normalised and biased; [`NOTHING`]
    /// where nothing is seen.
    pub depth: Vec<f32>,
    /// Nearest depth any texel sees, world units (PCSS bounds its blocker search with it).
    pub z_min: f32,
}

/// A light point's depth maps: one per face.
#[derive(Clone, Debug)]
pub struct LightMaps {
    /// One per face of the light view; a face no receiver falls in has an empty `depth` (not
    /// rendered; no lookup reads it).
    pub faces: Vec<FaceMap>,
    /// True for a cube of six faces, false for a single frustum.
    pub is_cube: bool,
}

crate::declare_stats! {
    /// Counters of a frame's depth maps (every method of the shadow-map family).
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct MapStats {
        /// Maps rendered.
        pub faces: u64 => ("map.faces", "maps", "depth maps rendered (of 1 frustum or 6 cube faces)"),
        /// Faces of the light view without a receiver: not rendered.
        pub faces_skipped: u64 => ("map.faces_skipped", "maps", "light faces without a receiver: no map rendered"),
        /// Map side.
        pub size: u64 => ("map.size", "texels", "side of each depth map"),
        /// Texels written.
        pub texels_written: u64 => ("map.texels_written", "texels", "texels of all maps written"),
        /// Texels that see a surface.
        pub texels_covered: u64 => ("map.texels_covered", "texels", "texels that see a surface"),
    }
}

impl MapStats {
    /// Adds another light point's map counters (faces and texels; `size` is left as it is).
    pub fn add_maps(&mut self, m: &MapStats) {
        self.faces += m.faces;
        self.faces_skipped += m.faces_skipped;
        self.texels_written += m.texels_written;
        self.texels_covered += m.texels_covered;
    }
}

impl LightMaps {
    /// The maps' counters; `size` the side they were rendered at.
    pub fn stats(&self, size: u32) -> MapStats {
        let rendered = self.faces.iter().filter(|f| !f.depth.is_empty());
        MapStats {
            faces: rendered.clone().count() as u64,
            faces_skipped: self.faces.iter().filter(|f| f.depth.is_empty()).count() as u64,
            size: size as u64,
            texels_written: rendered.clone().map(|f| f.depth.len() as u64).sum(),
            texels_covered: rendered
                .map(|f| f.depth.iter().filter(|d| d.is_finite()).count() as u64)
                .sum(),
        }
    }
}

/// A map read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lookup {
    /// The texel's depth.
    Depth(f32),
    /// Outside the map.
    Outside,
}

impl FaceMap {
    /// Texels per unit of the image plane.
    #[inline]
    pub fn texels_per_unit(&self) -> f32 {
        self.size as f32 / (2.0 * self.extent)
    }

    /// The continuous map position (texel `i` covers `[i, i + 1)`) and normalised depth of a point
    /// with face coordinates `f` (`f.z > 0`).
    #[inline]
    pub fn project_face(&self, f: Vec3) -> (Vec2, f32) {
        self.project_face_counted(sism_simd::Portable, f)
    }

    /// [`FaceMap::project_face`] counted by `s` (the same bits): four divides, a conversion, and
    /// seven adds and multiplies.
    #[inline(always)]
    pub fn project_face_counted<S: Simd>(&self, s: S, f: Vec3) -> (Vec2, f32) {
        let half = s.s_mul(
            0.5,
            s.s_fn(sism_simd::ScalarClass::Alu, self.size, |n: u32| n as f32),
        );
        let u = s.s_div(f.x, f.z);
        let v = s.s_div(f.y, f.z);
        let x = s.s_mul(s.s_add(s.s_div(u, self.extent), 1.0), half);
        let y = s.s_mul(s.s_sub(1.0, s.s_div(v, self.extent)), half);
        (Vec2::new(x, y), s.s_mul(s.s_sub(f.z, self.z0), self.inv_range))
    }

    /// [`FaceMap::project_face`] of `face.to_face(q + shift)` for 16 points at once, bit-identical
    /// to the scalar functions in every lane (the same operations in the same order: no fused
    /// multiply-adds, correctly rounded divides), so a vector kernel and the scalar visibility
    /// functions see the same fragment.
    ///
    /// `qx, qy, qz`: positions relative to the light centre (world units); `shift`: the offset to
    /// the map's light point. Returns the lanes of `m` in front of the face (`z > 0`) and, in those
    /// lanes, the continuous map position `(x, y)` and normalised depth; other lanes hold `+0.0`.
    #[inline(always)]
    pub fn project_lanes<S: Simd>(
        &self,
        s: S,
        m: sism_simd::Mask16,
        [qx, qy, qz]: [S::F32; 3],
        shift: Vec3,
    ) -> (sism_simd::Mask16, [S::F32; 3]) {
        let q = [
            s.add_f(qx, s.splat_f(shift.x)),
            s.add_f(qy, s.splat_f(shift.y)),
            s.add_f(qz, s.splat_f(shift.z)),
        ];
        // glam's dot: (x·x' + y·y') + z·z'. (A loop, not a closure: a vector operation inside a
        // closure is compiled out of line.)
        let f = &self.face;
        let mut fxyz = q;
        for (out, a) in fxyz.iter_mut().zip([f.right, f.up, f.axis]) {
            *out = s.add_f(
                s.add_f(s.mul_f(q[0], s.splat_f(a.x)), s.mul_f(q[1], s.splat_f(a.y))),
                s.mul_f(q[2], s.splat_f(a.z)),
            );
        }
        let [fx, fy, fz] = fxyz;
        let zero = s.splat_f(0.0);
        let front = s.mask_and(m, s.cmp_gt_f(fz, zero));
        // Lanes behind the face divide by 1 (no infinities to carry) and are zeroed below.
        let safe_z = s.select_f(front, fz, s.splat_f(1.0));
        let half = s.splat_f(0.5 * self.size as f32);
        let (one, extent) = (s.splat_f(1.0), s.splat_f(self.extent));
        let u = s.div_f(fx, safe_z);
        let v = s.div_f(fy, safe_z);
        let x = s.mul_f(s.add_f(s.div_f(u, extent), one), half);
        let y = s.mul_f(s.sub_f(one, s.div_f(v, extent)), half);
        let d = s.mul_f(s.sub_f(safe_z, s.splat_f(self.z0)), s.splat_f(self.inv_range));
        (
            front,
            [
                s.select_f(front, x, zero),
                s.select_f(front, y, zero),
                s.select_f(front, d, zero),
            ],
        )
    }

    /// [`FaceMap::project_face`] of world point `p`.
    #[inline]
    pub fn project(&self, p: Vec3) -> (Vec2, f32) {
        self.project_face(self.face.to_face(p - self.origin))
    }

    /// The depth of texel `(x, y)`, or [`Lookup::Outside`].
    #[inline]
    pub fn at(&self, x: i64, y: i64) -> Lookup {
        let n = self.size as i64;
        if x < 0 || y < 0 || x >= n || y >= n {
            Lookup::Outside
        } else {
            Lookup::Depth(self.depth[(y * n + x) as usize])
        }
    }

    /// World units of view depth per unit of normalised depth.
    #[inline]
    pub fn range(&self) -> f32 {
        1.0 / self.inv_range
    }

    /// The view depth (world units) of normalised depth `d`.
    #[inline]
    pub fn world_depth(&self, d: f32) -> f32 {
        self.z0 + d * self.range()
    }
}

/// Receivers per task of step `bounds`.
const BOUNDS_CHUNK: usize = 16384;

/// Step `bounds` of a depth map: over a chunk of one face's receivers seen from a light point,
/// the largest `|u|`, `|v|` of their image-plane positions and their nearest and farthest depth
/// (receivers in front of the point only), as `[extent, z_lo, z_hi]` (0, +inf, 0 for none). The
/// operations of `LightFace::to_face(q + center - origin)` in the same order, so the maps fitted on
/// them are the same as when this was scalar code.
struct FaceBounds<'a> {
    /// The chunk's receivers, all of face `face`.
    samples: &'a [SampleIn],
    face: LightFace,
    /// The light centre (receivers are stored relative to it) and the light point, world space.
    center: Vec3,
    origin: Vec3,
}

impl Kernel for FaceBounds<'_> {
    type Output = [f32; 3];
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> [f32; 3] {
        s.begin_task(task_kind::DEPTH_MAP_BOUNDS);
        // 16 samples are `SampleIn::WORDS` (9) consecutive vectors of words: loaded in sequence
        // (gathers at a 9-word stride measured 4.6x slower than streaming over the same DRAM:
        // 8.3 ms against 1.7 for palm's 1.9M receivers), then each coordinate's 16 lanes are
        // picked out of them by a permute and a blend per vector.
        const W: usize = SampleIn::WORDS;
        let words = SampleIn::words(self.samples);
        let q_at = SampleIn::Q_WORD;
        // Per coordinate c: lane j wants word `W * j + q_at + c`, lane `% 16` of vector `/ 16`.
        let mut pick = [[Mask16::from_bits(0); W]; 3];
        let mut lane_of = [[0i32; 16]; 3];
        for c in 0..3 {
            for (j, lane) in lane_of[c].iter_mut().enumerate() {
                let w = W * j + q_at + c;
                pick[c][w / 16] = Mask16::from_bits(pick[c][w / 16].bits() | 1 << j);
                *lane = (w % 16) as i32;
            }
        }
        let lane_of = [
            s.from_array_i(lane_of[0]),
            s.from_array_i(lane_of[1]),
            s.from_array_i(lane_of[2]),
        ];
        let (center, origin) = (splat3(s, self.center), splat3(s, self.origin));
        let axes = [
            splat3(s, self.face.right),
            splat3(s, self.face.up),
            splat3(s, self.face.axis),
        ];
        let zero = s.splat_f(0.0);
        let (mut extent, mut z_lo, mut z_hi) = (zero, s.splat_f(f32::INFINITY), zero);
        let mut i = 0;
        while i < self.samples.len() {
            let n = (self.samples.len() - i).min(16);
            let m = s.mask_first_n(n);
            let chunk = &words[W * i..W * (i + n)];
            let mut q = [zero; 3];
            for k in 0..W {
                if 16 * k >= chunk.len() {
                    break;
                }
                let v = s.mask_load_f(zero, s.mask_first_n(chunk.len() - 16 * k), &chunk[16 * k..]);
                for c in 0..3 {
                    if pick[c][k].any() {
                        q[c] = s.select_f(pick[c][k], s.permute_f(v, lane_of[c]), q[c]);
                    }
                }
            }
            let mut p = [zero; 3];
            for c in 0..3 {
                p[c] = s.sub_f(s.add_f(q[c], center[c]), origin[c]);
            }
            let f = [
                dot3_unfused(s, &p, &axes[0]),
                dot3_unfused(s, &p, &axes[1]),
                dot3_unfused(s, &p, &axes[2]),
            ];
            let front = s.mask_and(m, s.cmp_gt_f(f[2], zero));
            let u = s.abs_f(s.div_f(f[0], f[2]));
            let v = s.abs_f(s.div_f(f[1], f[2]));
            extent = s.select_f(front, s.max_f(s.max_f(extent, u), v), extent);
            z_lo = s.select_f(front, s.min_f(z_lo, f[2]), z_lo);
            z_hi = s.select_f(front, s.max_f(z_hi, f[2]), z_hi);
            i += 16;
        }
        let out = [s.reduce_max_f(extent), s.reduce_min_f(z_lo), s.reduce_max_f(z_hi)];
        s.end_task();
        out
    }
}

/// Renders the depth maps of `scene` seen from the light point `origin` for the receivers of
/// `samples` (their light view and faces: the light centre's), as the steps of `phase`: `bounds`
/// (each face's extent and depth range over its receivers), then per face `front_end`,
/// `tile_lists`, `tiles` (the rasterizer's) and `depth_min` — faces one after another.
pub fn render_maps(
    phase: &mut Phase,
    scene: &Scene,
    samples: &LightSamples,
    origin: Vec3,
    params: &MapParams,
) -> LightMaps {
    let n_faces = samples.view.faces.len();
    // Per face: largest |u|, |v| and the receivers' depth range (step `bounds`, 16 receivers a
    // vector, over runs of one face's samples).
    let mut extent = vec![0f32; n_faces];
    let mut z_lo = vec![f32::INFINITY; n_faces];
    let mut z_hi = vec![0f32; n_faces];
    // A face is rendered if any receiver is assigned to it, even one behind this light point
    // (its lookups still read the map).
    let mut has_receiver = vec![false; n_faces];
    let chunks = face_chunks(&samples.samples, BOUNDS_CHUNK);
    let bounds = phase.run_par(
        "bounds",
        chunks.par_iter().map(|(f, range)| FaceBounds {
            samples: &samples.samples[range.clone()],
            face: samples.view.faces[*f as usize],
            center: samples.light.center,
            origin,
        }),
    );
    for ((f, _), [e, lo, hi]) in chunks.iter().zip(bounds) {
        let f = *f as usize;
        has_receiver[f] = true;
        extent[f] = extent[f].max(e);
        z_lo[f] = z_lo[f].min(lo);
        z_hi[f] = z_hi[f].max(hi);
    }
    let size = params.size;
    let widen = size as f32 / (size - 2 * PAD_TEXELS) as f32;
    let faces = samples
        .view
        .faces
        .iter()
        .enumerate()
        .map(|(f, &face)| {
            let extent = (extent[f].max(1e-6) * widen).min(1e6);
            let (z0, z1) = if z_lo[f].is_finite() {
                (z_lo[f], z_hi[f])
            } else {
                (1.0, 2.0)
            };
            // A face whose receivers lie at nearly one depth (a floor seen straight down from the
            // light) would make normalised depth so fine that the constant bias falls below the
            // rasterizer's depth rounding (acne over the whole floor): the unit is never finer than
            // MIN_RANGE_SHARE of the farthest receiver's depth.
            let inv_range = 1.0 / (z1 - z0).max(z1 * MIN_RANGE_SHARE).max(f32::MIN_POSITIVE);
            let view = RasterView {
                frame: CameraFrame {
                    eye: origin,
                    forward: face.axis,
                    right: face.right,
                    up: face.up,
                    tan_half_fov: extent,
                    aspect: 1.0,
                    width: size,
                    height: size,
                },
                // Occluders nearer than a ten-thousandth of the nearest receiver are inside the light.
                z_near: z0 * 1e-4,
            };
            if !has_receiver[f] {
                // No receiver looks up this face (a cube face away from every receiver): no map.
                phase.skip();
                return FaceMap {
                    face,
                    origin,
                    extent,
                    size,
                    z0,
                    inv_range,
                    depth: Vec::new(),
                    z_min: f32::INFINITY,
                };
            }
            let mut depth: Vec<f32> = Vec::with_capacity(size as usize * size as usize);
            let resolve = DepthResolve {
                z0,
                inv_range,
                bias_constant: params.bias_constant,
                bias_slope: params.bias_slope,
            };
            let outs = tile_rows(&mut depth, size, size);
            rasterize(phase, scene, &view, &resolve, outs);
            // SAFETY: `rasterize` hands every tile's rows to that tile's resolve, which writes every
            // element of them (each texel, covered or not); the rows partition the map.
            unsafe { depth.set_len(size as usize * size as usize) };
            let d_min = phase
                .run_par(
                    "depth_min",
                    depth.par_chunks(MIN_CHUNK).map(|depth| MinDepth { depth }),
                )
                .into_iter()
                .fold(f32::INFINITY, f32::min);
            let z_min = if d_min.is_finite() {
                z0 + d_min / inv_range
            } else {
                f32::INFINITY
            };
            FaceMap {
                face,
                origin,
                extent,
                size,
                z0,
                inv_range,
                depth,
                z_min,
            }
        })
        .collect();
    LightMaps {
        faces,
        is_cube: samples.view.is_cube,
    }
}

/// Texels per `depth_min` task.
const MIN_CHUNK: usize = 1 << 16;

/// Step `depth_min`: the smallest depth of a chunk of texels (+∞ when none sees anything).
struct MinDepth<'a> {
    depth: &'a [f32],
}

impl sism_simd::Kernel for MinDepth<'_> {
    type Output = f32;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> f32 {
        s.begin_task(task_kind::DEPTH_MAP_MIN);
        let inf = s.splat_f(f32::INFINITY);
        let mut m = inf;
        let mut i = 0;
        while i < self.depth.len() {
            let lanes = s.mask_first_n(self.depth.len() - i);
            m = s.min_f(m, s.mask_load_f(inf, lanes, &self.depth[i..]));
            i += 16;
        }
        s.end_task();
        s.reduce_min_f(m)
    }
}

/// A depth map's resolve: each texel's normalised, biased depth.
struct DepthResolve {
    z0: f32,
    inv_range: f32,
    bias_constant: f32,
    bias_slope: f32,
}

impl TileResolve for DepthResolve {
    type Out<'a> = TileRows<'a, f32>;
    const TASK_KIND: u32 = task_kind::DEPTH_MAP_TEXELS;
    #[inline(always)]
    fn resolve<S: Simd>(&self, s: S, tile: &TileRaster<'_>, out: TileRows<'_, f32>) -> u64 {
        write_depths(s, self, tile, out)
    }
}

/// Writes a tile's texels, a 4×4 block (16 lanes) at a time; returns the number covered.
#[inline(always)]
fn write_depths<S: Simd>(s: S, r: &DepthResolve, tile: &TileRaster<'_>, out: TileRows<'_, f32>) -> u64 {
    let mut rows = out.rows;
    let th = rows.len() as u32;
    let tw = rows.first().map_or(0, |row| row.len()) as u32;
    let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
    let (z0, inv_range) = (s.splat_f(r.z0), s.splat_f(r.inv_range));
    let (c, k) = (s.splat_f(r.bias_constant), s.splat_f(r.bias_slope));
    let nothing = s.splat_f(NOTHING);
    let mut covered = 0u64;
    for by in (0..th).step_by(4) {
        for bx in (0..tw).step_by(4) {
            let base = TileBuf::index(bx, by);
            let slot = s.load_i(&tile.buf.id[base..base + 16]);
            let hit = s.cmp_ge_i(slot, s.splat_i(0));
            let mut vals = [NOTHING; 16];
            // The block's branch, counted with its outcome (a covered block or not).
            if s.s_branch(s.mask_any(hit)) {
                let inv_z = s.load_f(&tile.buf.inv_z[base..base + 16]);
                let z = s.div_f(one, s.select_f(hit, inv_z, one));
                let gx = s.mask_gather_f(zero, hit, &tile.triangles.inv_z_dx, slot);
                let gy = s.mask_gather_f(zero, hit, &tile.triangles.inv_z_dy, slot);
                // |dz/dpixel| = z² |d(1/z)/dpixel|, in normalised depth.
                let g = s.max_f(s.abs_f(gx), s.abs_f(gy));
                let slope = s.mul_f(s.mul_f(s.mul_f(z, z), g), inv_range);
                let d = s.fmadd(s.sub_f(z, z0), inv_range, s.fmadd(k, slope, c));
                vals = s.to_array_f(s.select_f(hit, d, nothing));
                covered += s.mask_popcnt(hit) as u64;
            }
            let rows_here = (th - by).min(4) as usize;
            let cols_here = (tw - bx).min(4) as usize;
            // Counted: the block's extents; per block row the whole-row test, then its four
            // texels as one 16-byte load from the block and one store into the map's row (a
            // copy of a run whose length the compiler cannot see would be a `memcpy` call per
            // row, which the host spent more time in than in the rest of the resolve); a
            // partial row (the image's last columns) a texel at a time. Each row's stored line
            // is recorded once.
            s.scalar_op(ScalarClass::Alu);
            s.scalar_op(ScalarClass::Alu);
            for rr in 0..rows_here {
                let row = &mut rows[by as usize + rr][bx as usize..bx as usize + cols_here];
                let texels = &vals[4 * rr..4 * rr + 4];
                if s.s_branch(row.len() == 4) {
                    s.scalar_op(ScalarClass::Mem);
                    s.scalar_op(ScalarClass::Store);
                    let whole: &mut [MaybeUninit<f32>; 4] = (&mut *row).try_into().expect("a row of 4");
                    *whole = [texels[0], texels[1], texels[2], texels[3]].map(MaybeUninit::new);
                } else {
                    for (cc, texel) in row.iter_mut().enumerate() {
                        s.scalar_op(ScalarClass::Mem);
                        s.scalar_op(ScalarClass::Store);
                        texel.write(texels[cc]);
                    }
                }
                s.scalar_write(row);
            }
        }
    }
    covered
}
