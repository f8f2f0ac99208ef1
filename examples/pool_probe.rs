//! Times a step on a fresh rayon pool after (or without) a counted frame, as `validate` runs it:
//! `pool_probe SCENE ALGO STEP THREADS COUNTED(0|1) [FRAMES]` (THREADS 0: the global pool; 6 frames),
//! at 1600×1200 unless `PROBE_W` and `PROBE_H` say otherwise.
use sism::algorithms::PreparedScene;
use sism::exec::Exec;
use sism::render::{render_prepared, RenderOptions};

#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<mimalloc::MiMalloc> = sism_simd::LineAlloc(mimalloc::MiMalloc);

fn main() {
    // As the `sism` binary: freed pages are kept (mimalloc's `mi_option_purge_delay`, 15, at -1), so
    // warm frames take no page faults.
    // SAFETY: sets an option of the global allocator before any thread is started.
    unsafe { libmimalloc_sys::mi_option_set(15, -1) };
    let a: Vec<String> = std::env::args().collect();
    let mut scene = sism::scene::Scene::load(std::path::Path::new(&a[1])).unwrap();
    scene.camera.width = std::env::var("PROBE_W").map_or(1600, |v| v.parse().unwrap());
    scene.camera.height = std::env::var("PROBE_H").map_or(1200, |v| v.parse().unwrap());
    let algo = sism::algorithms::find(&a[2]).unwrap();
    let params = algo.params(&[]).unwrap();
    let threads: usize = a[4].parse().unwrap();
    let prepared = PreparedScene::new(&scene);
    let opts = |exec| RenderOptions {
        exec,
        progress: false,
    };
    if a[5] == "1" {
        let r = render_prepared(&prepared, algo, &params, &opts(Exec::Counting));
        drop(r);
    }
    let run = || {
        let frames: usize = a.get(6).map_or(6, |f| f.parse().unwrap());
        for _ in 0..frames {
            let r = render_prepared(&prepared, algo, &params, &opts(Exec::Native));
            println!(
                "{} {:.2} ms",
                a[3],
                r.stats.get(&format!("time.{}", a[3])).unwrap_or(-1.0)
            );
        }
    };
    // 0: the global pool (RAYON_NUM_THREADS).
    if threads == 0 {
        run();
    } else {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(run);
    }
}
