//! The machine model's own speed: one 1600x1200 japanese-maple SISM frame (198K triangles) run
//! natively, then under the counting context (every counter and the line stream on), then replayed
//! on larrabee-24. Prints host seconds (medians of 3 runs each: the host may be shared) and the
//! slowdowns against the native frame.
//!
//! `cargo bench --bench machine` (plain `main`, no criterion: one counted frame takes seconds, and
//! the whole bench about a minute). `SISM_BENCH_SCENE=palm` picks another shared scene.

use std::path::Path;
use std::time::Instant;

use sism::algorithms::{self, PreparedScene};
use sism::exec::Exec;
use sism::machine::{simulate, MachineConfig};
use sism::render::{render_prepared, RenderOptions};
use sism::scene::Scene;

/// As in the `sism` binary: mimalloc, with line-aligned blocks and no reuse within a counted frame.
#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<mimalloc::MiMalloc> = sism_simd::LineAlloc(mimalloc::MiMalloc);

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
    let algo = algorithms::find("sism").expect("registered");
    let params = algo.params(&[]).expect("defaults");
    let run = |exec| {
        let t = Instant::now();
        let frame = render_prepared(
            &prepared,
            algo,
            &params,
            &RenderOptions {
                exec,
                progress: false,
            },
        );
        (t.elapsed().as_secs_f64(), frame)
    };
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // The host is shared and noisy: medians of 3 runs each (after a native warm-up).
    run(Exec::Native);
    let native = median((0..3).map(|_| run(Exec::Native).0).collect());
    let mut counting = Vec::new();
    let mut frame = None;
    let mut fingerprints = Vec::new();
    for _ in 0..3 {
        let (t, f) = run(Exec::Counting);
        counting.push(t);
        // Counters and line-stream lengths of every task: the same in every counted run.
        let fp: Vec<_> = f
            .records
            .iter()
            .flat_map(|p| p.tasks.iter().map(|t| (t.counters, t.lines.len())))
            .collect();
        fingerprints.push(fp);
        frame = Some(f);
    }
    assert!(
        fingerprints.windows(2).all(|w| w[0] == w[1]),
        "counted runs differ"
    );
    let counting = median(counting);
    let records = frame.expect("3 counted frames").records;
    let config = MachineConfig::larrabee_24();
    let mut sims = Vec::new();
    let mut report = None;
    for _ in 0..3 {
        let t = Instant::now();
        let r = simulate(&records, &config);
        sims.push(t.elapsed().as_secs_f64());
        report = Some(r);
    }
    let sim = median(sims);
    let report = report.expect("3 simulations");
    let accesses = report.frame.memory.accesses;
    println!(
        "{name} 1600x1200, {} host threads, medians of 3",
        rayon::current_num_threads()
    );
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
        "simulated frame           {:>9.3} ms on {} ({} cycles)",
        report.frame.ms, config.name, report.frame.cycles
    );
}
