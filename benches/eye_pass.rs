//! Eye pass (binned rasterizer) against the ray-cast primary pass, at 1600×1200 on japanese-maple
//! (198K triangles) and palm.
//!
//! `cargo bench --bench eye_pass`. Both produce the same `Receivers`; the BVH build is not timed.

use std::path::Path;

use criterion::{criterion_group, Criterion};
use sism::algorithms::reference::cast_primary_rays;
use sism::bvh::SceneBvh;
use sism::exec::Exec;
use sism::raster::eye::{eye_pass_with, receivers};
use sism::scene::Scene;

fn bench_scene(c: &mut Criterion, name: &str, path: &Path) {
    if !path.is_file() {
        eprintln!("skipping {name}: {} not found", path.display());
        return;
    }
    let mut scene = Scene::load(path).expect("scene loads");
    scene.camera.width = 1600;
    scene.camera.height = 1200;
    let bvh = SceneBvh::build(&scene);
    // The fastest of a few runs (the first one pays page faults and pool start-up).
    let runs: Vec<_> = (0..5)
        .map(|_| {
            let t = std::time::Instant::now();
            let (out, _) = eye_pass_with(&scene, Exec::Native);
            (t.elapsed(), out.stats)
        })
        .collect();
    let (time, s) = *runs.iter().min_by_key(|r| r.0).unwrap();
    eprintln!(
        "{name}: {} triangles, {} binned, {} pairs, {} blocks ({} full), {} depth writes, {} pixels; \
         eye pass {:.2} ms",
        s.triangles_in,
        s.screen_triangles,
        s.tile_triangle_pairs,
        s.blocks_tested,
        s.blocks_full,
        s.depth_writes,
        s.pixels_covered,
        time.as_secs_f64() * 1e3
    );
    let mut group = c.benchmark_group(format!("primary_{name}_1600x1200"));
    group.sample_size(10);
    group.bench_function("eye_pass (raster)", |b| b.iter(|| receivers(&scene)));
    group.bench_function("cast_primary_rays (CWBVH)", |b| {
        b.iter(|| cast_primary_rays(&scene, &bvh))
    });
    group.finish();
}

fn primary(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    bench_scene(c, "japanese-maple", &root.join("scenes/japanese-maple.toml"));
    bench_scene(c, "palm", &root.join("scenes/palm.toml"));
}

/// Process CPU time (user + system, all threads), from /proc/self/stat, seconds; None off Linux.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = stat.rsplit(')').next()?.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0) // USER_HZ is 100 on Linux
}

/// `EYE_PASS_CPU=1 cargo bench --bench eye_pass`: CPU seconds per frame instead of criterion's wall
/// times (meaningful on a shared, loaded machine).
fn cpu_times() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for name in ["japanese-maple", "palm"] {
        let path = root.join(format!("scenes/{name}.toml"));
        if !path.is_file() {
            continue;
        }
        let mut scene = Scene::load(&path).expect("scene loads");
        scene.camera.width = 1600;
        scene.camera.height = 1200;
        let bvh = SceneBvh::build(&scene);
        let measure = |f: &dyn Fn()| {
            f();
            let (c0, t0) = (cpu_seconds().unwrap_or(0.0), std::time::Instant::now());
            let n = 20;
            for _ in 0..n {
                f();
            }
            let cpu = cpu_seconds().unwrap_or(0.0) - c0;
            (cpu / n as f64 * 1e3, t0.elapsed().as_secs_f64() / n as f64 * 1e3)
        };
        let (rc, rw) = measure(&|| {
            std::hint::black_box(receivers(&scene));
        });
        let (pc, pw) = measure(&|| {
            std::hint::black_box(cast_primary_rays(&scene, &bvh));
        });
        println!(
            "{name} 1600x1200: eye_pass {rc:.1} ms CPU ({rw:.1} ms wall), cast_primary_rays {pc:.1} ms \
             CPU ({pw:.1} ms wall), {} threads",
            rayon::current_num_threads()
        );
    }
}

criterion_group!(benches, primary);

fn main() {
    if std::env::var_os("EYE_PASS_CPU").is_some() {
        cpu_times();
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
