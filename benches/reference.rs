//! Shadow-ray throughput of the ray-traced reference on a ~200K-triangle scene (japanese-maple, 198K
//! triangles plus a ground quad), and on the small embedded plate scene for comparison.
//!
//! `cargo bench --bench reference`. Throughput is reported as shadow rays per second (criterion's
//! "elem/s"), receivers fixed, 16 light samples per receiver.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use sism::algorithms::reference::{cast_primary_rays, render_visibility, ReferenceOptions};
use sism::bvh::SceneBvh;
use sism::scene::Scene;

fn bench_scene(c: &mut Criterion, name: &str, path: &Path, width: u32, height: u32) {
    if !path.is_file() {
        eprintln!("skipping {name}: {} not found", path.display());
        return;
    }
    let mut scene = Scene::load(path).expect("scene loads");
    scene.camera.width = width;
    scene.camera.height = height;
    let bvh = SceneBvh::build(&scene);
    let receivers = cast_primary_rays(&scene, &bvh);
    let options = ReferenceOptions {
        spp: 16,
        seed: 0,
        progress: false,
        ..Default::default()
    };
    let rays = render_visibility(&scene, &bvh, None, &receivers, &options).1.rays;
    let mut group = c.benchmark_group("reference_shadow_rays");
    group.throughput(Throughput::Elements(rays));
    group.sample_size(10);
    group.bench_function(
        format!("{name} ({} triangles, {rays} rays)", scene.triangle_count()),
        |b| b.iter(|| render_visibility(&scene, &bvh, None, &receivers, &options)),
    );
    group.finish();
}

fn shadow_rays(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    bench_scene(
        c,
        "japanese-maple",
        &root.join("scenes/japanese-maple.toml"),
        400,
        300,
    );
    bench_scene(c, "plate", &root.join("scenes/plate.toml"), 400, 300);
}

/// As the CLI: freed frame buffers stay mapped for the next frame (see src/main.rs).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

criterion_group!(benches, shadow_rays);
criterion_main!(benches);
