//! The binned, sort-middle software rasterizer in Larrabee's style (Seiler et al. 2008), for any
//! pinhole view: the eye view (receivers, [`eye`]) now, light views (depth maps) next.
//!
//! 1. **Front end** (step `front_end`, fixed chunks of [`FRONT_END_CHUNK`] triangles, 16 triangles a
//!    vector as Larrabee's renderer did its triangle setup): every scene triangle is transformed to
//!    the view's space, clipped against the near plane `z > z_near` (a triangle crossing it becomes
//!    one or two triangles; these few take a scalar path), projected to screen space in f32 (pixel
//!    centres at `i + 0.5`, `j + 0.5`, y down), culled when degenerate or off screen, and binned: its
//!    pixel bounding box gives the [`TILE`]×[`TILE`] tiles it may touch. The screen area's sign is
//!    taken from f32 where an error bound makes it certain and from the exact f64 area elsewhere.
//! 2. **Tile lists** (step `tile_lists`): a counting sort of the (tile, triangle) pairs by tile, chunks
//!    in order, so every tile's list is in triangle order whatever the host thread count.
//! 3. **Back end** (step `tiles`, one task per tile; a tile owns its pixels): for each triangle of the
//!    tile's list, hierarchical rejection on 16 lanes (the 16 sub-tiles of 16×16 pixels, then the 16
//!    blocks of 4×4 pixels of a surviving sub-tile), then the three edge functions and the depth
//!    `1/z` of a 4×4 block as one 16-lane vector, and a Z-buffer test keeping the larger `1/z`.
//!    At the end of each tile's task, while its triangles are in cache, a [`TileResolve`] turns the
//!    tile's depth buffer into the view's output (receivers for the eye view).
//!
//! **Watertightness.** Each edge function is evaluated in a canonical vertex order (the endpoint with
//! the smaller `(y, x)` first) and only then negated for the triangle's side, so the two triangles
//! sharing an edge compute bit-identical values of opposite sign for every pixel. A pixel exactly on
//! the edge (value 0) goes to the triangle on the positive side of the canonical edge (a top-left
//! rule): shared edges neither double-cover nor crack. Edge and depth planes are set up per tile in
//! `f64` relative to the tile origin and evaluated in `f32` with two fused multiply-adds, so huge
//! triangles (clipped close to the eye) stay accurate to a small fraction of a pixel.

pub mod eye;

use std::mem::MaybeUninit;

use glam::Vec3;
use rayon::prelude::*;
use sism_simd::{Kernel, Mask16, ScalarClass, Simd};

use crate::counted;
use crate::counted::{next_lane, LaneArray};

use crate::exec::{task_kind, Phase};
use crate::scene::{CameraFrame, Scene};
use crate::vmath::{dot3_unfused, lanes, splat3, sub3};

/// Side of a screen tile, pixels. A tile is one back-end task.
pub const TILE: u32 = 64;
/// Pixels of a tile.
const TILE_PIXELS: usize = (TILE * TILE) as usize;
/// Side of a sub-tile (first rejection level), pixels: a tile holds 4×4 of them.
const SUB: u32 = 16;
/// Triangles per front-end task.
pub const FRONT_END_CHUNK: usize = 4096;
/// Per-pixel triangle index of a pixel that sees nothing.
pub const NO_TRIANGLE: u32 = u32::MAX;

/// A view to rasterize: a pinhole frame (CONTRACTS.md camera conventions, any position and
/// orientation) and its near plane.
#[derive(Clone, Copy, Debug)]
pub struct RasterView {
    /// The pinhole frame: eye, orientation, field of view and image size.
    pub frame: CameraFrame,
    /// Near-plane distance along the view direction, world units, > 0: nearer geometry is clipped.
    pub z_near: f32,
}

impl RasterView {
    /// Tiles along x and y.
    pub fn tiles(&self) -> (u32, u32) {
        (self.frame.width.div_ceil(TILE), self.frame.height.div_ceil(TILE))
    }
}

crate::declare_stats! {
    /// Counts of one rasterization (rows without prefix; a view adds its own, e.g. `eye.`).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct RasterStats {
        /// Scene triangles read.
        pub triangles_in: u64 => ("triangles_in", "triangles", "triangles entering the rasterizer"),
        /// Triangles that crossed the near plane and were clipped (each gave 1 or 2 screen triangles).
        pub triangles_clipped: u64 => ("triangles_clipped", "triangles", "triangles clipped at the near plane"),
        /// Triangles that produced no screen triangle: degenerate (zero area, in the world or on
        /// screen), entirely behind the near plane, or entirely outside the image.
        pub triangles_culled: u64 => ("triangles_culled", "triangles", "triangles off screen, degenerate or behind the near plane: skipped"),
        /// Screen triangles after clipping and culling, as binned.
        pub screen_triangles: u64 => ("screen_triangles", "triangles", "screen triangles after clipping and culling"),
        /// Tiles of the image (`ceil(W/64) * ceil(H/64)`).
        pub tiles: u64 => ("tiles", "tiles", "64x64-pixel tiles (back-end tasks)"),
        /// Entries over all per-tile triangle lists.
        pub tile_triangle_pairs: u64 => ("tile_triangle_pairs", "pairs", "(screen tile, triangle) pairs after binning"),
        /// 16×16-pixel sub-tiles that survived the first rejection level.
        pub subtiles_tested: u64 => ("subtiles_tested", "subtiles", "16x16 sub-tiles surviving the first rejection level"),
        /// 4×4-pixel blocks that survived the second level and were rasterized (16 lanes each).
        pub blocks_tested: u64 => ("blocks_tested", "blocks", "4x4 pixel blocks tested 16-wide"),
        /// Of those, blocks found entirely inside the triangle, so no edge function was evaluated.
        pub blocks_full: u64 => ("blocks_full", "blocks", "blocks entirely inside their triangle (no edge test)"),
        /// Pixel writes that passed the depth test (overdraw included).
        pub depth_writes: u64 => ("depth_writes", "writes", "pixel writes passing the depth test (overdraw included)"),
        /// Pixels the resolve reported covered.
        pub pixels_covered: u64 => ("pixels_covered", "pixels", "pixels that see a triangle"),
    }
}

/// One tile's rasterized state, handed to its [`TileResolve`].
pub struct TileRaster<'a> {
    /// The view.
    pub view: &'a RasterView,
    /// Pixel position of the tile's top-left corner.
    pub origin: (u32, u32),
    /// Depth and winning triangle per pixel, block-major (see [`TileBuf::index`]).
    pub buf: &'a TileBuf,
    /// The tile's triangles by list position (what the buffer's ids index).
    pub triangles: &'a TileTriangles,
}

/// Turns a rasterized tile into a view's output. Implementations run inside the tile's kernel
/// (mark `resolve` `#[inline(always)]` so it compiles in the kernel's target-feature context).
pub trait TileResolve: Sync {
    /// A tile's piece of the output, handed to its task (one per tile, row-major tile order).
    type Out<'a>: Send;
    /// Task kind of the resolve in counting records.
    const TASK_KIND: u32;
    /// Writes the tile's output; returns the number of pixels covered.
    fn resolve<S: Simd>(&self, s: S, tile: &TileRaster<'_>, out: Self::Out<'_>) -> u64;
}

/// A tile's pieces of one per-pixel output buffer: one slice of at most [`TILE`] pixels per image
/// row of the tile, top to bottom. Uninitialised on entry; a resolve writes every element.
pub struct TileRows<'a, T> {
    /// One slice per image row of the tile, top to bottom, at most [`TILE`] pixels each.
    pub rows: Vec<&'a mut [MaybeUninit<T>]>,
}

/// Splits the spare capacity of `buf` (at least `width * height` elements) into each tile's rows,
/// row-major tile order. The caller sets the length once every tile has written all its elements.
pub fn tile_rows<T>(buf: &mut Vec<T>, width: u32, height: u32) -> Vec<TileRows<'_, T>> {
    let (w, n) = (width as usize, width as usize * height as usize);
    let tiles_x = width.div_ceil(TILE) as usize;
    let tile_count = tiles_x * height.div_ceil(TILE) as usize;
    buf.reserve(n);
    let mut tiles: Vec<TileRows<'_, T>> = (0..tile_count).map(|_| TileRows { rows: Vec::new() }).collect();
    for (y, row) in buf.spare_capacity_mut()[..n].chunks_mut(w).enumerate() {
        let first = (y / TILE as usize) * tiles_x;
        for (tx, piece) in row.chunks_mut(TILE as usize).enumerate() {
            tiles[first + tx].rows.push(piece);
        }
    }
    tiles
}

/// Rasterizes `scene`'s triangles into `view`, as the three steps of the module docs in `phase`,
/// handing each tile to `resolve` with its piece of `outs` (one per tile, row-major tile order).
/// The result is bit-identical for any execution and any host thread count.
pub fn rasterize<'o, R: TileResolve>(
    phase: &mut Phase,
    scene: &Scene,
    view: &RasterView,
    resolve: &R,
    outs: Vec<R::Out<'o>>,
) -> RasterStats {
    let frame = &view.frame;
    let (tiles_x, tiles_y) = view.tiles();
    let tile_count = (tiles_x * tiles_y) as usize;
    assert_eq!(outs.len(), tile_count, "one output piece per tile");

    // ---- Front end -------------------------------------------------------------------------
    let front = FrontEnd::new(frame, view.z_near, tiles_x);
    let mut offsets = Vec::with_capacity(scene.meshes.len() + 1);
    let mut total = 0usize;
    offsets.push(0usize);
    for m in &scene.meshes {
        total += m.triangles.len();
        offsets.push(total);
    }
    let chunks: Vec<FrontOut> = phase.run_par(
        "front_end",
        (0..total.div_ceil(FRONT_END_CHUNK))
            .into_par_iter()
            .map(|c| FrontEndKernel {
                scene,
                offsets: &offsets,
                range: c * FRONT_END_CHUNK..((c + 1) * FRONT_END_CHUNK).min(total),
                front: &front,
            }),
    );

    let mut stats = RasterStats {
        tiles: tile_count as u64,
        ..RasterStats::default()
    };
    // Counting sort of the (tile, triangle) pairs by tile, chunks in order: each tile's list is in
    // triangle order. The chunks' triangles stay where they are (a packed id names chunk and slot).
    let mut counts = vec![0u32; tile_count + 1];
    for out in &chunks {
        stats.triangles_in += out.triangles_in;
        stats.triangles_clipped += out.triangles_clipped;
        stats.triangles_culled += out.triangles_culled;
        stats.screen_triangles += out.tris.len() as u64;
        for &(tile, _) in &out.pairs {
            counts[tile as usize + 1] += 1;
        }
    }
    for i in 0..tile_count {
        counts[i + 1] += counts[i];
    }
    let mut fill: Vec<u32> = counts[..tile_count].to_vec();
    let mut lists = vec![0u32; counts[tile_count] as usize];
    // One task per chunk; they share the fill positions, so the host runs them in chunk order.
    for (c, out) in chunks.iter().enumerate() {
        phase.run(
            "tile_lists",
            TileListsKernel {
                chunk: c,
                pairs: &out.pairs,
                fill: &mut fill,
                lists: &mut lists,
            },
        );
    }
    let tris = TriStore {
        chunks: chunks.iter().map(|out| &out.tris[..]).collect(),
    };
    stats.tile_triangle_pairs = lists.len() as u64;

    // ---- Back end: one task per tile, rasterize then resolve --------------------------------
    let tiles: Vec<TileCounts> = phase.run_par(
        "tiles",
        outs.into_par_iter().enumerate().map(|(t, out)| TileKernel {
            view,
            tris: &tris,
            list: &lists[counts[t] as usize..counts[t + 1] as usize],
            origin: ((t as u32 % tiles_x) * TILE, (t as u32 / tiles_x) * TILE),
            resolve,
            out,
        }),
    );
    for c in tiles {
        stats.subtiles_tested += c.subtiles_tested;
        stats.blocks_tested += c.blocks_tested;
        stats.blocks_full += c.blocks_full;
        stats.depth_writes += c.depth_writes;
        stats.pixels_covered += c.pixels_covered;
    }
    stats
}

/// Bits of a packed screen-triangle id that hold its slot in its front-end chunk (a chunk emits at
/// most two screen triangles per scene triangle).
const ID_SLOT_BITS: u32 = 13;
const _: () = assert!(2 * FRONT_END_CHUNK <= 1 << ID_SLOT_BITS);

/// Packed id of screen triangle `slot` of front-end chunk `chunk`; ids sort in triangle order.
#[inline]
fn pack_id(chunk: usize, slot: u32) -> u32 {
    ((chunk as u32) << ID_SLOT_BITS) | slot
}

/// The screen triangles, chunk by chunk, addressed by packed id.
struct TriStore<'a> {
    chunks: Vec<&'a [ScreenTri]>,
}

impl TriStore<'_> {
    #[inline(always)]
    fn get(&self, id: u32) -> &ScreenTri {
        &self.chunks[(id >> ID_SLOT_BITS) as usize][(id & ((1 << ID_SLOT_BITS) - 1)) as usize]
    }
}

/// Step `tile_lists`: a front-end chunk's (tile, triangle) pairs written into the per-tile lists at
/// the tiles' fill positions (the histogram before it is folded into this task's scalar count).
struct TileListsKernel<'a> {
    chunk: usize,
    pairs: &'a [(u32, u32)],
    fill: &'a mut [u32],
    lists: &'a mut [u32],
}

impl Kernel for TileListsKernel<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::RASTER_TILE_LISTS);
        // Per pair: its load, the tile's fill position read, the packed id (a shift and an or)
        // stored, the position advanced.
        for i in 0..self.pairs.len() {
            let (tile, local) = s.s_load(self.pairs, i);
            let slot = s.s_load(self.fill, tile as usize);
            s.scalar_op(ScalarClass::Alu);
            s.scalar_op(ScalarClass::Alu);
            s.s_store(self.lists, slot as usize, pack_id(self.chunk, local));
            s.s_store(self.fill, tile as usize, s.s_add(slot, 1));
        }
        s.end_task();
    }
}

// ---------------------------------------------------------------------------------------------------
// Front end

/// A triangle after clipping and projection, ready for the back end.
#[derive(Clone, Copy, Debug)]
struct ScreenTri {
    /// Screen positions, pixels: x right, y down, pixel `(i, j)` centred at `(i + 0.5, j + 0.5)`.
    v: [[f32; 2]; 3],
    /// View-space depths (along `forward`), world units, all `> z_near`.
    z: [f32; 3],
    /// Sign of the screen-space area `edge(v0 -> v1)(v2)`: true when positive.
    positive: bool,
    /// Inclusive pixel bounding box `[x0, y0, x1, y1]`, clamped to the image, slightly conservative.
    bbox: [u32; 4],
    /// Index of the source triangle in [`Scene::triangles`] order.
    original: u32,
    /// Unit geometric normal of the source triangle, `(b - a) x (c - a)` normalised (not flipped).
    normal: Vec3,
    /// `normal · (corner - eye)`, world units: the plane's signed distance from the eye, so the
    /// centre ray `eye + t * dir` meets the plane at `t = plane_dist / (normal · dir)`.
    plane_dist: f32,
}

/// The camera and image constants of the front end.
struct FrontEnd {
    eye: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    /// `1 / (tan(fov_y/2) * aspect)` and `1 / tan(fov_y/2)`, rounded once from f64.
    inv_ta: f32,
    inv_t: f32,
    /// Half the image width and height, pixels (exact).
    half_w: f32,
    half_h: f32,
    /// Image width and height, pixels (exact: at most [`crate::scene::MAX_PIXELS`]).
    w: f32,
    h: f32,
    z_near: f32,
    tiles_x: u32,
}

/// Relative rounding-error bound of the f32 screen-space area `dx1 * dy2 - dy1 * dx2` against the
/// magnitudes of its two products: Shewchuk's `(3 + 16 ε) ε` for `orient2d` with ε = 2⁻²⁴, rounded up
/// to 4ε. Where `|area| >` this times `|dx1 * dy2| + |dy1 * dx2|`, the f32 sign is the exact sign.
const AREA_REL_ERROR: f32 = 4.0 * f32::EPSILON / 2.0;
/// Below this error bound the products may have underflowed (the relative bound fails): such
/// triangles (areas under 2⁻⁷⁸ square pixels) take the exact f64 test.
const AREA_MIN_BOUND: f32 = 1.0 / (1u128 << 100) as f32;
/// Margins of the pixel bounding box, pixels: a constant and a share of the coordinates' magnitude,
/// so a centre the edge functions place inside after rounding is never cut off by the box. The
/// relative part is 8× the f32 rounding of the box's own arithmetic.
const BOX_MARGIN: f32 = 1.0 / 64.0;
const BOX_REL_MARGIN: f32 = 1e-6;

impl FrontEnd {
    fn new(frame: &CameraFrame, z_near: f32, tiles_x: u32) -> Self {
        let t = frame.tan_half_fov as f64;
        Self {
            eye: frame.eye,
            right: frame.right,
            up: frame.up,
            forward: frame.forward,
            inv_ta: (1.0 / (t * frame.aspect as f64)) as f32,
            inv_t: (1.0 / t) as f32,
            half_w: 0.5 * frame.width as f32,
            half_h: 0.5 * frame.height as f32,
            w: frame.width as f32,
            h: frame.height as f32,
            z_near,
            tiles_x,
        }
    }

    /// View-space coordinates of world point `p`: (right, up, forward) components of `p - eye`.
    #[inline(always)]
    fn view<S: Simd>(&self, s: S, p: Vec3) -> Vec3 {
        let d = counted::sub(s, p, self.eye);
        Vec3::new(
            counted::dot(s, d, self.right),
            counted::dot(s, d, self.up),
            counted::dot(s, d, self.forward),
        )
    }

    /// Screen position of a view-space point with `z > 0`, pixels: in f32, the operations of the
    /// 16-lane [`FrontEnd::setup_lanes`] in the same order, so a vertex projects to the same bits on
    /// either path (shared edges stay watertight between clipped and unclipped triangles).
    #[inline(always)]
    fn project<S: Simd>(&self, s: S, v: Vec3) -> [f32; 2] {
        [
            s.s_mul(s.s_add(s.s_mul(s.s_div(v.x, v.z), self.inv_ta), 1.0), self.half_w),
            s.s_mul(s.s_sub(1.0, s.s_mul(s.s_div(v.y, v.z), self.inv_t)), self.half_h),
        ]
    }

    /// Clips, projects and bins world triangle `p` (index `original`), one triangle in scalar code:
    /// the path of triangles crossing the near plane (and of meshes too large for 32-bit lane
    /// indices). Returns true when it produced at least one screen triangle. Every scalar operation
    /// is counted.
    #[inline(always)]
    fn setup<S: Simd>(&self, s: S, p: [Vec3; 3], original: u32, out: &mut FrontOut) -> bool {
        let normal = counted::normalize_or_zero(
            s,
            counted::cross(s, counted::sub(s, p[1], p[0]), counted::sub(s, p[2], p[0])),
        );
        // Three compares and their branch.
        s.scalar_op(ScalarClass::Branch);
        s.scalar_op(ScalarClass::Branch);
        if s.s_branch(normal == Vec3::ZERO) {
            return false; // zero area in the world: nothing to see, and no normal
        }
        let v = [self.view(s, p[0]), self.view(s, p[1]), self.view(s, p[2])];
        let inside = [
            s.s_lt(self.z_near, v[0].z),
            s.s_lt(self.z_near, v[1].z),
            s.s_lt(self.z_near, v[2].z),
        ];
        let n_inside = inside.iter().filter(|&&b| b).count();
        // Sutherland–Hodgman against z > z_near; winding is preserved.
        let mut poly = [Vec3::ZERO; 4];
        let mut n = 0;
        if s.s_branch(n_inside == 0) {
            return false;
        } else if s.s_branch(n_inside == 3) {
            poly[..3].copy_from_slice(&v);
            n = 3;
        } else {
            out.triangles_clipped += 1;
            for k in 0..3 {
                let (a, b) = (v[k], v[(k + 1) % 3]);
                if s.s_branch(inside[k]) {
                    poly[n] = a;
                    n += 1;
                }
                if s.s_branch(inside[k] != inside[(k + 1) % 3]) {
                    // Always interpolate from the inside endpoint to the outside one, so the two
                    // triangles sharing this edge create the bit-identical vertex.
                    let (i, o) = if inside[k] { (a, b) } else { (b, a) };
                    let t = s.s_div(s.s_sub(self.z_near, i.z), s.s_sub(o.z, i.z));
                    let mut q = counted::add(s, i, counted::scale(s, counted::sub(s, o, i), t));
                    q.z = self.z_near;
                    poly[n] = q;
                    n += 1;
                }
            }
        }
        let plane_dist = counted::dot(s, normal, counted::sub(s, p[0], self.eye));
        let mut any = false;
        for k in 1..n - 1 {
            any |= self.emit(
                s,
                [poly[0], poly[k], poly[k + 1]],
                original,
                normal,
                plane_dist,
                out,
            );
        }
        any
    }

    /// [`FrontEnd::setup`] of triangle `t` of `mesh` (global index `original`), its corners loaded
    /// and counted; a triangle that gives no screen triangle is counted culled.
    #[inline(always)]
    fn setup_one<S: Simd>(
        &self,
        s: S,
        mesh: &crate::scene::Mesh,
        t: usize,
        original: usize,
        out: &mut FrontOut,
    ) {
        let [a, b, c] = s.s_load(&mesh.triangles, t);
        let corners = [
            s.s_load(&mesh.positions, a as usize),
            s.s_load(&mesh.positions, b as usize),
            s.s_load(&mesh.positions, c as usize),
        ];
        if !self.setup(s, corners, original as u32, out) {
            out.triangles_culled += 1;
        }
    }

    /// Projects one view-space triangle in front of the near plane, culls and bins it (scalar).
    #[inline(always)]
    fn emit<S: Simd>(
        &self,
        s: S,
        v: [Vec3; 3],
        original: u32,
        normal: Vec3,
        plane_dist: f32,
        out: &mut FrontOut,
    ) -> bool {
        let sp = [
            self.project(s, v[0]),
            self.project(s, v[1]),
            self.project(s, v[2]),
        ];
        let Some(positive) = exact_area_sign(s, &sp) else {
            return false; // zero area on screen (seen edge-on): covers no pixel centre consistently
        };
        let (Some((x0, x1)), Some((y0, y1))) = (
            pixel_range(s, sp[0][0], sp[1][0], sp[2][0], self.w),
            pixel_range(s, sp[0][1], sp[1][1], sp[2][1], self.h),
        ) else {
            return false;
        };
        self.bin(
            s,
            ScreenTri {
                v: sp,
                z: [v[0].z, v[1].z, v[2].z],
                positive,
                bbox: [x0, y0, x1, y1],
                original,
                normal,
                plane_dist,
            },
            out,
        );
        true
    }

    /// Stores screen triangle `t` and its (tile, triangle) pairs, one per tile of its box.
    #[inline(always)]
    fn bin<S: Simd>(&self, s: S, t: ScreenTri, out: &mut FrontOut) {
        let index = out.tris.len() as u32;
        let [x0, y0, x1, y1] = t.bbox;
        // Its fields were computed apart: stored a word at a time.
        s.s_push_words(&mut out.tris, t);
        for ty in y0 / TILE..=y1 / TILE {
            for tx in x0 / TILE..=x1 / TILE {
                s.s_push(&mut out.pairs, (s.s_add(s.s_mul(ty, self.tiles_x), tx), index));
            }
        }
    }

    /// The front end of triangles `first..first + n` (`n` in 1..=16) of `mesh`, whose global index
    /// is `global + lane`, as Larrabee's renderer did its triangle setup: 16 triangles a vector.
    /// Their corners are gathered, their normals, view-space corners, near-plane tests, projections,
    /// screen areas and pixel boxes computed on 16 lanes; then each triangle, in source order, is
    /// binned (whole in front of the near plane), clipped by the scalar [`FrontEnd::setup`] (crossing
    /// it) or culled. Results are bit-identical to [`FrontEnd::setup`] on every triangle: the same
    /// f32 operations in the same order, and screen areas whose f32 sign is not certain (slivers,
    /// overflow) decided by the scalar path's exact f64 area.
    #[inline(always)]
    fn setup_lanes<S: Simd>(
        &self,
        s: S,
        mesh: &crate::scene::Mesh,
        first: usize,
        n: usize,
        global: usize,
        out: &mut FrontOut,
    ) {
        let zero = s.splat_f(0.0);
        let zero_i = s.splat_i(0);
        let live = s.mask_first_n(n);
        // Corner indices (3 gathers), then the corners' coordinates (9 gathers).
        let flat_tris = sism_simd::as_i32(mesh.triangles.as_flattened());
        let flat_pos = flat_positions(&mesh.positions);
        let tri = s.mul_i(s.add_i(s.index_i(), s.splat_i(first as i32)), s.splat_i(3));
        let mut p = [[zero; 3]; 3];
        for (k, corner) in p.iter_mut().enumerate() {
            let vertex = s.mask_gather_i(zero_i, live, flat_tris, s.add_i(tri, s.splat_i(k as i32)));
            let base = s.mul_i(vertex, s.splat_i(3));
            for (c, coord) in corner.iter_mut().enumerate() {
                *coord = s.mask_gather_f(zero, live, flat_pos, s.add_i(base, s.splat_i(c as i32)));
            }
        }
        // The unit normal, as `counted::normalize_or_zero(counted::cross(p1 - p0, p2 - p0))`.
        let e1 = sub3(s, &p[1], &p[0]);
        let e2 = sub3(s, &p[2], &p[0]);
        let cr = [
            s.sub_f(s.mul_f(e1[1], e2[2]), s.mul_f(e2[1], e1[2])),
            s.sub_f(s.mul_f(e1[2], e2[0]), s.mul_f(e2[2], e1[0])),
            s.sub_f(s.mul_f(e1[0], e2[1]), s.mul_f(e2[0], e1[1])),
        ];
        let rcp = s.div_f(s.splat_f(1.0), s.sqrt_f(dot3_unfused(s, &cr, &cr)));
        let unit = s.mask_and(s.cmp_lt_f(rcp, s.splat_f(f32::INFINITY)), s.cmp_gt_f(rcp, zero));
        let mut normal = [zero; 3];
        for c in 0..3 {
            normal[c] = s.select_f(unit, s.mul_f(cr[c], rcp), zero);
        }
        let flat = s.mask_and(
            s.mask_and(s.cmp_eq_f(normal[0], zero), s.cmp_eq_f(normal[1], zero)),
            s.cmp_eq_f(normal[2], zero),
        );
        // View-space corners and the near-plane tests.
        let (eye, axes) = (
            splat3(s, self.eye),
            [splat3(s, self.right), splat3(s, self.up), splat3(s, self.forward)],
        );
        let z_near = s.splat_f(self.z_near);
        let mut rel = [[zero; 3]; 3];
        let mut v = [[zero; 3]; 3];
        let mut all_in = live;
        let mut any_in = Mask16::from_bits(0);
        for k in 0..3 {
            rel[k] = sub3(s, &p[k], &eye);
            for a in 0..3 {
                v[k][a] = dot3_unfused(s, &rel[k], &axes[a]);
            }
            let inside = s.cmp_lt_f(z_near, v[k][2]);
            all_in = s.mask_and(all_in, inside);
            any_in = s.mask_or(any_in, inside);
        }
        let seen = s.mask_andn(flat, live);
        let whole = s.mask_and(seen, all_in);
        let crossing = s.mask_andn(all_in, s.mask_and(seen, any_in));
        // Projection, as `FrontEnd::project`.
        let (one, inv_ta, inv_t) = (s.splat_f(1.0), s.splat_f(self.inv_ta), s.splat_f(self.inv_t));
        let (half_w, half_h) = (s.splat_f(self.half_w), s.splat_f(self.half_h));
        let mut sx = [zero; 3];
        let mut sy = [zero; 3];
        for k in 0..3 {
            let x = s.mul_f(s.div_f(v[k][0], v[k][2]), inv_ta);
            sx[k] = s.mul_f(s.add_f(x, one), half_w);
            let y = s.mul_f(s.div_f(v[k][1], v[k][2]), inv_t);
            sy[k] = s.mul_f(s.sub_f(one, y), half_h);
        }
        // Screen area's sign with an error filter: certain lanes take the f32 sign.
        let left = s.mul_f(s.sub_f(sx[1], sx[0]), s.sub_f(sy[2], sy[0]));
        let right = s.mul_f(s.sub_f(sy[1], sy[0]), s.sub_f(sx[2], sx[0]));
        let area = s.sub_f(left, right);
        let bound = s.mul_f(s.add_f(s.abs_f(left), s.abs_f(right)), s.splat_f(AREA_REL_ERROR));
        let certain = s.mask_and(
            s.cmp_gt_f(s.abs_f(area), bound),
            s.cmp_gt_f(bound, s.splat_f(AREA_MIN_BOUND)),
        );
        let positive = s.cmp_gt_f(area, zero);
        // Pixel boxes, as `pixel_range`.
        let (x0, x1, x_ok) = pixel_range_lanes(s, &sx, self.w);
        let (y0, y1, y_ok) = pixel_range_lanes(s, &sy, self.h);
        let boxed = s.mask_and(x_ok, y_ok);
        let plane_dist = dot3_unfused(s, &normal, &rel[0]);

        // Lanes to memory (line-aligned: one line per array in the counted line stream, wherever
        // the stack puts it), then each triangle in source order.
        let mut lanes_v = [[LaneArray([0.0f32; 16]); 3]; 3];
        let mut lanes_n = [LaneArray([0.0f32; 16]); 3];
        for k in 0..3 {
            lanes_v[k][0] = LaneArray(s.to_array_f(sx[k]));
            lanes_v[k][1] = LaneArray(s.to_array_f(sy[k]));
            lanes_v[k][2] = LaneArray(s.to_array_f(v[k][2]));
            lanes_n[k] = LaneArray(s.to_array_f(normal[k]));
        }
        let lanes_d = LaneArray(s.to_array_f(plane_dist));
        let lanes_box = [
            LaneArray(s.to_array_i(x0)),
            LaneArray(s.to_array_i(y0)),
            LaneArray(s.to_array_i(x1)),
            LaneArray(s.to_array_i(y1)),
        ];
        for lane in 0..n {
            let g = global + lane;
            if s.s_branch(whole.test(lane)) {
                let mut sp = [[0.0f32; 2]; 3];
                for (k, corner) in sp.iter_mut().enumerate() {
                    *corner = [s.s_load(&lanes_v[k][0].0, lane), s.s_load(&lanes_v[k][1].0, lane)];
                }
                let sign = if s.s_branch(certain.test(lane)) {
                    Some(positive.test(lane))
                } else {
                    exact_area_sign(s, &sp)
                };
                let (Some(positive), true) = (sign, s.s_branch(boxed.test(lane))) else {
                    out.triangles_culled += 1;
                    continue;
                };
                let z = [
                    s.s_load(&lanes_v[0][2].0, lane),
                    s.s_load(&lanes_v[1][2].0, lane),
                    s.s_load(&lanes_v[2][2].0, lane),
                ];
                let normal = Vec3::new(
                    s.s_load(&lanes_n[0].0, lane),
                    s.s_load(&lanes_n[1].0, lane),
                    s.s_load(&lanes_n[2].0, lane),
                );
                let mut bbox = [0u32; 4];
                for (b, lanes) in bbox.iter_mut().zip(&lanes_box) {
                    *b = s.s_load(&lanes.0, lane) as u32;
                }
                let plane_dist = s.s_load(&lanes_d.0, lane);
                self.bin(
                    s,
                    ScreenTri {
                        v: sp,
                        z,
                        positive,
                        bbox,
                        original: g as u32,
                        normal,
                        plane_dist,
                    },
                    out,
                );
            } else if s.s_branch(crossing.test(lane)) {
                self.setup_one(s, mesh, first + lane, g, out);
            } else {
                out.triangles_culled += 1; // degenerate in the world or wholly behind the near plane
            }
        }
    }
}

/// `mesh.positions` as one flat `[x0, y0, z0, x1, …]` slice, for gathers.
fn flat_positions(positions: &[Vec3]) -> &[f32] {
    const _: () = assert!(
        std::mem::size_of::<Vec3>() == 12 && std::mem::align_of::<Vec3>() == 4,
        "glam's Vec3 is three packed f32"
    );
    // SAFETY: glam's `Vec3` (no SIMD storage: 12 bytes, align 4, checked above) is `#[repr(C)]`
    // `{ x: f32, y: f32, z: f32 }`, so `len` of them are `3 * len` initialised, contiguous f32s,
    // borrowed for the same lifetime.
    unsafe { std::slice::from_raw_parts(positions.as_ptr().cast::<f32>(), positions.len() * 3) }
}

/// The exact sign of the screen area `(v1 - v0) × (v2 - v0)` of f32 corners, in f64 (the differences
/// and products are exact there, so only the last subtraction rounds, which keeps the sign): `None`
/// when it is zero or not finite (seen edge-on, or overflowed), else whether it is positive.
#[inline(always)]
fn exact_area_sign<S: Simd>(s: S, sp: &[[f32; 2]; 3]) -> Option<bool> {
    let f = |i: usize, c: usize| wide(s, sp[i][c]);
    let area2 = s.s_sub(
        s.s_mul(s.s_sub(f(1, 0), f(0, 0)), s.s_sub(f(2, 1), f(0, 1))),
        s.s_mul(s.s_sub(f(1, 1), f(0, 1)), s.s_sub(f(2, 0), f(0, 0))),
    );
    s.scalar_op(ScalarClass::Branch);
    if s.s_branch(area2 == 0.0 || !area2.is_finite()) {
        return None;
    }
    Some(s.s_lt(0.0, area2))
}

/// Inclusive range of pixel columns (or rows) whose centres `i + 0.5` lie in `[min, max]` of the
/// three finite coordinates `a, b, c`, widened by the box margins and clamped to `[0, size - 1]`;
/// `None` when empty. f32, the operations of [`pixel_range_lanes`] in the same order.
#[inline(always)]
fn pixel_range<S: Simd>(s: S, a: f32, b: f32, c: f32, size: f32) -> Option<(u32, u32)> {
    let lo = s.s_min(s.s_min(a, b), c);
    let hi = s.s_max(s.s_max(a, b), c);
    let magnitude = s.s_max(
        s.s_fn(ScalarClass::Float, lo, f32::abs),
        s.s_fn(ScalarClass::Float, hi, f32::abs),
    );
    let margin = s.s_add(BOX_MARGIN, s.s_mul(BOX_REL_MARGIN, magnitude));
    let first = s.s_max(
        s.s_fn(ScalarClass::Float, s.s_sub(s.s_sub(lo, 0.5), margin), f32::ceil),
        0.0,
    );
    let last = s.s_min(
        s.s_fn(ScalarClass::Float, s.s_add(s.s_sub(hi, 0.5), margin), f32::floor),
        s.s_sub(size, 1.0),
    );
    s.scalar_op(ScalarClass::Alu);
    s.scalar_op(ScalarClass::Alu);
    s.s_le(first, last).then_some((first as u32, last as u32))
}

/// [`pixel_range`] on 16 lanes: first and last pixel (valid where the mask is set) and the mask of
/// lanes whose range is not empty.
#[inline(always)]
fn pixel_range_lanes<S: Simd>(s: S, c: &[S::F32; 3], size: f32) -> (S::I32, S::I32, Mask16) {
    let lo = s.min_f(s.min_f(c[0], c[1]), c[2]);
    let hi = s.max_f(s.max_f(c[0], c[1]), c[2]);
    let magnitude = s.max_f(s.abs_f(lo), s.abs_f(hi));
    let margin = s.add_f(
        s.splat_f(BOX_MARGIN),
        s.mul_f(s.splat_f(BOX_REL_MARGIN), magnitude),
    );
    let half = s.splat_f(0.5);
    let first = s.max_f(s.ceil_f(s.sub_f(s.sub_f(lo, half), margin)), s.splat_f(0.0));
    let last = s.min_f(
        s.floor_f(s.add_f(s.sub_f(hi, half), margin)),
        s.splat_f(size - 1.0),
    );
    let ok = s.cmp_le_f(first, last);
    // Where `ok`, 0 <= first <= last <= size - 1: exact small integers. Elsewhere the values are
    // unused; the clamps keep the conversions in range anyway.
    (
        s.cvtt_f_i(s.min_f(first, s.splat_f(size))),
        s.cvtt_f_i(s.max_f(last, s.splat_f(-1.0))),
        ok,
    )
}

/// What one front-end chunk produces.
#[derive(Default)]
struct FrontOut {
    /// Screen triangles, in source order.
    tris: Vec<ScreenTri>,
    /// `(tile, index into tris)` pairs, in triangle order.
    pairs: Vec<(u32, u32)>,
    triangles_in: u64,
    triangles_clipped: u64,
    triangles_culled: u64,
}

/// The front end of triangles `range` (global indices in [`Scene::triangles`] order).
struct FrontEndKernel<'a> {
    scene: &'a Scene,
    /// Global index of each mesh's first triangle, plus the total at the end.
    offsets: &'a [usize],
    range: std::ops::Range<usize>,
    front: &'a FrontEnd,
}

impl Kernel for FrontEndKernel<'_> {
    type Output = FrontOut;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> FrontOut {
        s.begin_task(task_kind::RASTER_FRONT_END);
        // Room for every triangle and a pair each (more only where triangles are clipped in two
        // or span tiles): growing by pushes would copy the chunk's output several times, host work
        // no counted operation stands for.
        let mut out = FrontOut {
            tris: Vec::with_capacity(self.range.len()),
            pairs: Vec::with_capacity(self.range.len() + self.range.len() / 4),
            ..FrontOut::default()
        };
        let mut g = self.range.start;
        let mut m = self.offsets.partition_point(|&o| o <= g) - 1;
        while g < self.range.end {
            while g >= self.offsets[m + 1] {
                m += 1;
            }
            let mesh = &self.scene.meshes[m];
            let first = g - self.offsets[m];
            // 16 triangles of one mesh at a time (fewer at a mesh's or the chunk's end).
            let n = (self.offsets[m + 1].min(self.range.end) - g).min(16);
            out.triangles_in += n as u64;
            // Lane indices are i32: a mesh with more coordinates than that takes the scalar path.
            if s.s_branch(mesh.positions.len() * 3 <= i32::MAX as usize) {
                self.front.setup_lanes(s, mesh, first, n, g, &mut out);
            } else {
                for lane in 0..n {
                    self.front.setup_one(s, mesh, first + lane, g + lane, &mut out);
                }
            }
            g += n;
        }
        s.end_task();
        out
    }
}

// ---------------------------------------------------------------------------------------------------
// Back end

/// A tile's depth and triangle buffers in block-major order: 4×4 block `(bx, by)` (in blocks) holds
/// lanes `16 * (16 * by + bx) ..` with lane `4 * row + column`, so a block is one aligned vector.
#[repr(C, align(64))]
pub struct TileBuf {
    /// Largest `1/z` so far, 1/world units; 0 = nothing (infinitely far).
    pub inv_z: [f32; TILE_PIXELS],
    /// Winning triangle's position in the tile's list, -1 = none.
    pub id: [i32; TILE_PIXELS],
}

impl TileBuf {
    /// Clears the buffer (depth 0, no triangle) with the kernel's own vector stores: 32 KiB a tile,
    /// the back end's first work on a tile, counted as it executes. The buffer lives on the task's
    /// stack, as a core's tile buffer stays in its cache from tile to tile: the counting context
    /// renames stack lines alike for every task, so the model's caches keep it warm as the host's
    /// do. (A boxed buffer was fresh memory to the model at every tile, since the counting
    /// allocator never reuses an address within a frame, and `Box::new` of the filled arrays built
    /// them on the stack and copied them over, uncounted.) It clears in place: a constructor
    /// returning the 32 KiB value was compiled as a copy into the caller's frame, uncounted too.
    #[inline(always)]
    fn clear<S: Simd>(&mut self, s: S) {
        let (nothing, none) = (s.splat_f(0.0), s.splat_i(-1));
        for i in (0..TILE_PIXELS).step_by(16) {
            s.store_f(&mut self.inv_z[i..i + 16], nothing);
            s.store_i(&mut self.id[i..i + 16], none);
        }
    }

    /// Index in the buffers of the pixel at tile-local `(x, y)`.
    #[inline]
    pub fn index(x: u32, y: u32) -> usize {
        (((y / 4) * (TILE / 4) + x / 4) * 16 + (y % 4) * 4 + x % 4) as usize
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct TileCounts {
    subtiles_tested: u64,
    blocks_tested: u64,
    blocks_full: u64,
    depth_writes: u64,
    pixels_covered: u64,
}

/// One edge function of a triangle on one tile: value `a * dx + b * dy + e` at tile-local pixel
/// position `(dx, dy)`, positive inside.
#[derive(Clone, Copy)]
struct EdgeSetup {
    a: f32,
    b: f32,
    e: f32,
    /// Does a value of exactly 0 count as inside (the tie rule)?
    inclusive: bool,
    /// Bound on the rounding error of any value over the tile, plus a wide safety factor: the
    /// rejection tests use it so they never reject a pixel the per-pixel test would accept.
    eps: f32,
}

/// Edge `k` (from vertex `k` to `k + 1`) of `t` relative to tile origin `(ox, oy)`, set up in f64,
/// every scalar operation counted.
#[inline(always)]
fn edge_setup<S: Simd>(s: S, t: &ScreenTri, k: usize, ox: f64, oy: f64) -> EdgeSetup {
    let (p, q) = (t.v[k], t.v[(k + 1) % 3]);
    // Canonical order: the endpoint with the smaller (y, x) first (two compares).
    s.scalar_op(ScalarClass::Branch);
    let flip = s.s_branch((q[1], q[0]) < (p[1], p[0]));
    let (a, b) = if flip { (q, p) } else { (p, q) };
    let (ax, ay) = (wide(s, a[0]), wide(s, a[1]));
    let ex = s.s_sub(wide(s, b[0]), ax);
    let ey = s.s_sub(wide(s, b[1]), ay);
    let e = s.s_sub(s.s_mul(ex, s.s_sub(oy, ay)), s.s_mul(ey, s.s_sub(ox, ax)));
    // The triangle lies on the positive side of its edges when its area is positive; the
    // canonical flip negates. Negation commutes exactly with rounding and with fma.
    let inside_positive = t.positive != flip;
    let sign = if s.s_branch(inside_positive) { 1.0 } else { -1.0 };
    let (a32, b32, e32) = (
        narrow(s, s.s_mul(sign, neg(s, ey))),
        narrow(s, s.s_mul(sign, ex)),
        narrow(s, s.s_mul(sign, e)),
    );
    let abs = |x: f32| s.s_fn(ScalarClass::Alu, x, f32::abs);
    let reach = s.s_mul(TILE as f32, s.s_add(abs(a32), abs(b32)));
    EdgeSetup {
        a: a32,
        b: b32,
        e: e32,
        inclusive: inside_positive,
        eps: s.s_mul(s.s_add(abs(e32), reach), 1.0 / (1 << 20) as f32),
    }
}

/// `x as f64`, counted (a conversion).
#[inline(always)]
fn wide<S: Simd>(s: S, x: f32) -> f64 {
    s.s_fn(ScalarClass::Alu, x, f64::from)
}

/// `x as f32`, counted (a conversion).
#[inline(always)]
fn narrow<S: Simd>(s: S, x: f64) -> f32 {
    s.scalar_op(ScalarClass::Alu);
    x as f32
}

/// `-x`, counted (a sign flip).
#[inline(always)]
fn neg<S: Simd>(s: S, x: f64) -> f64 {
    s.scalar_op(ScalarClass::Alu);
    -x
}

/// Edge functions and depth plane of `t` relative to tile origin `(ox, oy)` (pixels), in f64, every
/// scalar operation counted.
#[inline(always)]
fn tile_setup<S: Simd>(s: S, t: &ScreenTri, ox: f64, oy: f64) -> ([EdgeSetup; 3], [f32; 5]) {
    let edges = [
        edge_setup(s, t, 0, ox, oy),
        edge_setup(s, t, 1, ox, oy),
        edge_setup(s, t, 2, ox, oy),
    ];
    // 1/z is affine in screen space: solve its plane from the three vertices.
    let iz = [
        s.s_div(1.0, wide(s, t.z[0])),
        s.s_div(1.0, wide(s, t.z[1])),
        s.s_div(1.0, wide(s, t.z[2])),
    ];
    let (x0, y0) = (wide(s, t.v[0][0]), wide(s, t.v[0][1]));
    let (d1x, d1y) = (s.s_sub(wide(s, t.v[1][0]), x0), s.s_sub(wide(s, t.v[1][1]), y0));
    let (d2x, d2y) = (s.s_sub(wide(s, t.v[2][0]), x0), s.s_sub(wide(s, t.v[2][1]), y0));
    let det = s.s_sub(s.s_mul(d1x, d2y), s.s_mul(d1y, d2x));
    let (di1, di2) = (s.s_sub(iz[1], iz[0]), s.s_sub(iz[2], iz[0]));
    let gx = s.s_div(s.s_sub(s.s_mul(di1, d2y), s.s_mul(di2, d1y)), det);
    let gy = s.s_div(s.s_sub(s.s_mul(di2, d1x), s.s_mul(di1, d2x)), det);
    let d = s.s_add(
        s.s_add(iz[0], s.s_mul(gx, s.s_sub(ox, x0))),
        s.s_mul(gy, s.s_sub(oy, y0)),
    );
    let lo = s.s_min(s.s_min(iz[0], iz[1]), iz[2]);
    let hi = s.s_max(s.s_max(iz[0], iz[1]), iz[2]);
    (
        edges,
        [
            narrow(s, gx),
            narrow(s, gy),
            narrow(s, d),
            narrow(s, lo),
            narrow(s, hi),
        ],
    )
}

/// Rasterizes a tile's triangle list into a [`TileBuf`], then hands it to the view's resolve.
struct TileKernel<'a, 'o, R: TileResolve> {
    view: &'a RasterView,
    tris: &'a TriStore<'a>,
    /// Packed ids of the tile's triangles, ascending (triangle order).
    list: &'a [u32],
    /// Pixel position of the tile's top-left corner.
    origin: (u32, u32),
    resolve: &'a R,
    /// The tile's piece of the output.
    out: R::Out<'o>,
}

/// An edge's coefficients broadcast to registers `(a, b, e)`.
#[inline(always)]
fn splat_edge<S: Simd>(s: S, e: &EdgeSetup) -> (S::F32, S::F32, S::F32) {
    (s.splat_f(e.a), s.splat_f(e.b), s.splat_f(e.e))
}

/// Bits of the 4×4 grid cells (`16 * row + ...` as `4 * row + col`) whose columns are in
/// `c0..=c1` and rows in `r0..=r1` (all in 0..4), without a branch: one row's bits times a bit at
/// the start of each chosen row (`row < 16`, so the nibbles do not carry). A loop over the rows
/// would end on a data-dependent trip count (1 to 4) that the host mispredicts; these nine counted
/// integer operations are what the host executes instead.
#[inline(always)]
fn grid_mask<S: Simd>(s: S, c0: u32, c1: u32, r0: u32, r1: u32) -> Mask16 {
    for _ in 0..9 {
        s.scalar_op(ScalarClass::Alu);
    }
    // Counted: bits c0..=c1 of one row (two shifts, a subtract); a bit at 4r for every r in
    // r0..=r1 (two shifts, their amounts 4r taken as free address arithmetic, a subtract, an and);
    // the product (a multiply); its truncation to 16 bits (a move).
    let row = (2u32 << c1) - (1u32 << c0);
    let starts = (0x1111u32 << (4 * r0)) & ((16u32 << (4 * r1)) - 1);
    Mask16((row * starts) as u16)
}

impl<R: TileResolve> Kernel for TileKernel<'_, '_, R> {
    type Output = TileCounts;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> TileCounts {
        s.begin_task(task_kind::RASTER_TILE);
        let mut counts = TileCounts::default();
        let (ox, oy) = self.origin;
        // SAFETY: every bit pattern, all zeros included, is a valid `TileBuf` (arrays of `f32` and
        // `i32`); `clear` then sets every element.
        let mut buf: TileBuf = unsafe { std::mem::zeroed() };
        buf.clear(s);
        // Lane constants: pixel-centre offsets inside a 4×4 block; centres of the sub-tiles of a
        // tile and of the blocks of a sub-tile (relative to its origin).
        let pix_x = s.from_array_f(lanes(|k| (k % 4) as f32 + 0.5));
        let pix_y = s.from_array_f(lanes(|k| (k / 4) as f32 + 0.5));
        let sub_x = s.from_array_f(lanes(|k| ((k % 4) * 16) as f32 + 8.0));
        let sub_y = s.from_array_f(lanes(|k| ((k / 4) * 16) as f32 + 8.0));
        let blk_x = s.from_array_f(lanes(|k| ((k % 4) * 4) as f32 + 2.0));
        let blk_y = s.from_array_f(lanes(|k| ((k / 4) * 4) as f32 + 2.0));
        let mut table = TileTriangles::with_capacity(self.list.len());
        for slot in 0..self.list.len() {
            // The list entry and the triangle it names (its lines in the task's stream).
            let t = self.tris.get(s.s_load(self.list, slot));
            let t = &s.s_read_words(t);
            let (edges, [gx, gy, gd, z_lo, z_hi]) = tile_setup(s, t, ox as f64, oy as f64);
            table.push(s, t, gx, gy);
            // Bounding box ∩ tile, tile-local inclusive pixels.
            let x0 = s.s_sub(s.s_max(t.bbox[0], ox), ox);
            let y0 = s.s_sub(s.s_max(t.bbox[1], oy), oy);
            let x1 = s.s_sub(s.s_min(t.bbox[2], ox + TILE - 1), ox);
            let y1 = s.s_sub(s.s_min(t.bbox[3], oy + TILE - 1), oy);
            let ev = [
                splat_edge(s, &edges[0]),
                splat_edge(s, &edges[1]),
                splat_edge(s, &edges[2]),
            ];
            // Level 1: the 16 sub-tiles; reject where an edge is negative at every pixel centre.
            // The box's sub-tiles: four shifts.
            for _ in 0..4 {
                s.scalar_op(ScalarClass::Alu);
            }
            let mut subs = grid_mask(s, x0 / SUB, x1 / SUB, y0 / SUB, y1 / SUB);
            let reach = |e: &EdgeSetup, k: f32| {
                let abs = |x: f32| s.s_fn(ScalarClass::Alu, x, f32::abs);
                s.s_add(s.s_mul(k, s.s_add(abs(e.a), abs(e.b))), e.eps)
            };
            for (e, &(a, b, c)) in edges.iter().zip(&ev) {
                let v = s.fmadd(a, sub_x, s.fmadd(b, sub_y, c));
                subs = s.mask_and(subs, s.cmp_ge_f(v, s.splat_f(-reach(e, 7.5))));
            }
            // The sub-tiles' loop: its test is a counted branch with its outcome (1 to 16 trips).
            let mut rest = subs.0;
            while let Some(k) = next_lane(s, &mut rest) {
                counts.subtiles_tested += 1;
                // Bit-scan, then the sub-tile's corner: shifts and masks.
                let (sx, sy) = (s.s_mul(k as u32 % 4, SUB), s.s_mul(k as u32 / 4, SUB));
                // Level 2: the 16 blocks of the sub-tile; also find blocks entirely inside. The
                // sub-tile overlaps the box (level 1 started from the box's sub-tiles).
                let bx0 = s.s_sub(s.s_max(x0, sx), sx) / 4;
                let bx1 = s.s_sub(s.s_min(x1, sx + SUB - 1), sx) / 4;
                let by0 = s.s_sub(s.s_max(y0, sy), sy) / 4;
                let by1 = s.s_sub(s.s_min(y1, sy + SUB - 1), sy) / 4;
                let mut blocks = grid_mask(s, bx0, bx1, by0, by1);
                let mut full = blocks;
                let cx = s.add_f(blk_x, s.splat_f(sx as f32));
                let cy = s.add_f(blk_y, s.splat_f(sy as f32));
                for (e, &(a, b, c)) in edges.iter().zip(&ev) {
                    let v = s.fmadd(a, cx, s.fmadd(b, cy, c));
                    let r = reach(e, 1.5);
                    blocks = s.mask_and(blocks, s.cmp_ge_f(v, s.splat_f(-r)));
                    full = s.mask_and(full, s.cmp_gt_f(v, s.splat_f(r)));
                }
                // The blocks' loop, its test counted with its outcome as the sub-tiles' is.
                let mut rest = blocks.0;
                while let Some(b) = next_lane(s, &mut rest) {
                    // Bit-scan, the block's corner, the full test.
                    let bx = s.s_add(sx, (b as u32 % 4) * 4);
                    let by = s.s_add(sy, (b as u32 / 4) * 4);
                    let dx = s.add_f(pix_x, s.splat_f(bx as f32));
                    let dy = s.add_f(pix_y, s.splat_f(by as f32));
                    counts.blocks_tested += 1;
                    let inside = if s.s_branch(full.test(b)) {
                        counts.blocks_full += 1;
                        Mask16::ALL
                    } else {
                        let mut m = Mask16::ALL;
                        for (e, &(a, b, c)) in edges.iter().zip(&ev) {
                            let v = s.fmadd(a, dx, s.fmadd(b, dy, c));
                            let zero = s.splat_f(0.0);
                            // The host branches on the edge's rule here (counted, predicted).
                            let hit = if s.s_branch(e.inclusive) {
                                s.cmp_ge_f(v, zero)
                            } else {
                                s.cmp_gt_f(v, zero)
                            };
                            m = s.mask_and(m, hit);
                        }
                        m
                    };
                    if !s.s_branch(s.mask_any(inside)) {
                        continue;
                    }
                    // Depth: 1/z, clamped to the vertices' range so slivers cannot overshoot.
                    let iz = s.fmadd(s.splat_f(gx), dx, s.fmadd(s.splat_f(gy), dy, s.splat_f(gd)));
                    let iz = s.clamp_f(iz, s.splat_f(z_lo), s.splat_f(z_hi));
                    let base = TileBuf::index(bx, by);
                    let old = s.load_f(&buf.inv_z[base..base + 16]);
                    // Strictly nearer wins: on a tie the earlier triangle (list order) stays.
                    let pass = s.mask_and(inside, s.cmp_gt_f(iz, old));
                    s.mask_store_f(&mut buf.inv_z[base..base + 16], pass, iz);
                    s.mask_store_i(&mut buf.id[base..base + 16], pass, s.splat_i(slot as i32));
                    counts.depth_writes += s.mask_popcnt(pass) as u64;
                }
            }
        }
        s.end_task();
        // Resolve, while the tile's triangles are still in cache.
        s.begin_task(R::TASK_KIND);
        let tile = TileRaster {
            view: self.view,
            origin: self.origin,
            buf: &buf,
            triangles: &table,
        };
        counts.pixels_covered = self.resolve.resolve(s, &tile, self.out);
        s.end_task();
        counts
    }
}

/// What a resolve needs of a tile's triangles, structure-of-arrays by list position (gathered by the
/// buffer's ids).
pub struct TileTriangles {
    /// Unit geometric normal of the source triangle, `(b - a) x (c - a)` normalised (not flipped).
    pub nx: Vec<f32>,
    /// `y` of the unit geometric normal.
    pub ny: Vec<f32>,
    /// `z` of the unit geometric normal.
    pub nz: Vec<f32>,
    /// `normal · (corner - eye)`, world units: the plane's signed distance from the view's eye.
    pub plane_dist: Vec<f32>,
    /// Index of the source triangle in [`Scene::triangles`] order.
    pub original: Vec<i32>,
    /// The plane of `1/z` (view depth) in screen space: its change per pixel along x and y,
    /// 1/world units per pixel (depth maps scale their slope bias with it).
    pub inv_z_dx: Vec<f32>,
    /// Change of `1/z` per pixel along y, 1/world units per pixel.
    pub inv_z_dy: Vec<f32>,
}

impl TileTriangles {
    fn with_capacity(n: usize) -> Self {
        Self {
            nx: Vec::with_capacity(n),
            ny: Vec::with_capacity(n),
            nz: Vec::with_capacity(n),
            plane_dist: Vec::with_capacity(n),
            original: Vec::with_capacity(n),
            inv_z_dx: Vec::with_capacity(n),
            inv_z_dy: Vec::with_capacity(n),
        }
    }

    #[inline(always)]
    fn push<S: Simd>(&mut self, s: S, t: &ScreenTri, inv_z_dx: f32, inv_z_dy: f32) {
        s.s_push(&mut self.nx, t.normal.x);
        s.s_push(&mut self.ny, t.normal.y);
        s.s_push(&mut self.nz, t.normal.z);
        s.s_push(&mut self.plane_dist, t.plane_dist);
        s.s_push(&mut self.original, t.original as i32);
        s.s_push(&mut self.inv_z_dx, inv_z_dx);
        s.s_push(&mut self.inv_z_dy, inv_z_dy);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The branch-free grid mask against its definition (a loop over the rows), for every box
    /// of the 4×4 grid.
    #[test]
    fn grid_mask_matches_the_cells_of_every_box() {
        let s = sism_simd::Portable;
        for (c0, c1, r0, r1) in (0..4).flat_map(|c0| {
            (c0..4).flat_map(move |c1| (0..4).flat_map(move |r0| (r0..4).map(move |r1| (c0, c1, r0, r1))))
        }) {
            let mut want = 0u16;
            for r in r0..=r1 {
                for c in c0..=c1 {
                    want |= 1 << (4 * r + c);
                }
            }
            assert_eq!(
                grid_mask(s, c0, c1, r0, r1).0,
                want,
                "columns {c0}..={c1}, rows {r0}..={r1}"
            );
        }
    }
}
