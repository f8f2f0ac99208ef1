//! The machine model's own speed: one 1600x1200 japanese-maple SISM frame (198K triangles) run
//! natively, then under the counting context (every counter and the line stream on), then replayed
//! on larrabee-24. Prints host seconds and the slowdowns against the native frame.
//!
//! `cargo bench --bench machine` (plain `main`, no criterion: one counted frame takes tens of
//! seconds). `SISM_BENCH_SCENE=palm` picks another shared scene.

use std::path::Path;
use std::time::Instant;

use sism::machine::{simulate, MachineConfig};
use sism::scene::Scene;
use sism::sism::{render_frame, Composition, Exec, PreparedScene, SismOptions};

fn main() {
    // `cargo bench` passes `--bench`; nothing to parse.
    let name = std::env::var("SISM_BENCH_SCENE").unwrap_or_else(|_| "japanese-maple".into());
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.toml"));
    let mut scene = match Scene::load(&path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("skipping {name}: {e}");
            return;
        }
    };
    scene.camera.width = 1600;
    scene.camera.height = 1200;
    let prepared = PreparedScene::new(&scene);
    let run = |exec| {
        let options = SismOptions {
            exec,
            composition: Composition::Additive,
            ..Default::default()
        };
        let t = Instant::now();
        let frame = render_frame(&scene, &prepared, &options);
        (t.elapsed().as_secs_f64(), frame)
    };
    // Warm-up, then the median of 3 native frames.
    run(Exec::Native);
    let mut native: Vec<f64> = (0..3).map(|_| run(Exec::Native).0).collect();
    native.sort_by(f64::total_cmp);
    let native = native[1];
    let (counting, frame) = run(Exec::Counting);
    let config = MachineConfig::larrabee_24();
    let t = Instant::now();
    let report = simulate(&frame.records, &config);
    let sim = t.elapsed().as_secs_f64();
    let accesses = report.frame.memory.accesses;
    println!("{name} 1600x1200, {} host threads", rayon::current_num_threads());
    println!("native frame              {native:>9.3} s");
    println!(
        "counting frame            {counting:>9.3} s  ({:.1}x native)",
        counting / native
    );
    println!(
        "simulation (larrabee-24)  {sim:>9.3} s  ({:.1}x native, {accesses} line accesses, {:.1} ns each)",
        sim / native,
        sim * 1e9 / accesses.max(1) as f64
    );
    println!(
        "counting + simulation     {:>9.3} s  ({:.1}x native)",
        counting + sim,
        (counting + sim) / native
    );
    println!(
        "simulated frame           {:>9.3} ms on {}",
        report.frame.ms, config.name
    );
}
