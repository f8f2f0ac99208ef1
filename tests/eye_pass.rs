//! The eye pass (binned rasterizer) against ray casting, its determinism, and its edge cases.

use std::path::{Path, PathBuf};

use glam::Vec3;
use sism::algorithms::reference::cast_primary_rays;
use sism::bvh::SceneBvh;
use sism::exec::task_kind::RASTER_TILE as TASK_TILE;
use sism::exec::Exec;
use sism::frame::Receivers;
use sism::raster::eye::receivers as eye_pass;
use sism::raster::{RasterStats, TILE};
use sism::scene::{Camera, Light, Mesh, Scene};
use sism_simd::TaskRecord;

/// An eye pass's output with its task records flattened (empty natively).
struct EyePassOutput {
    receivers: Receivers,
    triangles: Vec<u32>,
    stats: RasterStats,
    records: Vec<TaskRecord>,
}

fn eye_pass_with(scene: &Scene, exec: Exec) -> EyePassOutput {
    let (out, log) = sism::raster::eye::eye_pass_with(scene, exec);
    EyePassOutput {
        receivers: out.receivers,
        triangles: out.triangles,
        stats: out.stats,
        records: log
            .records()
            .iter()
            .flat_map(|p| p.tasks.iter().cloned())
            .collect(),
    }
}

// The integration tests' helpers (the shared-scene lookup); this binary uses only some of them.
#[allow(dead_code)]
#[path = "integration/util.rs"]
mod util;
use util::shared_scenes;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn load(name: &str, width: u32, height: u32) -> Scene {
    let mut scene = Scene::load(&root().join("scenes").join(name)).expect("scene loads");
    scene.camera.width = width;
    scene.camera.height = height;
    scene
}

/// Agreement of two receiver images over the pixels either covers.
#[derive(Debug, Default)]
struct Agreement {
    either: usize,
    agree: usize,
    only_raster: usize,
    only_rays: usize,
    /// Both covered but the positions differ by more than the tolerance.
    apart: usize,
    /// Largest relative position difference among agreeing pixels.
    max_rel: f32,
}

impl Agreement {
    fn fraction(&self) -> f64 {
        if self.either == 0 {
            1.0
        } else {
            self.agree as f64 / self.either as f64
        }
    }
}

/// Both covered and positions within `1e-3` of the distance to the eye.
fn compare(eye: Vec3, raster: &Receivers, rays: &Receivers) -> Agreement {
    assert_eq!((raster.width, raster.height), (rays.width, rays.height));
    let mut a = Agreement::default();
    for (r, q) in raster.pixels.iter().zip(&rays.pixels) {
        match (r, q) {
            (None, None) => {}
            (Some(_), None) => {
                a.either += 1;
                a.only_raster += 1;
            }
            (None, Some(_)) => {
                a.either += 1;
                a.only_rays += 1;
            }
            (Some(r), Some(q)) => {
                a.either += 1;
                let rel = (r.position - q.position).length() / (q.position - eye).length();
                if rel <= 1e-3 {
                    a.agree += 1;
                    a.max_rel = a.max_rel.max(rel);
                } else {
                    a.apart += 1;
                }
            }
        }
    }
    a
}

/// Rasterizes and ray-casts `scene`, prints the figures, and asserts >= 99.5% agreement.
fn check_against_rays(name: &str, scene: &Scene) -> EyePassOutput {
    let bvh = SceneBvh::build(scene);
    let rays = cast_primary_rays(scene, &bvh);
    let out = eye_pass_with(scene, Exec::Native);
    let a = compare(scene.camera.frame().eye, &out.receivers, &rays);
    let s = &out.stats;
    println!(
        "{name}: {}x{}, {} triangles ({} clipped, {} culled, {} binned, {} pairs): agreement {:.4}% of {} \
         pixels (raster only {}, rays only {}, apart {}, max rel diff {:.2e})",
        scene.camera.width,
        scene.camera.height,
        s.triangles_in,
        s.triangles_clipped,
        s.triangles_culled,
        s.screen_triangles,
        s.tile_triangle_pairs,
        100.0 * a.fraction(),
        a.either,
        a.only_raster,
        a.only_rays,
        a.apart,
        a.max_rel,
    );
    assert!(a.fraction() >= 0.995, "{name}: agreement {a:?}");
    // Covered pixels agree with the stats and the per-pixel triangle indices.
    let covered = out.receivers.pixels.iter().filter(|p| p.is_some()).count();
    assert_eq!(covered as u64, s.pixels_covered);
    for (p, &t) in out.receivers.pixels.iter().zip(&out.triangles) {
        assert_eq!(p.is_some(), t != u32::MAX);
        assert!(t == u32::MAX || (t as usize) < scene.triangle_count());
    }
    // Normals are unit and face the camera, and the receiver is exactly (bit for bit) where the
    // pixel's centre ray meets the winning triangle's plane, as a scalar glam computation gives it.
    let frame = scene.camera.frame();
    let corners: Vec<[Vec3; 3]> = scene.triangles().collect();
    let mut exact = 0usize;
    for (k, p) in out.receivers.pixels.iter().enumerate() {
        if let Some(r) = p {
            let (i, j) = (k as u32 % frame.width, k as u32 / frame.width);
            let dir = frame.ray_direction(i, j);
            assert!((r.normal.length() - 1.0).abs() < 1e-4);
            assert!(r.normal.dot(dir) <= 0.0);
            let [a, b, c] = corners[out.triangles[k] as usize];
            let n = (b - a).cross(c - a).normalize_or_zero();
            assert_eq!(r.normal.abs(), n.abs(), "pixel ({i}, {j})");
            let t = n.dot(a - frame.eye) / n.dot(dir);
            if t.is_finite() && t > 0.0 {
                assert_eq!(r.position, frame.eye + dir * t, "pixel ({i}, {j})");
                exact += 1;
            }
        }
    }
    // Only grazing rays may fall back to the rasterized depth.
    assert!(exact as u64 + s.pixels_covered / 1000 >= s.pixels_covered);
    out
}

#[test]
fn agrees_with_ray_casting_on_embedded_scenes() {
    for name in ["plate.toml", "sphere.toml", "room.toml"] {
        let scene = load(name, 320, 240);
        check_against_rays(name, &scene);
    }
    // The plate at its own resolution too (not a multiple of the tile size in height).
    check_against_rays("plate.toml 640x480", &load("plate.toml", 640, 480));
    check_against_rays("plate.toml 97x61", &load("plate.toml", 97, 61));
}

#[test]
fn agrees_with_ray_casting_on_shared_scenes() {
    if shared_scenes().is_none() {
        return;
    }
    for name in ["stanford-bunny.toml", "conference.toml", "japanese-maple.toml"] {
        let scene = load(name, 320, 240);
        let out = check_against_rays(name, &scene);
        if name == "conference.toml" {
            // The camera is inside the room: some walls cross the near plane or lie behind it.
            assert!(out.stats.triangles_culled > 0);
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// Synthetic scenes

fn camera(eye: [f32; 3], look_at: [f32; 3], width: u32, height: u32) -> Camera {
    Camera {
        eye,
        look_at,
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 60.0,
        width,
        height,
    }
}

fn scene(meshes: Vec<Mesh>, camera: Camera) -> Scene {
    Scene {
        source: PathBuf::from("synthetic"),
        origin: [0.0; 3],
        meshes,
        camera,
        light: Light {
            center: [0.0, 10.0, 0.0],
            radius: 0.5,
        },
    }
}

fn mesh(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    Mesh {
        name: "test".into(),
        positions,
        triangles,
    }
}

/// A sphere of many triangles (more than one front-end chunk) over a ground, camera looking down.
fn busy_scene(width: u32, height: u32) -> Scene {
    let text = format!(
        r#"
[[sphere]]
center = [0.0, 1.0, 0.0]
radius = 1.0
segments = 200
[[quad]]
corner = [-4.0, 0.0, 4.0]
edge_u = [8.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -8.0]
[camera]
eye = [0.3, 2.5, 3.0]
look_at = [0.0, 0.8, 0.0]
fov_y_deg = 50.0
width = {width}
height = {height}
[light]
center = [1.0, 4.0, -1.0]
radius = 0.5
"#
    );
    Scene::from_toml(&text, Path::new("busy.toml")).expect("scene parses")
}

fn assert_identical(a: &EyePassOutput, b: &EyePassOutput) {
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.receivers.pixels.len(), b.receivers.pixels.len());
    for (p, q) in a.receivers.pixels.iter().zip(&b.receivers.pixels) {
        let bits = |r: &Option<sism::frame::Receiver>| {
            r.map(|r| {
                (
                    r.position.to_array().map(f32::to_bits),
                    r.normal.to_array().map(f32::to_bits),
                )
            })
        };
        assert_eq!(bits(p), bits(q));
    }
    assert_eq!(a.stats.depth_writes, b.stats.depth_writes);
    assert_eq!(a.stats.blocks_tested, b.stats.blocks_tested);
    assert_eq!(a.stats.tile_triangle_pairs, b.stats.tile_triangle_pairs);
}

#[test]
fn deterministic_across_thread_counts_and_counting() {
    let scene = busy_scene(200, 150);
    assert!(scene.triangle_count() > 2 * sism::raster::FRONT_END_CHUNK);
    let run = |threads: usize, exec: Exec| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| eye_pass_with(&scene, exec))
    };
    let one = run(1, Exec::Native);
    let three = run(3, Exec::Native);
    assert_identical(&one, &three);
    assert!(one.records.is_empty());
    let counted = run(3, Exec::Counting);
    assert_identical(&one, &counted);
    let counted1 = run(1, Exec::Counting);
    assert_identical(&counted, &counted1);
    // One record per tile, in tile order, with the same counters whatever the thread count.
    let tiles: Vec<_> = counted.records.iter().filter(|r| r.kind == TASK_TILE).collect();
    assert_eq!(tiles.len() as u64, counted.stats.tiles);
    assert_eq!(tiles.len() as u32, 200u32.div_ceil(TILE) * 150u32.div_ceil(TILE));
    let tiles1: Vec<_> = counted1.records.iter().filter(|r| r.kind == TASK_TILE).collect();
    for (a, b) in tiles.iter().zip(&tiles1) {
        assert_eq!(a.counters.fma, b.counters.fma);
        assert_eq!(a.counters.valu, b.counters.valu);
        assert_eq!(a.counters.scalar, b.counters.scalar);
    }
    assert!(tiles.iter().map(|r| r.counters.fma).sum::<u64>() > 0);
    // And it agrees with ray casting.
    let bvh = SceneBvh::build(&scene);
    let a = compare(
        scene.camera.frame().eye,
        &one.receivers,
        &cast_primary_rays(&scene, &bvh),
    );
    assert!(a.fraction() >= 0.995, "{a:?}");
}

#[test]
fn triangle_crossing_the_near_plane() {
    // A floor running from behind the camera to far ahead: its triangles cross the near plane.
    let floor = mesh(
        vec![
            Vec3::new(-20.0, 0.0, 20.0),
            Vec3::new(20.0, 0.0, 20.0),
            Vec3::new(20.0, 0.0, -20.0),
            Vec3::new(-20.0, 0.0, -20.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    // Plus one triangle with one corner behind the eye that fills much of the view up close.
    let wall = mesh(
        vec![
            Vec3::new(-0.5, 0.5, 3.0),
            Vec3::new(1.0, 0.2, -1.0),
            Vec3::new(-1.0, 2.0, -1.5),
        ],
        vec![[0, 1, 2]],
    );
    let s = scene(
        vec![floor, wall],
        camera([0.0, 1.0, 2.0], [0.0, 0.7, 0.0], 160, 120),
    );
    let out = check_against_rays("near-plane", &s);
    assert!(out.stats.triangles_clipped >= 2, "{:?}", out.stats);
    assert!(out.stats.screen_triangles > out.stats.triangles_in - out.stats.triangles_culled);
}

#[test]
fn triangle_behind_the_camera_is_culled() {
    let behind = mesh(
        vec![
            Vec3::new(-1.0, 0.0, 5.0),
            Vec3::new(1.0, 0.0, 5.0),
            Vec3::new(0.0, 1.0, 5.0),
        ],
        vec![[0, 1, 2]],
    );
    let s = scene(vec![behind], camera([0.0, 0.5, 3.0], [0.0, 0.5, 0.0], 64, 48));
    let (r, stats) = eye_pass(&s);
    assert!(r.pixels.iter().all(|p| p.is_none()));
    assert_eq!((stats.triangles_in, stats.triangles_culled), (1, 1));
    assert_eq!(stats.tile_triangle_pairs, 0);
}

#[test]
fn degenerate_and_huge_triangles_do_not_panic() {
    let m = mesh(
        vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0), // collinear with the first two
            Vec3::new(0.5, 0.0, 0.0),
            // A huge triangle (thousands of image widths) behind everything, and one seen exactly
            // edge-on. (Not larger: the near plane is 1e-4 of the scene's diagonal.)
            Vec3::new(-3e3, -3e3, -100.0),
            Vec3::new(3e3, -3e3, -100.0),
            Vec3::new(0.0, 3e3, -100.0),
            Vec3::new(0.0, -1.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0),
            Vec3::new(0.0, 0.0, -3.0),
        ],
        vec![[0, 1, 2], [0, 0, 3], [3, 3, 3], [4, 5, 6], [7, 8, 9]],
    );
    let s = scene(vec![m], camera([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 64, 48));
    let out = check_against_rays("degenerate", &s);
    // The three degenerate triangles and the edge-on one cover nothing; the huge one covers all.
    assert!(out.stats.triangles_culled >= 3, "{:?}", out.stats);
    assert!(out.triangles.iter().all(|&t| t == 3));
}

/// Per-pixel coverage counts of `triangles`, each rasterized on its own.
fn coverage(positions: &[Vec3], triangles: &[[u32; 3]], cam: Camera) -> Vec<u32> {
    let mut count = vec![0u32; (cam.width * cam.height) as usize];
    for &t in triangles {
        let s = scene(vec![mesh(positions.to_vec(), vec![t])], cam);
        let (r, _) = eye_pass(&s);
        for (c, p) in count.iter_mut().zip(&r.pixels) {
            *c += p.is_some() as u32;
        }
    }
    count
}

#[test]
fn shared_edges_cover_every_pixel_exactly_once() {
    // A quad filling the view, split on its diagonal, which passes exactly through pixel centres
    // (square image, quad symmetric about the view axis).
    let cam = Camera {
        fov_y_deg: 90.0,
        ..camera([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], 64, 64)
    };
    let quad = [
        Vec3::new(-2.0, -2.0, 0.0),
        Vec3::new(2.0, -2.0, 0.0),
        Vec3::new(2.0, 2.0, 0.0),
        Vec3::new(-2.0, 2.0, 0.0),
    ];
    for tris in [
        [[0, 1, 2], [0, 2, 3]],
        [[0, 1, 3], [1, 2, 3]],
        [[2, 1, 0], [3, 2, 0]],
    ] {
        let count = coverage(&quad, &tris, cam);
        assert!(count.iter().all(|&c| c == 1), "{tris:?}: counts {:?}", count);
        let s = scene(vec![mesh(quad.to_vec(), tris.to_vec())], cam);
        let (r, stats) = eye_pass(&s);
        assert!(r.pixels.iter().all(|p| p.is_some()));
        assert_eq!(stats.pixels_covered, 64 * 64);
    }

    // A jittered grid of 12x9 quads in a slanted plane, several tiles wide, vertices at awkward
    // positions, some edges exactly through pixel centres: each pixel inside is covered exactly once.
    let cam = camera([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], 150, 100);
    let (nx, ny) = (12u32, 9u32);
    let mut positions = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let (u, v) = (i as f32 / nx as f32, j as f32 / ny as f32);
            let border = i == 0 || j == 0 || i == nx || j == ny;
            let jitter = if border {
                0.0
            } else {
                0.08 * ((i * 7 + j * 13) as f32).sin()
            };
            positions.push(Vec3::new(
                -5.0 + 10.0 * u + jitter,
                -4.0 + 8.0 * v - jitter,
                -1.0 - 0.6 * u + 0.3 * v,
            ));
        }
    }
    let mut tris = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let a = j * (nx + 1) + i;
            let (b, c, d) = (a + 1, a + nx + 2, a + nx + 1);
            if (i + j) % 2 == 0 {
                tris.extend([[a, b, c], [a, c, d]]);
            } else {
                tris.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    let count = coverage(&positions, &tris, cam);
    let twice = count.iter().filter(|&&c| c > 1).count();
    let holes = count.iter().filter(|&&c| c == 0).count();
    assert_eq!((twice, holes), (0, 0), "double-covered and uncovered pixels");
    let s = scene(vec![mesh(positions, tris)], cam);
    let out = check_against_rays("grid", &s);
    assert_eq!(out.stats.pixels_covered, 150 * 100);
}
