//! The eye pass: the receiver points of every pixel, by rasterizing the scene into the camera's view
//! (instead of ray casting) and resolving each tile's winners into receivers.
//!
//! The receiver of a covered pixel is the exact intersection of its CONTRACTS.md centre ray with the
//! winning triangle's plane, so it matches ray casting to float precision; the normal is the unit
//! geometric normal flipped to face the camera. The near plane is [`NEAR_PLANE_FRACTION`] of the
//! scene's bounding-box diagonal in front of the eye: geometry closer to the eye plane than that is
//! not seen (ray casting would see it).

use glam::Vec3;
use sism_simd::Simd;

use super::{
    rasterize, tile_rows, RasterStats, RasterView, TileBuf, TileRaster, TileResolve, TileRows, NO_TRIANGLE,
};
use crate::exec::{task_kind, Exec, FrameLog, Phase};
use crate::frame::{Receiver, Receivers};
use crate::scene::Scene;
use crate::stats::{StatRows, StatsReport};
use crate::vmath::{dot3_unfused, lanes, splat3};

/// Near plane distance as a fraction of the scene's bounding-box diagonal.
pub const NEAR_PLANE_FRACTION: f32 = 1e-4;

/// Everything an eye pass produces.
#[derive(Clone, Debug)]
pub struct EyePassOutput {
    /// The receivers, exactly as [`crate::algorithms::reference::cast_primary_rays`] lays them out.
    pub receivers: Receivers,
    /// Per pixel, row-major: the winning triangle's index in [`Scene::triangles`] order, or
    /// [`NO_TRIANGLE`].
    pub triangles: Vec<u32>,
    /// Counts of the rasterization.
    pub stats: RasterStats,
}

impl EyePassOutput {
    /// The eye pass's rows: the raster counts as `eye.*`.
    pub fn stat_rows(&self, out: &mut StatsReport) {
        out.prefixed("eye", |out| self.stats.rows(out));
    }
}

/// The camera's raster view of `scene`: its frame and the near plane.
pub fn camera_view(scene: &Scene) -> RasterView {
    let (lo, hi) = scene.bounds();
    let diagonal = (hi - lo).length();
    let z_near = if diagonal.is_finite() && diagonal > 0.0 {
        NEAR_PLANE_FRACTION * diagonal
    } else {
        1e-6
    };
    RasterView {
        frame: scene.camera.frame(),
        z_near,
    }
}

/// The eye pass of `scene` as the kernels of `phase` (steps `front_end`, `tile_lists`, `tiles`). The
/// output is bit-identical for any execution and any host thread count.
pub fn eye_pass(phase: &mut Phase, scene: &Scene) -> EyePassOutput {
    let view = camera_view(scene);
    let (width, height) = (view.frame.width, view.frame.height);
    let n = width as usize * height as usize;
    // The frame's vectors are written once, in place, by the tiles (pre-filling ~30 bytes per pixel
    // on one thread would cost as much as the resolve). Each tile gets its own row pieces.
    let mut pixels: Vec<Option<Receiver>> = Vec::with_capacity(n);
    let mut triangles: Vec<u32> = Vec::with_capacity(n);
    let outs: Vec<EyeTileOut<'_>> = tile_rows(&mut pixels, width, height)
        .into_iter()
        .zip(tile_rows(&mut triangles, width, height))
        .map(|(pixels, triangles)| EyeTileOut { pixels, triangles })
        .collect();
    let stats = rasterize(phase, scene, &view, &EyeResolve, outs);
    // SAFETY: `rasterize` hands every tile's piece to that tile's resolve, which writes every element
    // of every row piece it was given (each pixel, covered or not), and the pieces partition 0..n.
    // Had a task panicked, we would not get here.
    unsafe {
        pixels.set_len(n);
        triangles.set_len(n);
    }
    EyePassOutput {
        receivers: Receivers {
            width,
            height,
            pixels,
        },
        triangles,
        stats,
    }
}

/// The eye pass as its own one-phase frame, executed as `exec` says: the output and the log (with the
/// task records under [`Exec::Counting`]).
pub fn eye_pass_with(scene: &Scene, exec: Exec) -> (EyePassOutput, FrameLog) {
    let mut log = FrameLog::new(exec);
    let out = log.phase("eye_pass", "eye pass: receivers of every pixel", |p| {
        eye_pass(p, scene)
    });
    (out, log)
}

/// The receivers of every pixel of `scene`'s camera and the raster counts, natively (for tests,
/// benches and tools).
pub fn receivers(scene: &Scene) -> (Receivers, RasterStats) {
    let (out, _) = eye_pass_with(scene, Exec::Native);
    (out.receivers, out.stats)
}

/// A tile's pieces of the eye pass's two output buffers.
pub struct EyeTileOut<'a> {
    pixels: TileRows<'a, Option<Receiver>>,
    triangles: TileRows<'a, u32>,
}

/// The eye view's resolve: receivers and winning triangles.
struct EyeResolve;

impl TileResolve for EyeResolve {
    type Out<'a> = EyeTileOut<'a>;
    const TASK_KIND: u32 = task_kind::EYE_RECEIVERS;
    #[inline(always)]
    fn resolve<S: Simd>(&self, s: S, tile: &TileRaster<'_>, out: EyeTileOut<'_>) -> u64 {
        write_receivers(s, tile, out)
    }
}

/// Writes the receivers of a tile's pixels from its buffer, a 4×4 block (16 lanes) at a time;
/// returns the number covered. The receiver is where the pixel's CONTRACTS.md centre ray meets the
/// winning triangle's plane. The ray direction is computed with exactly the operations, in the
/// order, of [`crate::scene::CameraFrame::ray_direction`] (glam's scalar `Vec3`: no fused operations, correctly
/// rounded division and square root), so it is bit-identical to the one ray casting uses.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // index loops keep every vector op in the kernel body
fn write_receivers<S: Simd>(s: S, tile: &TileRaster<'_>, out: EyeTileOut<'_>) -> u64 {
    let (f, table, buf, (ox, oy)) = (&tile.view.frame, tile.triangles, tile.buf, tile.origin);
    let mut pixels = out.pixels.rows;
    let mut triangles = out.triangles.rows;
    let th = pixels.len() as u32;
    let tw = pixels.first().map_or(0, |r| r.len()) as u32;
    let (one, two, half, zero) = (s.splat_f(1.0), s.splat_f(2.0), s.splat_f(0.5), s.splat_f(0.0));
    let (w, h) = (s.splat_f(f.width as f32), s.splat_f(f.height as f32));
    let (tan, aspect) = (s.splat_f(f.tan_half_fov), s.splat_f(f.aspect));
    let (fw, rt, up, eye) = (
        splat3(s, f.forward),
        splat3(s, f.right),
        splat3(s, f.up),
        splat3(s, f.eye),
    );
    let lane_x = s.from_array_f(lanes(|k| (k % 4) as f32));
    let lane_y = s.from_array_f(lanes(|k| (k / 4) as f32));
    let mut covered = 0u64;
    for by in (0..th).step_by(4) {
        for bx in (0..tw).step_by(4) {
            let base = TileBuf::index(bx, by);
            let slot = s.load_i(&buf.id[base..base + 16]);
            let hit = s.cmp_ge_i(slot, s.splat_i(0));
            let rows_here = s.s_min(s.s_sub(th, by), 4) as usize;
            let cols_here = s.s_min(s.s_sub(tw, bx), 4) as usize;
            // Each block row's pieces of the two outputs, taken once (not a row lookup and two
            // bounds checks per pixel, which the host executed and the records did not count).
            let cols = bx as usize..bx as usize + cols_here;
            if !s.s_branch(s.mask_any(hit)) {
                for r in 0..rows_here {
                    let row = (by as usize) + r;
                    let tris = &mut triangles[row][cols.clone()];
                    for (px, tri) in pixels[row][cols.clone()].iter_mut().zip(tris) {
                        s.s_wrote(px.write(None));
                        s.s_wrote(tri.write(NO_TRIANGLE));
                    }
                }
                continue;
            }
            // Pixel indices as floats (exact: sides are at most 32768).
            let i = s.add_f(lane_x, s.splat_f((ox + bx) as f32));
            let j = s.add_f(lane_y, s.splat_f((oy + by) as f32));
            // sx = (2 (i + 0.5) / W - 1) t a; sy = (1 - 2 (j + 0.5) / H) t.
            let sx = s.div_f(s.mul_f(two, s.add_f(i, half)), w);
            let sx = s.mul_f(s.mul_f(s.sub_f(sx, one), tan), aspect);
            let sy = s.div_f(s.mul_f(two, s.add_f(j, half)), h);
            let sy = s.mul_f(s.sub_f(one, sy), tan);
            // d = forward + sx right + sy up, then normalised as glam does: d * (1 / sqrt(d · d)).
            // (No closures or array maps here: they would not inline into the backend's
            // target-feature entry point, and every vector op would become a call.)
            let mut d = [zero; 3];
            for c in 0..3 {
                d[c] = s.add_f(s.add_f(fw[c], s.mul_f(sx, rt[c])), s.mul_f(sy, up[c]));
            }
            let inv_len = s.div_f(one, s.sqrt_f(dot3_unfused(s, &d, &d)));
            let mut dir = [zero; 3];
            for c in 0..3 {
                dir[c] = s.mul_f(d[c], inv_len);
            }
            // The winning triangle's plane, gathered by list position.
            let n = [
                s.mask_gather_f(zero, hit, &table.nx, slot),
                s.mask_gather_f(zero, hit, &table.ny, slot),
                s.mask_gather_f(zero, hit, &table.nz, slot),
            ];
            let plane_dist = s.mask_gather_f(zero, hit, &table.plane_dist, slot);
            let original = s.mask_gather_i(s.splat_i(-1), hit, &table.original, slot);
            let denom = dot3_unfused(s, &n, &dir);
            let dist = s.div_f(plane_dist, denom);
            // Grazing rays (plane nearly parallel, dist not finite or not ahead) use the rasterized
            // depth instead: the centre ray at view depth z is eye + z d (d's forward part is 1).
            let ahead = s.mask_and(s.cmp_gt_f(dist, zero), s.cmp_lt_f(dist, s.splat_f(f32::INFINITY)));
            let inv_z = s.load_f(&buf.inv_z[base..base + 16]);
            // Flip the normal to face the camera.
            let away = s.cmp_gt_f(denom, zero);
            let mut pos = [[0.0f32; 16]; 3];
            let mut nrm = [[0.0f32; 16]; 3];
            for c in 0..3 {
                let on_plane = s.add_f(eye[c], s.mul_f(dir[c], dist));
                let by_depth = s.add_f(eye[c], s.div_f(d[c], inv_z));
                pos[c] = s.to_array_f(s.select_f(ahead, on_plane, by_depth));
                nrm[c] = s.to_array_f(s.select_f(away, s.neg_f(n[c]), n[c]));
            }
            let original = s.to_array_i(original);
            for r in 0..rows_here {
                let row = (by as usize) + r;
                let tris = &mut triangles[row][cols.clone()];
                for (c, (px, tri)) in pixels[row][cols.clone()].iter_mut().zip(tris).enumerate() {
                    let k = 4 * r + c;
                    if s.s_branch(hit.test(k)) {
                        // Counted as executed: six lanes read back from the spilled vectors, the
                        // receiver stored a field at a time (its tag and six floats), the
                        // triangle's lane read and stored.
                        s.s_wrote_words(px.write(Some(Receiver {
                            position: Vec3::new(
                                s.s_load(&pos[0], k),
                                s.s_load(&pos[1], k),
                                s.s_load(&pos[2], k),
                            ),
                            normal: Vec3::new(
                                s.s_load(&nrm[0], k),
                                s.s_load(&nrm[1], k),
                                s.s_load(&nrm[2], k),
                            ),
                        })));
                        s.s_wrote(tri.write(s.s_load(&original, k) as u32));
                        covered += 1;
                    } else {
                        s.s_wrote(px.write(None));
                        s.s_wrote(tri.write(NO_TRIANGLE));
                    }
                }
            }
        }
    }
    covered
}
